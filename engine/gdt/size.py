"""The size family of a plan (ISO 14405-1 / ASME Y14.5 §5.8): the size of a feature of size, a
cylinder (a hole or a pin), a sphere (a circle on a 2D template) or a width (two opposed
parallel planes: a slot or a tab), by one of four methods:

* ``lsq`` (ISO GG): the least-squares feature: a cylinder's or sphere's geometric least-squares
  diameter; a width's two parallel planes of one normal fitted by least squares to its two
  faces (the normal of least pooled spread about each face's centroid), their distance;
* ``two-point`` (ISO LP): each point's local size: its distance to the point of the opposite
  side nearest its mirror image (through the least-squares axis or centre; across the
  least-squares median plane), measured across the axis (a cylinder), through the centre (a
  sphere) or along the normal (a width); the smallest and the largest are reported and both
  must lie within the limits;
* ``min-circumscribed`` (ISO GN): the smallest cylinder / sphere / pair of parallel planes
  holding every point (for a pin or a tab the actual mating envelope, ASME);
* ``max-inscribed`` (ISO GX): the largest cylinder / sphere / pair of parallel planes with no
  point inside (for a hole or a slot the actual mating envelope, ASME).

GN and GX are minimax problems solved by engine.gdt.form.chebyshev (linear programs on the
exact distances, from the least-squares feature); the value is recomputed exactly. A size is
the feature's own: no datum, no pose (a rigid motion changes none of them).

Shapes: points (n, 3) (a 2D template's circle: (n, 2)), mm, in one frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..verdict import ACCEPT, INCONCLUSIVE, REJECT
from .decision import by_value, own, value_guard
from .features import (WIDTH_SIDE, FeatureError, SizeFit, axis_distances, complement,
                       cylinder_axis, fit_sphere_lsq, width_lsq, width_sides)
from .form import chebyshev
from .plan import SIZE_METHOD_WORDS, Characteristic
from .region_features import FACING, measured_hole, nominal_cylinder, region_nominal
from .results import CharacteristicResult, Geometry

ENVELOPES = ("min-circumscribed", "max-inscribed")
@dataclass(frozen=True)
class Width:
    """A width's two faces: ``side`` (n,) +1 for the points of the face that lies on the side
    of ``normal`` (3,), -1 for the other's; ``internal``: a slot (the faces' outward normals
    face each other), else a tab."""

    side: np.ndarray
    normal: np.ndarray
    internal: bool


def nominal_width(c: Characteristic, points: np.ndarray, normals: np.ndarray) -> tuple[
        Width, SizeFit]:
    """(the width's faces, its least-squares SizeFit) of a region's nominal points and outward
    normals; a region without two opposed faces is an InputError naming ``c``."""
    facing, axis = width_sides(normals)
    counts = [int(np.sum(facing > 0)), int(np.sum(facing < 0))]
    if min(counts) < WIDTH_SIDE or np.min(np.abs(normals @ axis)) < np.cos(FACING):
        raise InputError(f"[[characteristic]] '{c.id}': region '{c.region}' is no width "
                         "(feature = \"width\": two opposed parallel planes): its nominal "
                         f"points face {'one way' if min(counts) < WIDTH_SIDE else 'more than two ways'}"
                         f" ({counts[0]} and {counts[1]} points face either way)")
    gap = (points[facing > 0].mean(axis=0) - points[facing < 0].mean(axis=0)) @ axis
    side = -facing if gap < 0.0 else facing
    return Width(side, axis, bool(gap < 0.0)), width_lsq(points, side, axis)


def _width_residuals(q: np.ndarray, side: np.ndarray):
    """r(x) -> (r (n,), J (n, 3)): the signed distances of points q (n, 3) (a frame whose z is
    near the median plane's normal) from the plane {x . unit((a, b, 1)) = c}, x = [a, b, c],
    times each point's ``side``: each point's distance out from the median plane."""
    def fun(x):
        m = np.array([x[0], x[1], 1.0])
        nm = float(np.linalg.norm(m))
        t = q @ m
        r = side * (t / nm - x[2])
        da = q[:, 0] / nm - t * x[0] / nm ** 3
        db = q[:, 1] / nm - t * x[1] / nm ** 3
        return r, side[:, None] * np.column_stack([da, db, -np.ones(len(q))])
    return fun


def _round_residuals(q: np.ndarray):
    """r(x) -> (r, J): the distances of points q (n, dim) from the centre x (dim,)."""
    def fun(x):
        w = q - x
        r = np.linalg.norm(w, axis=1)
        return r, -w / r[:, None]
    return fun


def envelope(kind: str, X: np.ndarray, start: SizeFit, inscribed: bool,
             side: np.ndarray | None = None) -> SizeFit:
    """The minimum circumscribed (``inscribed`` False, GN) or maximum inscribed (GX) feature
    of ``kind`` (cylinder | round | width) holding the points X, from the least-squares
    ``start`` (``side``: a width's faces): each point's distance out from the axis, centre or
    median plane, its largest made smallest (GN) or its smallest largest (GX)."""
    scale = 0.5 * start.size
    if kind == "round":
        q = (X - start.point) / scale
        fun, x0 = _round_residuals(q), np.zeros(X.shape[1])
    else:
        if start.direction is None:  # a cylinder's or a width's fit has one
            raise ValueError(f"a {kind}'s least-squares fit has no direction")
        frame = np.vstack([complement(start.direction), start.direction])
        q = ((X - start.point) @ frame.T) / scale
        if kind == "cylinder":
            def fun(x):
                return axis_distances(q, x)
            x0 = np.zeros(4)
        elif side is None:
            raise ValueError("a width's envelope needs its faces (side)")
        else:
            fun, x0 = _width_residuals(q, side), np.zeros(3)
    if inscribed:  # the smallest distance made largest: 2 - r stays positive near r = 1
        def zone_fun(x):
            r, J = fun(x)
            return 2.0 - r, -J
    else:
        zone_fun = fun
    z = chebyshev(zone_fun, x0, two_sided=False, radius=0.1)
    r = fun(z.x)[0]
    size = 2.0 * scale * float(r.min() if inscribed else r.max())
    if kind == "round":
        return SizeFit(size, start.point + scale * z.x)
    if kind == "cylinder":
        point, direction = cylinder_axis(start.point, frame, z.x, scale)
        return SizeFit(size, point, direction)
    m = np.array([z.x[0], z.x[1], 1.0]) @ frame
    normal = m / np.linalg.norm(m)
    return SizeFit(size, start.point + scale * z.x[2] * normal, normal)


def two_point(kind: str, X: np.ndarray, start: SizeFit,
              side: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """((n,) each point's local two-point size (module docstring) about the least-squares
    ``start``: its distance to the point of the opposite side nearest its mirror image; (n,)
    the index of that point)."""
    from scipy.spatial import cKDTree

    if kind == "round":
        q = X - start.point
        mirror, across = -q, np.ones(X.shape[1], bool)
    else:
        if start.direction is None:  # a cylinder's or a width's fit has one
            raise ValueError(f"a {kind}'s least-squares fit has no direction")
        frame = np.vstack([complement(start.direction), start.direction])
        q = (X - start.point) @ frame.T
        flip = np.array([-1.0, -1.0, 1.0]) if kind == "cylinder" else np.array([1.0, 1.0, -1.0])
        mirror, across = q * flip, flip < 0
    if side is None:
        j = cKDTree(q).query(mirror)[1]
        return np.linalg.norm((q - q[j])[:, across], axis=1), j
    j = np.empty(len(q), dtype=int)
    for s in (1.0, -1.0):
        mine, theirs = np.flatnonzero(side == s), np.flatnonzero(side != s)
        j[mine] = theirs[cKDTree(q[theirs]).query(mirror[mine])[1]]
    return np.abs(q[:, 2] - q[j, 2]), j


@dataclass(frozen=True)
class Measured:
    """A region's measured feature of size at one pose: its kind (cylinder | round | width),
    points, least-squares fit, the width's faces (else None) and whether it is internal."""

    kind: str
    X: np.ndarray
    lsq: SizeFit
    side: np.ndarray | None
    internal: bool
    form_error: float | None = None
    """Peak to valley of the least-squares fit's residuals, mm (None for a width)."""


def measured_feature(c: Characteristic, idx: np.ndarray, geo: Geometry, shared, T,
                     region: str | None = None):
    """The region's measured feature of size (Measured) at pose T, or an INCONCLUSIVE result
    when its points do not determine it (``region``: one of a pattern's, else ``c``'s)."""
    from dataclasses import replace

    region = region or c.region
    c = replace(c, region=region)
    X, _, n = geo.evaluate(T, idx)
    kind = c.feature
    if kind == "width":
        width, nominal_fit = region_nominal_width(c, geo, shared)
        # Each point's face by the side of the nominal median plane it lies on, not by the
        # normal of the face its foot fell on: a point whose foot falls on a neighbouring face
        # (an edge, a chamfer) was put on the wrong face and turned the fit (NIST CTC-01's
        # slot 85/89 relative to a width datum: tilted 10 degrees, position 13 mm for 0.5).
        side = np.where((X - nominal_fit.point) @ width.normal >= 0.0, 1.0, -1.0)
        try:
            fit = width_lsq(X, side, width.normal)
        except FeatureError as e:
            return CharacteristicResult(c, None, INCONCLUSIVE, f"region '{region}': "
                                        f"{e.message}", idx)
        return Measured("width", X, fit, side, width.internal)
    if kind == "sphere" and X.shape[1] == 3:
        nom = region_nominal("sphere", geo, geo.nominal_masks[region])
        if nom is None:
            raise InputError(f"[[characteristic]] '{c.id}': region '{region}' is no sphere")
        got = fit_sphere_lsq(X)
        return Measured("round", X, SizeFit(2.0 * got.radius, got.centre), None,
                        bool(nom["internal"]), got.form_error)
    nom, normals = nominal_cylinder(c, geo, shared)
    got = measured_hole(c, idx, X, normals, nom)
    if isinstance(got, CharacteristicResult):
        return got
    internal = bool(shared.once(("internal", region), lambda: _inward(geo, region, nom)))
    if X.shape[1] == 2:
        return Measured("round", X, SizeFit(2.0 * got.radius, got.centre), None, internal,
                        got.form_error)
    return Measured("cylinder", X, SizeFit(2.0 * got.radius, got.point, got.direction),
                    None, internal, got.form_error)


def region_nominal_width(c: Characteristic, geo: Geometry, shared) -> tuple[Width, SizeFit]:
    """:func:`nominal_width` of ``c``'s region (its faces, its least-squares fit), once per
    plan evaluation."""
    mask = geo.nominal_masks[c.region]
    return shared.once(("width", c.region), lambda: nominal_width(
        c, geo.nominal_points[mask], geo.nominal_normals(np.flatnonzero(mask))))


def median_points(m: Measured) -> np.ndarray:
    """A measured width's derived median surface (ASME Y14.5's derived median plane: the
    centres of the segments across the feature; ISO 14405-1's median points) where its walls
    were probed: the midpoint of each point and its two-point partner (:func:`two_point`)."""
    return 0.5 * (m.X + m.X[two_point(m.kind, m.X, m.lsq, m.side)[1]])


def _inward(geo: Geometry, region: str, nom) -> bool:
    """Whether the region's nominal cylinder (circle) is a hole: its outward normals face its
    axis (centre)."""
    mask = geo.nominal_masks[region]
    points = geo.nominal_points[mask]
    if points.shape[1] == 2:
        radial = points - nom.centre
    else:
        radial = points - nom.point
        radial -= np.outer(radial @ nom.direction, nom.direction)
    return bool(np.sum(radial * geo.nominal_normals(np.flatnonzero(mask))) < 0.0)


def size_of(m: Measured, method: str) -> tuple[float, float, SizeFit | None]:
    """(smallest, largest size, the fitted feature (None: two-point)) of a measured feature
    by ``method`` (one value twice but for two-point)."""
    if method == "lsq":
        return m.lsq.size, m.lsq.size, m.lsq
    if method == "two-point":
        local = two_point(m.kind, m.X, m.lsq, m.side)[0]
        return float(local.min()), float(local.max()), None
    fit = envelope(m.kind, m.X, m.lsq, method == "max-inscribed", m.side)
    return fit.size, fit.size, fit


def mating_size(m: Measured, least: bool = False) -> float:
    """The actual mating size (ASME Y14.5; ``least``: the actual minimum material size): the
    largest inscribed (GX) feature of a hole or slot, the smallest circumscribed (GN) of a pin
    or tab; the other for ``least``."""
    return envelope(m.kind, m.X, m.lsq, m.internal != least, m.side).size


def judge_size(c: Characteristic, idx: np.ndarray, geo: Geometry, shared):
    """A size characteristic: the region's feature of size at the registration's pose by the
    characteristic's method, against nominal + lower .. nominal + upper (``shared``:
    engine.gdt.judgement.Shared)."""
    got = shared.once(("size", c.region, c.feature, c.method),
                      lambda: _size(c, idx, geo, shared))
    if isinstance(got, CharacteristicResult):
        return own(got, c)
    low, high, facts, guard = got
    what = SIZE_METHOD_WORDS[c.method] + (" width" if c.feature == "width" else " diameter")
    if c.method != "two-point":
        return by_value(c, idx, low, facts, what, guard)
    ends = [by_value(c, idx, v, facts, f"{which} {what}", guard)
            for which, v in (("smallest", low), ("largest", high))]
    rank = {REJECT: 2, INCONCLUSIVE: 1, ACCEPT: 0}
    worst = max(ends, key=lambda r: rank[r.verdict])
    return CharacteristicResult(c, worst.value, worst.verdict,
                                "; ".join(r.reason for r in ends), idx, facts=worst.facts)


def _size(c: Characteristic, idx: np.ndarray, geo: Geometry, shared):
    """(smallest, largest size, facts, its uncertainty bound), or an INCONCLUSIVE result."""
    m = measured_feature(c, idx, geo, shared, geo.T0)
    if isinstance(m, CharacteristicResult):
        return m
    low, high, fit = size_of(m, c.method)
    facts = {"method": c.method, "feature": c.feature, "internal": m.internal}
    if c.method == "lsq":  # as a size was reported before its methods: the fit and its form
        facts["fit"] = "least squares"
        if m.form_error is not None:
            facts["form_error"] = m.form_error
    if c.method == "two-point":
        facts.update(min_local_size=low, max_local_size=high)
    elif fit is not None:
        facts.update({"centre" if m.kind == "round" else "point": fit.point})
        if fit.direction is not None:
            facts["normal" if m.kind == "width" else "direction"] = fit.direction
    return low, high, facts, value_guard(geo, idx, geo.T0, form_only=True)
