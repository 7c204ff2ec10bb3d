"""Poses along the directions a fit's own points leave free, found again with the points it
excluded.

A least-squares pose leaves out the gross outliers (engine.outliers). Where the points it keeps
do not constrain a direction (a patch of a prismatic face slides along it, a patch of a cylinder
turns about its axis), the points it left out may be the only ones that would: a pose slid along
that direction fits every kept point at the noise and calls the points of the distinguishing
feature (an edge, a hole, a step) gross outliers. NIST CTC-03's 30% patch (bench_sweep's seed
103) came to rest 16.9 mm from the truth so, 13 of its 600 points 5 mm off the part and left
out, the other 587 at the noise; the truth fits all 600 at the noise.

The same holds for points the fit kept that lie far beyond its robust spread: an exact least
squares stalled 1.23 mm from the truth along such a direction, 28 points past an edge holding
it there (CTC-03's patch, seed 6105). The caller says which points fit (engine.exact_fit: the
gross-outlier rule's and the robust cut's); the others count as left out.

:func:`slid_poses` scans the pose along each such direction that some point constrains (not a
symmetry of the surface under every point) over the nominal's whole extent (a whole turn for a
rotation), scoring a few kept and left-out points on the surface judged, and refines the best
few places with more of them; the caller fits each again and keeps a pose that scores better.
Where no direction is free, the points left out may still say where the pose is, a few
millimetres away past a barrier that the kept points would have to cross:
:func:`shifted_poses` scores a grid of translations and the places along the direction the kept
points constrain least (and the nominal's axis nearest it) where a point left out crosses the
nominal (a look-alike a pocket's pitch away), :func:`jumped_poses` the translations that put
each point left out on the nominal. :func:`half_turns` turns a pose half way about the
nominal's frame axes, where a nearly symmetric part's patch may fit but for one feature.
"""

from __future__ import annotations

import numpy as np

from .neighbours import spread_subset
from .nominal import Nominal
from .pose import (apply_transform, make_transform, pose_jacobian, rotation_angle_deg,
                   screw_motion)
from .surface_fit import pose_loss
from .trust import DEGENERATE_STRENGTH, conditioning

SLIDE_STEP_OF_DIAGONAL = 3e-3
"""The scan's step along a free direction, as a fraction of the nominal's bounding-box
diagonal, at least (1.8 mm on CTC-03; its 485 mm along the patch's free direction, scanned
both ways in ``SLIDE_MAX_STEPS``, make it 8.1 mm there: a place is refined over a step on
either side)."""
SLIDE_MAX_STEPS = 120
"""Places scanned along one direction at most, one more for a slide (the step grows to keep to
it): each costs an exact evaluation of the scanned points."""
SCAN_POINTS = 8
"""Kept points and points left out (spread over each) that the scan scores, at most, on the
surface judged: the left-out ones say where the slid pose meets the feature that pins it, the
kept ones where it leaves the part (one left-out point alone touches a face at many places:
CTC-03's 30% patch of 90 points, seed 505). Not on the nominal's sample: a CAD tessellation's
long facets put that point 2.4 mm off the part at the truth, where it lies on a face."""
SLIDE_POINTS = 48
"""Kept points (spread over them) and points left out (as many at most) that the refinement
scores: the kept ones say where the slid pose leaves the part, the others where it meets the
feature."""
SLIDE_CANDIDATES = 3
"""Places along each direction (local minima of the scan, a run of equal ones as one) refined
and handed back, best first."""


SLIDE_STRENGTH = 1e-2
"""A direction whose strength (engine.trust.conditioning: its eigenvalue over the largest) is
below this among the kept points is scanned. Above engine.trust's WEAK_STRENGTH: a pose slid
along a free direction may keep a few points of the feature that would pin it, millimetres off
their own places, and they constrain it only so far (CTC-03's patch taken at its runner-up,
9.9 mm from the truth: 0.0028, its rms 0.019 mm against the noise's 0.002)."""


