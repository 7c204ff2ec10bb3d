"""Datum reference frames: place the part as the drawing's datums say, from the soft registration.

The soft registration finds the part anywhere on the bed; a plan's alignment then decides how the
part is judged. Datum features take the pose's degrees of freedom in order of precedence
(ASME Y14.5 / ISO 5459): the primary datum takes what its feature can constrain (a plane: the
translation along its normal and its two tilts), the secondary takes what it can of what is left
(a plane at right angles: one rotation and one translation), the tertiary the rest; what the
datums leave free is best-fitted on named regions, or stays where the registration put it.

The pose is found as one lexicographic fit. Each datum fits its measured points to its region's
ideal nominal feature (the unbounded plane, width, cylinder or sphere its simulator is, where the
region's nominal is one; else to the region's nominal surface) by moving the *part* within the
directions the higher datums left free,
and only along the directions its own feature can constrain there: those that do not leave the
ideal nominal feature in place (a plane is left in place by the translations along it and the
rotation about its normal, a cylinder by the slide along and the turn about its axis, a sphere
by the turns about its centre; in 2D a line by the slide along it, a circle by the turn about
its centre: :func:`invariant_motions`). Those directions are then fixed for the datums below
it. (Judged from the ideal feature, not from the measured points' deviations, whose normals
carry the sampling's noise: a hole below a plane takes two translations, never a spurious
third direction from the turn about its own axis.) Fits:

* ``tangent`` (the default of both standards): the datum simulator lies outside the material and
  touches the feature's high points. For a plane or line: no point beyond the nominal surface,
  the largest gap the smallest (a linear program). For a size feature (cylinder, sphere,
  circle, width) the simulator's size floats too: the largest inscribed hole or slot / smallest
  circumscribed shaft or tab (a linear program with a uniform offset of the surface). A width's
  datum is its median plane: it takes what a plane would.
* ``lsq``: least squares of the deviations (with the uniform offset for a size feature, so that a
  hole of another diameter is centred, not pulled).

Both are solved as sequences of linearised problems on the exact deviations, like the
registration. Shapes: points and normals (n, 3) in 3D (6 degrees of freedom), (n, 2) in a 2D
template's plane (3 degrees of freedom); poses 4x4 / 3x3 homogeneous, ``T_nominal_measured``;
units mm.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..pose import apply_update, pose_jacobian
from ..seeds import DEFAULT_SEED
from ..seeds import rng as stream_rng
from .plan import MIN_POINTS
from .tangent_lp import tangent_solve

SIZE_FEATURES = ("cylinder", "sphere", "circle", "width")
RANK_TOLERANCE = 1e-6
"""RPS: a direction counts as locked when its singular value exceeds this fraction of the
largest one (exact lock axes give exact zeros)."""
DETERMINED = 0.01
"""A datum's points determine each direction it takes when the smallest singular value of its
linearised deviations (per point, rotations weighed by the lever) is at least this: a plane
probed along one line leaves its tilt about that line below it (a hole probed on a narrow arc,
its centre against its size); the datum is then not established, rather than fitted to noise."""
ALIGNED_TOLERANCE = 1e-4
"""A datum's invariant motion counts as one of the free ones when it lies within this angle
(rad; rotations weighed by the lever) of their span: nominally perpendicular or coaxial features
of a CAD sample or mesh are so to 1e-9 .. 1e-5 (a hole's axis fitted to sampled wall points),
and a datum must not take a direction from that noise."""
STEP_TOLERANCE = 1e-9
"""The fit has settled when no point moves by more than this fraction of the points' extent."""
MAX_STEPS = 30
UNHELD = 0.5
"""A tangent simulator whose step would move the points by this fraction of the part's size
or more is not held by them (engine.gdt.datums._tangent): its datum is not established."""
BOOTSTRAP_DRAWS = 32
"""Fresh draws of the datums' scatter whose fits give the frame's (frame_scatter): its sigmas
to about 12%."""
BOOTSTRAP_STREAM = 5459
"""The bootstrap's random stream (engine.seeds; under the default seed: the plan layer is not
given the inspection's): the same points give the same frame scatter."""
CONTACT = 1e-7
"""A tangent simulator's contact points lie within this fraction of the lever of it (its linear
programs settle to STEP_TOLERANCE)."""


@dataclass(frozen=True)
class DatumFit:
    """How one datum feature took its degrees of freedom.

    label, feature, fit : as in the plan. n_points : measured points of its region.
    constrained : how many degrees of freedom it took (0: none were left, or too few points).
    offset : the simulator's uniform offset from the nominal surface, mm (size features: the
        fitted size's departure along the outward normal; else 0).
    gap : the largest distance of a point from the simulator at the end, mm (tangent fits: the
        largest gap; least squares: the largest |residual|).
    """

    label: str
    feature: str
    fit: str
    n_points: int
    constrained: int
    offset: float
    gap: float


@dataclass(frozen=True)
class FreeDirection:
    """A degree of freedom no datum took, in the nominal frame: a translation ``along`` a unit
    vector, or a rotation about the axis through ``through`` along the unit vector ``along``."""

    type: str
    along: tuple[float, ...]
    through: tuple[float, ...] | None = None

    def describe(self) -> str:
        v = ", ".join(f"{round(a, 3) + 0.0:+.3f}" for a in self.along)  # no "-0.000"
        if self.type == "translation":
            return f"translation along ({v})"
        if self.through is None:
            raise ValueError(f"a rotation about ({v}) needs the point it passes through")
        p = ", ".join(f"{a:.2f}" for a in self.through)
        return f"rotation about ({v}) through ({p})"


@dataclass(frozen=True)
class Alignment:
    """The part placed by its datums: ``T_nominal_measured`` and what it rests on.

    datums : one DatumFit per datum, primary first. free : the degrees of freedom no datum took.
    best_fitted : whether the free ones were best-fitted on regions' points (else they stay at
    the starting pose). complete : every datum had the points its feature needs (otherwise the
    pose rests on fewer datums than asked, and characteristics relative to them cannot be
    trusted). message : why not, in words.
    """

    T_nominal_measured: np.ndarray
    datums: tuple[DatumFit, ...]
    free: tuple[FreeDirection, ...]
    best_fitted: bool
    complete: bool
    message: str = ""
    free_basis: np.ndarray | None = None
    """(dof, f) the free directions in the fits' coordinates (rotation x length, translation,
    about the fits' centre), orthonormal: what ``free`` names."""
    first_order: Callable[[], tuple[np.ndarray, tuple[float, ...]]] | None = None
    """() -> (:attr:`scatter`, :attr:`scatter_sigma`) (:func:`frame_scatter` to first order;
    computed on the first call); None when not computed (an RPS; datums that did not place the
    part)."""
    bootstrapped: Callable[[], np.ndarray] | None = None
    """() -> the frame's scatter as ``scatter`` by a parametric bootstrap (BOOTSTRAP_DRAWS
    draws; computed on the first call): what is probed; ``scatter``, cheaper and larger,
    screens."""

    @property
    def scatter(self) -> np.ndarray | None:
        """(dof, q) how the scatter of the datums' points moves the frame: the principal
        1-sigma motions of the pose in the fits' coordinates, to first order, largest first;
        None when not computed."""
        return None if self.first_order is None else self.first_order()[0]

    @property
    def scatter_sigma(self) -> tuple[float, ...]:
        """Per datum that took directions (primary first), the scatter of its points about
        their least-squares feature that ``scatter`` comes from, mm (nan: too few points to
        tell)."""
        return () if self.first_order is None else self.first_order()[1]

Evaluate = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]
"""evaluate(T, idx) -> (X, d, normals): measured points ``idx`` at pose T in the nominal frame,
their signed deviations (mm, + outward) and the nominal's outward normals at their closest
points, exactly."""


