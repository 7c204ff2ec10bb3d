"""The Results section of a QIF document: the inspection's traceability, the measured file,
the feature and characteristic measurements, the point set, the transform and the status."""

from __future__ import annotations

import json

import numpy as np

from engine.choices import Verdict

from .model import CHAR_STATUS, QIFError, Qif
from .text import (algorithm, attributes, exact, file_description, fixed, flags, format_name,
                   geometry, id_list, numbers, uri, xml_attr, xml_text)


# InspectionStatusEnumType has no INDETERMINATE; UNKNOWN is its "cannot tell".
_INSPECTION_STATUS: dict[str, str] = {Verdict.ACCEPT: "PASS", Verdict.REJECT: "FAIL",
                                      Verdict.INCONCLUSIVE: "UNKNOWN"}


def write_results(w, q: Qif) -> None:
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
          f"            <URI>{xml_text(uri(measured_path))}</URI>\n"
          "            <FileSpec>\n              <OtherFileSpec>"
          f"{xml_text(format_name(measured_path, False))}</OtherFileSpec>\n"
          "            </FileSpec>\n"
          f"            <Description>{xml_text(file_description('measured', q.measured))}"
          "</Description>\n"
          "          </ExternalFileReference>\n        </ExternalFileReferences>\n")
    _feature_measurements(w, q)
    if ids.point_set:
        _point_set(w, ids.point_set, q.pts, q.dev, q.inside, q.labels, q.outlier, ids.device)
    _characteristic_measurements(w, q)
    if ids.transform:
        _transform(w, ids.transform, q.T, q.T_name)
    w("        <InspectionStatus>\n          <InspectionStatusEnum>"
      f"{_INSPECTION_STATUS[q.verdict]}</InspectionStatusEnum>\n        </InspectionStatus>\n")
    if ids.component:
        w(f'        <ActualComponentIds n="1">\n          <Id>{ids.component}</Id>\n'
          "        </ActualComponentIds>\n")
    w("      </MeasurementResults>\n    </MeasurementResultsSet>\n")
    if ids.component:
        w('    <ActualComponentSets n="1">\n      <ActualComponentSet n="1">\n'
          f'        <ActualComponent id="{ids.component}">\n'
          f"          <SerialNumber>{xml_text(q.cert['serial'])}</SerialNumber>\n"
          "          <Status>\n            <InspectionStatusEnum>"
          f"{_INSPECTION_STATUS[q.verdict]}</InspectionStatusEnum>\n          </Status>\n"
          "        </ActualComponent>\n      </ActualComponentSet>\n    </ActualComponentSets>\n")
    w("  </Results>\n</QIFDocument>\n")


def _feature_measurements(w, q: Qif) -> None:
    """MeasuredFeatures: each feature's measurement, pointing at the device and the transform
    of the points; the whole nominal's at the point set, a region's with its least-squares
    geometry."""
    ids = q.ids
    w(f'        <MeasuredFeatures n="{len(q.features)}">\n')
    for f in q.features:
        w(f'          <{f.kind}FeatureMeasurement id="{f.measurement}">\n'
          f"            <FeatureItemId>{f.item}</FeatureItemId>\n")
        if ids.device:
            w(id_list("MeasurementDeviceIds", [ids.device], 12))
        if ids.transform:
            w(f"            <ActualTransformId>{ids.transform}</ActualTransformId>\n")
        if f.whole and ids.point_set:
            w(f'            <PointList n="1">\n'
              f"              <WholePointSetId>{ids.point_set}</WholePointSetId>\n"
              "            </PointList>\n")
        if f.measured:
            w(algorithm("LEASTSQUARES", 12))
            w(geometry(f.kind, f.measured, True, 12))
        w(f"          </{f.kind}FeatureMeasurement>\n")
    w("        </MeasuredFeatures>\n")


