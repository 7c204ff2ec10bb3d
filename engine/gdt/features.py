"""Geometric features fitted to measured points: what a plan's characteristics and datums measure.

* :func:`flatness`: the minimum zone (Chebyshev) of a plane: the two closest parallel planes that
  hold every point (in 2D: two parallel lines, i.e. straightness), as a short sequence of linear
  programs over the plane's tilt (scipy's HiGHS); its outer plane is the tangent datum plane.
* :func:`fit_plane_lsq` (:func:`fit_line_lsq` in 2D): the least-squares plane.
* :func:`fit_circle_lsq`, :func:`fit_sphere_lsq`, :func:`fit_cylinder_lsq`: geometric
  (orthogonal-distance) least squares, from an algebraic start.
* :func:`position_value`: the position tolerance value of a fitted centre or axis.

Shapes: points are (n, 3) in 3D, (n, 2) for a 2D line or circle. Units mm. Everything is in the
frame the points are given in (the plan passes them in the nominal frame, at the alignment's pose).
Residuals are signed: positive away from the material of a solid feature's fitted surface, i.e.
along the plane's normal, away from a circle's / sphere's centre, away from a cylinder's axis.

Points that do not determine the feature (too few, all on a line, ...) raise
:class:`FeatureError`; a fit whose iteration did not converge is a value (``converged``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

_FLAT = 1e-9
"""Relative spread below which points count as lying on a line / in a plane (a singular value of
the centred points over the largest): such points do not determine the feature."""
_LSQ_TOL = 1e-15
"""Tolerances of scipy's least_squares (just above machine epsilon): iterate to the fixed point."""


class FeatureError(InputError):
    """The points do not determine the feature (too few, all on a line, ...) or an argument
    is malformed; the message says which."""


@dataclass(frozen=True)
class MinimumZone:
    """The minimum zone of a plane (3D) or line (2D): the two closest parallel planes / lines
    that hold every point. The zone is {x : low <= x . normal <= high}.

    With the normal out of the material, the plane x . normal = high is the tangent datum
    plane (minimax, constrained outside the material: ISO 5459's default, ASME Y14.5's
    tangent plane): minimising the largest gap with every point on one side is this problem.
    """

    normal: np.ndarray
    """(dim,) unit normal of the two planes, on the side of the hint."""
    low: float
    """Offset (mm) of the lower plane along ``normal``: min over the points of x . normal."""
    high: float
    """Offset (mm) of the upper plane: max over the points of x . normal."""
    width: float
    """high - low, mm: the flatness (straightness in 2D) value."""
    n_points: int
    linear_programs: int
    """Linear programs solved (the tilt settles in a few)."""

    @property
    def centre(self) -> np.ndarray:
        """A point on the zone's median plane: the origin's projection, (dim,) mm."""
        return 0.5 * (self.low + self.high) * self.normal


@dataclass(frozen=True)
class PlaneFit:
    """A least-squares plane (3D) or line (2D): {x : (x - centroid) . normal = 0}."""

    centroid: np.ndarray
    """(dim,) mm: the points' mean, on the plane."""
    normal: np.ndarray
    """(dim,) unit normal (the direction of least spread; on the hint's side if one was given)."""
    residuals: np.ndarray
    """(n,) mm: signed distances (x - centroid) . normal."""
    rms: float
    """sqrt(mean(residuals**2)), mm."""
    form_error: float
    """max - min of the residuals, mm (peak to valley about the least-squares plane)."""
    n_points: int


@dataclass(frozen=True)
class RoundFit:
    """A geometric least-squares circle (2D) or sphere (3D)."""

    centre: np.ndarray
    """(dim,) mm."""
    radius: float
    """mm; the diameter (a size characteristic) is twice this."""
    residuals: np.ndarray
    """(n,) mm: |x - centre| - radius (positive outside)."""
    rms: float
    """sqrt(mean(residuals**2)), mm: what the fit minimises."""
    form_error: float
    """max - min of the residuals, mm (roundness / sphericity about the least-squares centre)."""
    n_points: int
    converged: bool


