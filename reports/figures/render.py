"""3D deviation maps: the nominal surface shaded and every measured point at its foot on it,
coloured by band, rendered off-screen with pyvista from the views of reports.mapviews.
"""

from __future__ import annotations

import io
import math
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..callouts import point_spacing
from ..mapviews import xyz
from .colours import Zone, band_rgb

if TYPE_CHECKING:  # the render process should not pay for importing the engine
    from engine.inspection import Tolerance


@dataclass(frozen=True)
class View:
    """One rendered view of a 3D map."""

    name: str
    """Named by the nominal's axes: "Top (+Z)", "Iso (+X -Y +Z)" … (reports.mapviews)."""
    direction: tuple[float, float, float]
    """Unit vector from the part towards the camera, nominal frame."""
    png: bytes
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    """The picture's up, nominal frame (with ``direction``: the axis triad)."""
    anchors: tuple[tuple[int, float, float], ...] = ()
    """(point index, x, y) of each callout point visible in this view, in pixels of the
    picture (x from the left, y from the top)."""
    avoid: tuple[tuple[float, float], ...] = ()
    """Pixels of the other visible out-of-tolerance points, which labels should not hide."""


RENDER_SIZE = (960, 720)


def render_3d(nominal_points: np.ndarray, triangles: np.ndarray | None, feet: np.ndarray,
              normals: np.ndarray, d: np.ndarray, tol: "Tolerance | Zone",
              worst: list[tuple[int, str]], size: tuple[int, int] = RENDER_SIZE,
              nominal_normals: np.ndarray | None = None) -> list[View]:
    """The views of reports.mapviews.choose_views (every measured point faces one of them,
    parallel projection, the whole part framed) of the nominal surface, shaded, with each
    measured point drawn at its foot on the surface, coloured by band.

    nominal_points : (m, 3), triangles : (k, 3) or None; nominal_normals : (m, 3) outward unit
    normals of bare points (their display mesh is built from them; without them they are drawn
    as a grey cloud); feet, normals : (n, 3) foot points and outward unit normals, nominal
    frame; d : (n,) mm; worst : (point index, label text) of the callout points, whose pixels
    each view reports where the point is not hidden (the labels are drawn by the caller).
    """
    from .. import mapviews

    if not os.environ.get("DISPLAY"):
        # VTK's wheels try X first and fall back to EGL only after a slow failure.
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    surf, lift = display_surface(nominal_points, triangles, normals=nominal_normals)
    shown = feet + lift * normals  # just outside the surface, so the surface never hides them
    extent = np.vstack([nominal_points[:: max(1, len(nominal_points) // 50_000)], shown])
    out = (d < tol.lower) | (d > tol.upper)
    pl = pv.Plotter(off_screen=True, window_size=list(size))
    try:
        # pyvista's method decorators (_Wrapped) hide their signatures from mypy.
        pl.set_background("white")  # type: ignore[arg-type]
        if surf is not None:
            pl.add_mesh(surf, color=(0.80, 0.81, 0.83), smooth_shading=True, specular=0.2,
                        ambient=0.25)
        else:
            pl.add_points(extent[:-len(shown)], color=(0.72, 0.73, 0.75), point_size=2)
        rgb = band_rgb(d, tol)
        actors = [(pl.add_points(shown[mask], scalars=rgb[mask], rgb=True,
                                 render_points_as_spheres=True), grow)
                  for mask, grow in ((~out, 1.0), (out, 1.4)) if mask.any()]  # rejects stand out
        pl.enable_parallel_projection()  # type: ignore[call-arg]  # pyvista's _Wrapped
        idx = np.array([i for i, _ in worst] + list(np.flatnonzero(out)), dtype=int)
        marks = (shown[idx], normals[idx])
        spacing = point_spacing(feet)
        pl.show(auto_close=False)  # the first render sets the window up; each view renders once
        return [_shoot(pl, spec, extent, marks, idx, len(worst), size, (actors, spacing))
                for spec in mapviews.choose_views(normals)]
    finally:
        pl.close()


MARKER_SHARE = (1.0, 4.0, 24.0)
"""A measured point's sphere is this share of the typical spacing between points wide on
screen, within these pixel limits: neighbours nearly touch, so a cluster reads as a patch."""


def _shoot(pl, spec, extent, marks, idx, n_worst, size, markers) -> View:
    """Render one view; report where the callout points (the first ``n_worst`` of ``marks``)
    and the other out-of-tolerance points show, skipping those behind the part or facing
    away from the camera. markers : (the point actors with their size factors, the points'
    typical spacing in mm)."""
    from .. import mapviews

    fr = mapviews.frame(extent, spec, size[0] / size[1])
    px_per_mm = 0.5 * size[1] / fr.half_height
    share, smallest, largest = MARKER_SHARE
    marker_px = float(np.clip(share * markers[1] * px_per_mm, smallest, largest))
    for actor, grow in markers[0]:
        actor.prop.point_size = grow * marker_px
    d = np.asarray(spec.direction)
    marks, facing = marks[0], marks[1] @ d > -0.1
    pl.camera_position = [tuple(np.asarray(fr.centre) + fr.depth * d), fr.centre, spec.up]
    pl.camera.parallel_scale = fr.half_height
    pl.renderer.reset_camera_clipping_range()
    pl.render()
    png = _png(_grab(pl, zbuffer=False))
    xy = mapviews.project(marks, spec, fr, size)
    near, far = pl.camera.clipping_range
    z = _grab(pl, zbuffer=True)[:, :, 0]
    dist = np.where(z < 1.0, near + z * (far - near), np.nan)  # from the camera, mm
    # The farthest drawn depth around each point's pixel: its own sphere shows there unless
    # the part is in front (a neighbour's sphere may cover its centre).
    pad = np.pad(dist, 2, constant_values=np.nan)
    col = np.clip(xy[:, 0].astype(int), 0, size[0] - 1)
    row = np.clip(xy[:, 1].astype(int), 0, size[1] - 1)
    win = np.stack([pad[row + i, col + j] for i in range(5) for j in range(5)])
    seen = np.where(np.isnan(win).all(axis=0), np.inf, np.nanmax(np.nan_to_num(
        win, nan=-np.inf), axis=0))
    expected = fr.depth - (marks - np.asarray(fr.centre)) @ d
    slack = 0.005 * float(np.linalg.norm(np.ptp(extent, axis=0))) + \
        1.4 * marker_px / px_per_mm  # a sphere's front is nearer than its centre
    visible = facing & (seen >= expected - slack)  # nothing nearer to the camera all round
    anchors = tuple((int(idx[k]), float(xy[k, 0]), float(xy[k, 1]))
                    for k in range(n_worst) if visible[k])
    avoid = tuple((float(x), float(y)) for (x, y), v in zip(xy[n_worst:], visible[n_worst:])
                  if v)
    return View(spec.name, xyz(d), png, tuple(spec.up), anchors, avoid)


def _grab(pl, zbuffer: bool) -> np.ndarray:
    """The picture just rendered (rows from the top), colours or the z-buffer (0 near, 1
    far), read once without rendering again (pyvista's screenshot and depth each render)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkRenderingCore import vtkWindowToImageFilter

    f = vtkWindowToImageFilter()
    f.SetInput(pl.render_window)
    f.ShouldRerenderOff()
    f.ReadFrontBufferOff()
    if zbuffer:
        f.SetInputBufferTypeToZBuffer()
    else:
        f.SetInputBufferTypeToRGB()
    f.Update()
    img = f.GetOutput()
    w, h, _ = img.GetDimensions()
    return vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, -1)[::-1]


DISPLAY_TRIANGLES = 40_000
"""Nominal meshes with more triangles are simplified for the picture (software OpenGL renders
time in proportion); the deviations themselves never see this."""
CLUSTER_DIVISIONS = 150


def display_surface(nominal_points: np.ndarray, triangles: np.ndarray | None,
                    max_triangles: int = DISPLAY_TRIANGLES, normals: np.ndarray | None = None):
    """The nominal as a pyvista surface for display, simplified above ``max_triangles``, and
    how far (mm) to lift points off it along their normals so that the surface never hides
    them. Bare points with ``normals`` (m, 3) get a display mesh
    (reports.mapviews.display_mesh); without: None."""
    import pyvista as pv

    diagonal = float(np.linalg.norm(np.ptp(nominal_points, axis=0)))
    lift = 1e-3 * diagonal
    if triangles is None:
        if normals is None:
            return None, lift
        from ..mapviews import MESH_CELLS, display_mesh

        surf = display_mesh(nominal_points, normals)
        voxel = float(np.max(np.ptp(nominal_points, axis=0))) / MESH_CELLS
        return surf, max(lift, 0.3 * voxel)
    surf = pv.PolyData.from_regular_faces(nominal_points, triangles)
    if surf.n_cells > max_triangles:
        surf = _simplified(surf)
        lift = max(lift, 0.5 * diagonal / CLUSTER_DIVISIONS)
    return surf, lift


COLOURED_TRIANGLES = 600_000
"""A surface coloured by the deviations is subdivided to at most this many triangles."""


def coloured_surface(surf, feet: np.ndarray, d: np.ndarray, tol: "Tolerance | Zone",
                     lift: float, max_triangles: int = COLOURED_TRIANGLES,
                     cell_faces: np.ndarray | None = None):
    """The display surface ``surf`` (from :func:`display_surface`, whose ``lift`` it gave)
    coloured by the deviation field over the measured coverage: each vertex the band colour of
    its nearest measured point within reach (colours.surface_field: COVERAGE_SPACINGS typical
    spacings of the points, at least twice the display's distance from the nominal), grey
    beyond. Its triangles are first cut to edges of half that reach (at most
    ``max_triangles``), so that a large flat facet shows where its points are. Returns the
    surface (point data "rgb", uint8) and each of its cells' entry of ``cell_faces`` (the
    face of each cell of ``surf``), or None without them. (Within the budget it is cut to
    coarser edges; a cut that would lose area is not made.)"""
    from ..callouts import point_spacing
    from .colours import COVERAGE_SPACINGS, surface_field, surface_rgb

    reach = max(COVERAGE_SPACINGS * point_spacing(feet), 2.0 * lift)
    out = surf.copy()
    if cell_faces is not None:
        out.cell_data["qa_face"] = np.asarray(cell_faces)
    if out.n_cells < max_triangles and out.is_all_triangles:
        # Edges of half the reach, longer where that would pass the budget (VTK's filter stops
        # at its budget and drops the triangles it has not reached: a check of the area).
        # Halving edges down to e leaves triangles of about 0.15 e^2 each. (VTK's own area
        # limit, 1 by default whatever the unit, is set to the edge's.)
        area = float(out.area)
        edge = max(0.5 * reach, math.sqrt(area / (0.12 * max_triangles)))
        for _ in range(4):
            finer = out.subdivide_adaptive(max_edge_len=edge, max_tri_area=0.5 * edge * edge,
                                           max_n_tris=max_triangles)
            if abs(float(finer.area) - area) <= 1e-6 * area:
                out = finer
                break
            edge *= 1.6
    out.point_data["rgb"] = surface_rgb(surface_field(np.asarray(out.points), feet, d, reach),
                                        tol)
    faces = (np.asarray(out.cell_data["qa_face"]) if "qa_face" in out.cell_data else None)
    return out, faces


def _simplified(surf):
    """Quadric clustering (linear time) to about CLUSTER_DIVISIONS cells along the longest
    side."""
    import pyvista as pv
    from vtkmodules.vtkFiltersCore import vtkQuadricClustering

    q = vtkQuadricClustering()
    q.SetInputData(surf)
    q.SetNumberOfDivisions(CLUSTER_DIVISIONS, CLUSTER_DIVISIONS, CLUSTER_DIVISIONS)
    q.AutoAdjustNumberOfDivisionsOn()
    q.Update()
    return pv.wrap(q.GetOutput())


def face_on_direction(p: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Look along the measured patch's least-spread axis, from the side most normals face."""
    c = p - p.mean(axis=0)
    _, _, vt = np.linalg.svd(c[:: max(1, len(c) // 20000)], full_matrices=False)
    axis = vt[2]
    if normals @ axis @ np.ones(len(normals)) < 0:
        axis = -axis
    return axis / np.linalg.norm(axis)


def any_perpendicular(v: np.ndarray) -> np.ndarray:
    """The world axis least aligned with ``v``, made perpendicular: the screen's up."""
    a = np.eye(3)[int(np.argmin(np.abs(v)))]
    u = a - (a @ v) * v
    return u / np.linalg.norm(u)


def _png(img: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(img).save(buf, format="PNG", optimize=False, compress_level=1)
    return buf.getvalue()
