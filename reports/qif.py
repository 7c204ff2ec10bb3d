"""QIF 3.0 results document of one inspection (ANSI/DMSC QIF 3.0, ISO 23952).

:func:`qif_results_document` turns the JSON results document (:mod:`reports.results`) and the
per-point arrays into a ``QIFDocument`` (namespace ``http://qifstandards.org/xsd/qif3``,
``versionQIF="3.0.0"``) that validates against the official ``QIFDocument.xsd``.

Units: every length is in millimetres (``FileUnits/PrimaryUnits/LinearUnit`` = mm).
Sign: a deviation is positive along the nominal's outward normal (excess material), as QIF's
``PointDeviationType/Deviation`` defines it ("positive in the direction of the normal vector").

What carries what:

- ``Header/Application/Name``: "qa-inspect <version>"; ``Header/Author``: inspector and
  organisation when the certificate names them.
- ``FileUnits``: mm. ``MeasurementResources/MeasurementDevices/MeasurementDevice``: only when the
  certificate names a device; the point set and the characteristic measurement refer to it.
- ``Product/PartSet/Part``: ``Header/Name`` = part name, ``ModelNumber`` = part number,
  ``Version`` = revision; ``DefinitionExternal/DigitalModel`` = the nominal file (name, format,
  sha256 in its ``Description``).
- ``Features``: one freeform feature for the nominal, ``OtherSurfaceFeature*`` for a 3D nominal,
  ``OtherCurveFeature*`` for a 2D template (QIF has no analytic type for either).
- ``Characteristics``: one profile characteristic on that feature, ``SurfaceProfile*`` (3D) or
  ``LineProfile*`` (2D, ``Vector`` 0 0 1: the template lies in its XY plane). The zone
  [lower, upper] is ``ToleranceValue`` = upper - lower plus, unless symmetric,
  ``OuterDisposition`` = upper (the ASME form of an unequal/offset zone:
  lower = OuterDisposition - ToleranceValue).
- ``Results/MeasurementResultsSet/MeasurementResults``:
  ``InspectionTraceability`` (organisation, order, certificate number as ``ReportNumber``,
  inspector as ``InspectionOperator``, issue time as ``ReportPreparationDate``);
  ``ExternalFileReferences``: the measured points file and its sha256;
  ``MeasuredFeatures``: the feature measurement, pointing at the point set and at the
  registration transform;
  ``MeasuredPointSets/MeasuredPointSet``: every measured point in input order, ``Points`` =
  x y z in the nominal frame (one point a line), ``Deviations`` = signed deviation (one a line),
  plus ``AttributeStr`` per-point flags ("qa-inspect:in-tolerance",
  "qa-inspect:excluded-from-alignment" (a gross outlier the fit left out; judged all the same):
  one character '1'/'0' per point) and labels ("qa-inspect:labels", a JSON array of strings);
  ``MeasuredCharacteristics``: the profile measurement: ``Status`` (PASS / FAIL / INDETERMINATE
  for ACCEPT / REJECT / INCONCLUSIVE), ``Value`` = 2 * max |d - c| with c = (lower + upper) / 2,
  the width of the smallest zone centred like the tolerance zone that holds every point (so
  Value <= ToleranceValue exactly when every point is in tolerance; 2 * max |d| for a symmetric
  zone), ``WorstPositiveDeviation`` = max d, ``WorstNegativeDeviation`` = min d, and the
  verdict's reasons in ``Description``;
  ``ActualTransforms/Transform``: T_nominal_measured (before = measured, after = nominal);
  ``InspectionStatus``: PASS / FAIL / UNKNOWN; ``ActualComponentIds`` and
  ``Results/ActualComponentSets``: the serial number, when given.

Ids are consecutive integers from 1 (``idMax`` on the root). The document is deterministic: no
clock is read; ``QPId`` is a UUID 5 of the inputs' sha256s, the certificate number and the zone.
Numbers are written with 6 decimals (1 nm), the transform exactly (shortest round-trip repr).
"""

