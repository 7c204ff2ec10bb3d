"""A STEP model's exact faces as the inspection measures them: deviations exact to the B-rep
(:class:`ExactDistances`, an engine.surface.Surface, the registration's tessellation as its
fallback), the faces as regions of a plan (their samples and groups), the analytic features
the plan layer matches its regions to, and the model's facts for the results. Numbers in,
numbers out: the model itself comes from engine.io.step."""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import cKDTree

from .deviation import Deviations
from .errors import NoDistanceError
from .inspection import InspectionResult
from .nominal import Nominal
from .surface import SampledSurface
from .verdict import INCONCLUSIVE

def face_sample(distances: "ExactDistances", k: int = 32):
    """feet (n, 3) on a STEP model -> (n,) the tessellation point nearest each foot among those
    of the face it lies on (exactly: the model's own distance, ``distances``), so that a point
    joins its face's regions even where the face's samples lie only on its edges, shared with
    the next face's; the face's first sample when none of the k nearest is on it."""
    step = distances.step
    points = step.point_set.points
    ids = np.asarray(step.face_ids)
    first = np.full(step.n_faces + 1, -1)
    first[ids[::-1]] = np.arange(ids.size)[::-1]
    tree = cKDTree(points)

    def sample_of(feet: np.ndarray) -> np.ndarray:
        face = distances(feet)[3]
        _, near = tree.query(feet, k=min(k, ids.size))
        hit = ids[near] == face[:, None]
        pick = np.where(hit.any(axis=1), near[np.arange(len(feet)), hit.argmax(axis=1)],
                        first[face])
        return pick

    return sample_of


NEIGHBOURS = 8
"""Measured points of a rival face that say how far it lies from its nominal near a point."""
SPREAD_QUANTILE = 0.95
"""Rival faces are looked for within a point's own distance plus the largest, over the faces
measured with at least ``NEIGHBOURS`` points, of this quantile of their points' distances: how
far a face was seen to move, a few gross outliers aside."""


def face_rivals(distances: "ExactDistances"):
    """The points whose region rests on which of two faces they were measured on.

    Returns rivals(X (n, 3) nominal frame, signed (n,) their deviations, samples (n,) the
    tessellation point whose regions each takes (:func:`face_sample`), masks {region: (N,)
    bool over the tessellation points}, members {region: indices of its measured points}) ->
    ({region: its members in doubt}, (n,) each point's rival face id, 0 for none).

    A point's foot lies on its own face, at distance |d|. Another face g, outside one of its
    own face's regions, is its rival when g's own measured points near it lie as far from g
    as the point does, less |d|: the point fits g moved as g's points show it moved (a wall
    tilted, a hole shifted carries the points near their shared edge nearer the next face
    than their own). A dent next to an edge whose other face was measured where it belongs
    has no rival."""
    step = distances.step
    ids = np.asarray(step.face_ids)

    def rivals(X, signed, samples, masks, members):
        X, a = np.asarray(X, dtype=np.float64), np.abs(np.asarray(signed, dtype=np.float64))
        face = ids[samples]
        within = np.zeros((len(masks), step.n_faces + 1), bool)  # region x face id
        for k, m in enumerate(masks.values()):
            within[k, np.unique(ids[m])] = True
        counts = np.bincount(face, minlength=step.n_faces + 1)
        moved_most = max((float(np.quantile(a[face == f], SPREAD_QUANTILE))
                          for f in np.flatnonzero(counts >= NEIGHBOURS)), default=0.0)
        reach = a + moved_most
        pairs, dist = step.faces_within(X, reach, face, lambda f, g: np.any(
            within[:, f] != within[:, g], axis=0))
        rival = np.zeros(len(X), np.int64)
        best = np.full(len(X), np.inf)
        for g in np.unique(pairs[:, 1]):
            on_g = np.flatnonzero(face == g)
            if on_g.size == 0:  # nothing measured on g: nothing says it moved
                continue
            j = np.flatnonzero(pairs[:, 1] == g)
            i = pairs[j, 0]
            _, nb = cKDTree(X[on_g]).query(X[i], k=min(NEIGHBOURS, on_g.size))
            moved = a[on_g][np.asarray(nb).reshape(len(i), -1)].max(axis=1)
            fits = (dist[j] <= a[i] + moved) & (dist[j] < best[i])
            rival[i[fits]], best[i[fits]] = g, dist[j][fits]
        drop = {}
        for k, r in enumerate(masks):
            idx = members[r]
            g = rival[idx]
            drop[r] = idx[(g > 0) & ~within[k, g]]
        return drop, rival

    return rivals