def align(evaluate: Evaluate, T0: np.ndarray, datums: list, members: list, centre: np.ndarray,
          length: float, best_fit: np.ndarray | None = None,
          invariants: list | None = None, surfaces: list | None = None) -> Alignment:
    """Place the part by ``datums`` (engine.gdt.plan.Datum, primary first) from the pose T0.

    members[k] : indices of the measured points of datum k's region. centre (3,) or (2,), length
    (mm): the centre rotations are taken about and the lever that scales them (the measured
    points' centroid and RMS radius at T0: rotations and translations then weigh alike).
    best_fit : indices of the points that best-fit the freedom the datums leave (None: it stays
    at T0). invariants[k] : (dof, k) the motions that leave datum k's ideal nominal feature in
    place (:func:`invariant_motions`); None for a datum whose nominal is not its feature.
    surfaces[k] : an Evaluate of datum k's points against its ideal nominal feature
    (engine.gdt.region_features.datum_surface), what its simulator is; None: ``evaluate``, the
    nominal surface.
    """
    dof = 6 if T0.shape[0] == 4 else 3
    nrot = 3 if dof == 6 else 1
    free = np.eye(dof)
    T = np.array(T0, float)
    fits = []
    complete, message = True, ""
    took = []  # per datum that took directions: what frame_scatter needs of it
    invariants = invariants if invariants is not None else [None] * len(datums)
    surfaces = surfaces if surfaces is not None else [None] * len(datums)
    for datum, idx, inv, surface in zip(datums, members, invariants, surfaces):
        on = surface or evaluate
        idx = np.asarray(idx, dtype=np.int64)
        problem = None
        if idx.size < MIN_POINTS[datum.feature]:
            problem = (f"datum {datum.label} has {idx.size} measured points; its "
                       f"{datum.feature} needs at least {MIN_POINTS[datum.feature]}")
        elif inv is None:
            problem = (f"datum {datum.label}: the nominal points of its region do not form a "
                       f"{datum.feature}")
        fit = None
        if problem is None:
            taken = _complement(free, _within(free, inv))
            if not _determined(on, T, idx, taken, centre, length, nrot,
                               datum.feature in SIZE_FEATURES):
                problem = (f"datum {datum.label}: its {idx.size} points do not determine its "
                           f"{datum.feature} (they span too little of it: along a line, or a "
                           "narrow arc)")
            else:
                fit = _fit_datum(on, T, datum, idx, taken, centre, length, nrot)
                if fit is None:
                    problem = (f"datum {datum.label}: its {idx.size} points do not hold its "
                               f"tangent {datum.feature} (its simulator could move away "
                               "without bound: they span too little of it)")
        if fit is None:  # the datum is not established: ``problem`` says why
            complete, message = False, problem or ""
            fits.append(DatumFit(datum.label, datum.feature, datum.fit, int(idx.size), 0,
                                 0.0, float("nan")))
            continue
        T, offset, gap = fit
        fits.append(DatumFit(datum.label, datum.feature, datum.fit, int(idx.size),
                             taken.shape[1], offset, gap))
        if taken.shape[1]:
            own = _complement(np.eye(dof), _within(np.eye(dof), inv))
            took.append((on, idx, taken, own, datum.feature in SIZE_FEATURES,
                         datum.fit != "lsq"))
        free = _complement(free, taken)
    fitted = False
    if best_fit is not None and len(best_fit) and free.shape[1]:
        best_fit = np.asarray(best_fit, dtype=np.int64)
        T = _least_squares(evaluate, T, best_fit, free, centre, length, nrot, size=False)[0]
        fitted = True
    first_order, bootstrapped = None, None
    if complete and took:
        args = (evaluate, T, took, centre, length, nrot, best_fit if fitted else None, free)
        first_order = functools.cache(lambda: frame_scatter(*args))
        bootstrapped = functools.cache(
            lambda: frame_scatter(*args, draws=BOOTSTRAP_DRAWS)[0])
    return Alignment(T, tuple(fits), _describe_free(free, centre, length, nrot), fitted,
                     complete, message, free, first_order, bootstrapped)