from __future__ import annotations

import json
import math
import os
import re
import uuid
from dataclasses import dataclass
from datetime import UTC, datetime
from urllib.parse import quote

import numpy as np

from engine.errors import QAError

QIF_NAMESPACE = "http://qifstandards.org/xsd/qif3"
QIF_VERSION = "3.0.0"
_UUID_NAMESPACE = uuid.uuid5(uuid.NAMESPACE_URL, "https://qifstandards.org/xsd/qif3#qa-inspect")

_CHAR_STATUS = {"ACCEPT": "PASS", "REJECT": "FAIL", "INCONCLUSIVE": "INDETERMINATE"}
# InspectionStatusEnumType has no INDETERMINATE; UNKNOWN is its "cannot tell".
_INSPECTION_STATUS = {"ACCEPT": "PASS", "REJECT": "FAIL", "INCONCLUSIVE": "UNKNOWN"}

_XML_INVALID = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff]")


class QIFError(QAError, ValueError):
    """The arguments of :func:`qif_results_document` do not describe one inspection (arrays of
    different lengths, an unknown verdict, an issue time that is no ISO 8601 time): a bug in the
    caller, nothing is written."""


def qif_results_document(doc: dict, registered, deviations, in_tolerance, labels=None,
                         outlier=None) -> bytes:
    """The QIF 3.0 results document (UTF-8 XML bytes) of one inspection.

    doc : the dict of :func:`reports.results.result_document`, optionally with ``certificate``
        (number, part_number, part_name, serial, revision, order, inspector, organisation,
        device, issued: ISO 8601 time; any may be missing or None).
    registered : (n, 3) measured points in the nominal frame, mm ((n, 2) is taken as z = 0).
    deviations : (n,) signed deviations, mm, positive along the nominal's outward normal.
    in_tolerance : (n,) bool. labels : (n,) str or None. outlier : (n,) bool or None, the
        points excluded from the alignment as gross outliers (InspectionResult.outlier).

    Raises QIFError when the arguments do not fit together.
    """
    q = _Qif.of(doc, *_checked_points(registered, deviations, in_tolerance, labels, outlier))
    o: list[str] = []
    for section in (_header, _definitions, _product, _features, _characteristics, _results):
        section(o.append, q)
    return "".join(o).encode("utf-8")


def _checked_points(registered, deviations, in_tolerance, labels, outlier):
    """The per-point arguments as arrays (pts (n, 3), dev (n,), inside (n,), labels,
    outlier (n,) or None); QIFError when their lengths differ."""
    pts = np.asarray(registered, dtype=float)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise QIFError(f"registered must be (n, 3), got shape {pts.shape}")
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    dev = np.asarray(deviations, dtype=float).reshape(-1)
    inside = np.asarray(in_tolerance, dtype=bool).reshape(-1)
    n = pts.shape[0]
    for name, arr in (("deviations", dev), ("in_tolerance", inside)):
        if arr.size != n:
            raise QIFError(f"{name} has {arr.size} entries for {n} points")
    if labels is not None and len(labels) != n:
        raise QIFError(f"labels has {len(labels)} entries for {n} points")
    if outlier is not None:
        outlier = np.asarray(outlier, dtype=bool).reshape(-1)
        if outlier.size != n:
            raise QIFError(f"outlier has {outlier.size} entries for {n} points")
    return pts, dev, inside, labels, outlier


