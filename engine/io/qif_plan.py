"""Inspection plans read from a QIF 3.0 model-based definition (``.qif``/``.QIF``: a
``QIFDocument`` with ``Product``, ``Features`` and ``Characteristics``) ->
engine.gdt.plan.Plan, the same object a TOML plan gives.

What is read
    * units: the file's primary linear unit (``FileUnits``; its ``PMILinearUnit``, where it
      states one, for the characteristics' values), a value's own ``linearUnit`` where
      it names another of the file's units, and the ``ScaleCoefficient`` the Product declares
      for its geometry (Product and Features values are divided by it); everything in mm.
    * features: each ``…FeatureNominal`` with the faces of the file's own B-rep it is made of
      (``EntityInternalIds``); a plan region per feature (``qif:ID``), or per set of features
      a characteristic applies to together (``qif:ID+ID``), selecting the group of the same
      name: the STEP faces :func:`qif_face_groups` finds for it by geometry.
    * datums: each ``DatumDefinition`` on one plane, cylinder, sphere or width feature, as a plan datum
      (tangent, the ASME / ISO default) on that feature's region.
    * datum reference frames: their simple datums, and a ``CompoundDatum`` as the common
      datum "A-B"; a datum at MMC / LMC makes the characteristics that use it not judged.
    * characteristics: each ``…CharacteristicNominal`` (its id is the plan's characteristic id),
      mapped by engine.io.qif_characteristics: profile, form, orientation (an axis in a
      DiametricalZone is ``diametral``), location (holes, pins, widths, spheres, patterns, at
      MMC / LMC with the feature's size), runout and size (one per feature when it applies to
      several: ``ID.1``, ``ID.2`` …). Every other one is kept in ``Plan.not_judged`` with its
      reason (a datum at MMC, a length, a datum that is a width …): never dropped. Dimensions
      (radius, angle, distance) are read by engine.io.qif_dimensions.

Refusals (engine.errors.InputError, exit 65, naming the file and the item): not well-formed XML
or XML with a DOCTYPE (no entity is ever expanded, no network, no huge trees), a document that is
not QIF 3 (a QIF 2.x file), no linear unit, an element the plan needs that is missing or not a
number, and (:func:`qif_face_groups`) a feature that matches no face of the STEP nominal.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
import os
import re
from dataclasses import dataclass
from typing import cast

import numpy as np

from engine.errors import InputError
from engine.gdt.plan import Alignment, Datum, Part, Plan, Region, not_too_many

from .plan_tables import check_zones
from .points import read_bytes
from .qif_characteristics import RFS, CharacteristicReader
from .qif_names import ids_of, local_name, words
from .qif_faces import MATCH_FRACTION, FaceMatcher, QifFace, face_of

QIF3_NAMESPACE = "http://qifstandards.org/xsd/qif3"
DATUM_FEATURES = {"Plane": "plane", "Cylinder": "cylinder", "Sphere": "sphere",
                  "OppositeParallelPlanes": "width"}
"""QIF feature kinds a plan datum can be, and the plan's word for each."""
KNOWN_UNITS = {"mm": 1.0, "millimeter": 1.0, "millimetre": 1.0, "cm": 10.0, "m": 1000.0,
               "meter": 1000.0, "metre": 1000.0, "um": 1e-3, "micrometer": 1e-3,
               "inch": 25.4, "in": 25.4, "ft": 304.8, "foot": 304.8, "mil": 0.0254,
               "uin": 2.54e-5}
"""Linear units by the names QIF writers use (mm each), for a ``linearUnit`` the file uses
without declaring it (the NIST FTC-06 file's "inch"); a unit the file declares wins."""
PRECEDENCE = {"PRIMARY": 0, "SECONDARY": 1, "TERTIARY": 2}


@dataclass(frozen=True)
class QifFeature:
    """A QIF feature nominal: ``kind`` is its element's name without ``FeatureNominal``
    (Plane, Cylinder, OppositeParallelPlanes …); ``faces`` the ids of its QIF faces;
    ``internal``: a hole (None: not stated)."""

    id: str
    kind: str
    name: str
    faces: tuple[str, ...]
    internal: bool | None