@dataclass(frozen=True)
class CylinderFit:
    """A geometric least-squares cylinder: the points at distance ``radius`` from the axis
    through ``point`` along ``direction``."""

    point: np.ndarray
    """(3,) mm: the point of the axis closest to the points' centroid."""
    direction: np.ndarray
    """(3,) unit axis direction, on the side of the axis hint."""
    radius: float
    residuals: np.ndarray
    """(n,) mm: distance from the axis - radius (positive outside)."""
    rms: float
    form_error: float
    """max - min of the residuals, mm (cylindricity about the least-squares axis)."""
    ends: np.ndarray
    """(2, 3) mm: the axis points at the smallest and largest projection of the points on the
    axis: the extent of the axis that a position tolerance judges."""
    n_points: int
    converged: bool


@dataclass(frozen=True)
class Position:
    """A position tolerance value: the diameter of the smallest zone about the true position
    (a cylinder coaxial with the nominal axis, or a circle / sphere about the true point) that
    holds the fitted centre or both ends of the fitted axis."""

    value: float
    """The zone's diameter, mm: 2 x max(distances)."""
    distances: np.ndarray
    """(k,) mm: each given point's distance from the nominal axis (or true point)."""


def flatness(points: np.ndarray, normal_hint: np.ndarray | None = None,
             max_linear_programs: int = 50) -> MinimumZone:
    """The minimum zone (Chebyshev) of ``points`` (n, 3) mm, or of a 2D line's points (n, 2).

    The zone's normal is n(t) = unit(h + B t), with h the current normal and the rows of B
    spanning its orthogonal complement. For fixed h the width of the points along h + B t
    (not normalised) is linear in t, so its minimum over t is a linear program; its normal
    never widens the zone (dividing by |h + B t| >= 1 only narrows it). The program is solved
    again about each new normal until the normal settles (a step under 1e-12, or no narrower
    zone): at that fixed point the subgradient condition of the true width holds, the
    minimum. Once the program's extreme points are the zone's, its answer is the exact
    geometric one (the plane through three points, or the normal of two point pairs), so
    this takes a few programs. The width reported is max - min of points . normal, exactly.

    normal_hint : (dim,) the starting normal and the side the result's normal points to;
        default the least-squares normal. The minimum is the one nearest the hint: for points
        spread along a face (width far below extent) the global one.
    Only the convex hull's vertices can bound the zone, so the programs use those.
    """
    from scipy.optimize import linprog

    p = _as_points(points, (2, 3), "a plane (or a 2D line)")
    dim = p.shape[1]
    _require(p, dim, dim - 1, "a plane" if dim == 3 else "a line")
    g = p.mean(axis=0)
    scale = float(np.max(np.linalg.norm(p - g, axis=1)))
    q = _hull_vertices((p - g) / scale)
    if normal_hint is None:
        n = _orient(_lsq_normal(p - g), None)
    else:
        n = _unit(normal_hint, dim, "normal_hint")
    w = float(np.ptp(q @ n))
    lps = 0
    while lps < max_linear_programs:
        basis = complement(n)
        t = _tilt_program(linprog, q, n, basis)
        lps += 1
        if t is None:
            break
        n_new = n + t @ basis
        n_new /= np.linalg.norm(n_new)
        w_new = float(np.ptp(q @ n_new))
        if not w_new < w:
            break
        step = float(np.linalg.norm(n_new - n))
        n, w = n_new, w_new
        if step < 1e-12:
            break
    s = p @ n
    low, high = float(s.min()), float(s.max())
    return MinimumZone(n, low, high, high - low, len(p), lps)