@dataclass(frozen=True)
class _Refs:
    """The document's ids, consecutive from 1 in the order of the fields; None: the element is
    left out (no device named, no finite transform, no serial number, no points)."""

    standard: int
    device: int | None
    part: int
    definition: int
    model: int
    feat_def: int
    feat_nom: int
    feat_item: int
    char_def: int
    char_nom: int
    char_item: int
    results: int
    feat_meas: int
    point_set: int | None
    char_meas: int
    transform: int | None
    component: int | None
    last: int
    """The largest id (``idMax``)."""

    @classmethod
    def take(cls, device: bool, points: bool, transform: bool, component: bool) -> _Refs:
        ids = _Ids()
        standard = ids.take()
        device_id = ids.take() if device else None
        part, definition, model = ids.take(), ids.take(), ids.take()
        feat_def, feat_nom, feat_item = ids.take(), ids.take(), ids.take()
        char_def, char_nom, char_item = ids.take(), ids.take(), ids.take()
        results, feat_meas, point_set, char_meas = ids.take(), ids.take(), ids.take(), ids.take()
        transform_id = ids.take() if transform else None
        component_id = ids.take() if component else None
        return cls(standard, device_id, part, definition, model, feat_def, feat_nom, feat_item,
                   char_def, char_nom, char_item, results, feat_meas,
                   point_set if points else None, char_meas, transform_id, component_id,
                   ids.last)


@dataclass(frozen=True)
class _Qif:
    """What the sections of one QIF document share."""

    ids: _Refs
    verdict: str
    """ACCEPT, REJECT or INCONCLUSIVE."""
    lower: float
    """Tolerance zone, mm."""
    upper: float
    cert: dict
    """The certificate's entries that are given (no None or empty value)."""
    is_2d: bool
    nominal: dict
    """The nominal's input record (path, sha256, n_points / n_primitives)."""
    measured: dict
    app: str
    """'qa-inspect <version>'."""
    issued: str | None
    """The certificate's issue time as an xs:dateTime, UTC."""
    reasons: str
    T: np.ndarray
    """T_nominal_measured, (4, 4)."""
    pts: np.ndarray
    """(n, 3) registered points, mm, nominal frame."""
    dev: np.ndarray
    inside: np.ndarray
    labels: object
    outlier: np.ndarray | None
    qpid: uuid.UUID
    results_qpid: uuid.UUID

    @classmethod
    def of(cls, doc: dict, pts, dev, inside, labels, outlier) -> _Qif:
        verdict = doc["verdict"]
        if verdict not in _CHAR_STATUS:
            raise QIFError(f"unknown verdict {verdict!r}")
        lower = float(doc["tolerance"]["lower"])
        upper = float(doc["tolerance"]["upper"])
        cert = {k: v for k, v in (doc.get("certificate") or {}).items() if v not in (None, "")}
        inputs = {r.get("role"): r for r in doc.get("inputs", [])}
        nominal = inputs.get("nominal", {})
        measured = inputs.get("measured", {})
        software = doc.get("software", {})
        issued = _xs_datetime(cert["issued"]) if "issued" in cert else None
        T = np.asarray(doc["transform"], dtype=float)
        ids = _Refs.take(device="device" in cert, points=pts.shape[0] != 0,
                         transform=T.shape == (4, 4) and bool(np.isfinite(T).all()),
                         component="serial" in cert)
        key = json.dumps({"nominal": nominal.get("sha256"), "measured": measured.get("sha256"),
                          "certificate": cert.get("number"), "lower": lower, "upper": upper,
                          "verdict": verdict}, sort_keys=True)
        return cls(ids, verdict, lower, upper, cert, doc.get("template") is not None, nominal,
                   measured,
                   f"{software.get('name', 'qa-inspect')} {software.get('version', '')}".strip(),
                   issued, "; ".join(str(r) for r in doc.get("reasons", [])), T, pts, dev,
                   inside, labels, outlier, uuid.uuid5(_UUID_NAMESPACE, "document " + key),
                   uuid.uuid5(_UUID_NAMESPACE, "results " + key))

    @property
    def n(self) -> int:
        return self.pts.shape[0]

    @property
    def kind(self) -> str:
        """The feature kind: 'Curve' (2D template) or 'Surface'."""
        return "Curve" if self.is_2d else "Surface"

    @property
    def profile(self) -> str:
        return "LineProfile" if self.is_2d else "SurfaceProfile"

    @property
    def nominal_path(self) -> str:
        return str(self.nominal.get("path") or "nominal")

    @property
    def nominal_name(self) -> str:
        return os.path.basename(self.nominal_path) or self.nominal_path