@dataclasses.dataclass(frozen=True)
class StepFaces:
    """A STEP nominal's faces as a run keeps them for its views (engine.pipeline.Run ``faces``),
    without the OpenCascade shapes, so that a run still pickles.

    faces : the face records (engine.io.step.StepFace), ``faces[i].id == i + 1``.
    face_ids : (n,) int, the face of each nominal sample (the tessellation's points: the run's
        nominal's, in order; a triangle's three corners lie on one face).
    groups : the nominal's point groups a plan's region may select (:func:`face_groups`, and
        a QIF plan's regions: engine.io.qif_plan.qif_nominal_groups).
    """

    faces: tuple
    face_ids: np.ndarray
    groups: dict


def face_groups(step) -> dict[str, np.ndarray]:
    """A STEP model's faces as the tessellation's point groups a plan's region may select:
    ``face:N`` (its id) and ``name:NAME`` (where the file names the face, or its part)."""
    ids = np.asarray(step.face_ids)
    order = np.argsort(ids, kind="stable")
    bounds = np.searchsorted(ids[order], np.arange(1, step.n_faces + 2))
    groups: dict[str, list] = {}
    for f in step.faces:
        members = order[bounds[f.id - 1]:bounds[f.id]]
        groups[f"face:{f.id}"] = [members]
        for name in (f.name, f.part):
            if name:
                groups.setdefault(f"name:{name}", []).append(members)
    return {k: np.unique(np.concatenate(v)) for k, v in groups.items()}


class ExactDistances:
    """A STEP model's exact faces as the inspection measures against them (engine.surface.Surface:
    deviations exact to the B-rep, so no sampling margin; a closed model has no border, an open
    one the tessellation's).

    Calling it gives the exact distances (engine.io.step.StepNominal.deviations: ``(signed, foot,
    normal, face)`` of points X (n, 3), nominal frame), with the tessellation's distance
    standing in for a point to which OpenCascade finds none (engine.errors.NoDistanceError):
    the others are measured exactly again, and every point stood in for is kept in
    ``missed`` (its nominal-frame coordinates, where it was asked about) so that the verdict
    says so (:meth:`judged`): a "could not compute", never an internal error.

    step : the StepNominal; nominal : the Nominal built from its tessellation (its samples are
    ``step.point_set``'s, in order, so a sample's face is ``step.face_ids`` of it); None: built
    from it when a point first needs it.
    """

    exact = True
    normals_source = "B-rep"

    def __init__(self, step, nominal: Nominal | None = None):
        self.step, self._nominal = step, nominal
        self.missed: list[np.ndarray] = []
        self.why = ""

    @property
    def nominal(self) -> Nominal:
        if self._nominal is None:
            self._nominal = Nominal.from_point_set(self.step.point_set)
        return self._nominal

    def __call__(self, X: np.ndarray):
        X = np.asarray(X, dtype=np.float64)
        out = (np.empty(len(X)), np.empty((len(X), 3)), np.empty((len(X), 3)),
               np.empty(len(X), np.int64))
        exact = np.arange(len(X))
        while exact.size:  # each failure takes its points out: at most len(X) rounds
            try:
                got = self.step.deviations(X[exact])
            except NoDistanceError as e:
                self._stand_in(X[exact[e.points]], exact[e.points], out)
                self.why = e.why
                exact = np.delete(exact, e.points)
                continue
            for o, g in zip(out, got):
                o[exact] = g
            break
        return out

    def deviations(self, X: np.ndarray) -> Deviations:
        signed, foot, normal, _ = self(X)
        return Deviations(signed, foot, normal, np.zeros(signed.size, bool))

    def deviations_within(self, X: np.ndarray, within: float) -> Deviations:
        """:meth:`deviations` of the points X (n, 3) that lie within ``within`` mm of the model,
        NaN (signed, foot and normal) for the others: a search's few points scored at many
        poses, which need not know how far off a point is that fits nowhere near (OpenCascade
        measures a point 30 mm off a NIST part 9 x as long as one on it). A point to which
        OpenCascade finds no distance counts as far, NaN too: nothing is stood in for it."""
        signed, foot, normal, _ = self.step.deviations(np.asarray(X, dtype=np.float64), within)
        return Deviations(signed, foot, normal, np.zeros(signed.size, bool))

    def margins(self, dev: Deviations) -> np.ndarray:
        return np.zeros(dev.signed.size)

    def beyond(self, X: np.ndarray) -> np.ndarray:
        """Past the border: never for a closed model (StepNominal.closed: it has none, and
        its tessellation's faces, meshed apart, would put borders along every edge: 253 of
        600 points of the perfect NIST FTC-07 with 2 µm noise, at the truth); else as on the
        tessellation."""
        if self.step.closed:
            return np.zeros(len(X), bool)
        return SampledSurface(self.nominal).beyond(X)

    def _stand_in(self, P: np.ndarray, rows: np.ndarray, out) -> None:
        self.missed.append(P)
        dv = SampledSurface(self.nominal).deviations(P)
        out[0][rows], out[1][rows], out[2][rows] = dv.signed, dv.foot, dv.normal
        out[3][rows] = np.asarray(self.step.face_ids)[self.nominal.tree.query(dv.foot)[1]]

    def judged(self, result: InspectionResult, labels: np.ndarray | None) -> InspectionResult:
        """``result`` made INCONCLUSIVE by the points stood in for, its first reason naming
        them: the measured points (numbered from 1, as the outputs number them) that were
        stood in for at the pose reported, else the first one at a pose tried on the way."""
        missed = np.concatenate(self.missed)
        near, _ = cKDTree(missed).query(result.registered, k=1)
        at = np.flatnonzero(near <= SAME_POINT_MM)
        if at.size:
            label = "" if labels is None else f", label {labels[at[0]]}"
            who = (f"measured point {at[0] + 1}{label}" if at.size == 1 else
                   f"{at.size} measured points (the first: point {at[0] + 1}{label})")
        else:
            x, y, z = missed[0]
            who = (f"a measured point at a pose tried on the way (then at ({x:.4f}, {y:.4f}, "
                   f"{z:.4f}) mm in the nominal's frame)")
        reason = (f"no exact distance from {who} to the STEP model: {self.why} (its "
                  "projection and extrema search failed on every face near it); the "
                  "tessellation's distance stood in, so the verdict cannot be trusted")
        return dataclasses.replace(result, verdict=INCONCLUSIVE,
                                   reasons=(reason,) + tuple(result.reasons))