def scan_directions(X: np.ndarray, normals: np.ndarray, kept: np.ndarray, rms: float):
    """(twists, conditioning): the unit motions to scan, and the ``kept`` points' conditioning
    (engine.trust.conditioning) whose centre and length they are about. The directions the kept
    points of X (n, 3; nominal frame; normals at their feet) constrain below ``SLIDE_STRENGTH``
    span a subspace; within it, the motions that no point at all constrains (a symmetry of the
    surface under every point, kept or not: a turn about a part of revolution's axis, a slide
    along a cylinder's) are dropped (nothing along them can fit better, and a whole turn's scan
    and fits cost FTC-11 with a bump seconds for nothing), and the rest are scanned: the
    subspace's directions that every point constrains, a basis of them by the eigenvectors of
    the points' normal matrix within it (so that a free turn and a free slide, mixed by the
    eigenvalue solver into screws, are told apart)."""
    cond = conditioning(X[kept], normals[kept], rms, weak_below=SLIDE_STRENGTH)
    if not cond.weak:
        return [], cond
    W = np.array([w.twist for w in cond.weak], float).T  # (6, m), orthonormal columns
    J = pose_jacobian(X, normals, np.asarray(cond.centre, float))
    J[:, :3] /= cond.length
    A = J.T @ J
    top = float(np.linalg.eigvalsh(A)[-1]) or 1.0
    lam, U = np.linalg.eigh(W.T @ A @ W)
    twists = [W @ U[:, j] for j in range(len(lam)) if lam[j] >= DEGENERATE_STRENGTH * top]
    # The kept points' own weak directions too, where every point constrains them and no
    # direction above lies along them: the basis of every point mixes a free slide with a
    # weak turn that one point left out pins (NIST CTC-03's 90-point patch, seed 13855: 3.6 mm
    # off along y, which the kept points leave free; every point's basis scans two screws of
    # that slide and a turn about z, and the truth, a pure slide, lies on neither).
    for w in W.T:
        if (float(w @ A @ w) >= DEGENERATE_STRENGTH * top
                and all(abs(float(w @ t)) < ALONG_COSINE for t in twists)):
            twists.append(w)
    return twists, cond


ALONG_COSINE = 0.99
"""Two unit twists whose dot product is at least this lie along each other: one is scanned."""


def slid_poses(nominal: Nominal, measured: np.ndarray, T: np.ndarray, dev, kept: np.ndarray,
               rms: float, surface, scale: float,
               reach: float | None = None) -> list[np.ndarray]:
    """Poses (4, 4) to fit again from, best first: the pose T slid along each direction that the
    ``kept`` points (n,) bool leave weak, to where the points left out meet the nominal. Empty
    when no point was left out or no direction is weak.

    dev : every point's deviations at T (normals at their feet); rms : the fit's over the kept
    points; surface : the surface judged (engine.surface.Surface); scale : pose_score's
    (``outlier_floor`` x the nominal's diagonal); reach : the largest motion scanned, mm at the
    kept points' RMS radius (None: the nominal's extent, a whole turn)."""
    out = np.flatnonzero(~kept)
    if out.size == 0 or np.count_nonzero(kept) < 6:
        return []
    X = apply_transform(T, measured)
    twists, cond = scan_directions(X, dev.normal, kept, rms)
    if not twists:
        return []
    inside = np.flatnonzero(kept)
    use = np.concatenate(_spread_each(X, inside, out, SLIDE_POINTS))
    found: list[tuple[float, np.ndarray]] = []
    scanned = np.concatenate(_spread_each(X, inside, out, SCAN_POINTS))
    for twist in twists:
        found.extend(_along(nominal, T, X[scanned], X[use], twist, cond.centre, cond.length,
                            surface, scale, reach))
    return [Ts for _, Ts in sorted(found, key=lambda f: f[0])]