def frame_scatter(evaluate: Evaluate, T, took, centre, length, nrot, best_fit, free,
                  draws: int = 0):
    """(scatter (dof, q), sigmas): how the scatter of the datums' points about their features
    moves the frame they establish.

    Each datum's points scatter independently with the sigma of their residuals about the
    datum's own least-squares feature (the probe's noise, and the form its sampling sees).
    Each datum's fit is linearised at the final pose T along the directions B it took; what
    the higher datums' motion dp does to its points is J dp. The freedom the datums leave,
    best-fitted on ``best_fit``'s points, follows their motion (the scatter of those points
    is the characteristic's own, not the frame's). The principal axes of the frame motion's
    covariance, each scaled to its 1 sigma, are ``scatter``.

    draws = 0: to first order, each datum's step eta = -P (e + J dp) with P the least-squares
    solve of its points (with a size feature's offset), a tangent simulator's of its contact
    points alone (:func:`_contacts`): cheap, and larger than the truth (1.8 times a Monte
    Carlo's on a 10-point tangent width: a simulator rests on other points as the noise
    changes). draws > 0: a parametric bootstrap: ``draws`` fresh draws of that scatter
    (BOOTSTRAP_STREAM) on each datum's least-squares feature (its deviations less their
    residuals: drawn on the measured ones instead, a tangent fit's spread came out 1.6 times
    a Monte Carlo's), its linearised fit solved again (a tangent datum by its linear
    program), the covariance of the motions about their mean. took : per datum that
    took directions, (its Evaluate, point indices, directions taken (dof, r), the directions
    its feature constrains at all (dof, k), size feature, tangent fit)."""
    dof = 6 if T.shape[0] == 4 else 3
    M = np.zeros((dof, 0))
    dps = np.zeros((draws, dof))
    rng = stream_rng(DEFAULT_SEED, BOOTSTRAP_STREAM)
    sigmas = []
    for on, idx, B, own, size, tangent in took:
        X, d, n = on(T, idx)
        J = _jacobian(X, n, centre, length, nrot)
        A = J @ B
        # The residuals about the datum's own least-squares feature, in every direction its
        # feature has (not only those the higher datums left it: what it could not take is
        # the frame's, not scatter), with an offset (a tangent simulator lies off the points
        # by their form).
        full = np.column_stack([J @ own, np.ones(d.size)])
        left = d.size - np.linalg.matrix_rank(full)
        res = d - full @ np.linalg.lstsq(full, d, rcond=None)[0]
        sigma = float(np.sqrt(res @ res / left)) if left > 0 else float("nan")
        sigmas.append(sigma)
        sigma = sigma if np.isfinite(sigma) else 0.0
        r = B.shape[1]
        if draws:
            E = rng.normal(0.0, sigma, (draws, d.size))
            P = np.linalg.pinv(np.column_stack([A, -np.ones(d.size)]) if size else A)[:r]
            for k in range(draws):
                # The datum's feature without its residuals, a fresh draw of them, and what
                # the higher datums' motion does.
                seen = d - res + E[k] + J @ dps[k]
                if tangent:
                    x = tangent_solve(A, seen, size, length, STEP_TOLERANCE * length,
                                       ties=False)
                    eta = np.zeros(r) if x is None else x[:r]
                else:
                    eta = -P @ seen
                dps[k] += B @ eta
            continue
        rows = _contacts(d, r + size, size, length) if tangent else np.arange(d.size)
        Ar = np.column_stack([A[rows], -np.ones(rows.size)]) if size else A[rows]
        P = np.zeros((r, d.size))
        P[:, rows] = np.linalg.pinv(Ar)[:r]
        M = np.column_stack([M - B @ (P @ (J @ M)), -(B @ P) * sigma])
    follow = np.eye(dof)
    if best_fit is not None and free.shape[1]:
        X, _, n = evaluate(T, best_fit)
        J = _jacobian(X, n, centre, length, nrot)
        follow = follow - free @ (np.linalg.pinv(J @ free) @ J)
    if draws:
        dps = (dps - dps.mean(axis=0)) @ follow.T  # about the draws' mean motion
        w, V = np.linalg.eigh(dps.T @ dps / (draws - 1))
        order = np.argsort(-w)
        w, V = w[order], V[:, order]
        keep = w > 1e-24 * max(float(w[0]), 1e-300)
        return V[:, keep] * np.sqrt(w[keep]), tuple(sigmas)
    u, sv, _ = np.linalg.svd(follow @ M, full_matrices=False)
    keep = sv > 1e-12 * max(float(sv[0]) if sv.size else 0.0, 1e-300)
    return u[:, keep] * sv[keep], tuple(sigmas)