def _header(w, q: _Qif) -> None:
    """The root element, QPId, creation time and Header (application, author)."""
    cert = q.cert
    w('<?xml version="1.0" encoding="UTF-8"?>\n')
    w(f'<QIFDocument xmlns="{QIF_NAMESPACE}" versionQIF="{QIF_VERSION}" idMax="{q.ids.last}">\n')
    w(f"  <QPId>{q.qpid}</QPId>\n")
    if q.issued:
        w(f"  <Version>\n    <TimeCreated>{q.issued}</TimeCreated>\n  </Version>\n")
    w("  <Header>\n    <Application>\n")
    w(f"      <Name>{_text(q.app)}</Name>\n")
    w("    </Application>\n")
    if "inspector" in cert or "organisation" in cert:
        w("    <Author>\n")
        if "inspector" in cert:
            w(f"      <Name>{_text(cert['inspector'])}</Name>\n")
        if "organisation" in cert:
            w(f"      <Organization>{_text(cert['organisation'])}</Organization>\n")
        w("    </Author>\n")
    w(f"    <Description>Dimensional inspection results: {q.n} measured points against "
      f"{_text(q.nominal_name)}, signed deviations along the nominal's outward normal "
      "(positive = excess material), mm</Description>\n")
    w("  </Header>\n")


def _definitions(w, q: _Qif) -> None:
    """StandardsDefinitions (ASME Y14.5), FileUnits (mm) and, when the certificate names a
    device, MeasurementResources."""
    # Characteristics must cite a formal standard; OuterDisposition is the ASME form of an
    # unequally disposed profile zone.
    w(f'  <StandardsDefinitions n="1">\n    <Standard id="{q.ids.standard}">\n'
      "      <Organization>\n        <StandardsOrganizationEnum>ASME</StandardsOrganizationEnum>\n"
      "      </Organization>\n      <Designator>Y14.5</Designator>\n      <Year>2018</Year>\n"
      "    </Standard>\n  </StandardsDefinitions>\n")
    w("  <FileUnits>\n    <PrimaryUnits>\n      <LinearUnit>\n"
      "        <SIUnitName>meter</SIUnitName>\n        <UnitName>mm</UnitName>\n"
      "        <UnitConversion>\n          <Factor>0.001</Factor>\n        </UnitConversion>\n"
      "      </LinearUnit>\n    </PrimaryUnits>\n  </FileUnits>\n")
    if q.ids.device:
        w('  <MeasurementResources>\n    <MeasurementDevices n="1">\n')
        w(f'      <MeasurementDevice id="{q.ids.device}">\n'
          f"        <Name>{_text(q.cert['device'])}</Name>\n      </MeasurementDevice>\n")
        w("    </MeasurementDevices>\n  </MeasurementResources>\n")


def _product(w, q: _Qif) -> None:
    """Product/PartSet/Part: name, part number, revision and the nominal file."""
    ids, cert, nominal_path = q.ids, q.cert, q.nominal_path
    w(f'  <Product>\n    <PartSet n="1">\n      <Part id="{ids.part}">\n')
    if "part_name" in cert:
        w(f"        <Header>\n          <Name>{_text(cert['part_name'])}</Name>\n"
          "        </Header>\n")
    if "part_number" in cert:
        w(f"        <ModelNumber>{_text(cert['part_number'])}</ModelNumber>\n")
    if "revision" in cert:
        w(f"        <Version>{_text(cert['revision'])}</Version>\n")
    w(f'        <FeatureNominalIds n="1">\n          <Id>{ids.feat_nom}</Id>\n'
      "        </FeatureNominalIds>\n")
    w(f'        <CharacteristicNominalIds n="1">\n          <Id>{ids.char_nom}</Id>\n'
      "        </CharacteristicNominalIds>\n")
    w(f'        <DefinitionExternal id="{ids.definition}" n="1">\n'
      f'          <DigitalModel id="{ids.model}">\n'
      f"            <Name>{_text(q.nominal_name)}</Name>\n"
      f"            <File>\n              <Name>{_text(nominal_path)}</Name>\n"
      f"              <Format>\n                <OtherDigitalModelFormat>"
      f"{_text(_format_name(nominal_path, q.is_2d))}</OtherDigitalModelFormat>\n"
      "              </Format>\n            </File>\n"
      f"            <Description>{_text(_file_description('nominal', q.nominal))}"
      "</Description>\n"
      "          </DigitalModel>\n        </DefinitionExternal>\n")
    w("      </Part>\n    </PartSet>\n  </Product>\n")


