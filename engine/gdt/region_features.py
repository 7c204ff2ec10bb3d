"""The feature each region of a plan is (a plane, cylinder or sphere fitted to its nominal and
measured points, or a freeform surface), the motions that leave a datum's feature in place, and
the 3-2-1 (RPS) alignment."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from .datums import Alignment, align_rps
from .features import WIDTH_SIDE
from .plan import MIN_POINTS, Characteristic, Plan
from ..verdict import INCONCLUSIVE
from .results import CharacteristicResult, Geometry, RegionFeature

if TYPE_CHECKING:
    from .features import CylinderFit, PlaneFit, RoundFit

FACING = np.radians(10.0)
"""How far a sample's normal may turn from its feature's and still be of it (engine.gdt.regions
boxes take in strips of the neighbouring faces), and how far a measured feature's fitted plane
or axis may turn from the nominal's before its points are taken not to determine it."""
SPAN = 0.05
"""A flatness needs its points spread both ways over the face: the smaller in-plane spread at
least this fraction of the larger (points along a line leave the plane free to turn about it)."""
HOLE_SPREAD = 0.05
"""A hole's points determine its centre and size apart when the smallest singular value of
[radial direction, 1] per point (over the square root of their number) is at least this: about
a 75-degree arc; a 45-degree arc has 0.018, which turns 1 um of probing noise into 50 um of
size."""
IDEAL_MM = 1e-3
"""A datum is fitted to its ideal nominal feature (:func:`datum_surface`) when its region's
nominal samples lie within this of it, mm: a CAD face of that kind, a mesh's vertices on it."""
HOLE_FORM = 0.02
"""A region is a hole when its nominal points lie within this fraction of its radius of their
least-squares cylinder (circle); a tessellated hole of 32 facets is within 0.5%."""


def region_features(plan: Plan, geo: Geometry, members: dict[str, np.ndarray],
                    T: np.ndarray) -> tuple[RegionFeature, ...]:
    """Every region a datum or characteristic uses, in the plan's order, as its feature
    (RegionFeature): the nominal fitted to the region's nominal points, the measured to its
    measured points at pose ``T``."""
    kinds = _region_kinds(plan)
    datums: dict[str, list] = {}
    for d in plan.datums:
        datums.setdefault(d.region, []).append((d.label, d.fit))
    out = []
    for r in plan.regions:
        kind = kinds.get(r.name)
        if kind is None:
            continue
        on = tuple(datums.get(r.name, ()))
        if kind not in ("plane", "cylinder", "sphere") or geo.nominal_points.shape[1] != 3:
            out.append(RegionFeature(r.name, "freeform", datums=on))
            continue
        mask = geo.nominal_masks[r.name]
        normals = geo.nominal_normals(np.flatnonzero(mask))
        idx = members[r.name]
        measured = _fit_feature(kind, geo.evaluate(T, idx)[0], normals) if idx.size else None
        out.append(RegionFeature(r.name, kind, region_nominal(kind, geo, mask), measured, on))
    return tuple(out)


def _region_kinds(plan: Plan) -> dict[str, str]:
    """{region: the feature it is}: its datum's feature, else what its characteristic implies
    (engine.gdt.plan.implied_feature: flatness a plane, position and size a hole, ...), else
    freeform (a profile's surface)."""
    kinds: dict[str, str] = {}
    for d in plan.datums:
        kinds.setdefault(d.region, d.feature)
    for c in plan.characteristics:
        for region, feature in c.region_features:
            kinds.setdefault(region, feature)
    return kinds


def feature_masks(plan: Plan, geo: Geometry) -> dict[str, np.ndarray]:
    """The regions' nominal masks, those of a plane (line) or a cylinder kept to the samples
    that face as the feature does (within FACING of the region's mean normal; at right angles
    to a hole's axis within FACING): a box takes in strips of the neighbouring faces, whose
    points must not join a datum or tilt its nominal."""
    out = dict(geo.nominal_masks)
    planar = geo.nominal_points.shape[1] == 2
    datum_regions = {d.region for d in plan.datums}
    for name, kind in _region_kinds(plan).items():
        if kind not in ("plane", "line", "cylinder", "width") or (planar and kind == "cylinder"):
            continue
        idx = np.flatnonzero(out[name])
        n = geo.nominal_normals(idx)
        if kind == "width":  # two opposed faces: the samples along the normals' main axis
            axis = np.linalg.eigh(n.T @ n)[1][:, -1]
            keep = np.abs(n @ axis) >= np.cos(FACING)
        elif kind == "cylinder":
            axis = np.linalg.eigh(n.T @ n)[1][:, 0]
            keep = np.abs(n @ axis) <= np.sin(FACING)
        else:
            mean = n.sum(axis=0)
            keep = n @ (mean / (np.linalg.norm(mean) or 1.0)) >= np.cos(FACING)
        if keep.sum() < MIN_POINTS[kind]:
            raise InputError(f"[[region]] '{name}': its nominal points do not form a {kind} "
                             f"(only {int(keep.sum())} of {idx.size} face as one does)",
                             plan.path)
        if kind == "width" and name in datum_regions:  # (a characteristic's: size.py says)
            facing = n[keep] @ axis
            ways = (int(np.sum(facing > 0.0)), int(np.sum(facing < 0.0)))
            if min(ways) < WIDTH_SIDE:
                raise InputError(f"[[region]] '{name}': its nominal points do not form a width "
                                 f"(two opposed faces): {ways[0]} and {ways[1]} of them face "
                                 "either way", plan.path)
        mask = np.zeros_like(out[name])
        mask[idx[keep]] = True
        out[name] = mask
    return out