@dataclass(frozen=True)
class QifDocument:
    """A QIF MBD as read: its plan, the features its regions use with their QIF faces (mm),
    and the unit it was written in."""

    plan: Plan
    features: dict
    """Feature id -> QifFeature (those a region of the plan uses)."""
    faces: dict
    """QIF face id -> engine.io.qif_faces.QifFace (of those features)."""
    unit: str
    mm_per_unit: float
    scale: float
    names: dict = dataclasses.field(default_factory=dict)
    """Characteristic nominal id -> (its kind in words, its Name: the designator, e.g.
    "Position.14"), for every characteristic of the file."""


def read_qif_plan(path: str | os.PathLike) -> Plan:
    """The inspection plan of a QIF 3.0 MBD (see the module's docstring)."""
    return qif_document(path).plan


def qif_document(path: str | os.PathLike) -> QifDocument:
    path = os.fspath(path)
    return parse_qif(read_bytes(path), path)


def qif_face_groups(path: str | os.PathLike, step) -> dict[str, tuple[int, ...]]:
    """{region group of the QIF plan: the STEP face ids (ascending) of its features}: each QIF
    face matched to the faces of the STEP nominal ``step`` (engine.io.step.StepNominal) by
    geometry (engine.io.qif_faces). InputError naming the QIF file, the feature and the STEP
    file when a face of a feature matches none."""
    doc = qif_document(path)
    matcher = FaceMatcher(step)
    found: dict[str, list[int]] = {}
    for feature in doc.features.values():
        ids: set[int] = set()
        for face_id in feature.faces:
            hit = matcher.faces(doc.faces[face_id])
            if not hit:
                raise InputError(f"QIF feature {feature.id} ({describe(doc.faces[face_id])}"
                                 f"{'' if len(feature.faces) == 1 else f', its face {face_id}'}"
                                 f") matches no face of {os.path.basename(step.path)} within "
                                 f"{matcher.tol:.2g} mm", doc.plan.path)
            ids.update(hit)
            found[f"{feature.id}/{face_id}"] = sorted(hit)
        found[feature.id] = sorted(ids)
    # A QIF plan's regions are each one group "qif:<feature ids>" (parse_qif), a feature's
    # face "FEATURE/FACE" (an angle between the two faces of one feature).
    groups = [cast(str, r.group) for r in doc.plan.regions]
    return {g: tuple(sorted({f for fid in g[4:].split("+") for f in found[fid]})) for g in groups}


def check_qif_nominal(plan_path: str, nominal_path: str) -> None:
    """InputError naming the plan when its nominal is no STEP model: a QIF plan's features are
    found among a STEP model's faces."""
    from . import formats

    if formats.kind_of(nominal_path) != formats.STEP:
        raise InputError("a QIF plan's features are matched to the faces of a STEP nominal "
                         f"({', '.join(formats.STEP_SUFFIXES)}) by geometry; the nominal "
                         f"{os.path.basename(nominal_path)} is no STEP model", plan_path)


def qif_nominal_groups(path: str | os.PathLike, step, groups: dict | None
                       ) -> tuple[dict[str, np.ndarray], dict]:
    """The STEP nominal's point groups (engine.step_model.face_groups: ``face:N`` -> its
    tessellation points) with one more per region of the QIF plan (the points of the faces its
    features match, :func:`qif_face_groups`), and what the results say of the match."""
    faces = qif_face_groups(path, step)
    out = dict(groups or {})
    for name, ids in faces.items():
        out[name] = np.unique(np.concatenate([out[f"face:{i}"] for i in ids]))
    doc = qif_document(path)
    facts = {"path": os.fspath(path), "unit": doc.unit, "mm_per_unit": doc.mm_per_unit,
             "scale": doc.scale, "tolerance_mm": FaceMatcher(step).tol,
             "regions": {k: list(v) for k, v in faces.items()},
             "n_characteristics": doc.plan.n_source,
             "not_judged": [dataclasses.asdict(c) for c in doc.plan.not_judged],
             "not_judged_summary": doc.plan.not_judged_summary,
             "match": "each QIF face is the STEP faces on the same surface (normals and axes "
                      f"within {MATCH_FRACTION:g} rad; points and radii within tolerance_mm, "
                      f"{MATCH_FRACTION:g} of the model's diagonal) holding every point of "
                      "its boundary (vertices, edge middles) within tolerance_mm"}
    return out, facts


