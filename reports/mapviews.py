"""Where the 3D deviation maps look from and what they show of the nominal: views named by the
nominal's axes, chosen so that every measured point faces the camera in one of them; the
camera framing the whole part; a display mesh for nominals given as bare points.

Frames and units: everything here is in the nominal frame, millimetres. A view's ``direction``
is the unit vector from the part towards the camera; ``up`` the screen's up. No Qt, no reportlab;
pyvista/VTK only inside :func:`display_mesh`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

COVER_DEG = 60.0
"""A point faces a view when its outward normal is within this angle of the view's direction."""
MAX_VIEWS = 4


def xyz(v: np.ndarray) -> tuple[float, float, float]:
    """The three floats of a (3,) vector."""
    return float(v[0]), float(v[1]), float(v[2])


@dataclass(frozen=True)
class ViewSpec:
    """A camera direction with its name."""

    name: str
    """"Top (+Z)", "Front (-Y)", "Iso (+X -Y +Z)" …: named by the nominal's axes."""
    direction: tuple[float, float, float]
    """Unit vector from the part towards the camera, nominal frame."""
    up: tuple[float, float, float]
    """The screen's up, perpendicular to ``direction``."""


def _axis_views() -> list[ViewSpec]:
    z, y = (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)
    return [ViewSpec("Top (+Z)", (0.0, 0.0, 1.0), y), ViewSpec("Front (-Y)", (0.0, -1.0, 0.0), z),
            ViewSpec("Right (+X)", (1.0, 0.0, 0.0), z), ViewSpec("Bottom (-Z)", (0.0, 0.0, -1.0), y),
            ViewSpec("Back (+Y)", (0.0, 1.0, 0.0), z), ViewSpec("Left (-X)", (-1.0, 0.0, 0.0), z)]


def _iso_views() -> list[ViewSpec]:
    out = []
    for sz in (1, -1):
        for sy in (-1, 1):
            for sx in (1, -1):
                d = np.array([sx, sy, sz], dtype=float) / math.sqrt(3.0)
                up = np.array([0.0, 0.0, 1.0]) - d[2] * d
                up /= np.linalg.norm(up)
                name = "Iso (" + " ".join(f"{'+' if s > 0 else '-'}{a}" for s, a in
                                          ((sx, "X"), (sy, "Y"), (sz, "Z"))) + ")"
                out.append(ViewSpec(name, xyz(d), xyz(up)))
    return out


CANDIDATES = tuple(_axis_views() + _iso_views())
"""The six views along the nominal's axes, then the eight isometric views (top ones first)."""


def choose_views(normals: np.ndarray, max_views: int = MAX_VIEWS,
                 cover_deg: float = COVER_DEG) -> list[ViewSpec]:
    """The fewest :data:`CANDIDATES` (greedy set cover, at most ``max_views``) such that every
    point's outward normal is within ``cover_deg`` of some view's direction; the view covering
    the most points first (among equals, the one they face most directly). A part one view
    covers gets the isometric view covering the most points as a second, for its shape.

    normals : (n, 3) outward unit normals of the measured points' feet, nominal frame.
    """
    normals = np.asarray(normals, dtype=float).reshape(-1, 3)
    dirs = np.array([c.direction for c in CANDIDATES])
    cos = normals @ dirs.T
    covers = cos >= math.cos(math.radians(cover_deg)) - 1e-9
    left = np.ones(len(normals), dtype=bool)
    chosen: list[int] = []
    while left.any() and len(chosen) < max_views:
        new = covers & left[:, None]
        gain = new.sum(axis=0)
        if gain.max() == 0:
            break  # normals no candidate covers (none: the candidates cover the sphere)
        facing = np.where(new, cos, 0.0).sum(axis=0)
        k = int(np.lexsort((-np.arange(len(dirs)), facing, gain))[-1])
        chosen.append(k)
        left &= ~covers[:, k]
    if len(chosen) < 2 <= max_views:
        iso = [k for k in range(6, len(CANDIDATES)) if k not in chosen]
        gain = covers[:, iso].sum(axis=0) + 1e-6 * cos[:, iso].sum(axis=0)
        chosen.append(iso[int(np.argmax(gain))])
    return [CANDIDATES[k] for k in chosen]


def camera_basis(view: ViewSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(direction, right, up) unit vectors of a view: screen x along right, y along up."""
    d = np.asarray(view.direction, dtype=float)
    up = np.asarray(view.up, dtype=float)
    up = up - (up @ d) * d
    up /= np.linalg.norm(up)
    return d, np.cross(up, d), up


@dataclass(frozen=True)
class Framing:
    """A parallel-projection camera that shows given points whole."""

    centre: tuple[float, float, float]
    """The point the camera looks at, nominal frame, mm."""
    half_height: float
    """Half the picture's height in mm (VTK's parallel scale)."""
    depth: float
    """Distance from ``centre`` to the camera, mm (beyond every point)."""


def frame(points: np.ndarray, view: ViewSpec, aspect: float, fill: float = 0.84) -> Framing:
    """The camera of ``view`` that shows every one of ``points`` (n, 3) with the part's
    extent taking ``fill`` of the picture's width or height, whichever binds; aspect = width /
    height of the picture."""
    d, right, up = camera_basis(view)
    u, v, w = points @ right, points @ up, points @ d
    cu, cv = 0.5 * (u.max() + u.min()), 0.5 * (v.max() + v.min())
    centre = cu * right + cv * up + 0.5 * (w.max() + w.min()) * d
    span = max(float(np.ptp(v)), float(np.ptp(u)) / aspect, 1e-9)
    depth = float(np.ptp(w)) + float(np.ptp(u)) + float(np.ptp(v)) + 1.0
    return Framing(xyz(centre), 0.5 * span / fill, depth)


def project(points: np.ndarray, view: ViewSpec, framing: Framing,
            size: tuple[int, int]) -> np.ndarray:
    """(n, 2) pixel positions (x right from the left edge, y down from the top edge, pixel
    centres at half-integers) of ``points`` in the picture of ``size`` = (width, height)."""
    _, right, up = camera_basis(view)
    rel = np.asarray(points, dtype=float) - np.asarray(framing.centre)
    k = 0.5 * size[1] / framing.half_height
    return np.column_stack([0.5 * size[0] + k * (rel @ right), 0.5 * size[1] - k * (rel @ up)])


# ---------------------------------------------------------------------------- display mesh
MESH_CELLS = 90
"""Voxels along the part's longest side for the display mesh of a point nominal."""
MESH_POINTS = 60_000
"""At most this many nominal points build it (every k-th point above)."""