def _contacts(d: np.ndarray, k: int, size: bool, length: float) -> np.ndarray:
    """The contact points of a tangent simulator with ``k`` unknowns: the points at its
    surface (deviation within CONTACT x length of the largest: a plane's simulator at 0, a
    size feature's at its offset), and at least the k highest."""
    top = float(np.max(d)) if size else 0.0
    at = np.flatnonzero(d >= top - CONTACT * length)
    return at if at.size >= k else np.argsort(-d, kind="stable")[:k]


def moved_along(T: np.ndarray, motion: np.ndarray, centre: np.ndarray,
                length: float) -> np.ndarray:
    """Pose T moved by ``motion`` (dof,) in the fits' coordinates (rotation x length,
    translation, about ``centre``): a multiple of a column of ``Alignment.scatter``."""
    nrot = 3 if T.shape[0] == 4 else 1
    return _step(T, np.eye(motion.size), np.asarray(motion, float), centre, length, nrot)[0]


def _determined(evaluate, T, idx, taken, centre, length, nrot, size) -> bool:
    """Whether the points ``idx`` determine every direction ``taken`` (dof, r) (and a size
    feature's size beside them): DETERMINED."""
    if taken.shape[1] == 0:
        return True
    X, _, n = evaluate(T, idx)
    A = _jacobian(X, n, centre, length, nrot) @ taken
    if size:
        A = np.column_stack([A, -np.ones(len(idx))])
    s = np.linalg.svd(A / np.sqrt(len(idx)), compute_uv=False)
    return bool(s[-1] >= DETERMINED)