def describe(face: QifFace) -> str:
    """A QIF face's surface in words, mm: "plane z=0", "cylinder ⌀35 axis (0, 0, 1) through
    (-325, -175, 0)" …"""
    g = face.geometry
    if face.kind == "plane":
        n, p = g["normal"], g["point"]
        axis = [i for i in range(3) if abs(abs(n[i]) - 1.0) < 1e-9]
        if axis:
            return f"plane {'xyz'[axis[0]]}={p[axis[0]]:.6g}"
        return f"plane through {_point(p)} normal {_point(n)}"
    if face.kind == "cylinder":
        return (f"cylinder ⌀{2 * g['radius']:.6g} axis {_point(g['axis'])} through "
                f"{_point(g['point'])}")
    if face.kind == "sphere":
        return f"sphere ⌀{2 * g['radius']:.6g} centre {_point(g['centre'])}"
    if face.kind in ("cone", "torus"):
        at = g["apex"] if face.kind == "cone" else g["centre"]
        return f"{face.kind} axis {_point(g['axis'])} at {_point(at)}"
    return f"face {face.id} through {_point(face.points[0])}"


def _point(v) -> str:
    return "(" + ", ".join(f"{float(x):.6g}" for x in v) + ")"


# ---------------------------------------------------------------- the document
@functools.lru_cache(maxsize=4)
def parse_qif(raw: bytes, path: str) -> QifDocument:
    """The document these bytes of ``path`` hold, cached by the bytes (a run reads its plan for
    the zone and again with the nominal)."""
    root = qif_root(raw, path)
    units = QifUnits(root, path)
    index = {e.get("id"): e for e in root.iter() if e.get("id") is not None}
    features = _features(root, index, units, path)
    datums, datum_notes = _datums(root, features, path)
    frames = _frames(root, datums, datum_notes, path)
    reader = CharacteristicReader(path, index, units, features, datums, frames)
    nominals = [e for e in _children(root, "Characteristics/{*}CharacteristicNominals")]
    not_too_many(len(nominals), path)
    for e in nominals:
        reader.read(e)
    reader.finish()
    used = {part.partition("/")[0] for r in reader.regions for part in r[4:].split("+")}
    used |= {d.region[4:] for d in datums.values()}
    plan = Plan(path=path, sha256=hashlib.sha256(raw).hexdigest(), part=_part(root),
                regions=tuple(Region(name=g, group=g) for g in
                              dict.fromkeys([*(d.region for d in datums.values()),
                                             *reader.regions])),
                datums=tuple(datums.values()), alignment=Alignment(),
                characteristics=tuple(reader.judged), not_judged=tuple(reader.not_judged),
                n_source=len(nominals))

    check_zones(plan)  # before any zone is taken from it
    faces = {}
    for fid in used:
        for face_id in features[fid].faces:
            faces[face_id] = _face(index, face_id, units, fid, path)
    return QifDocument(plan, {fid: features[fid] for fid in sorted(used, key=_id_order)},
                       faces, units.unit, units.mm_per_unit, units.scale, dict(reader.names))


@dataclass(frozen=True)
class QifSource:
    """A QIF plan's own document as the results that answer it need it (reports.qif): its
    root element (lxml) and its units."""

    path: str
    root: object
    units: "QifUnits"


def qif_source(path: str | os.PathLike, sha256: str) -> QifSource:
    """The QIF plan ``path`` read again for results that reference its ids; InputError when
    its bytes are no longer those inspected (their SHA-256 ``sha256``): results must answer
    the plan that was judged."""
    path = os.fspath(path)
    raw = read_bytes(path)
    if hashlib.sha256(raw).hexdigest() != sha256:
        raise InputError("changed since it was inspected (its SHA-256 is not the inspected "
                         "plan's): the QIF results would not answer the plan judged", path)
    root = qif_root(raw, path)
    return QifSource(path, root, QifUnits(root, path))


