"""A QIF 3.0 MBD's characteristic nominals -> plan characteristics (engine.gdt.plan), or
NotJudged entries with their reason (engine.io.qif_plan reads the rest of the document).

Mapping (QIF ``…CharacteristicNominal`` -> plan type, on the QIF feature kinds it applies to)
    * SurfaceProfile -> profile (an ``OuterDisposition`` sets its limits); Flatness of a plane;
      Straightness of a cylinder's median line (a DiametricalZone); Circularity, Cylindricity
      of a cylinder;
    * Parallelism, Perpendicularity, Angularity (its ``Angle``, degrees) of a plane (a zone
      between two planes) or of a cylinder's axis in a DiametricalZone (``diametral``);
    * Position of holes and pins (a DiametricalZone), widths (OppositeParallelPlanes / Width:
      a slot or a tab, a zone between two planes), spheres; several features: a pattern; at
      MMC / LMC when a size characteristic of the file gives each feature's limits;
    * Coaxiality, Concentricity of a cylinder (an axis datum first), Symmetry of a width (a
      plane datum first); CircularRunout, TotalRunout about one datum axis or a common "A-B";
    * Diameter of a cylinder, Width of a width, SphericalDiameter of a sphere -> size;
    * Radius, SphericalRadius, Angle and DistanceBetween -> radius, angle and distance
      (engine.io.qif_dimensions, which also says why a Length is not judged).

Every other characteristic, and one these cannot take (a datum at MMC, a zone per unit, an
angularity whose angle is not stated …), stays in ``Plan.not_judged`` with its reason.
"""

from __future__ import annotations

import dataclasses
import re

from engine.errors import InputError
from engine.gdt.plan import ORIENTATION, RUNOUT, Characteristic, NotJudged, datum_parts

from .qif_dimensions import KINDS as DIMENSION_KINDS
from .qif_dimensions import read_dimension
from .qif_names import ids_of, local_name, words

RFS = ("", "NONE", "RFS", "REGARDLESS")
"""Material-condition words that mean regardless of feature size."""
MATERIAL = {"MAXIMUM": "MMC", "MMC": "MMC", "LEAST": "LMC", "LMC": "LMC"}
"""Material-condition words that name a bonus tolerance, and the plan's modifier for each."""
INFORMATIONAL = "informational: it has no tolerance (0 .. 0), so there is nothing to judge"
WIDTHS = ("OppositeParallelPlanes", "Width")
"""QIF feature kinds that are a width (two opposed parallel planes: a slot or a tab)."""
TYPES = {"SurfaceProfile": "profile", "Flatness": "flatness", "Straightness": "straightness",
         "Circularity": "circularity", "Cylindricity": "cylindricity",
         "Parallelism": "parallelism", "Perpendicularity": "perpendicularity",
         "Angularity": "angularity", "Position": "position", "Coaxiality": "coaxiality",
         "Concentricity": "concentricity", "Symmetry": "symmetry",
         "CircularRunout": "circular_runout", "TotalRunout": "total_runout",
         "Diameter": "size", "Width": "size", "SphericalDiameter": "size"}
"""QIF characteristic kinds the plan layer judges, and the plan type of each."""
FEATURES = {"flatness": ("Plane",), "straightness": ("Cylinder",),
            "circularity": ("Cylinder",), "cylindricity": ("Cylinder",),
            "coaxiality": ("Cylinder",), "concentricity": ("Cylinder",), "symmetry": WIDTHS,
            "circular_runout": ("Cylinder", "Plane"), "total_runout": ("Cylinder", "Plane"),
            "position": ("Cylinder", "Sphere") + WIDTHS,
            **{k: ("Plane", "Cylinder", *WIDTHS) for k in ORIENTATION}}
"""The QIF feature kinds each plan type is judged on (a profile: any)."""
SIZES = {"Diameter": ("Cylinder", None), "Width": (WIDTHS, "width"),
         "SphericalDiameter": (("Sphere",), "sphere")}
"""A size characteristic's QIF feature kinds and the plan's ``feature`` for them."""
SUPPORTED = ("the plan layer judges profile, form, orientation, location, runout, the "
             "size of a cylinder, width or sphere, a radius, an angle and a distance")