def _features(w, q: _Qif) -> None:
    """Features: the nominal as one freeform feature (definition, nominal, item)."""
    ids, kind, name = q.ids, q.kind, _text(q.nominal_name)
    w("  <Features>\n")
    w(f'    <FeatureDefinitions n="1">\n'
      f'      <Other{kind}FeatureDefinition id="{ids.feat_def}"/>\n'
      "    </FeatureDefinitions>\n")
    w(f'    <FeatureNominals n="1">\n      <Other{kind}FeatureNominal id="{ids.feat_nom}">\n'
      f"        <Name>{name}</Name>\n"
      f"        <FeatureDefinitionId>{ids.feat_def}</FeatureDefinitionId>\n"
      f"      </Other{kind}FeatureNominal>\n    </FeatureNominals>\n")
    w(f'    <FeatureItems n="1">\n      <Other{kind}FeatureItem id="{ids.feat_item}">\n'
      f"        <FeatureNominalId>{ids.feat_nom}</FeatureNominalId>\n"
      f"        <FeatureName>{name}</FeatureName>\n"
      "        <DeterminationMode>\n          <Checked>\n            <CheckDetails>\n"
      "              <Measured/>\n            </CheckDetails>\n          </Checked>\n"
      "        </DeterminationMode>\n"
      f"      </Other{kind}FeatureItem>\n    </FeatureItems>\n")
    w("  </Features>\n")


def _characteristics(w, q: _Qif) -> None:
    """Characteristics: the profile tolerance on the feature (definition with the zone,
    nominal, item)."""
    ids, profile, lower, upper = q.ids, q.profile, q.lower, q.upper
    symmetric = math.isclose(lower, -upper, rel_tol=0.0, abs_tol=1e-12)
    w("  <Characteristics>\n")
    w(f"    <FormalStandardId>{ids.standard}</FormalStandardId>\n")
    w(f'    <CharacteristicDefinitions n="1">\n'
      f'      <{profile}CharacteristicDefinition id="{ids.char_def}">\n'
      f"        <Description>tolerance zone {_f(lower)} .. {_f(upper)} mm of the signed "
      "deviation along the nominal's outward normal (positive = excess material); "
      "every point must lie inside</Description>\n"
      f"        <ToleranceValue>{_f(upper - lower)}</ToleranceValue>\n")
    if not symmetric:
        w(f"        <OuterDisposition>{_f(upper)}</OuterDisposition>\n")
    w(f"      </{profile}CharacteristicDefinition>\n    </CharacteristicDefinitions>\n")
    w(f'    <CharacteristicNominals n="1">\n'
      f'      <{profile}CharacteristicNominal id="{ids.char_nom}">\n'
      f"        <CharacteristicDefinitionId>{ids.char_def}</CharacteristicDefinitionId>\n"
      f'        <FeatureNominalIds n="1">\n          <Id>{ids.feat_nom}</Id>\n'
      "        </FeatureNominalIds>\n")
    if q.is_2d:
        w("        <Vector>0 0 1</Vector>\n")
    w(f"      </{profile}CharacteristicNominal>\n    </CharacteristicNominals>\n")
    w(f'    <CharacteristicItems n="1">\n'
      f'      <{profile}CharacteristicItem id="{ids.char_item}">\n'
      f"        <Name>{'Line' if q.is_2d else 'Surface'} profile</Name>\n"
      f'        <FeatureItemIds n="1">\n          <Id>{ids.feat_item}</Id>\n'
      "        </FeatureItemIds>\n")
    if ids.device:
        w(f'        <MeasurementDeviceIds n="1">\n          <Id>{ids.device}</Id>\n'
          "        </MeasurementDeviceIds>\n")
    w(f"        <CharacteristicNominalId>{ids.char_nom}</CharacteristicNominalId>\n"
      f"      </{profile}CharacteristicItem>\n    </CharacteristicItems>\n")
    w("  </Characteristics>\n")