def _id_order(fid: str):
    return (0, int(fid)) if fid.isdigit() else (1, fid)


def qif_root(raw: bytes, path: str):
    """The root element of untrusted XML, safely: no entity expanded, no DTD loaded, no
    network, no huge trees; a DOCTYPE is refused outright (a QIF document has none)."""
    from lxml import etree

    parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=False,
                             load_dtd=False, dtd_validation=False, remove_comments=True,
                             remove_pis=True)
    try:
        root = etree.fromstring(raw, parser)
    except etree.XMLSyntaxError as e:
        raise InputError(f"is not valid XML ({e})", path) from e
    if root.getroottree().docinfo.doctype:
        raise InputError("holds a DOCTYPE declaration; a QIF document has none (refused: "
                         "entities are never expanded)", path)
    ns, local = _split(root.tag)
    version = root.get("versionQIF", "")
    if local != "QIFDocument":
        raise InputError(f"is not a QIF document (its root element is <{local}>, not "
                         "<QIFDocument>)", path)
    if ns != QIF3_NAMESPACE or not version.startswith("3."):
        raise InputError(f"is a QIF {version or '(no versionQIF)'} document in namespace "
                         f"'{ns}'; plans are read from QIF 3.0 ({QIF3_NAMESPACE})", path)
    return root


def _split(tag: str) -> tuple[str, str]:
    if tag.startswith("{"):
        ns, local = tag[1:].split("}", 1)
        return ns, local
    return "", tag


def _children(root, path: str) -> list:
    """The element children of ``{*}path`` under the root (none when it is absent)."""
    parent = root.find("{*}" + path)
    return [] if parent is None else [c for c in parent if isinstance(c.tag, str)]


class QifUnits:
    """The file's linear units (name -> mm), its primary one, the primary one of its PMI (the
    Characteristics' values: ``PMILinearUnit``, which the QIF 3.0 schema says overrides the
    primary unit there; the primary one where the file states none), its angular units (name
    -> degrees) and the geometry's scale."""

    def __init__(self, root, path: str):
        self.path = path
        self.mm: dict[str, float] = {}
        primary = root.find("{*}FileUnits/{*}PrimaryUnits/{*}LinearUnit")
        if primary is None:
            raise InputError("states no linear unit (FileUnits/PrimaryUnits/LinearUnit): its "
                             "lengths cannot be read as mm", path)
        pmi = root.find("{*}FileUnits/{*}PrimaryUnits/{*}PMILinearUnit")
        for u in (primary, *(() if pmi is None else (pmi,)),
                  *root.iterfind("{*}FileUnits/{*}OtherUnits/{*}LinearUnit")):
            self.mm[(u.findtext("{*}UnitName") or "").strip()] = 1000.0 * _factor(u, path)
        self.unit = (primary.findtext("{*}UnitName") or "").strip()
        self.pmi_unit = self.unit if pmi is None else (pmi.findtext("{*}UnitName") or "").strip()
        self.mm_per_unit = self.mm[self.unit]
        self.degrees: dict[str, float] = {}
        for u in root.iterfind("{*}FileUnits/{*}*/{*}*"):
            if local_name(u) in ("AngularUnit", "PMIAngularUnit"):
                deg = math.degrees(_factor(u, path))
                # A degree's factor written to 15 digits (NIST's 0.017453292519943) is one.
                self.degrees[(u.findtext("{*}UnitName") or "").strip()] = \
                    1.0 if abs(deg - 1.0) < 1e-9 else deg
        angular = [root.find(f"{{*}}FileUnits/{{*}}PrimaryUnits/{{*}}{k}")
                   for k in ("PMIAngularUnit", "AngularUnit")]
        primary_angle = next((u for u in angular if u is not None), None)
        self.angle_unit = None if primary_angle is None else (
            primary_angle.findtext("{*}UnitName") or "").strip()
        scale = root.findtext("{*}Product/{*}Header/{*}ScaleCoefficient")
        self.scale = 1.0 if scale is None else _number(scale, "ScaleCoefficient", path)
        if not self.scale > 0:
            raise InputError(f"declares a ScaleCoefficient of {self.scale:g}; it must be > 0",
                             path)

    def length(self, e, what: str, geometry: bool = False) -> float:
        """The value of element ``e`` in mm (its own ``linearUnit`` where it names one, else the
        PMI's primary unit: a characteristic's value; a Product or Features value,
        ``geometry``, in the primary unit divided by the declared scale)."""
        unit = e.get("linearUnit")
        if unit is not None and unit not in self.mm and unit in KNOWN_UNITS:
            self.mm[unit] = KNOWN_UNITS[unit]
        if unit is not None and unit not in self.mm:
            raise InputError(f"{what}: linearUnit '{unit}' is not one of the file's units "
                             f"({', '.join(self.mm)})", self.path)
        value = _number(e.text, what, self.path) * self.mm[
            unit or (self.unit if geometry else self.pmi_unit)]
        return value / self.scale if geometry else value

    def angle(self, e, what: str) -> float:
        """The angle element ``e`` states, in degrees (its own ``angularUnit``, else the
        file's PMI or primary angular unit; a file that declares none: degrees)."""
        unit = e.get("angularUnit") or self.angle_unit
        if unit is not None and unit not in self.degrees:
            raise InputError(f"{what}: angularUnit '{unit}' is not one of the file's units "
                             f"({', '.join(self.degrees) or 'it declares none'})", self.path)
        return _number(e.text, what, self.path) * (1.0 if unit is None else self.degrees[unit])


