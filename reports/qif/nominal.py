"""The sections of a QIF document that define the part: the header, the standard and units,
the datums and datum reference frames, the measuring device, the product, the features and the
characteristics (each one's definition, nominal and item)."""

from __future__ import annotations

import math

from .model import DIMENSION_KINDS, QIF_NAMESPACE, QIF_VERSION, Char, Feature, QIFError, Qif
from .text import (algorithm, attributes, exact, file_description, fixed, format_name,
                   geometry, id_list, nmtoken, xml_attr, xml_text)


def write_header(w, q: Qif) -> None:
    """The root element, QPId, creation time and Header (application, author)."""
    cert = q.cert
    w('<?xml version="1.0" encoding="UTF-8"?>\n')
    w(f'<QIFDocument xmlns="{QIF_NAMESPACE}" versionQIF="{QIF_VERSION}" idMax="{q.id_max}">\n')
    w(f"  <QPId>{q.qpid}</QPId>\n")
    if q.issued:
        w(f"  <Version>\n    <TimeCreated>{q.issued}</TimeCreated>\n  </Version>\n")
    w("  <Header>\n    <Application>\n")
    w(f"      <Name>{xml_text(q.app)}</Name>\n")
    w("    </Application>\n")
    if "inspector" in cert or "organisation" in cert:
        w("    <Author>\n")
        if "inspector" in cert:
            w(f"      <Name>{xml_text(cert['inspector'])}</Name>\n")
        if "organisation" in cert:
            w(f"      <Organization>{xml_text(cert['organisation'])}</Organization>\n")
        w("    </Author>\n")
    w(f"    <Description>Dimensional inspection results: {q.n} measured points against "
      f"{xml_text(q.nominal_name)}, signed deviations along the nominal's outward normal "
      f"(positive = excess material), {xml_text(q.length_unit)}</Description>\n")
    w("  </Header>\n")


def write_definitions(w, q: Qif) -> None:
    """StandardsDefinitions (ASME Y14.5) and FileUnits (mm; and degrees, the primary angular
    unit, when an angle is among the characteristics)."""
    # Characteristics must cite a formal standard; OuterDisposition is the ASME form of an
    # unequally disposed profile zone.
    w(f'  <StandardsDefinitions n="1">\n    <Standard id="{q.ids.standard}">\n'
      "      <Organization>\n        <StandardsOrganizationEnum>ASME</StandardsOrganizationEnum>\n"
      "      </Organization>\n      <Designator>Y14.5</Designator>\n      <Year>2018</Year>\n"
      "    </Standard>\n  </StandardsDefinitions>\n")
    w("  <FileUnits>\n    <PrimaryUnits>\n")
    if any(c.kind == "Angle" for c in q.chars):  # an angle's values are degrees
        w("      <AngularUnit>\n        <SIUnitName>radian</SIUnitName>\n"
          "        <UnitName>degree</UnitName>\n        <UnitConversion>\n"
          f"          <Factor>{math.pi / 180.0!r}</Factor>\n        </UnitConversion>\n"
          "      </AngularUnit>\n")
    w("      <LinearUnit>\n"
      "        <SIUnitName>meter</SIUnitName>\n        <UnitName>mm</UnitName>\n"
      "        <UnitConversion>\n          <Factor>0.001</Factor>\n        </UnitConversion>\n"
      "      </LinearUnit>\n    </PrimaryUnits>\n  </FileUnits>\n")


_PRECEDENCE = ("PRIMARY", "SECONDARY", "TERTIARY", "QUATERNARY", "QUINARY", "SENARY")