def _results(w, q: _Qif) -> None:
    """Results: one MeasurementResults (traceability, the measured file, the feature
    measurement, the point set, the characteristic measurement, the transform, the status)
    and the serial number's ActualComponentSets."""
    ids = q.ids
    w(f'  <Results>\n    <MeasurementResultsSet n="1">\n'
      f'      <MeasurementResults id="{ids.results}">\n')
    _traceability(w, q.cert, q.issued)
    w(f"        <ThisResultsInstanceQPId>{q.results_qpid}</ThisResultsInstanceQPId>\n")
    measured_path = str(q.measured.get("path") or "")
    if measured_path:
        w('        <ExternalFileReferences n="1">\n          <ExternalFileReference>\n'
          f"            <URI>{_text(_uri(measured_path))}</URI>\n"
          "            <FileSpec>\n              <OtherFileSpec>"
          f"{_text(_format_name(measured_path, False))}</OtherFileSpec>\n"
          "            </FileSpec>\n"
          f"            <Description>{_text(_file_description('measured', q.measured))}"
          "</Description>\n"
          "          </ExternalFileReference>\n        </ExternalFileReferences>\n")
    _feature_measurement(w, q)
    if ids.point_set:
        _point_set(w, ids.point_set, q.pts, q.dev, q.inside, q.labels, q.outlier, ids.device)
    _characteristic_measurement(w, q)
    if ids.transform:
        _transform(w, ids.transform, q.T)
    w("        <InspectionStatus>\n          <InspectionStatusEnum>"
      f"{_INSPECTION_STATUS[q.verdict]}</InspectionStatusEnum>\n        </InspectionStatus>\n")
    if ids.component:
        w(f'        <ActualComponentIds n="1">\n          <Id>{ids.component}</Id>\n'
          "        </ActualComponentIds>\n")
    w("      </MeasurementResults>\n    </MeasurementResultsSet>\n")
    if ids.component:
        w('    <ActualComponentSets n="1">\n      <ActualComponentSet n="1">\n'
          f'        <ActualComponent id="{ids.component}">\n'
          f"          <SerialNumber>{_text(q.cert['serial'])}</SerialNumber>\n"
          "          <Status>\n            <InspectionStatusEnum>"
          f"{_INSPECTION_STATUS[q.verdict]}</InspectionStatusEnum>\n          </Status>\n"
          "        </ActualComponent>\n      </ActualComponentSet>\n    </ActualComponentSets>\n")
    w("  </Results>\n</QIFDocument>\n")


def _feature_measurement(w, q: _Qif) -> None:
    """MeasuredFeatures: the feature measurement, pointing at the device, the registration
    transform and the point set."""
    ids, kind = q.ids, q.kind
    w(f'        <MeasuredFeatures n="1">\n'
      f'          <Other{kind}FeatureMeasurement id="{ids.feat_meas}">\n'
      f"            <FeatureItemId>{ids.feat_item}</FeatureItemId>\n")
    if ids.device:
        w(f'            <MeasurementDeviceIds n="1">\n              <Id>{ids.device}</Id>\n'
          "            </MeasurementDeviceIds>\n")
    if ids.transform:
        w(f"            <ActualTransformId>{ids.transform}</ActualTransformId>\n")
    if ids.point_set:
        w(f'            <PointList n="1">\n'
          f"              <WholePointSetId>{ids.point_set}</WholePointSetId>\n"
          "            </PointList>\n")
    w(f"          </Other{kind}FeatureMeasurement>\n        </MeasuredFeatures>\n")