def _factor(unit, path: str) -> float:
    """A unit's UnitConversion Factor (to the SI unit; 1 where it states none), which must be
    > 0: a factor of 0 made every length 0, and the file was refused later for a feature
    that matched no face."""
    name = (unit.findtext("{*}UnitName") or "").strip()
    text = unit.findtext("{*}UnitConversion/{*}Factor")
    factor = _number(text if text is not None else "1", f"unit {name!r}", path)
    if not factor > 0:
        raise InputError(f"unit {name!r}: its UnitConversion Factor is {text.strip()!r}; a "
                         "unit's factor must be > 0", path)
    return factor


def _number(text: str | None, what: str, path: str) -> float:
    try:
        value = float((text or "").strip())
    except ValueError:
        raise InputError(f"{what}: {text!r} is not a number", path) from None
    if value != value or value in (float("inf"), float("-inf")):
        raise InputError(f"{what}: {text!r} is not a finite number", path)
    return value


def _face(index: dict, face_id: str, units: QifUnits, feature: str, path: str) -> QifFace:
    face = index.get(face_id)
    if face is None or local_name(face) != "Face":
        raise InputError(f"QIF feature {feature}: its entity {face_id} is not a Face of the "
                         "file's B-rep", path)
    try:
        return face_of(face, index, units.mm_per_unit / units.scale)
    except (KeyError, AttributeError, ValueError, IndexError) as e:
        raise InputError(f"QIF feature {feature}: its face {face_id} is incomplete (a "
                         f"surface, loop, edge, vertex or curve missing or not numbers: "
                         f"{e!r})", path) from None


def _part(root) -> Part:
    part = root.find("{*}Product/{*}PartSet/{*}Part")
    if part is None:
        return Part()
    return Part(number=(part.findtext("{*}ModelNumber") or "").strip(),
                name=(part.findtext("{*}Name") or part.get("label") or "").strip())


def _features(root, index: dict, units: QifUnits, path: str) -> dict[str, QifFeature]:
    out = {}
    for e in _children(root, "Features/{*}FeatureNominals"):
        kind = re.sub(r"FeatureNominal$", "", local_name(e))
        definition = index.get(e.findtext("{*}FeatureDefinitionId") or "")
        side = None if definition is None else definition.findtext("{*}InternalExternal")
        faces = tuple(i for i in ids_of(e, "EntityInternalIds")
                      if i in index and local_name(index[i]) == "Face")
        out[e.get("id")] = QifFeature(e.get("id"), kind, (e.findtext("{*}Name") or "").strip(),
                                      faces, None if side is None else side == "INTERNAL")
    return out