def _tilt_program(linprog, q: np.ndarray, n: np.ndarray, basis: np.ndarray):
    """The tilt t, (dim-1,), minimising max - min of q . (n + basis.T t) over |t_i| <= 1 (a
    trust region of 45 degrees per program), or None if the solver failed or the zone is
    already empty.

    Variables [tau, lo, hi] with t = w tau, the offsets in units of the current width w about
    its middle, so that the solver's absolute tolerances (1e-10) are relative to the zone
    (each program refines the last one's answer): minimise hi - lo subject to
    lo <= (q . n - mid) / w + (q @ basis.T) tau <= hi.
    """
    h = q @ n
    w = float(np.ptp(h))
    if w < 1e-15:
        return None
    hs = (h - 0.5 * (h.max() + h.min())) / w
    G = q @ basis.T
    m, k = G.shape
    one, zero = np.ones((m, 1)), np.zeros((m, 1))
    A = np.block([[G, zero, -one], [-G, one, zero]])
    b = np.concatenate([-hs, hs])
    cost = np.concatenate([np.zeros(k), [-1.0, 1.0]])
    bounds = [(-1.0 / w, 1.0 / w)] * k + [(None, None)] * 2
    sol = linprog(cost, A_ub=A, b_ub=b, bounds=bounds, method="highs",
                  options={"primal_feasibility_tolerance": 1e-10,
                           "dual_feasibility_tolerance": 1e-10})
    return w * sol.x[:k] if sol.status == 0 else None


def fit_plane_lsq(points: np.ndarray, normal_hint: np.ndarray | None = None) -> PlaneFit:
    """The least-squares plane of ``points`` (n, 3) mm (or the line of (n, 2) points): through
    the centroid, normal along the direction of least spread (SVD), which minimises the sum of
    squared orthogonal distances. ``normal_hint`` (dim,) picks the normal's side (else the
    side of the largest |component| is made positive)."""
    p = _as_points(points, (2, 3), "a plane (or a 2D line)")
    dim = p.shape[1]
    _require(p, dim, dim - 1, "a plane" if dim == 3 else "a line")
    g = p.mean(axis=0)
    n = _lsq_normal(p - g)
    hint = None if normal_hint is None else _unit(normal_hint, dim, "normal_hint")
    n = _orient(n, hint)
    r = (p - g) @ n
    return PlaneFit(g, n, r, float(np.sqrt(np.mean(r ** 2))), float(np.ptp(r)), len(p))


def fit_line_lsq(points2d: np.ndarray, normal_hint: np.ndarray | None = None) -> PlaneFit:
    """The least-squares line of (n, 2) points: :func:`fit_plane_lsq` in 2D."""
    _as_points(points2d, (2,), "a line")
    return fit_plane_lsq(points2d, normal_hint)


def fit_circle_lsq(points2d: np.ndarray) -> RoundFit:
    """The geometric least-squares circle of (n, 2) points, mm: minimises the sum of squared
    radial residuals |x - centre| - radius (Levenberg-Marquardt from the algebraic (Kasa) fit,
    which also starts partial arcs well)."""
    return _fit_round(_as_points(points2d, (2,), "a circle"), "a circle")


def fit_sphere_lsq(points: np.ndarray) -> RoundFit:
    """The geometric least-squares sphere of (n, 3) points, mm (as :func:`fit_circle_lsq`)."""
    return _fit_round(_as_points(points, (3,), "a sphere"), "a sphere")


def _fit_round(p: np.ndarray, what: str) -> RoundFit:
    from scipy.optimize import least_squares

    dim = p.shape[1]
    _require(p, dim + 1, dim, what)
    g = p.mean(axis=0)
    scale = float(np.sqrt(np.mean(np.sum((p - g) ** 2, axis=1))))
    q = (p - g) / scale  # well conditioned: centred, unit rms radius
    A = np.column_stack([2.0 * q, np.ones(len(q))])
    sol = np.linalg.lstsq(A, np.sum(q ** 2, axis=1), rcond=None)[0]
    c0 = sol[:dim]
    r0 = np.sqrt(sol[dim] + c0 @ c0)

    def residuals(x):
        return np.linalg.norm(q - x[:dim], axis=1) - x[dim]

    def jacobian(x):
        w = q - x[:dim]
        return np.column_stack([-w / np.linalg.norm(w, axis=1)[:, None], -np.ones(len(q))])

    res = least_squares(residuals, np.append(c0, r0), jac=jacobian, method="lm",
                        xtol=_LSQ_TOL, ftol=_LSQ_TOL, gtol=_LSQ_TOL)
    centre = g + scale * res.x[:dim]
    radius = scale * abs(float(res.x[dim]))
    r = np.linalg.norm(p - centre, axis=1) - radius
    return RoundFit(centre, radius, r, float(np.sqrt(np.mean(r ** 2))), float(np.ptp(r)),
                    len(p), bool(res.status > 0))