def write_datums(w, q: Qif) -> None:
    """A plan's DatumDefinitions (label, datum feature) and DatumReferenceFrames (the datums
    in precedence, each established on the actual part by its simulator)."""
    if q.datums:
        w(f'  <DatumDefinitions n="{len(q.datums)}">\n')
        for d in q.datums:
            w(f'    <DatumDefinition id="{d.id}">\n')
            label = nmtoken(d.label)
            if label != d.label:
                w('      <Attributes n="1">\n        <AttributeStr name="qa-inspect:label" '
                  f'value="{xml_attr(d.label)}"/>\n      </Attributes>\n')
            w(f"      <DatumLabel>{label}</DatumLabel>\n")
            if d.feature is not None:
                w(id_list("FeatureNominalIds", [d.feature.nominal_id], 6))
            w("    </DatumDefinition>\n")
        w("  </DatumDefinitions>\n")
    if q.frames:
        datums = {d.label: d for d in q.datums}
        w(f'  <DatumReferenceFrames n="{len(q.frames)}">\n')
        for f in q.frames:
            w(f'    <DatumReferenceFrame id="{f.id}">\n      <Datums n="{len(f.labels)}">\n')
            for precedence, label in zip(_PRECEDENCE, f.labels):
                d = datums[label]
                w(f"        <Datum>\n          <SimpleDatum>\n"
                  f"            <DatumDefinitionId>{d.id}</DatumDefinitionId>\n"
                  "            <MaterialModifier>NONE</MaterialModifier>\n"
                  "            <ReferencedComponent>ACTUAL</ReferencedComponent>\n")
                if d.algorithm:
                    w(algorithm(d.algorithm, 12))
                w("          </SimpleDatum>\n          <Precedence>\n"
                  f"            <PrecedenceEnum>{precedence}</PrecedenceEnum>\n"
                  "          </Precedence>\n        </Datum>\n")
            name = "|".join(f.labels)
            w(f"      </Datums>\n      <Name>{xml_text(name)}</Name>\n")
            w(f"      <Description>{xml_text(f'datum reference frame {name}')}"
              f"{'; ' + xml_text(f.alignment) if f.alignment else ''}</Description>\n")
            w("    </DatumReferenceFrame>\n")
        w("  </DatumReferenceFrames>\n")


def write_resources(w, q: Qif) -> None:
    """MeasurementResources, when the certificate names a device, its serial number, its
    calibration date or its probe: the device's Name (or "measuring device") and SerialNumber;
    the probe and stylus and the calibration date as attributes (a QIF Calibration needs an
    expiry date the certificate does not state)."""
    cert = q.cert
    if q.ids.device:
        w('  <MeasurementResources>\n    <MeasurementDevices n="1">\n')
        w(f'      <MeasurementDevice id="{q.ids.device}">\n'
          f"        <Name>{xml_text(cert.get('device', 'measuring device'))}</Name>\n")
        if "device_serial" in cert:
            w(f"        <SerialNumber>{xml_text(cert['device_serial'])}</SerialNumber>\n")
        w(attributes([("Str", "qa-inspect:probe", cert.get("probe")),
                      ("Str", "qa-inspect:calibration-date", cert.get("calibration_date"))], 8))
        w("      </MeasurementDevice>\n")
        w("    </MeasurementDevices>\n  </MeasurementResources>\n")


def write_product(w, q: Qif) -> None:
    """Product/PartSet/Part: name, part number, revision and the nominal file."""
    ids, cert, nominal_path = q.ids, q.cert, q.nominal_path
    w(f'  <Product>\n    <PartSet n="1">\n      <Part id="{ids.part}">\n')
    w(attributes([("Str", "qa-inspect:drawing", cert.get("drawing"))], 8))
    if "part_name" in cert:
        w(f"        <Header>\n          <Name>{xml_text(cert['part_name'])}</Name>\n"
          "        </Header>\n")
    if "part_number" in cert:
        w(f"        <ModelNumber>{xml_text(cert['part_number'])}</ModelNumber>\n")
    if "revision" in cert:
        w(f"        <Version>{xml_text(cert['revision'])}</Version>\n")
    w(id_list("FeatureNominalIds", [f.nominal_id for f in q.features], 8))
    w(id_list("CharacteristicNominalIds", [c.nominal_id for c in q.chars], 8))
    w(f'        <DefinitionExternal id="{ids.definition}" n="1">\n'
      f'          <DigitalModel id="{ids.model}">\n'
      f"            <Name>{xml_text(q.nominal_name)}</Name>\n"
      f"            <File>\n              <Name>{xml_text(nominal_path)}</Name>\n"
      + (f"              <Version>{xml_text(cert['cad_revision'])}</Version>\n"
         if "cad_revision" in cert else "") +
      f"              <Format>\n                <OtherDigitalModelFormat>"
      f"{xml_text(format_name(nominal_path, q.is_2d))}</OtherDigitalModelFormat>\n"
      "              </Format>\n            </File>\n"
      f"            <Description>{xml_text(file_description('nominal', q.nominal))}"
      "</Description>\n"
      "          </DigitalModel>\n        </DefinitionExternal>\n")
    w("      </Part>\n    </PartSet>\n  </Product>\n")