def _datums(root, features: dict, path: str) -> tuple[dict[str, Datum], dict[str, str]]:
    """{DatumDefinition id: plan Datum} for those on one plane, cylinder, sphere or width with faces,
    and {id: why not} for the others (with their label)."""
    datums, notes = {}, {}
    seen: dict[str, str] = {}  # label -> the DatumDefinition's id
    for e in _children(root, "DatumDefinitions"):
        label = (e.findtext("{*}DatumLabel") or "").strip()
        if not label:
            raise InputError(f"datum definition {e.get('id')} has no DatumLabel", path)
        if label in seen:
            raise InputError(f"datum definitions {seen[label]} and {e.get('id')} are both "
                             f"labelled {label}: a datum label names one datum", path)
        seen[label] = e.get("id") or "?"
        ids = ids_of(e, "FeatureNominalIds")
        kinds = [features[i].kind if i in features else "?" for i in ids]
        if len(ids) != 1 or kinds[0] not in DATUM_FEATURES or not features[ids[0]].faces:
            what = "no feature" if not ids else (
                f"{len(ids)} features" if len(ids) > 1 else
                _article(words(kinds[0])) + " feature" + ("" if kinds[0] == "?" or
                                                     features[ids[0]].faces else " without faces"))
            notes[e.get("id")] = (f"datum {label} is {what}; a plan datum is one plane, "
                                  "cylinder, sphere or width")
            continue
        datums[e.get("id")] = Datum(label=label, region=f"qif:{ids[0]}",
                                    feature=DATUM_FEATURES[kinds[0]])
    return datums, notes


def _frames(root, datums: dict, notes: dict, path: str) -> dict[str, tuple[tuple[str, ...], str]]:
    """{DatumReferenceFrame id: (labels primary first, why it cannot be used or "")}; a
    ``CompoundDatum`` of datums of one kind is the common datum "A-B"."""
    out = {}
    for e in _children(root, "DatumReferenceFrames"):
        entries: list[tuple[int, str]] = []
        why = ""
        for d in e.iterfind("{*}Datums/{*}Datum"):
            rank = PRECEDENCE.get((d.findtext("{*}Precedence/{*}PrecedenceEnum") or "").strip(),
                                  len(entries))
            simples = [d.find("{*}SimpleDatum")]
            if simples[0] is None:
                simples = list(d.iterfind("{*}CompoundDatum/{*}Datum/{*}SimpleDatum"))
                if not simples:
                    why = why or "its datum reference frame holds a datum that is no simple " \
                                  "or common datum"
                    continue
            labels = []
            for simple in simples:
                label, note = _simple_datum(simple, datums, notes, e.get("id"), path)
                why = why or note
                if label:
                    labels.append(label)
            if len(labels) == len(simples):
                kinds = {next(v for v in datums.values() if v.label == x).feature
                         for x in labels}
                if len(kinds) > 1:
                    why = why or (f"its common datum {'-'.join(labels)} joins a "
                                  f"{' and a '.join(sorted(kinds))}; a common datum is two "
                                  "datums of one kind")
                entries.append((rank, "-".join(labels)))
        out[e.get("id")] = (tuple(label for _, label in sorted(entries)), why)
    return out


def _simple_datum(simple, datums: dict, notes: dict, frame: str, path: str) -> tuple[str, str]:
    """(the label of a SimpleDatum of frame ``frame`` or "", why it cannot be used or "")."""
    ref = (simple.findtext("{*}DatumDefinitionId") or "").strip()
    modifier = (simple.findtext("{*}MaterialModifier") or "").strip()
    if ref in notes:
        return "", notes[ref]
    if ref not in datums:
        raise InputError(f"DatumReferenceFrame {frame}: DatumDefinitionId {ref!r} is no "
                         "DatumDefinition of the file", path)
    if modifier not in RFS:
        return datums[ref].label, (f"datum {datums[ref].label} is at {modifier.lower()} "
                                   "material condition (a datum feature at MMC / LMC, datum "
                                   "shift, is not judged yet)")
    return datums[ref].label, ""


def _article(word: str) -> str:
    return ("an " if word[:1] in "aeiou" else "a ") + word