def fit_cylinder_lsq(points: np.ndarray, axis_hint: np.ndarray) -> CylinderFit:
    """The geometric least-squares cylinder of (n, 3) points, mm: minimises the sum of squared
    residuals (distance from the axis - radius) over the axis (4 degrees of freedom) and the
    radius.

    axis_hint : (3,) the nominal axis direction: the start, and the side of the result's
        direction. It must be within ~45 degrees of the true axis. The start is the
        least-squares circle of the points seen along the hint; Levenberg-Marquardt then runs
        in the frame of the hint and once more in the frame of the fitted axis.
    """
    p = _as_points(points, (3,), "a cylinder")
    d0 = _unit(axis_hint, 3, "axis_hint")
    _require(p, 5, 2, "a cylinder")
    if _spread(p - p.mean(axis=0))[2] <= _FLAT:
        raise FeatureError("the points lie in one plane: they do not determine a cylinder (a "
                           "single cross-section is a circle; a strip along the axis leaves "
                           "the radius free)")
    g = p.mean(axis=0)
    scale = float(np.sqrt(np.mean(np.sum((p - g) ** 2, axis=1))))
    frame = np.vstack([complement(d0), d0])  # rows: e1, e2, axis
    seen = ((p - g) @ frame[:2].T) / scale  # not on a line: the points are not in a plane
    start = _fit_round(seen, "a cylinder's cross-section")
    origin = g + scale * (start.centre @ frame[:2])
    x, ok1 = _cylinder_lm(((p - origin) @ frame.T) / scale, start.radius / scale)
    origin, d = cylinder_axis(origin, frame, x, scale)
    frame = np.vstack([complement(d), d])
    x, ok2 = _cylinder_lm(((p - origin) @ frame.T) / scale, x[4])
    origin, d = cylinder_axis(origin, frame, x, scale)
    d = d if d @ d0 >= 0 else -d
    radius = scale * abs(float(x[4]))
    point = origin + ((g - origin) @ d) * d
    t = (p - point) @ d
    r = np.linalg.norm((p - point) - t[:, None] * d, axis=1) - radius
    ends = point + np.array([t.min(), t.max()])[:, None] * d
    return CylinderFit(point, d, radius, r, float(np.sqrt(np.mean(r ** 2))), float(np.ptp(r)),
                       ends, len(p), ok1 and ok2)


def _cylinder_lm(q: np.ndarray, r0: float) -> tuple[np.ndarray, bool]:
    """Levenberg-Marquardt on x = [x0, y0, a, b, R] for points q (n, 3) in a frame whose z is
    near the axis: the axis passes (x0, y0, 0) along unit((a, b, 1)). Returns (x, converged)."""
    from scipy.optimize import least_squares

    def residuals(x):
        return axis_distances(q, x)[0] - x[4]

    def jacobian(x):
        return np.column_stack([axis_distances(q, x)[1], -np.ones(len(q))])

    res = least_squares(residuals, np.array([0.0, 0.0, 0.0, 0.0, r0]), jac=jacobian,
                        method="lm", xtol=_LSQ_TOL, ftol=_LSQ_TOL, gtol=_LSQ_TOL)
    return res.x, bool(res.status > 0)