def _fit_datum(evaluate: Evaluate, T, datum, idx, taken, centre, length, nrot):
    """(T, offset, gap): datum's fit along the directions it takes (dof, r); None when a
    tangent simulator is not held by the points (:func:`_tangent`)."""
    if taken.shape[1] == 0:
        d = evaluate(T, idx)[1]
        return T, 0.0, float(np.max(d) - np.min(d))
    size = datum.feature in SIZE_FEATURES
    if datum.fit == "lsq":
        return _least_squares(evaluate, T, idx, taken, centre, length, nrot, size)
    return _tangent(evaluate, T, idx, taken, centre, length, nrot, size)


def _within(free: np.ndarray, invariant: np.ndarray) -> np.ndarray:
    """An orthonormal basis (dof, k) of span(free) ∩ span(invariant): the free motions that leave
    the datum's ideal feature in place."""
    if free.shape[1] == 0 or invariant.shape[1] == 0:
        return np.zeros((free.shape[0], 0))
    q, _ = np.linalg.qr(invariant)
    off = free - q @ (q.T @ free)  # each free direction's part outside span(invariant)
    _, s, vt = np.linalg.svd(off, full_matrices=True)
    s = np.concatenate([s, np.zeros(vt.shape[0] - s.size)])
    return free @ vt[s < ALIGNED_TOLERANCE].T


def moving(free: np.ndarray | None, invariant: np.ndarray, centre: np.ndarray,
           length: float) -> tuple[FreeDirection, ...]:
    """The free directions (dof, f) that move a feature whose invariant motions are
    ``invariant`` (dof, k), named; () when every free direction leaves it in place."""
    if free is None or free.shape[1] == 0:
        return ()
    nrot = 3 if free.shape[0] == 6 else 1
    return _describe_free(_complement(free, _within(free, invariant)), centre, length, nrot)


def invariant_motions(feature: str, nominal: dict, centre: np.ndarray,
                      length: float) -> np.ndarray:
    """(dof, k): the rigid motions, in the fits' coordinates (rotation x length, translation;
    about ``centre``), that leave the ideal feature in place. ``nominal`` as
    engine.gdt.characteristics fits it: a plane {point, normal}, a width's median plane {point,
    normal}, a cylinder {point, direction}, a sphere {centre}; in 2D a line {point, normal}, a
    circle {centre}."""
    c = np.asarray(centre, float)

    def turn(axis, through):
        """The rotation about ``axis`` through ``through``: w = axis, t = axis x (c - through)."""
        if c.size == 2:
            r = c - through
            return np.array([length, -r[1], r[0]])
        return np.concatenate([axis * length, np.cross(axis, c - through)])

    def slide(u):
        return np.concatenate([np.zeros(3 if c.size == 3 else 1), u])

    if feature in ("plane", "width"):  # a width: its median plane
        n = nominal["normal"]
        u, v = np.linalg.svd(n[None, :])[2][1:]
        return np.column_stack([slide(u), slide(v), turn(n, nominal["point"])])
    if feature == "cylinder":
        a = nominal["direction"]
        return np.column_stack([slide(a), turn(a, nominal["point"])])
    if feature == "sphere":
        return np.column_stack([turn(e, nominal["centre"]) for e in np.eye(3)])
    if feature == "line":
        n = nominal["normal"]
        return slide(np.array([-n[1], n[0]]))[:, None]
    return turn(None, nominal["centre"])[:, None]  # circle