def _nominal_feature(kind: str, points: np.ndarray, normals: np.ndarray) -> dict | None:
    """The least-squares ``kind`` of a region's nominal points (kept by feature_masks to those
    facing as the feature does); a cylinder or sphere says whether it is a hole (internal: the
    outward normals point towards its axis / centre)."""
    fit = _fit_feature(kind, points, normals)
    if fit is None:
        return None
    out = {k: v for k, v in fit.items() if k not in ("form_error", "n_points")}
    if kind not in ("plane", "line", "width"):
        radial = points - out.get("centre", out.get("point"))
        if kind == "cylinder":
            radial -= np.outer(radial @ out["direction"], out["direction"])
        out["internal"] = bool(np.sum(radial * normals) < 0.0)
    return out


def exact_nominal(geo: Geometry, kind: str, mask: np.ndarray) -> dict | None:
    """The region's nominal ``kind`` from the model's exact surface, or None (see
    Geometry.exact_feature)."""
    return None if geo.exact_feature is None else geo.exact_feature(kind, mask)


def region_nominal(kind: str, geo: Geometry, mask: np.ndarray) -> dict | None:
    """A region's nominal feature: the model's exact surface where it has one, else the
    least-squares fit to the region's nominal samples (``mask``)."""
    exact = exact_nominal(geo, kind, mask)
    if exact is not None:
        return exact
    return _nominal_feature(kind, geo.nominal_points[mask],
                            geo.nominal_normals(np.flatnonzero(mask)))


def datum_nominal(datum, geo: Geometry) -> dict | None:
    """The datum's nominal feature: its region's (:func:`region_nominal`)."""
    return region_nominal(datum.feature, geo, geo.nominal_masks[datum.region])


def datum_invariants(datum, geo: Geometry, nominal: dict | None) -> np.ndarray | None:
    """The motions that leave datum's ideal nominal feature in place (engine.gdt.datums), from
    its ``nominal`` (:func:`datum_nominal`); None when there is none."""
    from .datums import invariant_motions

    if nominal is None:
        return None
    return invariant_motions(datum.feature, nominal, geo.centre, geo.length)


def datum_surface(datum, geo: Geometry, nominal: dict | None):
    """evaluate(T, idx) -> (X, d, normals) of the measured points ``idx`` at pose T against the
    datum's ideal nominal feature (its region's plane, width, cylinder, sphere, line or circle,
    as :func:`datum_invariants` takes it), the one its simulator is (ASME Y14.5 §7, ISO 5459):
    unbounded, so that a point near an edge of the datum's face measures to the feature
    wherever the fit moves the part, never to the next face it slides over (CTC-01's top face
    as datum A, fitted from a pose turned 0.001 rad about its normal, tilted 3.8 mm over the
    plate by points near its pockets' edges). None where the region's nominal samples do not
    lie on one such feature (within IDEAL_MM), or no measured points are known: the datum is
    then fitted to the nominal surface. ``nominal``: its :func:`datum_nominal`."""
    from ..pose import apply_transform

    mask = geo.nominal_masks[datum.region]
    if nominal is None or geo.points is None:
        return None
    idx = np.flatnonzero(mask)
    deviate = ideal_deviations(datum.feature, nominal, geo.nominal_points[idx],
                               geo.nominal_normals(idx))
    if deviate is None or np.max(np.abs(deviate(geo.nominal_points[idx])[0])) > IDEAL_MM:
        return None
    points = geo.points

    def evaluate(T, sel):
        X = apply_transform(T, points[sel])
        return (X, *deviate(X))

    return evaluate


