"""What one QIF document states, made from the JSON results document: its fixed ids, the
features, characteristics, datums and datum reference frames (the profile over all points, or
an inspection plan's), and the values every section shares."""

from __future__ import annotations

import json
import os
import uuid
from dataclasses import dataclass
from datetime import UTC, datetime

import numpy as np

from engine.choices import Fit, Verdict
from engine.errors import QAError
from engine.gdt.plan import SIZE_METHOD_WORDS

from .text import fixed, signed


QIF_NAMESPACE = "http://qifstandards.org/xsd/qif3"
QIF_VERSION = "3.0.0"
_UUID_NAMESPACE = uuid.uuid5(uuid.NAMESPACE_URL, "https://qifstandards.org/xsd/qif3#qa-inspect")

# Keyed by the verdict as the results JSON spells it (a Verdict is its str).
CHAR_STATUS: dict[str, str] = {Verdict.ACCEPT: "PASS", Verdict.REJECT: "FAIL",
                               Verdict.INCONCLUSIVE: "INDETERMINATE"}


class QIFError(QAError, ValueError):
    """The arguments of :func:`qif_results_document` do not describe one inspection (arrays of
    different lengths, an unknown verdict, an issue time that is no ISO 8601 time): a bug in the
    caller, nothing is written."""


DEVICE_KEYS = ("device", "device_serial", "calibration_date", "probe")
"""The certificate's fields that describe the measuring device (any of them: a
MeasurementDevice)."""


class _Ids:
    def __init__(self, last: int = 0):
        self.last = last

    def take(self) -> int:
        self.last += 1
        return self.last


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
class Feature:
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
class Char:
    """One characteristic (definition, nominal, item, measurement)."""

    kind: str
    """QIF's prefix: SurfaceProfile, LineProfile, Flatness, Position, Diameter."""
    definition: int
    nominal_id: int
    item: int
    measurement: int
    feature: Feature
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
    diametral: bool = False
    """Straightness and orientation: a cylindrical zone (an axis), else two lines / planes."""
    modifier: str = "RFS"
    """Position: the material condition (RFS, MMC, LMC)."""
    bonus: float | None = None
    """Position at MMC or LMC: the bonus tolerance measured, mm."""
    feature_kind: str = ""
    """Size and location: the feature of size (cylinder, sphere, width)."""
    vector: tuple[float, float, float] = (0.0, 0.0, 1.0)
    """A line profile: the normal of the plane its curve lies in (a 2D template's: z)."""
    other: Feature | None = None
    """An angle or a distance: its second feature (``feature`` is its first)."""
    feature_measurements: tuple[int, ...] = ()
    """The feature measurements it was judged on, when they are not those of ``feature`` and
    ``other``: a QIF plan's characteristic on several of its features (reports.qif.linked)."""


