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
  certificate names a device (or its serial, calibration date or probe): ``Name``,
  ``SerialNumber``, and ``AttributeStr`` "qa-inspect:probe" (probe and stylus) and
  "qa-inspect:calibration-date" (YYYY-MM-DD; a QIF ``Calibration`` needs an expiry date the
  certificate does not state); the point set and the characteristic measurement refer to it.
- ``Product/PartSet/Part``: ``Header/Name`` = part name, ``ModelNumber`` = part number,
  ``Version`` = revision, ``AttributeStr`` "qa-inspect:drawing" = the drawing number;
  ``DefinitionExternal/DigitalModel`` = the nominal file (name, format, the CAD revision as its
  ``File/Version``, sha256 in its ``Description``).
- ``Features``: one freeform feature for the nominal, ``OtherSurfaceFeature*`` for a 3D nominal,
  ``OtherCurveFeature*`` for a 2D template (QIF has no analytic type for either).
- ``Characteristics``: one profile characteristic on that feature, ``SurfaceProfile*`` (3D) or
  ``LineProfile*`` (2D, ``Vector`` 0 0 1: the template lies in its XY plane). The zone
  [lower, upper] is ``ToleranceValue`` = upper - lower plus, unless symmetric,
  ``OuterDisposition`` = upper (the ASME form of an unequal/offset zone:
  lower = OuterDisposition - ToleranceValue).
- ``Results/MeasurementResultsSet/MeasurementResults``:
  ``InspectionTraceability`` (organisation, order, certificate number as ``ReportNumber``,
  inspector as ``InspectionOperator``, issue time as ``ReportPreparationDate``, the part's
  temperature (°C) as ``AttributeD1`` "qa-inspect:temperature-c" and the measurement program as
  ``AttributeStr`` "qa-inspect:measurement-program");
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