def ideal_deviations(kind: str, nominal: dict, P: np.ndarray, N: np.ndarray):
    """deviate(X) -> (signed deviations (m,), outward normals (m, dim)) of points X from the
    ideal ``kind`` described by ``nominal`` (:func:`region_nominal`), + along the outward
    normal (excess material); its sides (a width's slot or tab, a hole or a shaft) from the
    region's nominal samples P and their outward normals N. None for a kind it does not
    know."""
    if kind in ("plane", "line"):
        n = np.asarray(nominal["normal"], float)
        n = -n if float(np.sum(N @ n)) < 0.0 else n
        p = np.asarray(nominal["point"], float)
        return lambda X: ((X - p) @ n, np.broadcast_to(n, X.shape))
    if kind == "width":
        n, p = np.asarray(nominal["normal"], float), np.asarray(nominal["point"], float)
        half = 0.5 * float(nominal["width"])
        # A slot's walls face its median plane; a tab's face away from it.
        out = 1.0 if float(np.sum(np.sign((P - p) @ n) * (N @ n))) > 0.0 else -1.0

        def width(X):
            s = (X - p) @ n
            side = np.where(s < 0.0, -1.0, 1.0)
            return out * (np.abs(s) - half), (out * side)[:, None] * n

        return width
    if kind in ("cylinder", "sphere", "circle"):
        o = np.asarray(nominal.get("centre", nominal.get("point")), float)
        a = np.asarray(nominal["direction"], float) if kind == "cylinder" else None
        radius = 0.5 * float(nominal["diameter"])
        radial = P - o if a is None else (P - o) - np.outer((P - o) @ a, a)
        out = -1.0 if float(np.sum(radial * N)) < 0.0 else 1.0  # a hole's walls face its axis

        def round_(X):
            r = X - o if a is None else (X - o) - np.outer((X - o) @ a, a)
            length = np.linalg.norm(r, axis=1)
            u = r / np.maximum(length, 1e-300)[:, None]
            return out * (length - radius), out * u

        return round_
    return None


def _fit_feature(kind: str, X: np.ndarray, normals: np.ndarray) -> dict | None:
    """The least-squares ``kind`` of the points X (the region's nominal outward ``normals``
    orient a plane and start a cylinder's axis); None when X does not determine it."""
    from .features import (FeatureError, fit_circle_lsq, fit_cylinder_lsq, fit_plane_lsq,
                           fit_sphere_lsq, width_lsq, width_sides)

    f: PlaneFit | RoundFit | CylinderFit
    out: dict[str, np.ndarray | float]
    try:
        if kind == "width":  # its median plane (a datum of two opposed faces: a slot, a tab)
            side, axis = width_sides(normals)
            w = width_lsq(X, side, axis)
            if w.direction is None:
                return None
            return {"point": w.point, "normal": w.direction, "width": w.size,
                    "form_error": 0.0, "n_points": int(len(X))}
        if kind in ("plane", "line"):
            f = fit_plane_lsq(X, normals.sum(axis=0))
            out = {"point": f.centroid, "normal": f.normal}
        elif kind == "circle":
            f = fit_circle_lsq(X)
            out = {"centre": f.centre, "diameter": 2.0 * f.radius}
        elif kind == "cylinder":
            f = cylinder_from_normals(fit_cylinder_lsq, X, normals)
            out = {"point": f.point, "direction": f.direction, "diameter": 2.0 * f.radius}
        else:
            f = fit_sphere_lsq(X)
            out = {"centre": f.centre, "diameter": 2.0 * f.radius}
    except FeatureError:
        return None
    return {**out, "form_error": f.form_error, "n_points": f.n_points}


def rps_alignment(plan: Plan, geo: Geometry, best_fit: np.ndarray | None) -> Alignment:
    """The RPS alignment: each [[rps]] point's measured point (by its label) locked onto its
    nominal position along its locked axes."""
    if geo.labels is None:
        raise InputError("[alignment] method 'rps' finds its points by their labels, and the "
                         "measured file has none", plan.path)
    where: dict = {}
    for i, s in enumerate(geo.labels):
        where.setdefault(str(s), []).append(i)
    dim = geo.nominal_points.shape[1]
    idx, targets, axes = [], [], []
    for p in plan.rps:
        found = where.get(p.label, [])
        if len(found) != 1:
            raise InputError(f"[[rps]] '{p.label}': {len(found)} measured points carry this "
                             "label; it must name exactly one", plan.path)
        if dim == 2 and "z" in p.lock:
            raise InputError(f"[[rps]] '{p.label}': a 2D template's points lock x and y only, "
                             "not z", plan.path)
        for a in p.lock:
            e = np.zeros(dim)
            e["xyz".index(a)] = 1.0
            idx.append(found[0])
            targets.append(np.asarray(p.nominal, float)[:dim])
            axes.append(e)
    return align_rps(geo.evaluate, geo.T0, np.array(idx), np.array(targets), np.array(axes),
                     geo.centre, geo.length, best_fit)