def _characteristic_measurement(w, q: _Qif) -> None:
    """MeasuredCharacteristics: the profile's status, reasons and zone-centred Value."""
    ids, profile = q.ids, q.profile
    w('        <MeasuredCharacteristics>\n          <CharacteristicMeasurements n="1">\n'
      f'            <{profile}CharacteristicMeasurement id="{ids.char_meas}">\n')
    w(f"              <Description>{_text(f'{q.app} verdict {q.verdict}: {q.reasons}')}"
      "</Description>\n")
    w("              <Status>\n                <CharacteristicStatusEnum>"
      f"{_CHAR_STATUS[q.verdict]}</CharacteristicStatusEnum>\n              </Status>\n"
      f"              <CharacteristicItemId>{ids.char_item}</CharacteristicItemId>\n"
      f'              <FeatureMeasurementIds n="1">\n                <Id>{ids.feat_meas}</Id>\n'
      "              </FeatureMeasurementIds>\n")
    if ids.component:
        w(f"              <ActualComponentId>{ids.component}</ActualComponentId>\n")
    if ids.device:
        w(f'              <MeasurementDeviceIds n="1">\n                <Id>{ids.device}</Id>\n'
          "              </MeasurementDeviceIds>\n")
    finite = q.dev[np.isfinite(q.dev)]
    if finite.size:
        # Zone-centred width: comparable with ToleranceValue for symmetric, unequal and offset
        # zones alike (Value <= ToleranceValue iff every point is inside).
        centre = 0.5 * (q.lower + q.upper)
        w(f"              <Value>{_f(2.0 * float(np.abs(finite - centre).max()))}</Value>\n"
          f"              <WorstPositiveDeviation>{_f(float(finite.max()))}"
          "</WorstPositiveDeviation>\n"
          f"              <WorstNegativeDeviation>{_f(float(finite.min()))}"
          "</WorstNegativeDeviation>\n")
    w(f"            </{profile}CharacteristicMeasurement>\n"
      "          </CharacteristicMeasurements>\n        </MeasuredCharacteristics>\n")


def _transform(w, tid: int, T: np.ndarray) -> None:
    w(f'        <ActualTransforms n="1">\n          <Transform id="{tid}">\n'
      "            <Rotation>\n"
      f"              <XDirection>{_g(T[:3, 0])}</XDirection>\n"
      f"              <YDirection>{_g(T[:3, 1])}</YDirection>\n"
      f"              <ZDirection>{_g(T[:3, 2])}</ZDirection>\n"
      "            </Rotation>\n"
      f"            <Origin>{_g(T[:3, 3])}</Origin>\n"
      "            <Name>registration T_nominal_measured: measured (before) to nominal "
      "(after)</Name>\n"
      "          </Transform>\n        </ActualTransforms>\n")


def _traceability(w, cert: dict, issued: str | None) -> None:
    parts = []
    if "organisation" in cert:
        parts.append("          <InspectingOrganization>\n"
                     f"            <Name>{_text(cert['organisation'])}</Name>\n"
                     "          </InspectingOrganization>\n")
    if "order" in cert:
        parts.append(f"          <OrderNumber>{_text(cert['order'])}</OrderNumber>\n")
    if "number" in cert:
        parts.append(f"          <ReportNumber>{_text(cert['number'])}</ReportNumber>\n")
    if "inspector" in cert:
        parts.append("          <InspectionOperator>\n"
                     f"            <Name>{_text(cert['inspector'])}</Name>\n"
                     "          </InspectionOperator>\n")
    if issued:
        parts.append(f"          <ReportPreparationDate>{issued}</ReportPreparationDate>\n")
    if parts:
        w("        <InspectionTraceability>\n" + "".join(parts)
          + "        </InspectionTraceability>\n")