With an inspection plan (the JSON's ``characteristics``, ``features`` and ``alignment``,
:func:`reports.results.plan_json`) the plan's characteristics take the place of the profile over
all points, as producers of CMM results write them (CheckMate, NIST's CTC models):

- ``DatumDefinitions``: one per datum, ``DatumLabel`` (an xs:NMTOKEN: other characters become
  '_', the label itself then in ``AttributeStr`` "qa-inspect:label") and ``FeatureNominalIds``:
  its datum feature.
- ``DatumReferenceFrames``: one per distinct datum sequence (the alignment's, each
  characteristic's), ``SimpleDatum`` per datum in precedence (PRIMARY, SECONDARY, TERTIARY),
  ``MaterialModifier`` NONE (no modifier on the drawing), ``ReferencedComponent`` ACTUAL (the
  datums are established on the measured part), ``SubstituteFeatureAlgorithm`` = the datum
  simulator: ONESIDED (a tangent plane), MAXINSCRIBED / MINCIRCUMSCRIBED (a tangent hole /
  shaft), LEASTSQUARES.
- ``Features``: besides the nominal's freeform feature, one per region a datum or characteristic
  uses: ``PlaneFeature*`` (nominal ``Location``, ``Normal``), ``CylinderFeature*`` (definition
  ``InternalExternal``, ``Diameter``; nominal ``Axis``), ``SphereFeature*`` (nominal
  ``Location``), the least-squares fit of the region's nominal points; a profile's region, or
  one whose nominal points do not determine its feature, is an ``OtherSurfaceFeature*``. The
  feature measurement gives the least-squares fit of its measured points (``Location`` /
  ``Normal``, ``Axis``, ``Diameter``, ``Form`` = peak to valley of the residuals) in the frame
  of the point set.
- ``Characteristics``: per plan characteristic, in the plan's order, its item's
  ``CharacteristicDesignator/Designator`` = the plan's id (the balloon): profile:
  ``SurfaceProfile*`` (zone as above, ``DatumReferenceFrameId`` when it has datums); flatness:
  ``Flatness*`` (``ToleranceValue``); position: ``Position*`` (``ToleranceValue`` = the
  diameter of the zone, ``DatumReferenceFrameId``, ``MaterialCondition`` NONE, ``ZoneShape``
  ``DiametricalZone``); size: ``Diameter*`` (``TargetValue`` = the nominal diameter,
  ``Tolerance`` ``MaxValue``/``MinValue`` = the limits about it). The zone over all points
  (``tol``), when it is part of the verdict, is a profile on the nominal's feature.
- ``MeasuredCharacteristics``: per characteristic ``Status`` (as above), ``Value`` = the JSON's
  value in the drawing's convention (absent when it could not be measured) and its reason.
- ``ActualTransforms/Transform``: the plan's alignment, the pose of the points.

Ids are consecutive integers from 1 (``idMax`` on the root). The document is deterministic: no
clock is read; ``QPId`` is a UUID 5 of the inputs' sha256s, the certificate number and the zone
(and the plan's sha256).
Numbers are written with 6 decimals (1 nm), the transform and unit vectors exactly (shortest
round-trip repr).
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

from .messages import printable

QIF_NAMESPACE = "http://qifstandards.org/xsd/qif3"
QIF_VERSION = "3.0.0"
_UUID_NAMESPACE = uuid.uuid5(uuid.NAMESPACE_URL, "https://qifstandards.org/xsd/qif3#qa-inspect")

_CHAR_STATUS = {"ACCEPT": "PASS", "REJECT": "FAIL", "INCONCLUSIVE": "INDETERMINATE"}
# InspectionStatusEnumType has no INDETERMINATE; UNKNOWN is its "cannot tell".
_INSPECTION_STATUS = {"ACCEPT": "PASS", "REJECT": "FAIL", "INCONCLUSIVE": "UNKNOWN"}

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
    for section in (_header, _definitions, _datums, _resources, _product, _features,
                    _characteristics, _results):
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
    """The document's fixed ids, consecutive from 1 in the order of the fields; None: the
    element is left out (no device named, no finite transform, no serial number, no points;
    with a plan, the profile over all points: the plan's characteristics take its place)."""

    standard: int
    device: int | None
    part: int
    definition: int
    model: int
    feat_def: int
    feat_nom: int
    feat_item: int
    char_def: int | None
    char_nom: int | None
    char_item: int | None
    results: int
    feat_meas: int
    point_set: int | None
    char_meas: int | None
    transform: int | None
    component: int | None

    @classmethod
    def take(cls, ids: _Ids, device: bool, points: bool, transform: bool, component: bool,
             profile: bool) -> _Refs:
        standard = ids.take()
        device_id = ids.take() if device else None
        part, definition, model = ids.take(), ids.take(), ids.take()
        feat_def, feat_nom, feat_item = ids.take(), ids.take(), ids.take()
        char_def, char_nom, char_item = ((ids.take(), ids.take(), ids.take()) if profile
                                         else (None, None, None))
        results, feat_meas = ids.take(), ids.take()
        # Without a plan the point set's id is taken even when there are no points: the ids
        # of such a document stay those it always had.
        point_set = ids.take() if points or profile else None
        char_meas = ids.take() if profile else None
        transform_id = ids.take() if transform else None
        component_id = ids.take() if component else None
        return cls(standard, device_id, part, definition, model, feat_def, feat_nom, feat_item,
                   char_def, char_nom, char_item, results, feat_meas,
                   point_set if points else None, char_meas, transform_id, component_id)


@dataclass(frozen=True)
class _Feature:
    """One feature (definition, nominal, item, measurement): the whole nominal (freeform; its
    measurement carries the point set) or a plan's region."""

    name: str
    kind: str
    """QIF's prefix: Plane, Cylinder, Sphere (with their geometry), OtherSurface or
    OtherCurve (freeform)."""
    definition: int
    nominal_id: int
    item: int
    measurement: int
    nominal: dict | None = None
    """Plane: point, normal; Cylinder: point, direction, diameter, internal; Sphere: centre,
    diameter, internal (the JSON's ``features``)."""
    measured: dict | None = None
    """The same least-squares geometry (no internal) with form_error, or None."""
    whole: bool = False


@dataclass(frozen=True)
class _Char:
    """One characteristic (definition, nominal, item, measurement)."""

    kind: str
    """QIF's prefix: SurfaceProfile, LineProfile, Flatness, Position, Diameter."""
    definition: int
    nominal_id: int
    item: int
    measurement: int
    feature: _Feature
    name: str
    designator: str | None
    """The drawing's balloon (the plan's id), or None."""
    text: str
    """The definition's Description."""
    lower: float
    """The zone, mm: profile: limits of the signed deviation; flatness and position: 0 ..
    the zone; Diameter: limits about ``target``."""
    upper: float
    target: float | None
    frame: int | None
    """The DatumReferenceFrame's id, or None (form only)."""
    verdict: str
    value: float | None
    description: str
    """The measurement's Description: the verdict and its reasons."""
    worst: tuple[float, float] | None = None
    """Largest and smallest deviation (the profile over all points)."""


@dataclass(frozen=True)
class _Datum:
    id: int
    label: str
    feature: _Feature | None
    """The datum feature (its region's), or None when the document does not name it."""
    algorithm: str | None
    """The datum simulator (SubstituteFeatureAlgorithmEnum), or None when unknown."""


@dataclass(frozen=True)
class _Frame:
    id: int
    labels: tuple[str, ...]
    """Datum labels, primary first."""
    alignment: str | None
    """How the plan's alignment stands when this frame places the part, else None."""


@dataclass(frozen=True)
class _Qif:
    """What the sections of one QIF document share."""

    ids: _Refs
    id_max: int
    verdict: str
    """ACCEPT, REJECT or INCONCLUSIVE."""
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
    T: np.ndarray
    """T_nominal_measured of the points, (4, 4): the registration, or the plan's alignment."""
    T_name: str
    pts: np.ndarray
    """(n, 3) registered points, mm, nominal frame."""
    dev: np.ndarray
    inside: np.ndarray
    labels: object
    outlier: np.ndarray | None
    qpid: uuid.UUID
    results_qpid: uuid.UUID
    features: tuple[_Feature, ...]
    chars: tuple[_Char, ...]
    datums: tuple[_Datum, ...] = ()
    frames: tuple[_Frame, ...] = ()

    @classmethod
    def of(cls, doc: dict, pts, dev, inside, labels, outlier) -> _Qif:
        verdict = doc["verdict"]
        if verdict not in _CHAR_STATUS:
            raise QIFError(f"unknown verdict {verdict!r}")
        cert = {k: v for k, v in (doc.get("certificate") or {}).items() if v not in (None, "")}
        inputs = {r.get("role"): r for r in doc.get("inputs", [])}
        nominal, measured = inputs.get("nominal", {}), inputs.get("measured", {})
        software = doc.get("software", {})
        app = f"{software.get('name', 'qa-inspect')} {software.get('version', '')}".strip()
        planned = doc.get("characteristics") is not None
        alignment = doc.get("alignment") or {}
        T = np.asarray(alignment.get("T_nominal_measured", doc["transform"]) if planned
                       else doc["transform"], dtype=float)
        ids = _Ids()
        refs = _Refs.take(ids, device=any(k in cert for k in DEVICE_KEYS),
                          points=pts.shape[0] != 0,
                          transform=T.shape == (4, 4) and bool(np.isfinite(T).all()),
                          component="serial" in cert, profile=not planned)
        is_2d = doc.get("template") is not None
        path = str(nominal.get("path") or "nominal")
        whole = _Feature(os.path.basename(path) or path, "OtherCurve" if is_2d else "OtherSurface", refs.feat_def,
                         refs.feat_nom, refs.feat_item, refs.feat_meas, whole=True)
        if planned:
            parts = _plan(doc, ids, whole, app)
        else:
            parts = ((whole,), (_whole_profile(doc, refs, whole, dev, app),), (), ())
        key = {"nominal": nominal.get("sha256"), "measured": measured.get("sha256"),
               "certificate": cert.get("number"), "lower": float(doc["tolerance"]["lower"]),
               "upper": float(doc["tolerance"]["upper"]), "verdict": verdict}
        if planned:
            key["plan"] = (doc.get("plan") or {}).get("sha256")
        key = json.dumps(key, sort_keys=True)
        T_name = ("registration T_nominal_measured" if not planned else
                  f"plan alignment ({alignment.get('method', '?')}) T_nominal_measured")
        return cls(refs, ids.last, verdict, cert, is_2d, nominal, measured, app,
                   _xs_datetime(cert["issued"]) if "issued" in cert else None, T,
                   f"{T_name}: measured (before) to nominal (after)", pts, dev, inside, labels,
                   outlier, uuid.uuid5(_UUID_NAMESPACE, "document " + key),
                   uuid.uuid5(_UUID_NAMESPACE, "results " + key), *parts)

    @property
    def n(self) -> int:
        return self.pts.shape[0]

    @property
    def nominal_path(self) -> str:
        return str(self.nominal.get("path") or "nominal")

    @property
    def nominal_name(self) -> str:
        return os.path.basename(self.nominal_path) or self.nominal_path


def _whole_profile(doc: dict, refs: _Refs, whole: _Feature, dev: np.ndarray, app: str) -> _Char:
    """The profile over all points (no plan): the zone, its zone-centred Value and the worst
    deviations from the per-point arrays."""
    lower, upper = float(doc["tolerance"]["lower"]), float(doc["tolerance"]["upper"])
    is_2d = whole.kind == "OtherCurve"
    finite = dev[np.isfinite(dev)]
    value = worst = None
    if finite.size:
        # Zone-centred width: comparable with ToleranceValue for symmetric, unequal and offset
        # zones alike (Value <= ToleranceValue iff every point is inside).
        value = 2.0 * float(np.abs(finite - 0.5 * (lower + upper)).max())
        worst = (float(finite.max()), float(finite.min()))
    reasons = "; ".join(str(r) for r in doc.get("reasons", []))
    return _Char("LineProfile" if is_2d else "SurfaceProfile", refs.char_def, refs.char_nom,
                 refs.char_item, refs.char_meas, whole,
                 f"{'Line' if is_2d else 'Surface'} profile", None, _profile_text(lower, upper),
                 lower, upper, None, None, doc["verdict"], value,
                 f"{app} verdict {doc['verdict']}: {reasons}", worst)


def _profile_text(lower: float, upper: float) -> str:
    return (f"tolerance zone {_f(lower)} .. {_f(upper)} mm of the signed deviation along the "
            "nominal's outward normal (positive = excess material); every point must lie inside")


_GEOMETRIC = {"plane": "Plane", "cylinder": "Cylinder", "sphere": "Sphere"}
_PLAN_CHAR = {"profile": "SurfaceProfile", "flatness": "Flatness", "position": "Position",
              "size": "Diameter"}
_PRECEDENCE = ("PRIMARY", "SECONDARY", "TERTIARY", "QUATERNARY", "QUINARY", "SENARY")


def _plan(doc: dict, ids: _Ids, whole: _Feature, app: str):
    """The features, characteristics, datums and datum reference frames of an inspection plan
    (the JSON's ``features``, ``characteristics`` and ``alignment``)."""
    freeform = whole.kind
    features, regions, datum_features = [whole], {}, {}
    for f in doc.get("features") or []:
        kind = _GEOMETRIC.get(f.get("feature"), freeform) if f.get("nominal") else freeform
        feat = _Feature(f["region"], kind, ids.take(), ids.take(), ids.take(), ids.take(),
                        f.get("nominal") if kind != freeform else None,
                        f.get("measured") if kind != freeform else None)
        features.append(feat)
        regions[feat.name] = feat
        for d in f.get("datums") or []:
            datum_features[d["label"]] = (feat, _datum_algorithm(f, d.get("fit")))
    tol = doc.get("tolerance_in_verdict")
    for c in doc["characteristics"]:
        if c["region"] not in regions and not (tol and c["id"] == "tol"):
            regions[c["region"]] = _Feature(c["region"], freeform, ids.take(), ids.take(),
                                            ids.take(), ids.take())
            features.append(regions[c["region"]])
    alignment = doc.get("alignment") or {}
    reference = tuple(alignment.get("reference") or ())
    frame_labels = ([reference] if reference else []) + [
        tuple(c["datums"]) for c in doc["characteristics"] if c.get("datums")]
    labels = list(datum_features) + [x for t in frame_labels for x in t]
    datums = {}
    for label in labels:
        if label not in datums:
            feat, algorithm = datum_features.get(label, (None, None))
            datums[label] = _Datum(ids.take(), label, feat, algorithm)
    frames: dict[tuple, _Frame] = {}
    for t in frame_labels:
        if t not in frames:
            frames[t] = _Frame(ids.take(), t, _alignment_state(alignment) if t == reference
                               else None)
    chars = tuple(_plan_char(c, ids, regions.get(c["region"], whole), frames, app, freeform)
                  for c in doc["characteristics"])
    return tuple(features), chars, tuple(datums.values()), tuple(frames.values())


def _datum_algorithm(feature: dict, fit: str | None) -> str | None:
    """The datum simulator as QIF names it: least squares; tangent: one-sided for a plane, the
    largest inscribed hole / smallest circumscribed shaft for a size feature."""
    if fit == "lsq":
        return "LEASTSQUARES"
    if fit != "tangent":
        return None
    if feature.get("feature") == "plane":
        return "ONESIDED"
    internal = (feature.get("nominal") or {}).get("internal")
    return None if internal is None else "MAXINSCRIBED" if internal else "MINCIRCUMSCRIBED"


def _alignment_state(alignment: dict) -> str:
    if alignment.get("complete", True):
        free = alignment.get("free_dofs") or []
        return ("the plan's alignment" + (f"; free: {', '.join(free)}" if free else ""))
    return f"the plan's alignment, incomplete: {alignment.get('message', '')}"


def _plan_char(c: dict, ids: _Ids, feature: _Feature, frames: dict, app: str,
               freeform: str) -> _Char:
    """One characteristic of the plan (its JSON entry) on its region's feature."""
    kind = _PLAN_CHAR.get(c["type"], "SurfaceProfile")
    if kind == "SurfaceProfile" and freeform == "OtherCurve":
        kind = "LineProfile"
    datums = tuple(c.get("datums") or ())
    frame = frames[datums].id if datums else None
    lower, upper = float(c["lower"]), float(c["upper"])
    target = None if c.get("nominal") is None else float(c["nominal"])
    where = f"region '{c['region']}'" + (f" relative to {'|'.join(datums)}" if datums else "")
    text = {
        "Flatness": f"flatness of {where}: minimum-zone width at most {_f(upper - lower)} mm",
        "Position": f"position of the axis of {where}: a cylindrical zone of diameter "
                    f"{_f(upper - lower)} mm about the true position",
        "Diameter": f"least-squares diameter of {where}: {_f(target or 0.0)} mm "
                    f"{_signed(lower)} / {_signed(upper)} mm",
    }.get(kind, "all points at the registration's best fit: " + _profile_text(lower, upper)
          if feature.whole else
          f"profile of {where}" + ("" if datums else f", form only ({c.get('fit', 'lsq')} "
                                   "refit)") + ": " + _profile_text(lower, upper))
    name = f"{c['type']} {c['region']}" + (" |" + "|".join(datums) if datums else "")
    value = c.get("value")
    return _Char(kind, ids.take(), ids.take(), ids.take(), ids.take(), feature, name,
                 str(c["id"]), text, lower, upper, target, frame, c["verdict"],
                 None if value is None else float(value),
                 f"{app} verdict {c['verdict']}: {c.get('reason', '')}")


def _header(w, q: _Qif) -> None:
    """The root element, QPId, creation time and Header (application, author)."""
    cert = q.cert
    w('<?xml version="1.0" encoding="UTF-8"?>\n')
    w(f'<QIFDocument xmlns="{QIF_NAMESPACE}" versionQIF="{QIF_VERSION}" idMax="{q.id_max}">\n')
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
    """StandardsDefinitions (ASME Y14.5) and FileUnits (mm)."""
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


def _datums(w, q: _Qif) -> None:
    """A plan's DatumDefinitions (label, datum feature) and DatumReferenceFrames (the datums
    in precedence, each established on the actual part by its simulator)."""
    if q.datums:
        w(f'  <DatumDefinitions n="{len(q.datums)}">\n')
        for d in q.datums:
            w(f'    <DatumDefinition id="{d.id}">\n')
            label = _nmtoken(d.label)
            if label != d.label:
                w('      <Attributes n="1">\n        <AttributeStr name="qa-inspect:label" '
                  f'value="{_attr(d.label)}"/>\n      </Attributes>\n')
            w(f"      <DatumLabel>{label}</DatumLabel>\n")
            if d.feature is not None:
                w(_id_list("FeatureNominalIds", [d.feature.nominal_id], 6))
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
                    w(_algorithm(d.algorithm, 12))
                w("          </SimpleDatum>\n          <Precedence>\n"
                  f"            <PrecedenceEnum>{precedence}</PrecedenceEnum>\n"
                  "          </Precedence>\n        </Datum>\n")
            name = "|".join(f.labels)
            w(f"      </Datums>\n      <Name>{_text(name)}</Name>\n")
            w(f"      <Description>{_text(f'datum reference frame {name}')}"
              f"{'; ' + _text(f.alignment) if f.alignment else ''}</Description>\n")
            w("    </DatumReferenceFrame>\n")
        w("  </DatumReferenceFrames>\n")


DEVICE_KEYS = ("device", "device_serial", "calibration_date", "probe")
"""The certificate's fields that describe the measuring device (any of them: a
MeasurementDevice)."""


def _resources(w, q: _Qif) -> None:
    """MeasurementResources, when the certificate names a device, its serial number, its
    calibration date or its probe: the device's Name (or "measuring device") and SerialNumber;
    the probe and stylus and the calibration date as attributes (a QIF Calibration needs an
    expiry date the certificate does not state)."""
    cert = q.cert
    if q.ids.device:
        w('  <MeasurementResources>\n    <MeasurementDevices n="1">\n')
        w(f'      <MeasurementDevice id="{q.ids.device}">\n'
          f"        <Name>{_text(cert.get('device', 'measuring device'))}</Name>\n")
        if "device_serial" in cert:
            w(f"        <SerialNumber>{_text(cert['device_serial'])}</SerialNumber>\n")
        w(_attributes([("Str", "qa-inspect:probe", cert.get("probe")),
                       ("Str", "qa-inspect:calibration-date", cert.get("calibration_date"))], 8))
        w("      </MeasurementDevice>\n")
        w("    </MeasurementDevices>\n  </MeasurementResources>\n")


def _attributes(items, indent: int) -> str:
    """QIF Attributes of (kind, name, value) items whose value is given ("" when none):
    kind "Str" (AttributeStr) or "D1" (AttributeD1, a number)."""
    items = [(k, n, v) for k, n, v in items if v not in (None, "")]
    if not items:
        return ""
    pad = " " * indent
    body = "".join(f'{pad}  <Attribute{k} name="{n}" value="'
                   f'{_attr(v) if k == "Str" else _f(float(v))}"/>\n' for k, n, v in items)
    return f'{pad}<Attributes n="{len(items)}">\n{body}{pad}</Attributes>\n'



def _product(w, q: _Qif) -> None:
    """Product/PartSet/Part: name, part number, revision and the nominal file."""
    ids, cert, nominal_path = q.ids, q.cert, q.nominal_path
    w(f'  <Product>\n    <PartSet n="1">\n      <Part id="{ids.part}">\n')
    w(_attributes([("Str", "qa-inspect:drawing", cert.get("drawing"))], 8))
    if "part_name" in cert:
        w(f"        <Header>\n          <Name>{_text(cert['part_name'])}</Name>\n"
          "        </Header>\n")
    if "part_number" in cert:
        w(f"        <ModelNumber>{_text(cert['part_number'])}</ModelNumber>\n")
    if "revision" in cert:
        w(f"        <Version>{_text(cert['revision'])}</Version>\n")
    w(_id_list("FeatureNominalIds", [f.nominal_id for f in q.features], 8))
    w(_id_list("CharacteristicNominalIds", [c.nominal_id for c in q.chars], 8))
    w(f'        <DefinitionExternal id="{ids.definition}" n="1">\n'
      f'          <DigitalModel id="{ids.model}">\n'
      f"            <Name>{_text(q.nominal_name)}</Name>\n"
      f"            <File>\n              <Name>{_text(nominal_path)}</Name>\n"
      + (f"              <Version>{_text(cert['cad_revision'])}</Version>\n"
         if "cad_revision" in cert else "") +
      f"              <Format>\n                <OtherDigitalModelFormat>"
      f"{_text(_format_name(nominal_path, q.is_2d))}</OtherDigitalModelFormat>\n"
      "              </Format>\n            </File>\n"
      f"            <Description>{_text(_file_description('nominal', q.nominal))}"
      "</Description>\n"
      "          </DigitalModel>\n        </DefinitionExternal>\n")
    w("      </Part>\n    </PartSet>\n  </Product>\n")


def _features(w, q: _Qif) -> None:
    """Features: each feature's definition, nominal (with its geometry) and item."""
    n = len(q.features)
    w(f'  <Features>\n    <FeatureDefinitions n="{n}">\n')
    for f in q.features:
        if f.kind in ("Cylinder", "Sphere"):
            internal = "INTERNAL" if f.nominal.get("internal") else "EXTERNAL"
            w(f'      <{f.kind}FeatureDefinition id="{f.definition}">\n'
              f"        <InternalExternal>{internal}</InternalExternal>\n"
              f"        <Diameter>{_f(f.nominal['diameter'])}</Diameter>\n"
              f"      </{f.kind}FeatureDefinition>\n")
        else:
            w(f'      <{f.kind}FeatureDefinition id="{f.definition}"/>\n')
    w(f'    </FeatureDefinitions>\n    <FeatureNominals n="{n}">\n')
    for f in q.features:
        w(f'      <{f.kind}FeatureNominal id="{f.nominal_id}">\n'
          f"        <Name>{_text(f.name)}</Name>\n"
          f"        <FeatureDefinitionId>{f.definition}</FeatureDefinitionId>\n")
        if f.nominal:
            w(_geometry(f.kind, f.nominal, False, 8))
        w(f"      </{f.kind}FeatureNominal>\n")
    w(f'    </FeatureNominals>\n    <FeatureItems n="{n}">\n')
    for f in q.features:
        w(f'      <{f.kind}FeatureItem id="{f.item}">\n'
          f"        <FeatureNominalId>{f.nominal_id}</FeatureNominalId>\n"
          f"        <FeatureName>{_text(f.name)}</FeatureName>\n"
          "        <DeterminationMode>\n          <Checked>\n            <CheckDetails>\n"
          "              <Measured/>\n            </CheckDetails>\n          </Checked>\n"
          "        </DeterminationMode>\n"
          f"      </{f.kind}FeatureItem>\n")
    w("    </FeatureItems>\n  </Features>\n")


def _geometry(kind: str, g: dict, measured: bool, indent: int) -> str:
    """A plane's, cylinder's or sphere's elements (nominal; measured: with the diameter of a
    cylinder or sphere and the form error)."""
    s = " " * indent
    if kind == "Plane":
        out = (f"{s}<Location>{_point(g['point'])}</Location>\n"
               f"{s}<Normal>{_g(g['normal'])}</Normal>\n")
    elif kind == "Cylinder":
        out = (f"{s}<Axis>\n{s}  <AxisPoint>{_point(g['point'])}</AxisPoint>\n"
               f"{s}  <Direction>{_g(g['direction'])}</Direction>\n{s}</Axis>\n")
    else:
        out = f"{s}<Location>{_point(g['centre'])}</Location>\n"
    if measured and kind != "Plane":
        out += f"{s}<Diameter>{_f(g['diameter'])}</Diameter>\n"
    if measured and g.get("form_error") is not None:
        out += f"{s}<Form>{_f(g['form_error'])}</Form>\n"
    return out


def _characteristics(w, q: _Qif) -> None:
    """Characteristics: each one's definition (the zone, its datum reference frame), nominal
    (its feature) and item."""
    n = len(q.chars)
    w("  <Characteristics>\n")
    w(f"    <FormalStandardId>{q.ids.standard}</FormalStandardId>\n")
    w(f'    <CharacteristicDefinitions n="{n}">\n')
    for c in q.chars:
        w(f'      <{c.kind}CharacteristicDefinition id="{c.definition}">\n'
          f"        <Description>{_text(c.text)}</Description>\n")
        w(_zone(c))
        w(f"      </{c.kind}CharacteristicDefinition>\n")
    w(f'    </CharacteristicDefinitions>\n    <CharacteristicNominals n="{n}">\n')
    for c in q.chars:
        w(f'      <{c.kind}CharacteristicNominal id="{c.nominal_id}">\n'
          f"        <CharacteristicDefinitionId>{c.definition}</CharacteristicDefinitionId>\n")
        w(_id_list("FeatureNominalIds", [c.feature.nominal_id], 8))
        if c.kind == "LineProfile":
            w("        <Vector>0 0 1</Vector>\n")
        if c.target is not None:
            w(f"        <TargetValue>{_f(c.target)}</TargetValue>\n")
        w(f"      </{c.kind}CharacteristicNominal>\n")
    w(f'    </CharacteristicNominals>\n    <CharacteristicItems n="{n}">\n')
    for c in q.chars:
        w(f'      <{c.kind}CharacteristicItem id="{c.item}">\n'
          f"        <Name>{_text(c.name)}</Name>\n")
        if c.designator is not None:
            w("        <CharacteristicDesignator>\n"
              f"          <Designator>{_text(c.designator)}</Designator>\n"
              "        </CharacteristicDesignator>\n")
        w(_id_list("FeatureItemIds", [c.feature.item], 8))
        if q.ids.device:
            w(_id_list("MeasurementDeviceIds", [q.ids.device], 8))
        w(f"        <CharacteristicNominalId>{c.nominal_id}</CharacteristicNominalId>\n"
          f"      </{c.kind}CharacteristicItem>\n")
    w("    </CharacteristicItems>\n  </Characteristics>\n")


def _zone(c: _Char) -> str:
    """A characteristic definition's tolerance: a profile's width (and, unless symmetric,
    OuterDisposition = upper), flatness, position (diametrical zone, no material modifier) or
    a diameter's limits about its target; the datum reference frame where it has one."""
    s = " " * 8
    frame = f"{s}<DatumReferenceFrameId>{c.frame}</DatumReferenceFrameId>\n" if c.frame else ""
    if c.kind == "Diameter":
        return (f"{s}<Tolerance>\n{s}  <MaxValue>{_f(c.upper)}</MaxValue>\n"
                f"{s}  <MinValue>{_f(c.lower)}</MinValue>\n"
                f"{s}  <DefinedAsLimit>false</DefinedAsLimit>\n{s}</Tolerance>\n")
    out = f"{s}<ToleranceValue>{_f(c.upper - c.lower)}</ToleranceValue>\n"
    if c.kind.endswith("Profile"):
        if not math.isclose(c.lower, -c.upper, rel_tol=0.0, abs_tol=1e-12):
            out += f"{s}<OuterDisposition>{_f(c.upper)}</OuterDisposition>\n"
        return out + frame
    if c.kind == "Position":
        return (out + frame + f"{s}<MaterialCondition>NONE</MaterialCondition>\n"
                f"{s}<ZoneShape>\n{s}  <DiametricalZone/>\n{s}</ZoneShape>\n")
    return out


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
          f"          <SerialNumber>{_text(q.cert['serial'])}</SerialNumber>\n"
          "          <Status>\n            <InspectionStatusEnum>"
          f"{_INSPECTION_STATUS[q.verdict]}</InspectionStatusEnum>\n          </Status>\n"
          "        </ActualComponent>\n      </ActualComponentSet>\n    </ActualComponentSets>\n")
    w("  </Results>\n</QIFDocument>\n")


def _feature_measurements(w, q: _Qif) -> None:
    """MeasuredFeatures: each feature's measurement, pointing at the device and the transform
    of the points; the whole nominal's at the point set, a region's with its least-squares
    geometry."""
    ids = q.ids
    w(f'        <MeasuredFeatures n="{len(q.features)}">\n')
    for f in q.features:
        w(f'          <{f.kind}FeatureMeasurement id="{f.measurement}">\n'
          f"            <FeatureItemId>{f.item}</FeatureItemId>\n")
        if ids.device:
            w(_id_list("MeasurementDeviceIds", [ids.device], 12))
        if ids.transform:
            w(f"            <ActualTransformId>{ids.transform}</ActualTransformId>\n")
        if f.whole and ids.point_set:
            w(f'            <PointList n="1">\n'
              f"              <WholePointSetId>{ids.point_set}</WholePointSetId>\n"
              "            </PointList>\n")
        if f.measured:
            w(_algorithm("LEASTSQUARES", 12))
            w(_geometry(f.kind, f.measured, True, 12))
        w(f"          </{f.kind}FeatureMeasurement>\n")
    w("        </MeasuredFeatures>\n")


def _characteristic_measurements(w, q: _Qif) -> None:
    """MeasuredCharacteristics: each characteristic's status, reasons and value (a profile
    over all points also its worst deviations)."""
    ids = q.ids
    w('        <MeasuredCharacteristics>\n'
      f'          <CharacteristicMeasurements n="{len(q.chars)}">\n')
    for c in q.chars:
        if c.verdict not in _CHAR_STATUS:
            raise QIFError(f"characteristic {c.designator}: unknown verdict {c.verdict!r}")
        w(f'            <{c.kind}CharacteristicMeasurement id="{c.measurement}">\n'
          f"              <Description>{_text(c.description)}</Description>\n"
          "              <Status>\n                <CharacteristicStatusEnum>"
          f"{_CHAR_STATUS[c.verdict]}</CharacteristicStatusEnum>\n              </Status>\n"
          f"              <CharacteristicItemId>{c.item}</CharacteristicItemId>\n")
        w(_id_list("FeatureMeasurementIds", [c.feature.measurement], 14))
        if ids.component:
            w(f"              <ActualComponentId>{ids.component}</ActualComponentId>\n")
        if ids.device:
            w(_id_list("MeasurementDeviceIds", [ids.device], 14))
        if c.value is not None:
            w(f"              <Value>{_f(c.value)}</Value>\n")
        if c.worst is not None:
            w(f"              <WorstPositiveDeviation>{_f(c.worst[0])}"
              "</WorstPositiveDeviation>\n"
              f"              <WorstNegativeDeviation>{_f(c.worst[1])}"
              "</WorstNegativeDeviation>\n")
        w(f"            </{c.kind}CharacteristicMeasurement>\n")
    w("          </CharacteristicMeasurements>\n        </MeasuredCharacteristics>\n")


def _transform(w, tid: int, T: np.ndarray, name: str) -> None:
    w(f'        <ActualTransforms n="1">\n          <Transform id="{tid}">\n'
      "            <Rotation>\n"
      f"              <XDirection>{_g(T[:3, 0])}</XDirection>\n"
      f"              <YDirection>{_g(T[:3, 1])}</YDirection>\n"
      f"              <ZDirection>{_g(T[:3, 2])}</ZDirection>\n"
      "            </Rotation>\n"
      f"            <Origin>{_g(T[:3, 3])}</Origin>\n"
      f"            <Name>{_text(name)}</Name>\n"
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
    parts.append(_attributes([("D1", "qa-inspect:temperature-c", cert.get("temperature_c")),
                              ("Str", "qa-inspect:measurement-program", cert.get("program"))],
                             10))
    if any(parts):
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


def _id_list(tag: str, values, indent: int) -> str:
    s = " " * indent
    return (f'{s}<{tag} n="{len(values)}">\n' + "".join(f"{s}  <Id>{v}</Id>\n" for v in values)
            + f"{s}</{tag}>\n")


def _algorithm(name: str, indent: int) -> str:
    s = " " * indent
    return (f"{s}<SubstituteFeatureAlgorithm>\n"
            f"{s}  <SubstituteFeatureAlgorithmEnum>{name}</SubstituteFeatureAlgorithmEnum>\n"
            f"{s}</SubstituteFeatureAlgorithm>\n")


def _signed(v: float) -> str:
    s = _f(v)
    return s if s.startswith("-") else "+" + s


def _point(p) -> str:
    return " ".join(_f(float(v)) for v in p)


def _nmtoken(s: str) -> str:
    """``s`` as an xs:NMTOKEN (a datum label): characters other than ASCII letters, digits and
    . - _ : become '_'."""
    return re.sub(r"[^A-Za-z0-9._:-]", "_", str(s)) or "_"


def _text(s) -> str:
    """``s`` (a file name, a label, a certificate field) as XML text: its control characters
    written out (reports.messages.printable: most are not allowed in XML 1.0 at all, and a
    dropped one would change the name), then the XML specials escaped."""
    return (printable(s).replace("&", "&amp;").replace("<", "&lt;")
            .replace(">", "&gt;"))


def _attr(s) -> str:
    return _text(s).replace('"', "&quot;")


def _uri(path: str) -> str:
    # A file name's bytes that are not UTF-8 (lone surrogates) are percent-encoded as they are.
    return quote(path.replace("\\", "/"), safe="/:._-~", errors="surrogateescape")


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