def _characteristic_measurements(w, q: Qif) -> None:
    """MeasuredCharacteristics: each characteristic's status, reasons and value (a profile
    over all points also its worst deviations)."""
    ids = q.ids
    w('        <MeasuredCharacteristics>\n'
      f'          <CharacteristicMeasurements n="{len(q.chars)}">\n')
    for c in q.chars:
        if c.verdict not in CHAR_STATUS:
            raise QIFError(f"characteristic {c.designator}: unknown verdict {c.verdict!r}")
        w(f'            <{c.kind}CharacteristicMeasurement id="{c.measurement}">\n'
          f"              <Description>{xml_text(c.description)}</Description>\n"
          "              <Status>\n                <CharacteristicStatusEnum>"
          f"{CHAR_STATUS[c.verdict]}</CharacteristicStatusEnum>\n              </Status>\n"
          f"              <CharacteristicItemId>{c.item}</CharacteristicItemId>\n")
        w(id_list("FeatureMeasurementIds", list(c.feature_measurements) or (
            [c.feature.measurement] + ([] if c.other is None else [c.other.measurement])), 14))
        if ids.component:
            w(f"              <ActualComponentId>{ids.component}</ActualComponentId>\n")
        if ids.device:
            w(id_list("MeasurementDeviceIds", [ids.device], 14))
        if c.value is not None:
            w(f"              <Value>{fixed(c.value)}</Value>\n")
        if c.worst is not None:
            w(f"              <WorstPositiveDeviation>{fixed(c.worst[0])}"
              "</WorstPositiveDeviation>\n"
              f"              <WorstNegativeDeviation>{fixed(c.worst[1])}"
              "</WorstNegativeDeviation>\n")
        if c.kind == "Position" and c.bonus is not None and c.modifier != "RFS":
            w(f"              <Bonus>{fixed(c.bonus)}</Bonus>\n")
        if c.kind in ("LinearCoordinate", "AngularCoordinate"):  # a QIF plan's, not judged
            w("              <TypeOfCoordinates>\n                <CoordinateEnum>UNDEFINED"
              "</CoordinateEnum>\n              </TypeOfCoordinates>\n")
        w(f"            </{c.kind}CharacteristicMeasurement>\n")
    w("          </CharacteristicMeasurements>\n        </MeasuredCharacteristics>\n")


def _transform(w, tid: int, T: np.ndarray, name: str) -> None:
    w(f'        <ActualTransforms n="1">\n          <Transform id="{tid}">\n'
      "            <Rotation>\n"
      f"              <XDirection>{exact(T[:3, 0])}</XDirection>\n"
      f"              <YDirection>{exact(T[:3, 1])}</YDirection>\n"
      f"              <ZDirection>{exact(T[:3, 2])}</ZDirection>\n"
      "            </Rotation>\n"
      f"            <Origin>{exact(T[:3, 3])}</Origin>\n"
      f"            <Name>{xml_text(name)}</Name>\n"
      "          </Transform>\n        </ActualTransforms>\n")


def _traceability(w, cert: dict, issued: str | None) -> None:
    parts = []
    if "organisation" in cert:
        parts.append("          <InspectingOrganization>\n"
                     f"            <Name>{xml_text(cert['organisation'])}</Name>\n"
                     "          </InspectingOrganization>\n")
    if "order" in cert:
        parts.append(f"          <OrderNumber>{xml_text(cert['order'])}</OrderNumber>\n")
    if "number" in cert:
        parts.append(f"          <ReportNumber>{xml_text(cert['number'])}</ReportNumber>\n")
    if "inspector" in cert:
        parts.append("          <InspectionOperator>\n"
                     f"            <Name>{xml_text(cert['inspector'])}</Name>\n"
                     "          </InspectionOperator>\n")
    if issued:
        parts.append(f"          <ReportPreparationDate>{issued}</ReportPreparationDate>\n")
    parts.append(attributes([("D1", "qa-inspect:temperature-c", cert.get("temperature_c")),
                             ("Str", "qa-inspect:measurement-program", cert.get("program"))],
                            10))
    if any(parts):
        w("        <InspectionTraceability>\n" + "".join(parts)
          + "        </InspectionTraceability>\n")


def _point_set(w, ps_id, pts, dev, inside, labels, outlier, device) -> None:
    n = pts.shape[0]
    attrs = [("qa-inspect:in-tolerance", flags(inside))]
    if outlier is not None:
        attrs.append(("qa-inspect:excluded-from-alignment", flags(outlier)))
    if labels is not None:
        attrs.append(("qa-inspect:labels", json.dumps([str(s) for s in labels])))
    w(f'        <MeasuredPointSets n="1">\n          <MeasuredPointSet id="{ps_id}" count="{n}">\n')
    w(f'            <Attributes n="{len(attrs)}">\n')
    for name, value in attrs:
        w(f'              <AttributeStr name="{name}" value="{xml_attr(value)}"/>\n')
    w("            </Attributes>\n")
    w("            <Points>\n")
    w(numbers(pts.ravel(), 3))
    w("            </Points>\n")
    # The points are surface points (deviations were measured from them as they are), so
    # no probe-radius compensation is left to apply.
    w("            <Compensated>true</Compensated>\n")
    if device:
        w(f"            <MeasurementDeviceId>{device}</MeasurementDeviceId>\n")
    w("            <Deviations>\n")
    w(numbers(dev, 1))
    w("            </Deviations>\n")
    w("          </MeasuredPointSet>\n        </MeasuredPointSets>\n")
