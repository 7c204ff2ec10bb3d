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
rotation), scoring the points left out on the nominal's sample, and refines the best few
places on the surface judged with a few fitting points as well; the caller fits each again and
keeps a pose that scores better (no pose found may score better than the one reported).
"""

from __future__ import annotations

import numpy as np

from .deviation import point_to_surface
from .neighbours import spread_subset
from .nominal import Nominal
from .pose import apply_transform, pose_jacobian, screw_motion
from .trust import DEGENERATE_STRENGTH, conditioning

SLIDE_STEP_OF_DIAGONAL = 3e-3
"""The scan's step along a free direction, as a fraction of the nominal's bounding-box
diagonal (1.8 mm on CTC-03: its truth's basin on the sample is some 6 mm wide)."""
SLIDE_MAX_STEPS = 1000
"""Places scanned along one direction at most (the step grows to keep to it)."""
SLIDE_POINTS = 48
"""Kept points (spread over them) and points left out (as many at most) that the refinement
scores: the kept ones say where the slid pose leaves the part, the others where it meets the
feature (the scan scores these alone)."""
SCAN_SCALE = 10.0
"""The scan's loss on the nominal's sample counts a point as least squares up to this x
pose_score's scale: the sample's own chordal error is of that scale (0.06 mm on CTC-03), and the
kept points' share of it hid the truth there. The scan scores the points left out only; where
the kept points leave the part is the refinement's concern, on the surface judged."""
SLIDE_CANDIDATES = 3
"""Places along each direction refined and handed back, best first, at least
``SLIDE_SEPARATION`` steps apart."""
SLIDE_SEPARATION = 4


SLIDE_STRENGTH = 1e-2
"""A direction whose strength (engine.trust.conditioning: its eigenvalue over the largest) is
below this among the kept points is scanned. Above engine.trust's WEAK_STRENGTH: a pose slid
along a free direction may keep a few points of the feature that would pin it, millimetres off
their own places, and they constrain it only so far (CTC-03's patch taken at its runner-up,
9.9 mm from the truth: 0.0028, its rms 0.019 mm against the noise's 0.002)."""


def weak_directions(X: np.ndarray, normals: np.ndarray, kept: np.ndarray, rms: float):
    """The directions (engine.trust.WeakDirection) that the ``kept`` points of X (n, 3; nominal
    frame; normals at their feet) constrain below ``SLIDE_STRENGTH``, and the fit's
    conditioning of them."""
    cond = conditioning(X[kept], normals[kept], rms, weak_below=SLIDE_STRENGTH)
    return cond.weak, cond


def _score_rows(d: np.ndarray, scale: float) -> np.ndarray:
    """Per row of deviations d (k, m): the mean Cauchy loss that engine.registration.pose_score
    ranks by (lower is better)."""
    return np.mean(np.log(d * d + scale * scale), axis=1)


def slid_poses(nominal: Nominal, measured: np.ndarray, T: np.ndarray, dev, kept: np.ndarray,
               rms: float, deviations_at, scale: float) -> list[np.ndarray]:
    """Poses (4, 4) to fit again from, best first: the pose T slid along each direction that the
    ``kept`` points (n,) bool leave weak, to where the points left out meet the nominal. Empty
    when no point was left out or no direction is weak.

    dev : every point's deviations at T (normals at their feet); rms : the fit's over the kept
    points; deviations_at(T, idx) : the signed deviations (mm) of measured points ``idx`` on
    the surface judged; scale : pose_score's (``outlier_floor`` x the nominal's diagonal)."""
    out = np.flatnonzero(~kept)
    if out.size == 0 or np.count_nonzero(kept) < 6:
        return []
    X = apply_transform(T, measured)
    weak, cond = weak_directions(X, dev.normal, kept, rms)
    weak = [w for w in weak if not _free_for_all(X, dev.normal, cond, w.twist)]
    if not weak:
        return []
    inside = np.flatnonzero(kept)
    use = np.concatenate([inside[spread_subset(X[inside], SLIDE_POINTS)],
                          out[spread_subset(X[out], SLIDE_POINTS)]])
    found: list[tuple[float, np.ndarray]] = []
    for w in weak:
        found.extend(_along(nominal, T, X[use[-min(out.size, SLIDE_POINTS):]], use, w, cond,
                            deviations_at, scale))
    return [Ts for _, Ts in sorted(found, key=lambda f: f[0])]


def _free_for_all(X: np.ndarray, normals: np.ndarray, cond, twist) -> bool:
    """Whether no point of X (n, 3), kept or not, constrains the motion ``twist`` (a symmetry
    of the surface under every point: a turn about a part of revolution's axis). Nothing along
    it can then fit better, and a whole turn's scan and fits cost a part of revolution with a
    bump or a mis-probe seconds for nothing (NIST FTC-11)."""
    J = pose_jacobian(X, normals, np.asarray(cond.centre, float))
    J[:, :3] /= cond.length
    A = J.T @ J
    top = float(np.linalg.eigvalsh(A)[-1]) or 1.0
    v = np.asarray(twist, float)
    return float(v @ A @ v) < DEGENERATE_STRENGTH * top


def _along(nominal: Nominal, T: np.ndarray, P: np.ndarray, use: np.ndarray, w, cond,
           deviations_at, scale: float):
    """[(loss, pose)] at the best places along weak direction ``w`` (engine.trust.WeakDirection)
    from pose T: the local minima of the loss of the points left out, P (m, 3) at T, on the
    nominal's sample (at ``SCAN_SCALE`` x ``scale``), each refined by the loss of the measured
    points ``use`` (kept and left out) on the surface judged; those that score better there
    than T itself."""
    twist = np.asarray(w.twist, float)
    centre, length = np.asarray(cond.centre, float), cond.length
    if w.type == "rotation":
        # A whole turn: amplitude is mm of arc at ``length`` per unit of rotation.
        span = np.pi * length / max(float(np.linalg.norm(twist[:3])), 1e-12)
        periodic = True
    else:
        proj = nominal.points @ np.asarray(w.axis, float)
        span = float(np.ptp(proj))
        periodic = False
    step = max(SLIDE_STEP_OF_DIAGONAL * nominal.diagonal, 2.0 * span / SLIDE_MAX_STEPS)
    k = int(np.ceil(span / step))
    amps = step * np.arange(-k, k if periodic else k + 1)
    motions = np.stack([screw_motion(twist, a, centre, length) for a in amps])
    moved = np.einsum("kij,mj->kmi", motions[:, :3, :3], P) + motions[:, None, :3, 3]
    d = point_to_surface(nominal, moved.reshape(-1, 3)).signed.reshape(len(amps), -1)
    loss = _score_rows(d, SCAN_SCALE * scale)
    n = len(amps)
    nb_prev = np.roll(loss, 1)
    nb_next = np.roll(loss, -1)
    if not periodic:
        nb_prev[0], nb_next[-1] = np.inf, np.inf
    minima = np.flatnonzero((loss <= nb_prev) & (loss <= nb_next))
    chosen: list[int] = []
    for i in minima[np.argsort(loss[minima], kind="stable")]:
        gap = np.abs(i - np.array(chosen, int))
        if periodic:
            gap = np.minimum(gap, n - gap)
        if i != k and (not chosen or gap.min() >= SLIDE_SEPARATION):  # k: the pose itself
            chosen.append(int(i))
        if len(chosen) == SLIDE_CANDIDATES:
            break

    def pose(a: float) -> np.ndarray:
        return screw_motion(twist, a, centre, length) @ T

    def surface_loss(a: float) -> float:
        return float(_score_rows(deviations_at(pose(a), use)[None, :], scale)[0])

    from scipy.optimize import minimize_scalar  # only here: its import costs 0.1 s

    here_loss = surface_loss(0.0)
    found = []
    for i in chosen:
        r = minimize_scalar(surface_loss, bounds=(amps[i] - step, amps[i] + step),
                            method="bounded", options={"xatol": 1e-3 * step})
        if r.fun < here_loss:
            found.append((float(r.fun), pose(float(r.x))))
    return found