def _along(nominal: Nominal, T: np.ndarray, P: np.ndarray, Q: np.ndarray, twist, centre,
           length: float, surface, scale: float, reach: float | None = None):
    """[(loss, pose)] at the best places along the unit motion ``twist`` (rotation in mm at
    ``length`` about ``centre``, then translation; engine.pose.screw_motion) from pose
    T: the local minima of the loss of a few points P (m, 3; kept and left out, at T) on
    ``surface``, each refined by the loss of more of them, Q; those that score better there than
    T itself. Both losses are pose_score's at ``scale``. reach : slid_poses'."""
    twist = np.asarray(twist, float)
    centre = np.asarray(centre, float)
    rot, tr = float(np.linalg.norm(twist[:3])), float(np.linalg.norm(twist[3:]))
    diagonal_step = SLIDE_STEP_OF_DIAGONAL * nominal.diagonal
    # A turn (by the larger part, as engine.trust names a direction): half a turn each way,
    # amplitude being mm of arc at ``length``; a slide: the nominal's extent along it each way.
    span = (np.pi * length / rot if rot >= tr
            else float(np.ptp(nominal.points @ (twist[3:] / tr))) / tr)
    # A turn about an axis (its translation along the axis, the pitch, under a step in a whole
    # turn) comes back to where it started: the places wrap round, a whole turn in 2k steps.
    pitch = abs(float(twist[:3] @ twist[3:])) / rot * 2.0 * span if rot >= tr else 0.0
    periodic = rot >= tr and pitch < diagonal_step
    # A short slide (``reach``) is refined within it too; a long one may be refined a step past
    # the nominal's extent.
    limit = np.inf
    if reach is not None and reach < span:
        span, periodic, limit = reach, False, reach
    k = max(int(np.ceil(span / max(diagonal_step, 2.0 * span / SLIDE_MAX_STEPS))), 1)
    step = span / k
    amps = step * np.arange(-k, k if periodic else k + 1)
    motions = np.stack([screw_motion(twist, a, centre, length) for a in amps])
    moved = np.einsum("kij,mj->kmi", motions[:, :3, :3], P) + motions[:, None, :3, 3]
    loss = _loss(surface, moved, scale)
    nb_prev = np.roll(loss, 1)
    nb_next = np.roll(loss, -1)
    if not periodic:
        nb_prev[0], nb_next[-1] = np.inf, np.inf
    minima = np.flatnonzero((loss <= nb_prev) & (loss <= nb_next))
    # Runs of equal minima are one place, refined over the whole run: where a few points fit
    # over a stretch (a slide along a face), the rest fit somewhere in it.
    runs = np.split(minima, np.flatnonzero(np.diff(minima) > 1) + 1) if minima.size else []
    runs.sort(key=lambda r: float(loss[r].min()))
    chosen = runs[:SLIDE_CANDIDATES]

    def motion(a: float) -> np.ndarray:
        return screw_motion(twist, a, centre, length)

    def surface_loss(a: float) -> float:
        return float(_loss(surface, apply_transform(motion(a), Q), scale))

    from scipy.optimize import minimize_scalar  # only here: its import costs 0.1 s

    here_loss = surface_loss(0.0)
    found = []
    for run in chosen:
        r = minimize_scalar(surface_loss, bounds=(max(amps[run[0]] - step, -limit),
                                                  min(amps[run[-1]] + step, limit)),
                            method="bounded", options={"xatol": 1e-3 * step})
        if r.fun < here_loss:
            found.append((float(r.fun), motion(float(r.x)) @ T))
    return found


def twin_turns(nominal: Nominal, measured: np.ndarray, T: np.ndarray, dev, T_twin: np.ndarray,
               surface, scale: float) -> list[np.ndarray]:
    """Poses (4, 4) to fit again from, best first: the pose T turned about the axis of its
    motion to ``T_twin``, a pose every point fits as well (a patch of a part whose features
    repeat about an axis: a turn that maps the part onto itself), over a whole turn, where the
    points score better than at T (``_along``: a few spread points scanned, more refined; the
    score pose_loss at ``scale``). Empty when the two poses do not turn apart, or when the turn
    moves no point off its face (a part of revolution about its axis: NIST FTC-11's twins,
    every turn fitting alike). dev : every point's deviations at T (normals at their feet).

    (NIST CTC-05 (AP203), its 90-point patch of seed 19601: the pose and its runner-up are
    150 and 30 degrees about z from the truth, a rim of features 30 degrees apart; both score
    3.26 µm, the truth 1.94 µm, and every point fits all three within 0.014 mm.)"""
    G = T_twin @ np.linalg.inv(T)  # the motion, nominal frame
    R, t = G[:3, :3], G[:3, 3]
    if rotation_angle_deg(R) < TWIN_LEAST_TURN_DEG:  # a slide, not a turn
        return []
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if np.linalg.norm(w) < 1e-6:  # a half turn: its axis is R + R^T's top eigenvector
        w = np.linalg.eigh(R + R.T)[1][:, -1]
    axis = w / np.linalg.norm(w)
    # A point of the axis: (I - R) c = t across it (t along it, a screw's pitch, left aside).
    c = np.linalg.lstsq(np.eye(3) - R, t - axis * float(axis @ t), rcond=None)[0]
    X = apply_transform(T, measured)
    radial = (X - c) - np.outer((X - c) @ axis, axis)
    length = float(np.sqrt(np.mean(np.sum(radial ** 2, 1)))) or 1.0
    # Each point's deviation changes at this rate (mm per mm of arc at the points' radius).
    rate = np.cross(X - c, dev.normal) @ axis / length
    if float(np.sqrt(np.mean(rate ** 2))) < TWIN_FREE_RATE:
        return []
    P, Q = X[spread_subset(X, 2 * SCAN_POINTS)], X[spread_subset(X, 2 * SLIDE_POINTS)]
    found = _along(nominal, T, P, Q, np.concatenate([axis, np.zeros(3)]), c, length, surface,
                   scale)
    return [Ts for _, Ts in sorted(found, key=lambda f: f[0])]