def write_features(w, q: Qif) -> None:
    """Features: each feature's definition, nominal (with its geometry) and item."""
    n = len(q.features)
    w(f'  <Features>\n    <FeatureDefinitions n="{n}">\n')
    for f in q.features:
        w(feature_definition(f))
    w(f'    </FeatureDefinitions>\n    <FeatureNominals n="{n}">\n')
    for f in q.features:
        w(feature_nominal(f))
    w(f'    </FeatureNominals>\n    <FeatureItems n="{n}">\n')
    for f in q.features:
        w(feature_item(f.kind, f.item, f.nominal_id, f.name))
    w("    </FeatureItems>\n  </Features>\n")


def feature_definition(f: Feature) -> str:
    if f.kind in ("Cylinder", "Sphere"):
        if f.nominal is None:  # the plan's features are geometric only with a nominal
            raise QIFError(f"feature {f.name}: a {f.kind} without its nominal geometry")
        internal = "INTERNAL" if f.nominal.get("internal") else "EXTERNAL"
        return (f'      <{f.kind}FeatureDefinition id="{f.definition}">\n'
                f"        <InternalExternal>{internal}</InternalExternal>\n"
                f"        <Diameter>{fixed(f.nominal['diameter'])}</Diameter>\n"
                f"      </{f.kind}FeatureDefinition>\n")
    return f'      <{f.kind}FeatureDefinition id="{f.definition}"/>\n'


def feature_nominal(f: Feature) -> str:
    return (f'      <{f.kind}FeatureNominal id="{f.nominal_id}">\n'
            f"        <Name>{xml_text(f.name)}</Name>\n"
            f"        <FeatureDefinitionId>{f.definition}</FeatureDefinitionId>\n"
            + (geometry(f.kind, f.nominal, False, 8) if f.nominal else "")
            + f"      </{f.kind}FeatureNominal>\n")


def feature_item(kind: str, item: int, nominal_id, name: str) -> str:
    """A feature item: the feature of the nominal ``nominal_id`` as it is measured (a shape
    feature's: checked by measurement; a non-shape feature or a pattern states no mode)."""
    mode = "" if "NonShape" in kind or kind.startswith("Pattern") else (
        "        <DeterminationMode>\n          <Checked>\n            <CheckDetails>\n"
        "              <Measured/>\n            </CheckDetails>\n          </Checked>\n"
        "        </DeterminationMode>\n")
    return (f'      <{kind}FeatureItem id="{item}">\n'
            f"        <FeatureNominalId>{nominal_id}</FeatureNominalId>\n"
            f"        <FeatureName>{xml_text(name)}</FeatureName>\n"
            + mode + f"      </{kind}FeatureItem>\n")


def write_characteristics(w, q: Qif) -> None:
    """Characteristics: each one's definition (the zone, its datum reference frame), nominal
    (its feature) and item."""
    n = len(q.chars)
    w("  <Characteristics>\n")
    w(f"    <FormalStandardId>{q.ids.standard}</FormalStandardId>\n")
    w(f'    <CharacteristicDefinitions n="{n}">\n')
    for c in q.chars:
        w(characteristic_definition(c))
    w(f'    </CharacteristicDefinitions>\n    <CharacteristicNominals n="{n}">\n')
    for c in q.chars:
        w(characteristic_nominal(c))
    w(f'    </CharacteristicNominals>\n    <CharacteristicItems n="{n}">\n')
    for c in q.chars:
        w(characteristic_item(c.kind, c.item, c.nominal_id, c.name, c.designator,
                              [f.item for f in _features(c)], q.ids.device))
    w("    </CharacteristicItems>\n  </Characteristics>\n")


def characteristic_definition(c: Char) -> str:
    return (f'      <{c.kind}CharacteristicDefinition id="{c.definition}">\n'
            f"        <Description>{xml_text(c.text)}</Description>\n"
            + _zone(c) + f"      </{c.kind}CharacteristicDefinition>\n")