@dataclass(frozen=True)
class _Datum:
    id: int
    label: str
    feature: Feature | None
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
class Qif:
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
    features: tuple[Feature, ...]
    chars: tuple[Char, ...]
    datums: tuple[_Datum, ...] = ()
    frames: tuple[_Frame, ...] = ()
    length_unit: str = "mm"
    """The unit of the lengths written (a QIF plan's own, reports.qif.linked)."""

    @classmethod
    def of(cls, doc: dict, pts, dev, inside, labels, outlier, after_id: int = 0) -> Qif:
        """The document's contents; its ids are consecutive from ``after_id`` + 1 (another
        document's ids below them: a QIF plan's, reports.qif.linked)."""
        verdict = doc["verdict"]
        if verdict not in CHAR_STATUS:
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
        ids = _Ids(after_id)
        refs = _Refs.take(ids, device=any(k in cert for k in DEVICE_KEYS),
                          points=pts.shape[0] != 0,
                          transform=T.shape == (4, 4) and bool(np.isfinite(T).all()),
                          component="serial" in cert, profile=not planned)
        is_2d = doc.get("template") is not None
        path = str(nominal.get("path") or "nominal")
        whole = Feature(os.path.basename(path) or path,
                        "OtherCurve" if is_2d else "OtherSurface", refs.feat_def,
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
        seed = json.dumps(key, sort_keys=True)
        T_name = ("registration T_nominal_measured" if not planned else
                  f"plan alignment ({alignment.get('method', '?')}) T_nominal_measured")
        return cls(refs, ids.last, verdict, cert, is_2d, nominal, measured, app,
                   _xs_datetime(cert["issued"]) if "issued" in cert else None, T,
                   f"{T_name}: measured (before) to nominal (after)", pts, dev, inside, labels,
                   outlier, uuid.uuid5(_UUID_NAMESPACE, "document " + seed),
                   uuid.uuid5(_UUID_NAMESPACE, "results " + seed), *parts)

    @property
    def n(self) -> int:
        return self.pts.shape[0]

    @property
    def nominal_path(self) -> str:
        return str(self.nominal.get("path") or "nominal")

    @property
    def nominal_name(self) -> str:
        return os.path.basename(self.nominal_path) or self.nominal_path


def _whole_profile(doc: dict, refs: _Refs, whole: Feature, dev: np.ndarray, app: str) -> Char:
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
    if refs.char_def is None or refs.char_nom is None or refs.char_item is None \
            or refs.char_meas is None:  # _Refs.take(profile=True) takes them
        raise QIFError("the profile over all points has no ids: the document has a plan")
    return Char("LineProfile" if is_2d else "SurfaceProfile", refs.char_def, refs.char_nom,
                refs.char_item, refs.char_meas, whole,
                f"{'Line' if is_2d else 'Surface'} profile", None, _profile_text(lower, upper),
                lower, upper, None, None, doc["verdict"], value,
                f"{app} verdict {doc['verdict']}: {reasons}", worst)


def _profile_text(lower: float, upper: float) -> str:
    return (f"tolerance zone {fixed(lower)} .. {fixed(upper)} mm of the signed deviation along the "
            "nominal's outward normal (positive = excess material); every point must lie inside")


_GEOMETRIC = {"plane": "Plane", "cylinder": "Cylinder", "sphere": "Sphere"}
_PLAN_CHAR = {"profile": "SurfaceProfile", "flatness": "Flatness", "position": "Position",
              "size": "Diameter", "straightness": "Straightness", "circularity": "Circularity",
              "cylindricity": "Cylindricity", "parallelism": "Parallelism",
              "perpendicularity": "Perpendicularity", "angularity": "Angularity",
              "coaxiality": "Coaxiality", "concentricity": "Concentricity",
              "symmetry": "Symmetry", "circular_runout": "CircularRunout",
              "total_runout": "TotalRunout", "line_profile": "LineProfile"}
_SIZE_CHAR = {"width": "Width", "sphere": "SphericalDiameter"}
"""QIF's characteristic of a size by its feature (a cylinder's: Diameter)."""
_DIMENSION_CHAR = {"radius": "Radius", "angle": "Angle", "distance": "DistanceBetween"}
"""QIF's characteristic of a plan's dimension (a sphere's radius: SphericalRadius)."""
DIMENSION_KINDS = ("Radius", "SphericalRadius", "Angle", "DistanceBetween")


_FORM_AND_ORIENTATION = ("Straightness", "Circularity", "Cylindricity", "Parallelism",
                         "Perpendicularity", "Angularity")


def _plan(doc: dict, ids: _Ids, whole: Feature, app: str):
    """The features, characteristics, datums and datum reference frames of an inspection plan
    (the JSON's ``features``, ``characteristics`` and ``alignment``)."""
    freeform = whole.kind
    features, regions, datum_features = [whole], {}, {}
    for f in doc.get("features") or []:
        kind = _GEOMETRIC.get(f.get("feature"), freeform) if f.get("nominal") else freeform
        feat = Feature(f["region"], kind, ids.take(), ids.take(), ids.take(), ids.take(),
                        f.get("nominal") if kind != freeform else None,
                        f.get("measured") if kind != freeform else None)
        features.append(feat)
        regions[feat.name] = feat
        for d in f.get("datums") or []:
            datum_features[d["label"]] = (feat, _datum_algorithm(f, d.get("fit")))
    tol = doc.get("tolerance_in_verdict")
    for c in doc["characteristics"]:
        pair = c.get("regions", [])[1:] if c["type"] in _DIMENSION_CHAR else []
        for region in (c["region"], *pair):
            if region not in regions and not (tol and c["id"] == "tol"):
                regions[region] = Feature(region, freeform, ids.take(), ids.take(),
                                           ids.take(), ids.take())
                features.append(regions[region])
    alignment = doc.get("alignment") or {}
    reference = tuple(alignment.get("reference") or ())
    frame_labels = ([reference] if reference else []) + [
        tuple(c["datums"]) for c in doc["characteristics"] if c.get("datums")]
    labels = list(datum_features) + [x for t in frame_labels for x in t]
    datums = {}
    for label in labels:
        if label not in datums:
            datum_feature, algorithm = datum_features.get(label, (None, None))
            datums[label] = _Datum(ids.take(), label, datum_feature, algorithm)
    frames: dict[tuple, _Frame] = {}
    for t in frame_labels:
        if t not in frames:
            frames[t] = _Frame(ids.take(), t, _alignment_state(alignment) if t == reference
                               else None)
    chars = tuple(_plan_char(c, ids, regions.get(c["region"], whole), frames, app, freeform,
                             regions)
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


def _plan_char(c: dict, ids: _Ids, feature: Feature, frames: dict, app: str,
               freeform: str, regions: dict) -> Char:
    """One characteristic of the plan (its JSON entry) on its region's feature."""
    kind = _PLAN_CHAR.get(c["type"], _DIMENSION_CHAR.get(c["type"], "SurfaceProfile"))
    if kind == "Diameter":
        kind = _SIZE_CHAR.get(c.get("feature", ""), kind)
    if kind == "Radius" and c.get("feature") == "sphere":
        kind = "SphericalRadius"
    pair = c.get("regions") or []
    other = regions.get(pair[1]) if kind in ("Angle", "DistanceBetween") and len(pair) > 1 \
        else None
    if kind == "SurfaceProfile" and freeform == "OtherCurve":
        kind = "LineProfile"
    datums = tuple(c.get("datums") or ())
    frame = frames[datums].id if datums else None
    lower, upper = float(c["lower"]), float(c["upper"])
    target = None if c.get("nominal") is None else float(c["nominal"])
    where = f"region '{c['region']}'" + (f" relative to {'|'.join(datums)}" if datums else "")
    # An angle's or a distance's two features (a pattern's "features" are its fits' facts).
    pair_features = " and ".join(c.get("features") or []) \
        if kind in ("Angle", "DistanceBetween") else ""
    text = {
        "Flatness": f"flatness of {where}: minimum-zone width at most {fixed(upper - lower)} mm",
        "Position": f"position of the axis of {where}: a cylindrical zone of diameter "
                    f"{fixed(upper - lower)} mm about the true position",
        **{k: f"{SIZE_METHOD_WORDS[c.get('method', 'lsq')]} "
           f"{'width' if k == 'Width' else 'diameter'} of "
           f"{where}: {fixed(target or 0.0)} mm {signed(lower)} / {signed(upper)} mm"
           for k in ("Diameter", "Width", "SphericalDiameter")},
        **{k: f"{c['type']} of the axis of {where}: a cylindrical zone of diameter "
           f"{fixed(upper - lower)} mm about the datum axis"
           for k in ("Coaxiality", "Concentricity")},
        "Symmetry": f"symmetry of the median surface of {where}: a zone of two planes "
                    f"{fixed(upper - lower)} mm apart about the true median plane",
        **{k: f"least-squares radius of {where}: {fixed(target or 0.0)} mm {signed(lower)} / "
           f"{signed(upper)} mm" for k in ("Radius", "SphericalRadius")},
        "Angle": f"angle between the least-squares features of regions '{' and '.join(pair)}' "
                 f"({pair_features}): {fixed(target or 0.0)} degrees "
                 f"{signed(lower)} / {signed(upper)} degrees",
        "DistanceBetween": f"distance between the least-squares features of regions "
                           f"'{' and '.join(pair)}' "
                           f"({pair_features}): "
                           f"{fixed(target or 0.0)} mm {signed(lower)} / {signed(upper)} mm",
        **{k: f"{c['type']} of {where}" + (f" at {c['angle']:g}°" if c.get("angle") else "")
           + (" (diametral: the axis)" if c.get("diametral") else "") + ": minimum zone at "
           f"most {fixed(upper - lower)} mm" for k in _FORM_AND_ORIENTATION},
        **{k: f"{c['type'].replace('_', ' ')} of {where}: full indicator movement at most "
           f"{fixed(upper - lower)} mm turned about the datum axis"
           for k in ("CircularRunout", "TotalRunout")},
    }.get(kind, "all points at the registration's best fit: " + _profile_text(lower, upper)
          if feature.whole else
          f"profile of {where}" + ("" if datums else f", form only ({c.get('fit', Fit.LSQ)} "
                                   "refit)") + ": " + _profile_text(lower, upper))
    name = f"{c['type']} {c['region']}" + (" |" + "|".join(datums) if datums else "")
    value = c.get("value")
    return Char(kind, ids.take(), ids.take(), ids.take(), ids.take(), feature, name,
                str(c["id"]), text, lower, upper, target, frame, c["verdict"],
                None if value is None else float(value),
                f"{app} verdict {c['verdict']}: {c.get('reason', '')}",
                diametral=bool(c.get("diametral")), modifier=c.get("modifier") or "RFS",
                bonus=c.get("bonus"), feature_kind=c.get("feature") or "",
                vector=tuple(c.get("direction") or (0.0, 0.0, 1.0)), other=other)


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