TWIN_LEAST_TURN_DEG = 1.0
"""Twins turned apart by less than this are a slide apart: :func:`twin_turns` has no axis."""
TWIN_FREE_RATE = 1e-4
"""A turn that changes the points' deviations at an RMS rate below this (mm per mm of arc at
their radius) moves no point off its face: :func:`twin_turns` does not scan it."""


def half_turns(nominal: Nominal, T: np.ndarray, measured: np.ndarray) -> list[np.ndarray]:
    """The pose T turned 180 degrees about each axis of the nominal's frame through the centre
    of its bounding box, where most ``measured`` points then lie near the nominal's finest
    sample (:data:`TURN_NEAR_SHARE`): a part that is nearly symmetric so (CAD parts are drawn
    along their frame's axes) fits a patch in both poses but for the feature that breaks the
    symmetry. (NIST CTC-05 (AP203), its 90-point patch, seed 7855: the pose the truth turned
    about z, 89 points at the noise and one 2.65 mm off; turned back it lands on the truth,
    0.0019 mm against 0.0254, 87 % of its points near, the other two turns' at most 1 %. The
    turns about the principal axes of its tessellation's points land 200-500 mm off.)"""
    centre = 0.5 * (nominal.points.min(axis=0) + nominal.points.max(axis=0))
    halves = [2.0 * np.outer(axis, axis) - np.eye(3) for axis in np.eye(3)]  # half turns
    pts, nrm, tree = nominal.level(nominal.finest_level)
    spacing = nominal.level_spacing(nominal.finest_level)
    turned = []
    for R in halves:
        K = make_transform(R, centre - R @ centre) @ T
        X = apply_transform(K, measured)
        d, j = tree.query(X, distance_upper_bound=TURN_NEAR_SPACINGS * spacing)
        j = np.minimum(j, len(pts) - 1)  # (no sample that near: j is len(pts), d inf)
        plane = np.abs(np.einsum("ij,ij->i", X - pts[j], nrm[j]))
        if np.mean(np.isfinite(d) & (plane <= TURN_PLANE_SPACINGS * spacing)) >= TURN_NEAR_SHARE:
            turned.append(K)
    return turned


TURN_NEAR_SPACINGS = 3.0
TURN_PLANE_SPACINGS = 0.1
"""A point lies near the nominal at a half turn (:func:`half_turns`) when a sample point
of the nominal's finest level lies within ``TURN_NEAR_SPACINGS`` of its spacings and the point
within ``TURN_PLANE_SPACINGS`` of them of that sample's tangent plane (a point on a face may
lie a spacing from its nearest sample, but off that sample's tangent plane only as far as the
face curves between them) …"""
TURN_NEAR_SHARE = 0.5
"""… and a half turn is fitted only where at least this share of the points lies near: each
fit of a turn that puts the points millimetres off costs 0.1-0.5 s (an exact evaluation of a
point far off: about 0.5 ms). (NIST patches of 90 points with two mis-probes each, six parts x
three seeds: 21 of the 54 turns lie near and are fitted, and the 18 cases take 37.3 s, 55.4 s
when every turn was fitted; CTC-05 (AP203)'s seed 7855 keeps its one turn, 1.25 s, 2.36 s.)"""


SHIFT_STEPS = 3
"""Grid places each way along each axis that :func:`shifted_poses` scores ((2k + 1)^3 shifts,
each an exact evaluation of 2 x SCAN_POINTS points: 0.55-0.6 s on CTC-03's 90-point patches,
where they lie millimetres off the faces; 2.4-2.9 s on FTC-08's of seed 5455, up to 10 mm
off) …"""
SHIFT_REACH = 2.0
"""… reaching this x the largest deviation of a point left out (a shift oblique to that point's
normal must go further than its deviation) …"""
SHIFT_REACH_OF_DIAGONAL = 0.02
"""… and this fraction of the nominal's bounding-box diagonal at most."""
SHIFT_CANDIDATES = 3
"""Local minima of the shift scan confirmed with more points and handed back, best first."""
LINE_STEPS = 16
"""Places each way along each left-out point's normal that :func:`shifted_poses` scores too, out
to ``SHIFT_REACH`` x its deviation (0.14 mm apart on CTC-03's patch of seed 12555) …"""
LINE_STEP_OF_SCALE = 3.0
"""… for a point whose places would lie at most this x the score's scale apart (0.18 mm on
CTC-03; the basin there is 0.3 mm wide)."""


