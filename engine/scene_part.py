"""Which objects of a scene are the part: a 3D camera's view of a table holds, once the table is
removed (engine.scene), the part and whatever else stands on it. The objects are the scene's
connected components (engine.scene.objects); each one that could be the part is registered to
the nominal on its own (engine.registration), and at that pose every object is the part's
when most of its points lie within reach of the nominal. The candidate whose pose claims the
most points is the part.

An object is kept or dropped whole, never point by point: a dent or a bump of the part is
connected to it, so it stays in the inspection however far it lies from the nominal. What goes
are separate objects (another device, a cable, a box) that the nominal does not fit.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from .choices import Verdict
from .deviation import point_to_surface
from .neighbours import voxel_spread
from .nominal import Nominal
from .pointset import PointSet
from .pose import apply_transform
from .progress import report
from .registration import register
from .registration_types import RegistrationSettings
from .seeds import DEFAULT_SEED
from .scene import (LINK_SPACINGS, MIN_KEPT, Plane, Selection, objects, on_a_line,
                    typical_spacing)
from .surface_fit import ROBUST_ITERATIONS

OBJECT_POINTS = 200_000
"""Objects are found on at most this many of the points, spread by voxels (a dense scan's
millions would cost gigabytes of neighbour pairs)."""
MAX_CANDIDATES = 4
"""Objects registered at most, largest first: each costs a registration."""
SIZE_RATIO = 1.5
"""An object can be the part only if its bounding-box diagonal is at most this many times the
nominal's: a larger one is a scene, not a view of the part (a camera's mixed pixels widen a part
by a few of its spacings)."""
REACH_SIGMAS = 2.5
"""A point lies within reach of the nominal within this many noise standard deviations (or the
registration's near distance, if wider): 99% of a normal noise's points."""
MAJORITY = 0.5
"""An object belongs to the part at a pose when more than this fraction of its points lies
within reach."""


@dataclass(frozen=True)
class PartInScene:
    """The part's objects in a scene's points.

    kept : (k,) int64 ascending indices into the points given, the points of the part's
    objects; n_objects : objects the points hold; n_part_objects : of them, the part's;
    candidates : objects registered; link : mm, the distance that links two points of one
    object; reach : mm, the distance within which a point counts for an object at a pose.
    """

    kept: np.ndarray
    n_objects: int
    n_part_objects: int
    candidates: int
    link: float
    reach: float


def part_in_scene(nominal: Nominal, points: np.ndarray, noise: float,
                  zone_width: float | None = None, seed: int = DEFAULT_SEED) -> PartInScene:
    """The objects of ``points`` (n, 3), mm, the measured frame) that are the part ``nominal``
    shows, for a measurement of noise ``noise`` mm (a standard deviation). With one object
    only, every point is kept and nothing is registered. Objects are found, and the points a
    pose claims counted, on at most ``OBJECT_POINTS`` of the points, one per voxel
    (engine.neighbours.voxel_spread; every point takes its nearest one's object). ``seed``: the
    inspection's (engine.seeds)."""
    p = np.asarray(points, dtype=np.float64)
    sub = np.arange(p.shape[0]) if p.shape[0] <= OBJECT_POINTS else \
        voxel_spread(p, typical_spacing(p, seed=seed), OBJECT_POINTS)
    q = p[sub]
    link = LINK_SPACINGS * typical_spacing(q, seed=seed)
    label_q = objects(q, link) if link > 0 else np.zeros(q.shape[0], np.int64)
    label = label_q if sub.size == p.shape[0] else label_q[cKDTree(q).query(p)[1]]
    sizes = np.bincount(label_q)
    settings = RegistrationSettings(noise_mm=noise, seed=seed)
    # A candidate's pose only counts the points it claims (the inspection then registers the
    # part's points in full): its finishes stop after their robust iterations.
    quick = replace(settings, max_final_iterations=ROBUST_ITERATIONS)
    reach = max(REACH_SIGMAS * noise, settings.near(nominal.diagonal)[0])
    if sizes.size == 1:
        return PartInScene(np.arange(p.shape[0]), 1, 1, 0, link, reach)
    # An object on one line (a cable, a row of mixed pixels) fixes no pose: no candidate.
    candidates = [k for k in range(sizes.size) if sizes[k] >= MIN_KEPT
                  and np.linalg.norm(np.ptp(q[label_q == k], axis=0))
                  <= SIZE_RATIO * nominal.diagonal
                  and not on_a_line(q[label_q == k])][:MAX_CANDIDATES]
    best, best_key = None, None
    for i, k in enumerate(candidates):
        report(f"which object is the part: object {i + 1} of {len(candidates)}",
               i / max(len(candidates), 1))
        reg = register(nominal, p[label == k], quick, zone_width)
        d = point_to_surface(nominal, apply_transform(reg.T_nominal_measured, q)).signed
        near = np.abs(d) <= reach
        share = np.bincount(label_q, weights=near, minlength=sizes.size) / sizes
        members = np.flatnonzero(share > MAJORITY)
        claimed = int(np.count_nonzero(near & np.isin(label_q, members)))
        key = (claimed, -reg.score)  # the most points claimed; a tie by the better fit
        if k in members and (best_key is None or key > best_key):
            best, best_key = members, key
    if best is None:  # no object fits the nominal: nothing to choose, every point is judged
        best = np.arange(sizes.size)
    return PartInScene(np.flatnonzero(np.isin(label, best)), int(sizes.size), int(best.size),
                       len(candidates), link, reach)


def through_the_table(nominal_points: np.ndarray, T_nominal_measured: np.ndarray, normal,
                      offset: float, kept: np.ndarray) -> float:
    """How far (mm) the nominal, at the pose T_nominal_measured (4, 4), reaches through the plane
    {x : normal . x = offset} (the measured frame) to the side away from the kept measured
    points (k, 3): 0.0 when it stays on their side. A part stands on its table: a pose that
    puts it through the table is not the part's.

    >>> box = np.array([[0., 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]])
    >>> lifted = np.eye(4); lifted[2, 3] = -3.0  # nominal = measured - 3 in z: measured z + 3
    >>> float(through_the_table(box, lifted, [0, 0, 1.], 5.0, np.array([[0, 0, 9.]])))
    2.0
    """
    n = np.asarray(normal, dtype=np.float64)
    side = 1.0 if np.median(kept @ n - offset) >= 0 else -1.0
    X = apply_transform(np.linalg.inv(T_nominal_measured), nominal_points)
    return float(max(0.0, -np.min(side * (X @ n - offset))))


def the_part(nominal: Nominal, measured: PointSet, selection: Selection, settings
             ) -> tuple[PointSet, Selection]:
    """The measured points left on a scene's table (``selection``: engine.scene, its plane
    removed) less the other objects standing on it (:func:`part_in_scene`, the table's spread
    as the noise), and the selection that says so; ``settings``: the inspection's
    (engine.settings.InspectionSettings), whose tolerance zone sets the gross-outlier rule."""
    if selection.plane is None:
        raise ValueError("the_part needs a scene whose table plane was removed")
    report("which object is the part", 0.0)
    tol = settings.tolerance
    part = part_in_scene(nominal, measured.points, selection.plane.sigma,
                         None if tol is None else tol.width, settings.seed)
    return measured.take(part.kept), replace(
        selection, kept=selection.kept[part.kept], n_objects=part.n_objects,
        n_other_objects=measured.n - part.kept.size, object_link=part.link)


def on_the_table(result, nominal: Nominal, measured: PointSet, plane: Plane):
    """The inspection ``result`` (engine.inspection.InspectionResult), INCONCLUSIVE when its pose
    puts the nominal through the plane removed as the table beyond the removal distance
    (:func:`through_the_table`): a part cannot stand in its table, so the pose is not the
    part's, whatever its fit."""
    depth = through_the_table(nominal.points, result.registration.T_nominal_measured,
                              plane.normal, plane.offset, measured.points)
    if not depth > plane.distance:
        return result
    said = (f"at the pose found the nominal reaches {depth:.3g} mm through the plane removed as "
            f"the table, beyond its removal distance ({plane.distance:.3g} mm): a part cannot "
            "stand in its table, so the pose is not the part's")
    return replace(result, verdict=Verdict.INCONCLUSIVE, reasons=(said,) + tuple(result.reasons))
