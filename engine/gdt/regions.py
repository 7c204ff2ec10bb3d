"""Which nominal and measured points belong to each region of an inspection plan.

A region selects nominal points: a box in nominal coordinates, a glob on the nominal point
file's labels, or a named group (a mesh's face group: OBJ ``g``/``o``, a PLY face property; a 2D
template's DXF layer; engine.io). A group's nominal points are the vertices of its faces (a
vertex between two groups' faces is in both), a layer's the samples of its contours. A measured
point belongs to the regions of the nominal sample nearest its
closest point on the surface at the registered pose, however far from it (a gross defect is
judged in its region, never dropped), or, where the region gives ``measured_labels``, to the
region its label matches. Regions may overlap (a datum face inside
a profile's region). Units mm, nominal frame.
"""

from __future__ import annotations

from fnmatch import fnmatchcase

import numpy as np

from ..errors import InputError
from .plan import Plan, Region


def nominal_members(plan: Plan, points: np.ndarray, labels: np.ndarray | None,
                    groups: dict[str, np.ndarray] | None = None, fold_case: bool = False,
                    triangles: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """{region name: (N,) bool over the nominal points (N, dim)}; a region that selects no
    nominal point, or a selector the nominal cannot answer (a group it does not have), is an
    InputError naming the plan.

    labels : (N,) the nominal points' labels, or None. groups : {name: indices of its nominal
    points} (engine.pointset.PointSet ``groups``; a 2D template's layers), or None for a
    nominal without groups. fold_case : group names compare without case (DXF layer names do).
    triangles : (m, 3) the nominal's triangles, a STEP model's tessellation, whose points lie
    only on its faces' edges (a box over the middle of a plane holds none of them): a box then
    selects every sample of the faces (``face:N`` groups) its triangles cross, and the
    measured points whose closest point lies in it (:func:`measured_members`' feet); None: a
    box selects the points inside it.
    """
    face_of = None if triangles is None else _face_of(groups or {}, len(points))
    out = {}
    for r in plan.regions:
        out[r.name] = _select(plan, r, points, labels, groups, fold_case)
        if r.box is not None and triangles is not None and face_of is not None:
            crossing = triangles[triangles_in_box(points[triangles], *r.box)].ravel()
            faces = np.unique(face_of[crossing])
            out[r.name] |= np.isin(face_of, faces[faces >= 0])
        if not out[r.name].any():
            raise InputError(f"[[region]] '{r.name}': selects no point of the nominal "
                             f"({_selector(r)})", plan.path)
    return out


def _select(plan: Plan, r: Region, points: np.ndarray, labels: np.ndarray | None,
            groups: dict[str, np.ndarray] | None, fold_case: bool) -> np.ndarray:
    if r.box is not None:
        lo = np.asarray(r.box[0], float)[:points.shape[1]]
        hi = np.asarray(r.box[1], float)[:points.shape[1]]
        return np.all((points >= lo) & (points <= hi), axis=1)
    if r.labels is not None:
        if labels is None:
            raise InputError(f"[[region]] '{r.name}': 'labels' selects by the nominal's point "
                             "labels, and this nominal has none", plan.path)
        return np.array([fnmatchcase(str(s), r.labels) for s in labels], dtype=bool)
    if not groups:
        raise InputError(f"[[region]] '{r.name}': 'group' selects a named group of the "
                         "nominal (an OBJ mesh's g or o, a PLY mesh's group property, a DXF "
                         "layer), and this nominal has no groups", plan.path)
    mask = np.zeros(points.shape[0], dtype=bool)
    for name in group_names(r):
        key = {n.lower(): n for n in groups}.get(name.lower(), name) if fold_case else name
        if key not in groups:
            names = list(groups)
            shown = ", ".join(f"'{n}'" for n in names[:GROUPS_SHOWN])
            more = f", … ({len(names)} in all)" if len(names) > GROUPS_SHOWN else ""
            raise InputError(f"[[region]] '{r.name}': the nominal has no group '{name}' (its "
                             f"groups: {shown}{more})", plan.path)
        mask[groups[key]] = True
    return mask


def group_names(r: Region) -> tuple[str, ...]:
    """The names of the groups ``r`` selects (``group``: one name or several)."""
    return (r.group,) if isinstance(r.group, str) else tuple(r.group or ())
def _face_of(groups: dict[str, np.ndarray], n: int) -> np.ndarray:
    """(n,) each sample's STEP face (its ``face:N`` group, engine.step_model.face_groups), -1
    for none."""
    out = np.full(n, -1)
    for name, idx in groups.items():
        if name.startswith("face:"):
            out[idx] = int(name[5:])
    return out


def triangles_in_box(V: np.ndarray, lo, hi) -> np.ndarray:
    """(m,) bool: whether each triangle V (m, 3, 3) meets the axis-aligned box [lo, hi] (3,),
    mm: no separating axis among the box's three, the triangle's normal and the nine cross
    products of their edges (Akenine-Möller's test)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = V - 0.5 * (lo + hi)
    half = 0.5 * (hi - lo)
    edges = np.roll(v, -1, axis=1) - v
    axes = [np.broadcast_to(e, (len(V), 3)) for e in np.eye(3)]
    axes.append(np.cross(edges[:, 0], edges[:, 1]))
    axes += [np.cross(edges[:, j], e) for j in range(3) for e in np.eye(3)]
    apart = np.zeros(len(V), dtype=bool)
    for a in axes:
        p = np.einsum("mkj,mj->mk", v, a)
        r = np.abs(a) @ half
        apart |= (p.min(axis=1) > r) | (p.max(axis=1) < -r)
    return ~apart


GROUPS_SHOWN = 12
"""How many of the nominal's groups a message about a missing group lists."""


def _selector(r: Region) -> str:
    if r.box is not None:
        return f"box {[list(c) for c in r.box]}"
    if r.labels is not None:
        return f"labels '{r.labels}'"
    names = group_names(r)
    return f"group '{names[0]}'" if len(names) == 1 else \
        "groups " + ", ".join(f"'{g}'" for g in names)


def measured_members(plan: Plan, nominal_masks: dict[str, np.ndarray], nearest: np.ndarray,
                     labels: np.ndarray | None, feet: np.ndarray | None = None
                     ) -> dict[str, np.ndarray]:
    """{region name: indices of its measured points (ascending)}.

    nearest : (n,) index of the nominal sample nearest each registered measured point's closest
    point on the surface, however far the point lies from it (a gross defect stays in its
    region, to be judged there); labels : the measured points' labels, or None. feet : (n, dim)
    those closest points, or None: given (a STEP model's, whose box regions hold whole
    faces), a box holds only the points whose closest point lies inside it."""
    out = {}
    for r in plan.regions:
        if r.measured_labels is not None:
            if labels is None:
                raise InputError(f"[[region]] '{r.name}': 'measured_labels' selects measured "
                                 "points by label, and the measured file has none", plan.path)
            mask = np.array([fnmatchcase(str(s), r.measured_labels) for s in labels], bool)
        else:
            mask = nominal_masks[r.name][nearest]
            if r.box is not None and feet is not None:
                lo, hi = (np.asarray(c, float)[:feet.shape[1]] for c in r.box)
                mask &= np.all((feet >= lo) & (feet <= hi), axis=1)
        out[r.name] = np.flatnonzero(mask)
    return out


def region_column(plan: Plan, members: dict[str, np.ndarray], n: int) -> np.ndarray:
    """(n,) str: each measured point's regions joined by '+', in the plan's order ('' for
    none), for the per-point outputs."""
    names: list[list[str]] = [[] for _ in range(n)]
    for r in plan.regions:
        for i in members[r.name]:
            names[i].append(r.name)
    return np.array(["+".join(x) for x in names], dtype=object)