def shifted_poses(nominal: Nominal, measured: np.ndarray, T: np.ndarray, dev,
                  kept: np.ndarray, surface, scale: float) -> list[np.ndarray]:
    """Poses (4, 4) to fit again from, best first: the pose T shifted (translated in the
    nominal's frame) to where the points left out meet the nominal while the kept ones stay on
    it. A grid of shifts out to ``SHIFT_REACH`` x the largest deviation of a point left out is
    scored by the loss (pose_loss at ``scale``) of a few kept and left-out points on
    ``surface``; its best local minima are scored again with more of them, and those better
    than T there are handed back; then the places along the direction the kept points
    constrain least (and the nominal's axis nearest it) where a point left out crosses the
    surface (:func:`_crossings`), confirmed alike; then, unconfirmed, the best local minima
    of that loss along each left-out point's normal and along that direction, at a finer
    step (``LINE_STEPS``). Empty when no point was left out.

    A least-squares pose can rest a few millimetres from the truth with every point but those
    of one feature at the noise and no direction free: slid along an extrusion, held there by
    one point of a top face that lands on a side face (NIST CTC-03's 90-point patch, seed 7705:
    3.5 mm off, three points 1.6-3.4 mm off). No gradient leads home: that point must leave its
    face on the way. (The nominal's sample cannot score the grid: at the true pose of CTC-03's
    patch of seed 6705 its tessellation puts points up to 3.5 mm off.) (dev: every point's
    deviations at T; kept (n,) bool: the points that fit.)"""
    out = np.flatnonzero(~kept)
    if out.size == 0 or np.count_nonzero(kept) < 6:
        return []
    reach = min(SHIFT_REACH * float(np.max(np.abs(dev.signed[out]))),
                SHIFT_REACH_OF_DIAGONAL * nominal.diagonal)
    X = apply_transform(T, measured)
    inside = np.flatnonzero(kept)
    p_in, p_out = _spread_each(X, inside, out, SCAN_POINTS)
    P = X[np.concatenate([p_in, p_out])]
    wp = _stratum_weights(p_in.size, p_out.size, inside.size, out.size)
    k, n = SHIFT_STEPS, 2 * SHIFT_STEPS + 1
    g = np.linspace(-reach, reach, n)
    shifts = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    loss = _loss(surface, P[None] + shifts[:, None], scale, wp).reshape(n, n, n)
    # Local minima: no lower place among each one's 26 neighbours (beyond the grid counts as
    # higher).
    from scipy.ndimage import minimum_filter  # only here, as engine.weak_search's scipy.optimize

    lowest = minimum_filter(loss, size=3, mode="constant", cval=np.inf)
    minima = np.flatnonzero(((loss <= lowest) & (loss < loss[k, k, k])).ravel())
    minima = minima[np.argsort(loss.ravel()[minima], kind="stable")][:SHIFT_CANDIDATES]
    found = _confirmed(X, inside, out, shifts[minima], T, surface, scale)
    # Along each left-out point's normal, finer than the grid: a thin wall's one side fitted on
    # its other side rests the wall's thickness off along its normal, in a basin narrower than
    # the grid's step (CTC-03's 90-point patch, seed 12555: 1.97 mm off along a wall's normal,
    # its basin 0.3 mm wide, the grid's step 0.74 mm). Handed back unconfirmed: the normal at
    # the foot of a point on the wrong face is off the way home (there by 5 degrees: the place
    # 1.95 mm along it is 0.16 mm off sideways, and more points put it worse than the pose,
    # until a least squares from it comes home).
    # Each line reaches as far as the grid would for its point alone; a line whose steps would
    # be coarser than LINE_STEP_OF_SCALE x scale finds no narrow basin (a mis-probe millimetres
    # off, whose points off the faces cost 0.5 ms an evaluation each: 0.7 s a grid's lines).
    along = np.minimum(SHIFT_REACH * np.abs(dev.signed[p_out]), reach)
    movers = np.flatnonzero(along <= LINE_STEPS * LINE_STEP_OF_SCALE * scale)
    a = np.linspace(-1.0, 1.0, 2 * LINE_STEPS + 1)
    lines = [dev.normal[p_out[movers]][:, None, :] * (along[movers, None] * a)[:, :, None]]
    # And along the direction the kept points constrain least, as far as the grid may reach
    # (SHIFT_REACH_OF_DIAGONAL), at that finest step (or WEAKEST_LINE_STEPS each way): the
    # wrong side of a thin wall lies there when the points on the wall's sides are few and no
    # point left out says how far (CTC-03's 90-point patches: seed 5105, noise 10 µm, 1.9 mm
    # off along x, which 2 of the 86 kept points constrain, the 4 left out on faces whose
    # normals are 14-76 degrees from x; seed 16855, 1.94 mm off along x, the 2 left out 0.09
    # and 0.13 mm off, so that the grid reached 0.26 mm).
    weakest = np.linalg.eigh(dev.normal[inside].T @ dev.normal[inside])[1][:, 0]
    far = SHIFT_REACH_OF_DIAGONAL * nominal.diagonal
    k = int(min(np.ceil(far / (LINE_STEP_OF_SCALE * scale)), WEAKEST_LINE_STEPS))
    lines.append((weakest[None, :] * np.linspace(-far, far, 2 * k + 1)[:, None])[None])
    on_lines = sorted((m for offsets in lines
                       for m in _line_minima(P, wp, offsets, surface, scale)),
                      key=lambda m: m[0])[:SHIFT_CANDIDATES]
    # The crossings along that direction, and along the nominal's axis nearest it: CAD repeats
    # its pockets along its frame's axes, and a weak direction 8.6 degrees off x walks a point
    # 57 mm along it 8.5 mm off the way home (FTC-07's 90-point patch, seed 25001: 56.9 mm off
    # along x, the kept points constraining x and y weakly, 0.66 and 3.66 of 84.7).
    axis = np.eye(3)[int(np.argmax(np.abs(weakest)))]
    ways = [weakest] + ([axis] if abs(float(axis @ weakest)) < ALONG_COSINE else [])
    crossed = _confirmed(X, inside, out, np.concatenate(
        [_crossings(P, wp, p_out.size, way, nominal, surface, scale) for way in ways]),
        T, surface, scale)[:SHIFT_CANDIDATES]
    return found + crossed + [make_transform(np.eye(3), shift) @ T for _, shift in on_lines]