def _jacobian(X, normals, centre, length, nrot):
    J = pose_jacobian(X, normals, centre)
    J[:, :nrot] /= length
    return J


def _step(T, B, eta, centre, length, nrot):
    p = B @ eta
    p[:nrot] /= length
    return apply_update(T, p, centre), float(np.max(np.abs(B @ eta))) if eta.size else 0.0


def _least_squares(evaluate, T, idx, B, centre, length, nrot, size):
    """Gauss-Newton on sum (d + J B eta - offset)^2 over the directions B (dof, r); the uniform
    ``offset`` is a variable of size features only. (T, offset, largest |residual|)."""
    offset = 0.0
    for _ in range(MAX_STEPS):
        X, d, n = evaluate(T, idx)
        A = _jacobian(X, n, centre, length, nrot) @ B
        if size:
            A = np.column_stack([A, -np.ones(d.size)])
        sol = _determined_solve(A, -d)
        eta = sol[:B.shape[1]]
        offset = float(sol[-1]) if size else 0.0
        T, moved = _step(T, B, eta, centre, length, nrot)
        if moved <= STEP_TOLERANCE * length:
            break
    X, d, n = evaluate(T, idx)
    if size:
        offset = float(np.mean(d))
    return T, offset, float(np.max(np.abs(d - offset)))