SAME_POINT_MM = 1e-6
"""A point stood in for (ExactDistances) is a measured point at the pose reported when it lies
this near it (the same transform of the same point, up to rounding)."""


SAME_SURFACE = 1e-9
"""Faces lie on one surface when their planes, axes, centres and radii agree to this (unit
vectors; lengths relative to the model's size)."""


def exact_features(step):
    """feature(kind, mask) -> the nominal feature (engine.gdt.characteristics._nominal_feature's
    keys) of a region whose tessellation samples ``mask`` all lie on faces of one plane,
    cylinder or sphere of the STEP model ``step``: its exact surface (a cylinder's axis and
    radius from the model, not a fit to samples whose edge nodes stray from it by the edges'
    tolerance), the axis point or plane point taken nearest the samples' centroid; None
    otherwise (the caller fits the samples)."""
    scale = float(np.linalg.norm(np.ptp(step.bounds, axis=0))) or 1.0

    def feature(kind: str, mask: np.ndarray) -> dict | None:
        faces = [step.faces[int(f) - 1] for f in np.unique(step.face_ids[mask])]
        if not faces or any(f.surface != kind for f in faces) or kind not in _EXACT_KINDS:
            return None
        g = [{k: np.asarray(v, float) for k, v in f.geometry.items()} for f in faces]
        if not all(_EXACT_KINDS[kind](g[0], h, scale) for h in g[1:]):
            return None
        c = step.point_set.points[mask].mean(axis=0)
        if kind == "plane":
            n, p = g[0]["normal"], g[0]["point"]
            return {"point": c - ((c - p) @ n) * n, "normal": n}
        internal = bool(g[0]["hole"])
        if kind == "cylinder":
            a, o = g[0]["axis"], g[0]["point"]
            return {"point": o + ((c - o) @ a) * a, "direction": a,
                    "diameter": 2.0 * float(g[0]["radius"]), "internal": internal}
        return {"centre": g[0]["centre"], "diameter": 2.0 * float(g[0]["radius"]),
                "internal": internal}

    return feature


def _same_plane(g: dict, h: dict, scale: float) -> bool:
    return (abs(g["normal"] @ h["normal"] - 1.0) <= SAME_SURFACE
            and abs((h["point"] - g["point"]) @ g["normal"]) <= SAME_SURFACE * scale)


def _same_cylinder(g: dict, h: dict, scale: float) -> bool:
    a, d = g["axis"], h["point"] - g["point"]
    return bool(abs(abs(a @ h["axis"]) - 1.0) <= SAME_SURFACE
                and bool(g["hole"]) == bool(h["hole"])
                and np.linalg.norm(d - (d @ a) * a) <= SAME_SURFACE * scale
                and abs(g["radius"] - h["radius"]) <= SAME_SURFACE * scale)


def _same_sphere(g: dict, h: dict, scale: float) -> bool:
    return bool(np.linalg.norm(g["centre"] - h["centre"]) <= SAME_SURFACE * scale
                and abs(g["radius"] - h["radius"]) <= SAME_SURFACE * scale
                and bool(g["hole"]) == bool(h["hole"]))


_EXACT_KINDS = {"plane": _same_plane, "cylinder": _same_cylinder, "sphere": _same_sphere}


def step_facts(step) -> dict:
    """What the outputs say of a STEP nominal (JSON ``step``)."""
    return {"schema": step.schema, "unit": step.unit, "mm_per_unit": step.mm_per_unit,
            "faces": step.n_faces, "deflection_mm": step.deflection,
            "method": "exact B-rep", "warnings": list(step.warnings),
            "units_definition": "the file's length unit; every coordinate is converted to mm"}