CROSSING_STEP_OF_DIAGONAL = 3e-3
"""The step of :func:`_crossings`' scan, as a fraction of the nominal's bounding-box diagonal
(1.2 mm on FTC-07): a wall thinner than it may be crossed unseen."""
CROSSING_MAX_STEPS = 400
"""Places each way at most of that scan (the step grows to keep to it)."""


def _crossings(P: np.ndarray, w: np.ndarray, n_out: int, direction: np.ndarray,
               nominal: Nominal, surface, scale: float) -> np.ndarray:
    """Shifts (k, 3) along the unit ``direction``, best first, at most SHIFT_CANDIDATES and
    none within a step of a better one: where one of the last ``n_out`` points of P (m, 3; the
    points left out, after the kept ones) crosses ``surface`` within the nominal's extent along
    it either way, found by a change of sign of its deviation over a step
    (``CROSSING_STEP_OF_DIAGONAL``), placed by linear interpolation, and kept if the loss of P
    there (pose_loss at ``scale``, weights w), once refined, is lower than at the pose.
    A patch of repeated pockets fits a look-alike one pocket's pitch away, every point but one
    at the noise (NIST FTC-07's 90-point patches, seeds 12601 and 12604: 15.0 and 14.8 mm off
    along x, which at most one kept point constrains). Its basin is 0.5 mm wide; the point left
    out lands on its face there, and its deviation changes sign on the way. Each place is
    refined first by translation (:func:`_translation_steps`)."""
    span = float(np.ptp(nominal.points @ direction))
    step = max(CROSSING_STEP_OF_DIAGONAL * nominal.diagonal, span / CROSSING_MAX_STEPS)
    k = max(int(np.ceil(span / step)), 1)
    s = step * np.arange(-k, k + 1)
    movers = P[P.shape[0] - n_out:]
    places = movers[None] + s[:, None, None] * direction  # (2k + 1, n_out, 3)
    # Only where a point lies within the nominal's box (a step beyond it): it crosses nothing
    # elsewhere, and a point far off the part cost up to 0.3 ms an evaluation (CTC-05, 542 mm
    # along x each way) before the distances were asked only within the step.
    lo, hi = nominal.points.min(axis=0) - step, nominal.points.max(axis=0) + step
    inside = np.all((places >= lo) & (places <= hi), axis=-1)
    d = np.full(inside.shape, np.nan)
    d[inside] = _deviations(surface, places[inside], step).signed
    a, b = d[:-1], d[1:]
    # A change of sign with both deviations within the step: the point crossed the surface (a
    # deviation changes by at most the point's motion; a jump of the nearest face's side does
    # not).
    i, j = np.nonzero((np.signbit(a) != np.signbit(b)) & (np.abs(a) + np.abs(b) <= 1.01 * step))
    if i.size == 0:
        return np.zeros((0, 3))
    shifts = (s[i] + step * a[i, j] / (a[i, j] - b[i, j]))[:, None] * direction
    # The direction is the kept points' least constrained, not the way home: CTC-03's 90-point
    # patch of seed 13600 rests 20.7 mm off along y, and that direction is 1 degree off y, so
    # the crossing lands 0.35 mm off along x, which the kept points pin, and scores worse
    # than the pose. Each is moved first to where its points fit best.
    for _ in range(CROSSING_STEPS):
        shifts = shifts + _translation_steps(surface, P, shifts, w, scale, step)
    loss = _loss(surface, P[None] + shifts[:, None], scale, w)
    here = float(_loss(surface, P, scale, w))
    chosen: list[np.ndarray] = []
    for c in np.argsort(loss, kind="stable"):
        if loss[c] >= here or len(chosen) == SHIFT_CANDIDATES:
            break
        if all(np.linalg.norm(shifts[c] - x) > step for x in chosen):
            chosen.append(shifts[c])
    return np.array(chosen).reshape(-1, 3)