def cylinder_from_normals(fit_cylinder_lsq, X: np.ndarray,
                          normals: np.ndarray) -> CylinderFit:
    """The least-squares cylinder of X, started from the nominal region's axis direction: the
    one its surface normals are all perpendicular to (the smallest eigenvector of sum n n^T)."""
    _, vecs = np.linalg.eigh(normals.T @ normals)
    return fit_cylinder_lsq(X, vecs[:, 0])


def nominal_cylinder(c, geo: Geometry, shared) -> tuple:
    """(the nominal hole or pin of ``c``'s region (:func:`nominal_hole`), its samples'
    normals), computed once per region (``shared``: engine.gdt.judgement.Shared); a region
    that is no cylinder (its nominal points off their best one by more than HOLE_FORM of its
    radius, or in one plane) is an InputError naming the characteristic."""
    from ..errors import InputError
    from .features import FeatureError

    try:
        nom, normals = shared.once(("hole", c.region), lambda: nominal_hole(geo, c.region))
    except FeatureError as e:
        raise InputError(f"[[characteristic]] '{c.id}': region '{c.region}' is no "
                         f"{'circle' if geo.nominal_points.shape[1] == 2 else 'cylinder'} "
                         f"({e.message})") from None
    spread = np.linalg.eigvalsh(normals.T @ normals)
    if spread[-2] < HOLE_SPREAD * spread[-1]:  # a plane is a cylinder of infinite radius
        raise InputError(f"[[characteristic]] '{c.id}': region '{c.region}' is no "
                         f"{'hole' if c.type in ('position', 'size') else 'cylinder'}: the "
                         "normals of its nominal points all face one way")
    if nom.form_error > HOLE_FORM * nom.radius:
        raise InputError(f"[[characteristic]] '{c.id}': region '{c.region}' is no "
                         f"{'hole' if c.type in ('position', 'size') else 'cylinder'}: its "
                         f"nominal points lie up to {nom.form_error:.3g} mm off their best "
                         f"{'circle' if normals.shape[1] == 2 else 'cylinder'}")
    return nom, normals


def nominal_hole(geo: Geometry, region: str):
    """(the region's nominal hole: the model's exact cylinder where it has one, else the fit
    to its samples; the samples' normals)."""
    mask = geo.nominal_masks[region]
    nominal, normals = geo.nominal_points[mask], geo.nominal_normals(np.flatnonzero(mask))
    nom = hole_fit(nominal, normals)
    exact = exact_nominal(geo, "cylinder", mask) if nominal.shape[1] == 3 else None
    if exact is not None:  # the model's own axis and radius, not a fit to its samples
        nom = replace(nom, point=exact["point"], direction=exact["direction"],
                      radius=0.5 * exact["diameter"], form_error=0.0)
    return nom, normals


def hole_fit(X: np.ndarray, normals: np.ndarray):
    """The least-squares circle (2D) or cylinder (3D, its axis started from the normals)."""
    from .features import fit_circle_lsq, fit_cylinder_lsq

    return fit_circle_lsq(X) if X.shape[1] == 2 else cylinder_from_normals(fit_cylinder_lsq, X, normals)


def measured_hole(c: Characteristic, idx: np.ndarray, X: np.ndarray, normals: np.ndarray,
                   nom):
    """The measured hole's fit, or an INCONCLUSIVE result when its points do not determine it
    (the fit did not settle, or its axis turned from the nominal's by more than FACING: a hole
    probed on a narrow arc)."""
    radial = X - (nom.centre if X.shape[1] == 2 else nom.point)
    if X.shape[1] == 3:
        radial -= np.outer(radial @ nom.direction, nom.direction)
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    across = np.linalg.svd(np.column_stack([radial, np.ones(len(X))]) / np.sqrt(len(X)),
                           compute_uv=False)
    # (3D: a 4th, along the axis, is zero; fewer than 3 points give fewer than 3 values)
    if across.size < 3 or across[2] < HOLE_SPREAD:
        return CharacteristicResult(c, None, INCONCLUSIVE, f"the {idx.size} points of region "
                                    f"'{c.region}' do not determine the hole (they cover too "
                                    "little of its circumference)", idx)
    got = hole_fit(X, normals)
    turn = 0.0 if X.shape[1] == 2 else float(np.degrees(np.arccos(np.clip(
        abs(got.direction @ nom.direction), 0.0, 1.0))))
    if got.converged and turn <= np.degrees(FACING):
        return got
    why = f"its axis turns {turn:.0f}° from the nominal's" if got.converged else \
        "the fit does not settle"
    return CharacteristicResult(c, None, INCONCLUSIVE, f"the {idx.size} points of region "
                                f"'{c.region}' do not determine the hole ({why})", idx)