def axis_distances(q: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rho (n,), J (n, 4)): the distances of points q (n, 3) from the axis through (x0, y0, 0)
    along unit((a, b, 1)), x = [x0, y0, a, b, ...] (only the first four are read), and their
    derivatives by x0, y0, a, b. Exact for any x; a frame whose z is near the axis keeps a and b
    small."""
    # rho^2 = |w|^2 - (w . d)^2: d rho / d(x0, y0) = -perp / rho, and since d d / d(a, b)
    # = (I - d d^T) e / |m|, d rho / d(a, b) = -t perp / (rho |m|).
    m = np.array([x[2], x[3], 1.0])
    nm = float(np.linalg.norm(m))
    w = q - np.array([x[0], x[1], 0.0])
    t = w @ (m / nm)
    perp = w - t[:, None] * (m / nm)
    rho = np.linalg.norm(perp, axis=1)
    dxy = -perp[:, :2] / np.maximum(rho, 1e-300)[:, None]
    return rho, np.column_stack([dxy, dxy * (t / nm)[:, None]])


def cylinder_axis(origin: np.ndarray, frame: np.ndarray, x: np.ndarray, scale: float):
    """(a point of the axis, unit direction) in the points' frame from :func:`axis_distances`'
    x in the frame (rows of ``frame``) at ``origin``, scaled by ``scale``."""
    point = origin + scale * (np.array([x[0], x[1], 0.0]) @ frame)
    m = np.array([x[2], x[3], 1.0]) @ frame
    return point, m / np.linalg.norm(m)


def position_value(actual: np.ndarray, nominal_point: np.ndarray,
                   nominal_direction: np.ndarray | None = None) -> Position:
    """The position tolerance value of a fitted feature, mm.

    actual : (dim,) a fitted centre, or (k, dim) points: the two ends of a fitted axis
        (:attr:`CylinderFit.ends`), or one centre per row.
    nominal_point : (dim,) the true position (a point of the nominal axis).
    nominal_direction : (3,) the nominal axis direction: the zone is a cylinder coaxial with
        it, and each distance is from that axis. None: the zone is a circle (2D) or sphere
        (3D) about ``nominal_point``, each distance from it.
    All in the same (datum) frame. value = 2 x the largest distance.
    """
    a = np.asarray(actual, dtype=np.float64)
    a = a[None, :] if a.ndim == 1 else a
    c = np.asarray(nominal_point, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] not in (2, 3) or len(a) == 0 or c.shape != a.shape[1:]:
        raise FeatureError(f"position needs points (k, 2) or (k, 3) and a true position of the "
                           f"same dimension, got shapes {np.shape(actual)} and "
                           f"{np.shape(nominal_point)}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(c))):
        raise FeatureError("position: the points contain NaN or infinite coordinates")
    w = a - c
    if nominal_direction is not None:
        if a.shape[1] != 3:
            raise FeatureError("position about an axis needs 3D points")
        d = _unit(nominal_direction, 3, "nominal_direction")
        w = w - (w @ d)[:, None] * d
    dist = np.linalg.norm(w, axis=1)
    return Position(2.0 * float(dist.max()), dist)


def _as_points(points, dims: tuple[int, ...], what: str) -> np.ndarray:
    """``points`` as a float (n, dim) array with dim in ``dims``, all finite, else FeatureError
    naming the feature ``what`` ("a plane", ...)."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] not in dims:
        cols = " or ".join(f"(n, {k})" for k in dims)
        raise FeatureError(f"{what} is fitted to points {cols}, got an array of shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise FeatureError(f"the points of {what} contain NaN or infinite coordinates")
    return p


def _require(p: np.ndarray, k: int, rank: int, what: str) -> None:
    """FeatureError unless there are k points or more spanning ``rank`` dimensions (1: not all
    coincident, 2: not all on a line, 3: not all in a plane); ``what`` names the feature."""
    if len(p) < k:
        raise FeatureError(f"{what} needs at least {k} points, got {len(p)}")
    have = int(np.sum(_spread(p - p.mean(axis=0)) > _FLAT))
    if have < rank:
        where = ("coincide", "lie on a line", "lie in a plane")[have]
        raise FeatureError(f"the points {where}: they do not determine {what}")


def _spread(q: np.ndarray) -> np.ndarray:
    """Singular values of centred points q (n, dim) over the largest, (dim,) (padded with 0)."""
    s = np.zeros(q.shape[1])
    sv = np.linalg.svd(q, compute_uv=False)
    s[:sv.size] = sv
    return s / s[0] if s[0] > 0 else s


def _lsq_normal(q: np.ndarray) -> np.ndarray:
    """The unit direction of least spread of centred points q (n, dim)."""
    return np.linalg.svd(q, full_matrices=False)[2][-1]


def _orient(n: np.ndarray, hint: np.ndarray | None) -> np.ndarray:
    """n on the hint's side; without a hint, its largest |component| positive (deterministic)."""
    ref = hint if hint is not None else np.eye(n.size)[np.argmax(np.abs(n))]
    return n if n @ ref >= 0 else -n


def _unit(v, dim: int, name: str) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    nrm = float(np.linalg.norm(a)) if a.shape == (dim,) else 0.0
    if not np.isfinite(nrm) or nrm == 0.0:
        raise FeatureError(f"{name} must be a finite non-zero vector of {dim} components, "
                           f"got {v!r}")
    return a / nrm


def complement(n: np.ndarray) -> np.ndarray:
    """(dim-1, dim) orthonormal rows spanning the complement of unit n."""
    return np.linalg.svd(n[None, :])[2][1:]


def _hull_vertices(q: np.ndarray) -> np.ndarray:
    """The convex hull's vertices of q (n, dim), or q itself when the hull is flat (exactly
    planar points) or too small to build."""
    from scipy.spatial import ConvexHull, QhullError

    if len(q) <= q.shape[1] + 1:
        return q
    try:
        return q[ConvexHull(q).vertices]
    except QhullError:
        return q


WIDTH_SIDE = 3
"""Fewest points each face of a width needs (three determine a plane)."""


@dataclass(frozen=True)
class SizeFit:
    """A feature of size fitted one way: its size and where it is.

    size : the diameter (cylinder, sphere, circle) or the width, mm.
    point : (dim,) a point of the axis (cylinder), the centre (sphere, circle) or a point of
        the median plane (width), mm.
    direction : (3,) the unit axis (cylinder) or the median plane's normal (width); None for a
        sphere or circle.
    """

    size: float
    point: np.ndarray
    direction: np.ndarray | None = None


def width_sides(normals: np.ndarray, axis: np.ndarray | None = None) -> tuple[np.ndarray,
                                                                                 np.ndarray]:
    """(side (n,) of +-1, the unit axis (dim,)) of a width's points from their nominal outward
    ``normals`` (n, dim): the side each faces along ``axis`` (default: the normals' principal
    direction)."""
    if axis is None:
        axis = np.linalg.eigh(normals.T @ normals)[1][:, -1]
    return np.where(normals @ axis >= 0.0, 1.0, -1.0), axis


def width_lsq(points: np.ndarray, side: np.ndarray, hint: np.ndarray) -> SizeFit:
    """The least-squares width of ``points`` (n, dim) on two faces (``side`` +-1): two parallel
    planes of one normal, each through its face's centroid, the normal a principal direction of
    the pooled spread, the one nearest ``hint`` (the nominal's normal; on its side); size: their
    distance, point: midway between the centroids. (Nearest the hint, not of least spread: a
    face sampled in a narrow strip spreads less across its strip than a few stray points do
    along the normal, and the least spread then turned the width 90 degrees.)"""
    up, down = points[side > 0], points[side < 0]
    if len(up) < WIDTH_SIDE or len(down) < WIDTH_SIDE:
        raise FeatureError(f"a width needs {WIDTH_SIDE} points on each face; it has "
                           f"{len(up)} and {len(down)}")
    a, b = up.mean(axis=0), down.mean(axis=0)
    pooled = np.vstack([up - a, down - b])
    vectors = np.linalg.eigh(pooled.T @ pooled)[1]
    n = vectors[:, int(np.argmax(np.abs(vectors.T @ hint)))]
    n = n if n @ hint >= 0.0 else -n
    return SizeFit(float(abs((a - b) @ n)), 0.5 * (a + b), n)