def characteristic_nominal(c: Char) -> str:
    out = (f'      <{c.kind}CharacteristicNominal id="{c.nominal_id}">\n'
           f"        <CharacteristicDefinitionId>{c.definition}</CharacteristicDefinitionId>\n"
           + id_list("FeatureNominalIds", [f.nominal_id for f in _features(c)], 8))
    if c.kind == "LineProfile":
        vector = "0 0 1" if tuple(c.vector) == (0.0, 0.0, 1.0) else exact(c.vector)
        out += f"        <Vector>{vector}</Vector>\n"
    if c.target is not None:
        out += f"        <TargetValue>{fixed(c.target)}</TargetValue>\n"
    if c.kind == "DistanceBetween":
        first, second = _features(c)
        out += ('        <FeatureNominalPairs n="1">\n          <FeaturePair>\n'
                f"            <FirstFeature>{first.nominal_id}</FirstFeature>\n"
                f"            <SecondFeature>{second.nominal_id}</SecondFeature>\n"
                "          </FeaturePair>\n        </FeatureNominalPairs>\n"
                "        <AnalysisMode>THREEDIMENSIONAL</AnalysisMode>\n")
    return out + f"      </{c.kind}CharacteristicNominal>\n"


def characteristic_item(kind: str, item: int, nominal_id, name: str, designator: str | None,
                        feature_items: list, device: int | None) -> str:
    """A characteristic item: the characteristic of the nominal ``nominal_id`` as it is
    measured, on the feature items ``feature_items``."""
    out = (f'      <{kind}CharacteristicItem id="{item}">\n'
           f"        <Name>{xml_text(name)}</Name>\n")
    if designator is not None:
        out += ("        <CharacteristicDesignator>\n"
                f"          <Designator>{xml_text(designator)}</Designator>\n"
                "        </CharacteristicDesignator>\n")
    out += id_list("FeatureItemIds", feature_items, 8)
    if device:
        out += id_list("MeasurementDeviceIds", [device], 8)
    return (out + f"        <CharacteristicNominalId>{nominal_id}</CharacteristicNominalId>\n"
            f"      </{kind}CharacteristicItem>\n")


def _zone(c: Char) -> str:
    """A characteristic definition's tolerance: a profile's width (and, unless symmetric,
    OuterDisposition = upper), flatness, circularity, cylindricity, straightness (its zone's
    shape), position and orientation (diametrical or planar zone, no material modifier) or
    a diameter's limits about its target; the datum reference frame where it has one."""
    s = " " * 8
    frame = f"{s}<DatumReferenceFrameId>{c.frame}</DatumReferenceFrameId>\n" if c.frame else ""
    if c.kind in ("Diameter", "Width", "SphericalDiameter") + DIMENSION_KINDS:
        return (f"{s}<Tolerance>\n{s}  <MaxValue>{fixed(c.upper)}</MaxValue>\n"
                f"{s}  <MinValue>{fixed(c.lower)}</MinValue>\n"
                f"{s}  <DefinedAsLimit>false</DefinedAsLimit>\n{s}</Tolerance>\n")
    out = f"{s}<ToleranceValue>{fixed(c.upper - c.lower)}</ToleranceValue>\n"
    if c.kind.endswith("Profile"):
        if not math.isclose(c.lower, -c.upper, rel_tol=0.0, abs_tol=1e-12):
            out += f"{s}<OuterDisposition>{fixed(c.upper)}</OuterDisposition>\n"
        return out + frame
    if c.kind == "Position":
        condition = {"MMC": "MAXIMUM", "LMC": "LEAST"}.get(c.modifier, "NONE")
        shape = {"width": "NonDiametricalZone", "sphere": "SphericalZone"}.get(
            c.feature_kind, "DiametricalZone")
        return (out + frame + f"{s}<MaterialCondition>{condition}</MaterialCondition>\n"
                f"{s}<ZoneShape>\n{s}  <{shape}/>\n{s}</ZoneShape>\n")
    if c.kind in ("Coaxiality", "Concentricity"):
        return out + frame + f"{s}<ZoneShape>\n{s}  <DiametricalZone/>\n{s}</ZoneShape>\n"
    if c.kind in ("Symmetry", "CircularRunout", "TotalRunout"):
        return out + frame
    if c.kind == "Straightness":
        shape = "DiametricalZone" if c.diametral else "NonDiametricalZone"
        return out + f"{s}<ZoneShape>\n{s}  <{shape}/>\n{s}</ZoneShape>\n"
    if c.kind in ("Parallelism", "Perpendicularity", "Angularity"):
        shape = "DiametricalZone" if c.diametral else "PlanarZone"
        return (out + frame + f"{s}<MaterialCondition>NONE</MaterialCondition>\n"
                f"{s}<ZoneShape>\n{s}  <{shape}/>\n{s}</ZoneShape>\n")
    return out


def _features(c: Char) -> list:
    """The features a characteristic is on: its one, or an angle's and a distance's two."""
    return [c.feature] if c.other is None else [c.feature, c.other]