def _determined_solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The least-squares solution of A x = b (m, k) along the directions the rows determine
    (singular value of A / sqrt(m) at least ``DETERMINED``, as a datum's directions must be),
    zero along the others: a region that leaves a motion free or nearly so (a cylinder's turn
    and slide, a plane's slides) is not moved along it by whatever the nominal's sampling
    makes of a nearly singular system (a form-only profile of a shaft's collar slid 0.3 mm
    off its ends with a least-squares refit: a 0.27 mm profile for a 3 µm part)."""
    U, sv, Vt = np.linalg.svd(A / np.sqrt(max(len(b), 1)), full_matrices=False)
    ok = sv >= DETERMINED
    coef = np.where(ok, (U.T @ b) / np.sqrt(max(len(b), 1)) / np.where(ok, sv, 1.0), 0.0)
    return Vt.T @ coef


def _tangent(evaluate, T, idx, B, centre, length, nrot, size):
    """Sequential linear programs for the tangent simulator within directions B (dof, r).

    Plane / line: minimise the largest gap g subject to no point beyond the nominal surface
    (d' <= 0) and none farther inside than g. Size feature: the simulator is the nominal surface
    offset by s along the outward normal; minimise s subject to d' <= s (no material beyond the
    simulator: the largest inscribed hole, the smallest circumscribed shaft). Where several
    simulators reach that optimum (a plane rocking on a high spot), the one with the smallest
    sum of gaps is taken, so that the datum does not depend on the solver's path or on the
    part's pose. (T, offset s, largest gap g); None when a step would move the points by
    ``UNHELD`` x the part's size or more: the points do not hold the simulator (a hole's
    largest inscribed cylinder grows without bound on points along less than half of its
    circumference; NIST CTC-03's datum B on 5 points went 1e20 mm away, each step's trust
    region four times the last, and a 12,000-point plan ran for more than 11 minutes)."""
    r = B.shape[1]
    radius = length
    settle = STEP_TOLERANCE * length
    for _ in range(MAX_STEPS):
        X, d, n = evaluate(T, idx)
        A = _jacobian(X, n, centre, length, nrot) @ B
        x = tangent_solve(A, d, size, radius, settle)
        if x is None:
            break
        T, moved = _step(T, B, x[:r], centre, length, nrot)
        if moved >= UNHELD * length:
            return None
        if moved <= settle:
            break
        radius = min(length, max(4.0 * moved, 1e-3 * length))
    X, d, n = evaluate(T, idx)
    s = float(np.max(d)) if size else 0.0
    return T, s, float(s - np.min(d)) if size else float(np.max(d) - np.min(d))


def _complement(free: np.ndarray, taken: np.ndarray) -> np.ndarray:
    """An orthonormal basis (dof, f - r) of the part of span(free) orthogonal to span(taken)."""
    if taken.shape[1] == 0:
        return free
    if taken.shape[1] >= free.shape[1]:
        return np.zeros((free.shape[0], 0))
    coords = free.T @ taken  # taken in the free basis (f, r)
    u, _, _ = np.linalg.svd(coords, full_matrices=True)
    return free @ u[:, taken.shape[1]:]


def _describe_free(free: np.ndarray, centre: np.ndarray, length: float, nrot: int):
    """The free directions (dof, f) as translations and rotations in the nominal frame.

    A rotation-bearing direction (w, t) (w scaled by 1/length as in the fit) moves x by
    w x (x - c) + t: a rotation about the axis along w through c + w x t / |w|^2 (its pitch
    part along w is left out)."""
    out = []
    # Rotations first: the combination without translation parts comes out as its own vector.
    for v in free.T:
        # The sign of a basis vector is arbitrary: show each with its largest component positive,
        # so that the same freedom reads the same whatever the pose.
        v = v * (1.0 if v[np.argmax(np.abs(v))] > 0 else -1.0)
        w, t = v[:nrot] / length, v[nrot:]
        if np.linalg.norm(w) * length < 1e-9 * max(float(np.linalg.norm(v)), 1e-300):
            u = t / np.linalg.norm(t)
            out.append(FreeDirection("translation", tuple(float(a) for a in u)))
        elif nrot == 3:
            p = centre + np.cross(w, t) / float(w @ w)
            out.append(FreeDirection("rotation", tuple(float(a) for a in w / np.linalg.norm(w)),
                                     tuple(float(a) for a in p)))
        else:
            # 2D: a rotation about the normal of the plane through c + (-t_y, t_x) / w.
            p = centre + np.array([-t[1], t[0]]) / float(w[0])
            out.append(FreeDirection("rotation", (0.0, 0.0, 1.0), tuple(float(a) for a in p)))
    return tuple(out)


def align_rps(evaluate: Evaluate, T0: np.ndarray, indices: np.ndarray, targets: np.ndarray,
              axes: np.ndarray, centre: np.ndarray, length: float,
              best_fit: np.ndarray | None = None) -> Alignment:
    """Place the part by a reference point system from the pose T0.

    Row k locks the measured point ``indices[k]`` onto ``targets[k]`` (nominal frame, mm) along
    the unit axis ``axes[k]`` (the usual 3-2-1 RPS: six rows; more are fitted in least
    squares). The freedom the rows leave is best-fitted on ``best_fit`` as in :func:`align`."""
    dof = 6 if T0.shape[0] == 4 else 3
    nrot = 3 if dof == 6 else 1
    indices = np.asarray(indices, dtype=np.int64)

    def locks(T, rows):
        X = evaluate(T, indices[rows])[0]
        return X, np.einsum("ij,ij->i", axes[rows], X - targets[rows]), axes[rows]

    rows = np.arange(indices.size)
    X, _, n = locks(T0, rows)
    _, s, Vt = np.linalg.svd(_jacobian(X, n, centre, length, nrot), full_matrices=False)
    r = int(np.sum(s > RANK_TOLERANCE * max(s[0], 1e-300)))
    taken = Vt[:r].T
    T, _, gap = _least_squares(locks, np.array(T0, float), rows, taken, centre, length, nrot,
                               size=False)
    free = _complement(np.eye(dof), taken)
    fitted = False
    if best_fit is not None and len(best_fit) and free.shape[1]:
        T = _least_squares(evaluate, T, np.asarray(best_fit, dtype=np.int64), free, centre,
                           length, nrot, size=False)[0]
        fitted = True
    fit = DatumFit("RPS", "points", "lsq", int(np.unique(indices).size), r, 0.0, gap)
    return Alignment(T, (fit,), _describe_free(free, centre, length, nrot), fitted, True, "",
                     free)