CROSSING_STEPS = 2
"""Gauss-Newton steps of :func:`_translation_steps` a crossing's shift takes."""


def _translation_steps(surface, P: np.ndarray, shifts: np.ndarray, w: np.ndarray,
                       scale: float, largest: float) -> np.ndarray:
    """(k, 3) a Gauss-Newton step in translation alone from each of ``shifts`` (k, 3) of the
    points P (m, 3; weights w) on ``surface``, iteratively reweighted for pose_loss at ``scale``
    (each point by 1 / (d^2 + scale^2)): the points' deviations and normals there, a point
    farther than FAR_OF_SCALE x scale left out; no longer than ``largest`` mm."""
    k, m = shifts.shape[0], P.shape[0]
    dev = _deviations(surface, (P[None] + shifts[:, None]).reshape(-1, 3), FAR_OF_SCALE * scale)
    d = dev.signed.reshape(k, m)
    ok = np.isfinite(d)
    d0 = np.where(ok, d, 0.0)
    n = np.where(ok[..., None], dev.normal.reshape(k, m, 3), 0.0)
    c = np.where(ok, w[None] / (d0 * d0 + scale * scale), 0.0)
    A = np.einsum("km,kmi,kmj->kij", c, n, n)
    A += (1e-9 * np.trace(A, axis1=1, axis2=2) + 1e-300)[:, None, None] * np.eye(3)
    step = np.linalg.solve(A, -np.einsum("km,km,kmi->ki", c, d0, n)[..., None])[..., 0]
    length = np.linalg.norm(step, axis=1, keepdims=True)
    return step * np.minimum(1.0, largest / np.maximum(length, 1e-300))


WEAKEST_LINE_STEPS = 64
"""Places each way at most along the direction the kept points constrain least
(:func:`shifted_poses`)."""


def _line_minima(P: np.ndarray, w: np.ndarray, offsets: np.ndarray, surface,
                 scale: float) -> list[tuple[float, np.ndarray]]:
    """[(loss, shift (3,))] at the local minima along lines of shifts ``offsets`` (l, 2k+1, 3),
    each line's middle place the pose itself (shift 0): the loss (pose_loss at ``scale``,
    weights w) of the points P (m, 3) on ``surface``, lower than at the middle and than the
    place before, and not above the one after (a run of equal places is one: its first)."""
    if offsets.shape[0] == 0:
        return []
    flat = offsets.reshape(-1, 3)
    loss = _loss(surface, P[None] + flat[:, None], scale, w).reshape(offsets.shape[:2])
    edged = np.pad(loss, ((0, 0), (1, 1)), constant_values=np.inf)
    middle = offsets.shape[1] // 2
    here = loss[:, middle:middle + 1]
    at = np.flatnonzero(((loss < edged[:, :-2]) & (loss <= edged[:, 2:]) & (loss < here)).ravel())
    return [(float(loss.ravel()[i]), flat[i]) for i in at]