def display_mesh(points: np.ndarray, normals: np.ndarray, cells: int = MESH_CELLS):
    """A triangle mesh for drawing a nominal given as points with outward normals: the zero
    level of the signed distance to the points' tangent planes (Hoppe et al. 1992, each voxel
    corner taking its nearest point's plane), contoured by marching cubes (VTK's flying edges);
    triangles farther from every point than the sampling allows (where an open sheet's planes
    run on past its border) are dropped. For display only: the deviations never see it.

    points, normals : (m, 3) mm and unit vectors, nominal frame. Returns a pyvista PolyData
    with point normals, or None when there is nothing to draw.
    """
    import pyvista as pv
    from scipy.spatial import cKDTree

    step = max(1, len(points) // MESH_POINTS)
    p, n = points[::step], normals[::step]
    ok = np.isfinite(n).all(axis=1)
    p, n = p[ok], n[ok]
    if len(p) < 4:
        return None
    tree = cKDTree(p, balanced_tree=False)  # sliding midpoint: far queries 7x faster here
    lo, hi = p.min(axis=0), p.max(axis=0)
    h = max(float(np.max(hi - lo)) / cells, 1e-9)
    spacing = float(np.median(tree.query(p[:: max(1, len(p) // 2000)], k=2)[0][:, 1]))
    reach = max(2.0 * spacing, 0.9 * h)
    lo, dims = lo - 2.37 * h, np.ceil((hi - lo) / h).astype(int) + 6  # corners off the faces
    grid = pv.ImageData(dimensions=tuple(int(x) for x in dims), spacing=(h, h, h),
                        origin=tuple(lo))
    corners = np.asarray(grid.points)
    # Only corners near a point need its plane; the others only a sign, that of the nearest
    # corner that has one (so no level runs between the two).
    near = _near_corners(p, np.asarray(lo), h, dims)
    dist, j = tree.query(corners[near], distance_upper_bound=3.0 * h)
    found = np.isfinite(dist)
    near, j = near[found], j[found]
    level = np.einsum("ij,ij->i", corners[near] - p[j], n[j])
    # A corner whose foot on the plane lies far from the point that gave it (Hoppe's test) is
    # past an edge or a border, where that plane does not hold.
    foot = corners[near] - level[:, None] * n[j]
    held = np.linalg.norm(foot - p[j], axis=1) <= reach
    near = near[held]
    sdf = np.zeros(len(corners))
    sdf[near] = level[held]
    sdf = _signed_beyond(sdf, near, dims, 3.0 * h)
    grid.point_data["sdf"] = sdf
    surf = grid.contour([0.0], scalars="sdf", method="flying_edges")
    if surf.n_cells == 0:
        return None
    far = tree.query(surf.cell_centers().points)[0] > reach
    if far.any():
        surf = surf.extract_cells(np.flatnonzero(~far)).extract_surface(algorithm="dataset_surface")
    surf = surf.compute_normals(auto_orient_normals=False, consistent_normals=False,
                                split_vertices=False)
    return surf if surf.n_cells else None


def _near_corners(p: np.ndarray, origin: np.ndarray, h: float, dims: np.ndarray) -> np.ndarray:
    """Flat indices (VTK order: x fastest) of the grid corners within about one voxel of a
    point: the corners of each occupied voxel, grown by one corner every way."""
    from scipy.ndimage import binary_dilation

    shape = (int(dims[2]), int(dims[1]), int(dims[0]))
    ijk = np.clip(np.floor((p - origin) / h).astype(np.int64), 0, dims - 2)
    occupied = np.zeros(shape, dtype=bool)
    occupied[ijk[:, 2], ijk[:, 1], ijk[:, 0]] = True
    near = binary_dilation(occupied, structure=np.ones((3, 3, 3), dtype=bool), iterations=1)
    near[1:, 1:, 1:] |= near[:-1, :-1, :-1]  # the far corners of each voxel
    return np.flatnonzero(near.reshape(-1))


def _signed_beyond(sdf: np.ndarray, near: np.ndarray, dims: np.ndarray, far: float) -> np.ndarray:
    """``sdf`` with each corner outside ``near`` set to +-far, the sign of the nearest corner
    in ``near`` (a Euclidean distance transform over the grid)."""
    from scipy.ndimage import distance_transform_edt

    shape = (int(dims[2]), int(dims[1]), int(dims[0]))  # VTK order: x fastest
    unknown = np.ones(len(sdf), dtype=bool)
    unknown[near] = False
    nearest = distance_transform_edt(unknown.reshape(shape), return_distances=False,
                                     return_indices=True)
    flat = np.ravel_multi_index(tuple(nearest), shape).reshape(-1)
    out = np.where(sdf[flat] < 0, -far, far)
    out[near] = sdf[near]
    return out