def _point_set(w, ps_id, pts, dev, inside, labels, outlier, device) -> None:
    n = pts.shape[0]
    attrs = [("qa-inspect:in-tolerance", _flags(inside))]
    if outlier is not None:
        attrs.append(("qa-inspect:excluded-from-alignment", _flags(outlier)))
    if labels is not None:
        attrs.append(("qa-inspect:labels", json.dumps([str(s) for s in labels])))
    w(f'        <MeasuredPointSets n="1">\n          <MeasuredPointSet id="{ps_id}" count="{n}">\n')
    w(f'            <Attributes n="{len(attrs)}">\n')
    for name, value in attrs:
        w(f'              <AttributeStr name="{name}" value="{_attr(value)}"/>\n')
    w("            </Attributes>\n")
    w("            <Points>\n")
    w(_numbers(pts.ravel(), 3))
    w("            </Points>\n")
    # The points are surface points (deviations were measured from them as they are), so
    # no probe-radius compensation is left to apply.
    w("            <Compensated>true</Compensated>\n")
    if device:
        w(f"            <MeasurementDeviceId>{device}</MeasurementDeviceId>\n")
    w("            <Deviations>\n")
    w(_numbers(dev, 1))
    w("            </Deviations>\n")
    w("          </MeasuredPointSet>\n        </MeasuredPointSets>\n")


class _Ids:
    def __init__(self):
        self.last = 0

    def take(self) -> int:
        self.last += 1
        return self.last


def _numbers(values: np.ndarray, per_line: int) -> str:
    """'%.6f' numbers, ``per_line`` a line; one %-format over the whole array is the fast path."""
    flat = np.asarray(values, dtype=float).ravel()
    if flat.size == 0:
        return ""
    text = (("%.6f " * (per_line - 1) + "%.6f\n") * (flat.size // per_line)) % tuple(flat.tolist())
    if not np.isfinite(flat).all():
        # '%f' gives nan/inf; xs:double spells them NaN/INF.
        text = re.sub(r"-?nan|-?inf", lambda m: {"nan": "NaN", "-nan": "NaN", "inf": "INF",
                                                  "-inf": "-INF"}[m.group(0)], text)
    return text


def _flags(mask: np.ndarray) -> str:
    return (np.asarray(mask, dtype=bool).astype(np.uint8) + ord("0")).tobytes().decode("ascii")


def _f(v: float) -> str:
    s = f"{v:.6f}"
    return "0.000000" if s == "-0.000000" else s


def _g(vec) -> str:
    return " ".join(repr(float(v)) for v in vec)


def _text(s) -> str:
    s = _XML_INVALID.sub("", str(s))
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _attr(s) -> str:
    return (_text(s).replace('"', "&quot;").replace("\n", "&#10;").replace("\r", "&#13;")
            .replace("\t", "&#9;"))


def _uri(path: str) -> str:
    return quote(path.replace("\\", "/"), safe="/:._-~")


def _format_name(path: str, is_template: bool) -> str:
    ext = os.path.splitext(path)[1].lstrip(".").upper() or "unknown"
    return f"{ext} 2D template" if is_template else ext


def _file_description(role: str, rec: dict) -> str:
    bits = [f"{role} file"]
    if rec.get("sha256"):
        bits.append(f"sha256 {rec['sha256']}")
    if rec.get("n_points") is not None:
        bits.append(f"{rec['n_points']} points")
    if rec.get("n_primitives") is not None:
        bits.append(f"{rec['n_primitives']} primitives")
    return ", ".join(bits)


def _xs_datetime(value) -> str:
    """ISO 8601 time as an xs:dateTime in UTC (naive times are taken as UTC)."""
    text = str(value).strip()
    try:
        t = datetime.fromisoformat(text[:-1] + "+00:00" if text.endswith("Z") else text)
    except ValueError:
        raise QIFError(f"certificate 'issued' is not an ISO 8601 time: {text!r}") from None
    if t.tzinfo is None:
        t = t.replace(tzinfo=UTC)
    return t.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