def jumped_poses(measured: np.ndarray, T: np.ndarray, dev, kept: np.ndarray, surface,
                 scale: float) -> list[np.ndarray]:
    """Poses (4, 4) to fit again from, best first: the pose T shifted along the foot normal of
    a point left out by its deviation (each of up to SCAN_POINTS of them, spread), so that it
    meets the nominal, kept if a few kept and left-out points score better there than at T on
    ``surface`` (pose_loss at ``scale``, each stratum weighing as its points do), and more of
    them again. Empty when no point was left out.

    A patch of a thin wall's one side fits its other side too (unsigned distances), and the
    pose then rests one wall's thickness off with every point but those of the next face at
    the noise (NIST CTC-03's 90-point patch, seed 2705: 1.9 mm along the wall's normal, two
    points 1.91 mm off): the kept points would have to cross the wall to come home."""
    out = np.flatnonzero(~kept)
    if out.size == 0 or np.count_nonzero(kept) < 6:
        return []
    X = apply_transform(T, measured)
    inside = np.flatnonzero(kept)
    stay, movers = _spread_each(X, inside, out, SCAN_POINTS)
    P = X[np.concatenate([stay, movers])]
    shifts = -dev.signed[movers, None] * dev.normal[movers]
    moved = P[None] + shifts[:, None]
    w = _stratum_weights(stay.size, movers.size, inside.size, out.size)
    loss = _loss(surface, moved, scale, w)
    here = float(_loss(surface, P, scale, w))
    better = np.flatnonzero(loss < here)
    better = better[np.argsort(loss[better], kind="stable")][:SHIFT_CANDIDATES]
    return _confirmed(X, inside, out, shifts[better], T, surface, scale)


def _confirmed(X: np.ndarray, inside: np.ndarray, out: np.ndarray, shifts: np.ndarray,
               T: np.ndarray, surface, scale: float) -> list[np.ndarray]:
    """The poses T shifted by each of ``shifts`` (k, 3) that score better than T on more of
    the kept points (indices ``inside`` into X, the points at T) and of those left out
    (``out``), SLIDE_POINTS of each at most, spread, each weighing as its stratum does; best
    first."""
    if shifts.shape[0] == 0:
        return []
    q_in, q_out = _spread_each(X, inside, out, SLIDE_POINTS)
    Q = X[np.concatenate([q_in, q_out])]
    w = _stratum_weights(q_in.size, q_out.size, inside.size, out.size)
    loss = _loss(surface, Q[None] + shifts[:, None], scale, w)
    here = float(_loss(surface, Q, scale, w))
    return [make_transform(np.eye(3), shifts[i]) @ T
            for i in np.argsort(loss, kind="stable") if loss[i] < here]


def _spread_each(X: np.ndarray, inside: np.ndarray, out: np.ndarray,
                 m: int) -> tuple[np.ndarray, np.ndarray]:
    """Up to ``m`` of the kept points (indices ``inside`` into X, the points at the pose) and up
    to ``m`` of those left out (``out``), each spread over its own (spread_subset)."""
    return inside[spread_subset(X[inside], m)], out[spread_subset(X[out], m)]


def _stratum_weights(n_kept_chosen: int, n_out_chosen: int, n_kept: int,
                     n_out: int) -> np.ndarray:
    """Weights (m,) of a few points chosen from the kept ones (the first ``n_kept_chosen`` of
    ``n_kept``) and from those left out (the other ``n_out_chosen`` of ``n_out``), each stratum
    weighing as much as its points: a scan of as many of each must not take a pose where the
    few left out fit and many kept ones leave the part for better (a face bowed 1 mm, its
    points left out: the pose moved 1 mm along their normal fits them and takes the rest of the
    face off)."""
    return np.concatenate([np.full(n_kept_chosen, n_kept / max(n_kept_chosen, 1)),
                           np.full(n_out_chosen, n_out / max(n_out_chosen, 1))]) \
        / (n_kept + n_out)


FAR_OF_SCALE = 50.0
"""A point scored by a search counts as this x the score's scale off wherever it lies farther
off (2 mm on NIST FTC-07, 3 mm on CTC-03): it fits nowhere near, and OpenCascade measures a
point 30 mm off 9 x as long as one on the part (NIST CTC-03's 90-point patch, seed 14604: its
searches asked 92,700 distances at 120 µs each, 11 s of the case's 21)."""


def _deviations(surface, X: np.ndarray, within: float):
    """Deviations of points X (n, 3) on ``surface``, NaN (or the deviation) where a point lies
    farther than ``within`` mm off (engine.step_model.ExactDistances.deviations_within; another
    surface measures every point)."""
    near = getattr(surface, "deviations_within", None)
    return surface.deviations(X) if near is None else near(X, within)


def _loss(surface, P: np.ndarray, scale: float, w: np.ndarray | None = None) -> np.ndarray:
    """pose_loss at ``scale`` (weights w) of points P (..., m, 3) on ``surface``, per row of m
    points, each farther off than FAR_OF_SCALE x scale counted as that far."""
    far = FAR_OF_SCALE * scale
    d = _deviations(surface, P.reshape(-1, 3), far).signed.reshape(P.shape[:-1])
    return pose_loss(np.where(np.abs(d) <= far, d, far), scale, w)