def _kind_of(f) -> str:
    return "width" if f.kind in WIDTHS else f.kind.lower()


class CharacteristicReader:
    """Reads characteristic nominals into plan characteristics or NotJudged entries.

    features : {id: engine.io.qif_plan.QifFeature}; datums : {DatumDefinition id: Datum};
    frames : {DatumReferenceFrame id: (labels primary first, why it cannot be used or "")};
    units : its ``length(e, what)`` reads a value in mm."""

    def __init__(self, path, index, units, features, datums, frames):
        self.path, self.index, self.units = path, index, units
        self.features, self.datums = features, datums
        self.frames: dict[str, tuple[tuple[str, ...], str]] = frames
        self.judged: list[Characteristic] = []
        self.not_judged: list[NotJudged] = []
        self.names: dict[str, tuple[str, str]] = {}

    @property
    def regions(self) -> list[str]:
        """The regions the judged characteristics use, in order of first use."""
        return list(dict.fromkeys(r for c in self.judged for r in c.all_regions))

    def read(self, e) -> None:
        kind = re.sub(r"CharacteristicNominal$", "", local_name(e))
        cid = (e.get("id") or "").strip()
        name = (e.findtext("{*}Name") or "").strip()
        if not cid:
            raise InputError(f"a {local_name(e)}{f' ({name})' if name else ''} has no id",
                             self.path)
        if cid in self.names:
            raise InputError(f"two characteristic nominals have the id {cid} ("
                             f"{self.names[cid][1] or self.names[cid][0]} and "
                             f"{name or words(kind)}): an id names one item", self.path)
        definition = self.index.get((e.findtext("{*}CharacteristicDefinitionId") or "").strip())
        if definition is None:
            raise InputError(f"characteristic {cid} ({name}): its CharacteristicDefinitionId "
                             "is no element of the file", self.path)
        ids = ids_of(e, "FeatureNominalIds")
        for i in ids:
            if i not in self.features:
                raise InputError(f"characteristic {cid} ({name}): FeatureNominalId {i} is no "
                                 "feature nominal of the file", self.path)
        self.names[cid] = (words(kind), name)
        if kind in DIMENSION_KINDS:
            made = read_dimension(self, kind, cid, name, definition, e, ids)
        else:
            made = self._why_not(kind, definition, e, ids) or self._make(
                kind, cid, name, definition, e, ids)
        if isinstance(made, str):
            self.not_judged.append(NotJudged(cid, words(kind), name, made))
        else:
            # Its name, balloon and element travel with it (the JSON's name, designator and
            # source; the certificate's balloon).
            designator = (e.findtext("{*}CharacteristicDesignator/{*}Designator") or "").strip()
            self.judged.extend(dataclasses.replace(c, name=name, designator=designator,
                                                   source=f"{local_name(e)} {cid}")
                               for c in made)

    def finish(self) -> None:
        """A position at MMC or LMC needs its features' size limits: without a size
        characteristic on each of its regions it is not judged, with that reason."""
        sized = {c.region for c in self.judged if c.type == "size"}
        keep = []
        for c in self.judged:
            missing = [r for r in c.all_regions if r not in sized]
            if c.modifier != "RFS" and missing:
                kind, name = self.names[c.id]
                self.not_judged.append(NotJudged(
                    c.id, kind, name, f"at {c.modifier} it needs the size limits of feature "
                    f"{missing[0][4:]}, and no size characteristic of the file judged here "
                    "gives them"))
            else:
                keep.append(c)
        self.judged = keep

    def _why_not(self, kind: str, definition, e, ids: list[str]) -> str:
        """Why the plan layer cannot judge this characteristic ("" when it can)."""
        feats = [self.features[i] for i in ids]
        if kind not in TYPES:
            return f"{words(kind)} is not judged yet ({SUPPORTED})"
        plan_type = TYPES[kind]
        if not feats or any(not f.faces for f in feats):
            return "it applies to no feature with faces of the model"
        kinds = ", ".join(sorted({words(f.kind) for f in feats}))
        if plan_type == "size":
            if any(f.kind not in SIZES[kind][0] for f in feats):
                return f"{words(kind)} of {kinds} features is not judged"
            return ""
        condition = (definition.findtext("{*}MaterialCondition") or "").strip().upper()
        if condition not in RFS and (plan_type != "position" or condition not in MATERIAL):
            return f"its {condition.lower()} material condition is not judged yet"
        frame = (definition.findtext("{*}DatumReferenceFrameId") or "").strip()
        if frame and frame not in self.frames:
            return f"its DatumReferenceFrameId {frame} is no datum reference frame of the file"
        labels, frame_why = self.frames[frame] if frame else ((), "")
        if frame_why:
            return frame_why
        per_unit = [local_name(c) for c in definition if isinstance(c.tag, str)
                    and local_name(c).startswith("ToleranceZonePerUnit")]
        if per_unit:
            return f"a zone per unit ({per_unit[0]}) is not judged yet"
        if plan_type != "profile" and any(f.kind not in FEATURES[plan_type] for f in feats):
            return f"{words(kind)} of {kinds} features is not judged yet"
        if plan_type not in ("profile", "position") and len(feats) != 1:
            return f"{words(kind)} of {len(feats)} features together is not judged yet"
        if plan_type == "position" and len({_kind_of(f) for f in feats}) != 1:
            return f"a pattern of {kinds} features together is not judged yet"
        diametral = definition.find("{*}ZoneShape/{*}DiametricalZone") is not None
        if plan_type == "position" and feats[0].kind == "Cylinder" and not diametral:
            return "a position of a cylinder's axis in a non-diametral zone is not judged yet"
        if plan_type == "straightness" and not diametral:
            return ("straightness of a cylinder's line elements (a non-diametral zone) is not "
                    "judged yet: the plan judges a cylinder's median line (a diametral zone)")
        if plan_type in ORIENTATION and feats[0].kind == "Cylinder" and not diametral:
            return (f"{plan_type} of a cylinder's axis in a zone between two planes is not "
                    "judged yet: the plan judges an axis in a cylindrical (diametral) zone")
        if plan_type in ORIENTATION and feats[0].kind in WIDTHS and diametral:
            return (f"{plan_type} of a width in a cylindrical (diametral) zone: a width's "
                    "median plane is held between two planes")
        if plan_type == "angularity":
            angle = self._angle(e)
            if angle is None or not 0.0 < angle < 180.0:
                return ("its basic angle is not stated (Angle "
                        f"{e.findtext('{*}Angle') or 'missing'}): an angularity needs one "
                        "between 0 and 180 degrees")
        needs_datum = plan_type in ORIENTATION + RUNOUT or plan_type in (
            "position", "coaxiality", "concentricity", "symmetry")
        if needs_datum and not labels:
            return f"a {plan_type.replace('_', ' ')} relative to no datum is not judged"
        if plan_type in RUNOUT and len(labels) != 1:
            return (f"a {plan_type.replace('_', ' ')} is judged about one datum axis, not "
                    f"{len(labels)} datums")
        axis = {"coaxiality": "cylinder", "concentricity": "cylinder", "symmetry": "plane",
                **{k: "cylinder" for k in RUNOUT}}.get(plan_type)
        if axis and any(self._datum(p).feature != axis for p in self._parts(labels[0])):
            return (f"its datum {labels[0]} is no {axis}: a {plan_type.replace('_', ' ')} is "
                    f"relative to a datum {'axis' if axis == 'cylinder' else 'plane'}")
        regions = {"qif:" + i for i in ids} | {self._region(ids)}
        for label in labels:
            for part in self._parts(label):
                if self._datum(part).region in regions:
                    return f"its datum {part} is its own feature"
        return ""

    def _datum(self, label: str):
        return next(d for d in self.datums.values() if d.label == label)

    def _parts(self, label: str) -> tuple[str, ...]:
        """The datum labels a reference of a frame names: itself, or a common datum's parts
        (a label may hold a hyphen itself: "B-1")."""
        return datum_parts(label, [d.label for d in self.datums.values()]) or (label,)

    def _angle(self, e) -> float | None:
        """An angularity's basic angle, degrees (in its angularUnit, as the file's units say;
        InputError for no number or an unknown unit); None when it states none."""
        element = e.find("{*}Angle")
        if element is None:
            return None
        return self.units.angle(element, f"characteristic {e.get('id')}'s Angle")

    @staticmethod
    def _region(ids: list[str]) -> str:
        return "qif:" + "+".join(ids)

    def _make(self, kind, cid, name, definition, e, ids) -> list[Characteristic] | str:
        """The plan characteristics of a characteristic the plan layer judges, or why it is
        not judged after all (an informational item without tolerance)."""
        frame = (definition.findtext("{*}DatumReferenceFrameId") or "").strip()
        labels = self.frames[frame][0] if frame else ()
        what = f"characteristic {cid} ({name})"
        plan_type = TYPES[kind]
        if plan_type == "size":
            return self._sizes(kind, cid, what, definition, e, ids)
        zone = self._length(definition, "ToleranceValue", what)
        if zone == 0.0:
            return INFORMATIONAL
        if not zone > 0:
            raise InputError(f"{what}: ToleranceValue must be > 0, got {zone:g}", self.path)
        feats = [self.features[i] for i in ids]
        diametral = definition.find("{*}ZoneShape/{*}DiametricalZone") is not None
        if plan_type == "position":
            condition = (definition.findtext("{*}MaterialCondition") or "").strip().upper()
            regions = tuple("qif:" + i for i in ids)
            feature = _kind_of(feats[0])
            return [Characteristic(cid, "position", regions[0], 0.0, zone, labels,
                                   kind=None if feature == "cylinder" else feature,
                                   modifier=MATERIAL.get(condition, "RFS"),
                                   regions=regions if len(regions) > 1 else ())]
        if plan_type == "profile":
            outer = definition.find("{*}OuterDisposition")
            upper = zone / 2 if outer is None else self.units.length(outer, what)
            return [Characteristic(cid, "profile", self._region(ids), upper - zone, upper,
                                   labels)]
        extra: dict = {}
        if plan_type in ORIENTATION:
            extra["diametral"] = feats[0].kind == "Cylinder"
            if feats[0].kind in WIDTHS:  # its median plane
                extra["kind"] = "width"
        if plan_type == "angularity":
            extra["angle"] = self._angle(e)
        if plan_type == "straightness":
            extra["diametral"] = diametral
        if plan_type == "symmetry":
            extra["kind"] = "width"
        return [Characteristic(cid, plan_type, self._region(ids), 0.0, zone, labels,
                               **extra)]

    def _sizes(self, kind, cid, what, definition, e, ids) -> list[Characteristic] | str:
        """A size characteristic on each of its features (``cid.k`` for several)."""
        nominal = self._length(e, "TargetValue", what)
        tol = definition.find("{*}Tolerance")
        if tol is None:
            if definition.find("{*}NonTolerance") is not None:
                return (f"informational: a {words(kind)} with no tolerance "
                        f"({(definition.findtext('{*}NonTolerance') or '').strip().lower()}), "
                        "so there is nothing to judge")
            raise InputError(f"{what}: its definition has no Tolerance", self.path)
        low, high = (self._length(tol, k, what) for k in ("MinValue", "MaxValue"))
        if (tol.findtext("{*}DefinedAsLimit") or "").strip() == "true":
            low, high = low - nominal, high - nominal
        # Limits minus the target: 34.8 - 35 must be -0.2, not -0.20000000000000284.
        low, high = round(low, 12), round(high, 12)
        if low == high == 0.0:
            return INFORMATIONAL
        if not nominal > 0 or not low < high or nominal + low <= 0:
            raise InputError(f"{what}: a {words(kind)} of {nominal:g} mm with limits "
                             f"{low:+g} / {high:+g} mm is no size tolerance", self.path)
        feature = SIZES[kind][1]
        return [Characteristic(cid if len(ids) == 1 else f"{cid}.{k}", "size", f"qif:{i}",
                               low, high, nominal=nominal, kind=feature)
                for k, i in enumerate(ids, start=1)]

    def _length(self, e, tag: str, what: str) -> float:
        found = e.find("{*}" + tag)
        if found is None:
            raise InputError(f"{what}: {tag} is missing", self.path)
        return self.units.length(found, f"{what}: {tag}")
