"""Figures of an inspection: the tolerance-banded colour scale, 3D deviation maps (pyvista,
rendered off-screen), the 2D contour with magnified deviation whiskers and the histogram
(reportlab vector drawings). No Qt: the desktop app reuses the colour scale.

Colour scale: a diverging scale across the tolerance zone [lower, upper] in 12-16 equal-looking
steps: blue at the lower limit, through cyan to green at the nominal (deviation 0, the middle
of a green band) and through yellow to red at the upper limit, interpolated in CIELAB so that
neighbouring steps differ by about the same perceived amount on each side. Beyond the zone,
two darker colours on each side, a quarter zone wide and farther: navy then violet below
the lower limit (material missing), maroon then magenta above the upper limit (excess
material). A deviation exactly on a limit is in tolerance.
"""

from __future__ import annotations

import functools
import io
import math
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from engine.errors import QAError

from .callouts import point_spacing

if TYPE_CHECKING:  # the render process should not pay for importing the engine
    from engine.inspection import Tolerance

ZONE_STEPS = 15
"""Steps of the scale inside the zone (odd: the nominal sits in the middle of a green one);
an asymmetric zone gets 14-16, as its sides divide."""
RAMP = ((0.16, 0.27, 0.80), (0.08, 0.62, 0.86), (0.22, 0.68, 0.24), (0.96, 0.84, 0.16),
        (0.84, 0.13, 0.11))
"""sRGB anchors of the in-zone ramp at the lower limit, half way down, the nominal, half way up
and the upper limit: blue, cyan, green, yellow, red."""
BELOW = ((0.35, 0.06, 0.45), (0.04, 0.09, 0.42))
"""Beyond the lower limit, farthest first: violet (more than a quarter zone), navy."""
ABOVE = ((0.50, 0.0, 0.06), (0.86, 0.0, 0.62))
"""Beyond the upper limit, nearest first: maroon, magenta (more than a quarter zone)."""


@dataclass(frozen=True)
class Band:
    """One colour band of deviations (mm): [lower, upper) below and inside the zone, (lower,
    upper] above it; the zone's bands include both limits."""

    lower: float
    upper: float
    rgb: tuple[float, float, float]
    in_tolerance: bool
    digits: int = 3
    """Decimals the labels print (finer for a narrow zone)."""


def _zone_edges(lo: float, hi: float) -> np.ndarray:
    """Edges of the in-zone bands, lo to hi: a green band 1/ZONE_STEPS of the zone wide
    centred on the nominal (on the zone's middle when 0 lies outside), each side divided into
    steps of that width, rounded to whole steps."""
    w = (hi - lo) / ZONE_STEPS
    m = min(max(0.0, lo + w / 2), hi - w / 2) if lo <= 0.0 <= hi else 0.5 * (lo + hi)
    k_lo = int(round((m - w / 2 - lo) / w))
    k_hi = int(round((hi - m - w / 2) / w))
    lower = np.linspace(lo, m - w / 2, k_lo + 1) if k_lo else np.array([lo])
    upper = np.linspace(m + w / 2, hi, k_hi + 1) if k_hi else np.array([hi])
    return np.concatenate([lower, upper])


def _srgb_to_lab(rgb: np.ndarray) -> np.ndarray:
    """CIELAB (D65) of sRGB colours in 0..1, (n, 3)."""
    c = np.asarray(rgb, dtype=float)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    xyz = lin @ np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                          [0.0193, 0.1192, 0.9505]]).T / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.column_stack([116 * f[:, 1] - 16, 500 * (f[:, 0] - f[:, 1]),
                            200 * (f[:, 1] - f[:, 2])])


def _lab_to_srgb(lab: np.ndarray) -> np.ndarray:
    fy = (lab[:, 0] + 16) / 116
    f = np.column_stack([fy + lab[:, 1] / 500, fy, fy - lab[:, 2] / 200])
    xyz = np.where(f > 6 / 29, f**3, 3 * (6 / 29) ** 2 * (f - 4 / 29))
    xyz = xyz * np.array([0.95047, 1.0, 1.08883])
    lin = xyz @ np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415],
                          [0.0557, -0.2040, 1.0570]]).T
    lin = np.clip(lin, 0.0, 1.0)
    return np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)


@functools.lru_cache(maxsize=1)
def _ramp_table(samples: int = 401):
    """The ramp sampled densely over t in [-1, 1] (t: -1 lower limit, 0 nominal, +1 upper)
    in CIELAB, and each sample's share of its side's path length (so that equal steps of
    that share are equal perceived steps)."""
    anchors = _srgb_to_lab(np.array(RAMP))
    t = np.linspace(-1.0, 1.0, samples)
    lab = np.column_stack([np.interp(t, np.linspace(-1, 1, len(RAMP)), anchors[:, k])
                           for k in range(3)])
    step = np.r_[0.0, np.linalg.norm(np.diff(lab, axis=0), axis=1)]
    mid = samples // 2
    share = np.empty(samples)
    for side in (slice(0, mid + 1), slice(mid, samples)):
        arc = np.cumsum(step[side]) - step[side][0]
        share[side] = arc / arc[-1]
    share[: mid + 1] -= 1.0  # -1 at the lower limit, 0 at the nominal
    return share, lab


def ramp_rgb(t: np.ndarray) -> np.ndarray:
    """(n, 3) sRGB in 0..1 of the in-zone ramp at ``t`` in [-1, 1] (the share of the way from
    the nominal to a limit, -1 lower, +1 upper), perceptually even on each side."""
    share, lab = _ramp_table()
    t = np.clip(np.asarray(t, dtype=float).reshape(-1), -1.0, 1.0)
    col = np.column_stack([np.interp(t, share, lab[:, k]) for k in range(3)])
    return _lab_to_srgb(col)


@functools.lru_cache(maxsize=64)
def _bands(lo: float, hi: float) -> tuple[Band, ...]:
    edges = _zone_edges(lo, hi)
    centres = 0.5 * (edges[:-1] + edges[1:])
    green = int(np.argmin(np.abs(centres - (0.0 if lo <= 0.0 <= hi else 0.5 * (lo + hi)))))
    m = centres[green]
    t = np.where(centres < m, (centres - m) / (m - lo if m > lo else 1.0),
                 (centres - m) / (hi - m if hi > m else 1.0))
    rgb = [tuple(round(float(v), 4) for v in c) for c in ramp_rgb(t)]
    digits = max(3, int(math.ceil(-math.log10(float(np.min(np.diff(edges)))))) + 1)
    s = (hi - lo) / 4.0
    out = [Band(-math.inf, lo - s, BELOW[0], False, digits),
           Band(lo - s, lo, BELOW[1], False, digits)]
    out += [Band(float(edges[k]), float(edges[k + 1]), rgb[k], True, digits)
            for k in range(len(centres))]
    out += [Band(hi, hi + s, ABOVE[0], False, digits),
            Band(hi + s, math.inf, ABOVE[1], False, digits)]
    return tuple(out)


def bands(tol: "Tolerance") -> list[Band]:
    """The bands from the most negative to the most positive deviation: two below the zone,
    12-16 inside it (:data:`ZONE_STEPS`), two above it."""
    return list(_bands(float(tol.lower), float(tol.upper)))


def band_label(b: Band) -> str:
    """The band's range as the legends print it, mm."""
    n = b.digits
    if math.isinf(b.upper):
        return f"> {b.lower:+.{n}f}"
    if math.isinf(b.lower):
        return f"< {b.upper:+.{n}f}"
    return f"{b.lower:+.{n}f} … {b.upper:+.{n}f}"


def band_index(d: np.ndarray, tol: "Tolerance") -> np.ndarray:
    """Index into :func:`bands` of each deviation (mm): a band holds [lower, upper), the zone
    its limits, the first band beyond a limit the next quarter zone (its far end included)."""
    d = np.asarray(d, dtype=float)
    lo, hi = float(tol.lower), float(tol.upper)
    s = (hi - lo) / 4.0
    edges = _zone_edges(lo, hi)
    inside = 2 + np.clip(np.searchsorted(edges, d, side="right") - 1, 0, len(edges) - 2)
    last = len(edges) + 1  # the first band above the zone
    return np.where(d < lo - s, 0, np.where(d < lo, 1, np.where(
        d > hi + s, last + 1, np.where(d > hi, last, inside))))


def band_rgb(d: np.ndarray, tol: "Tolerance") -> np.ndarray:
    """(n, 3) uint8 colours of deviations ``d``."""
    table = (np.array([b.rgb for b in bands(tol)]) * 255).round().astype(np.uint8)
    return table[band_index(d, tol)]


REGION_RGB = ((0.90, 0.62, 0.0), (0.34, 0.71, 0.91), (0.0, 0.62, 0.45), (0.80, 0.47, 0.65),
              (0.0, 0.45, 0.70), (0.84, 0.37, 0.0), (0.94, 0.89, 0.26), (0.35, 0.35, 0.40))
"""The regions' colours (Okabe and Ito's palette, told apart with colour-blindness), in the
order of the regions' names; repeated beyond eight regions."""
NO_REGION_RGB = (0.80, 0.80, 0.82)
"""Points in no region."""


def region_colours(regions: np.ndarray) -> tuple[list[tuple[str, tuple, int]], np.ndarray]:
    """The colours of the points' plan regions.

    regions : (n,) str, each point's regions ('a+b' for a point in two, '' for none:
    engine.gdt.characteristics.PlanResult.regions). Returns the legend, [(name, rgb in 0..1,
    number of points)] with the named regions in sorted order and "(no region)" last, and the
    (n, 3) uint8 colour of each point.
    """
    regions = np.asarray(regions, dtype=str)
    names, inverse, counts = np.unique(regions, return_inverse=True, return_counts=True)
    colour = {n: REGION_RGB[k % len(REGION_RGB)] for k, n in enumerate(n for n in names if n)}
    colour[""] = NO_REGION_RGB
    rgb = [colour[n] for n in names]
    table = (np.array(rgb, dtype=float).reshape(-1, 3) * 255).round().astype(np.uint8)
    legend = [(str(n) or "(no region)", c, int(k)) for n, c, k in zip(names, rgb, counts)]
    if names.size and names[0] == "":  # '' sorts first; listed last
        legend = legend[1:] + legend[:1]
    return legend, table[inverse.reshape(-1)]


def fmt_mm(v: float, signed: bool = True) -> str:
    return f"{v:+.3f}" if signed else f"{v:.3f}"


# ---------------------------------------------------------------------------- 3D maps
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


@dataclass(frozen=True)
class Zone:
    """Tolerance limits, mm (what the colour scale needs of an engine Tolerance)."""

    lower: float
    upper: float


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
    from . import mapviews

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
        pl.set_background("white")
        if surf is not None:
            pl.add_mesh(surf, color=(0.80, 0.81, 0.83), smooth_shading=True, specular=0.2,
                        ambient=0.25)
        else:
            pl.add_points(extent[:-len(shown)], color=(0.72, 0.73, 0.75), point_size=2)
        rgb = band_rgb(d, tol)
        actors = [(pl.add_points(shown[mask], scalars=rgb[mask], rgb=True,
                                 render_points_as_spheres=True), grow)
                  for mask, grow in ((~out, 1.0), (out, 1.4)) if mask.any()]  # rejects stand out
        pl.enable_parallel_projection()
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
    from . import mapviews

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
    return View(spec.name, tuple(float(v) for v in d), png, tuple(spec.up), anchors, avoid)


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
        from .mapviews import MESH_CELLS, display_mesh

        surf = display_mesh(nominal_points, normals)
        voxel = float(np.max(np.ptp(nominal_points, axis=0))) / MESH_CELLS
        return surf, max(lift, 0.3 * voxel)
    surf = pv.PolyData.from_regular_faces(nominal_points, triangles)
    if surf.n_cells > max_triangles:
        surf = _simplified(surf)
        lift = max(lift, 0.5 * diagonal / CLUSTER_DIVISIONS)
    return surf, lift


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


class RenderError(QAError, RuntimeError):
    """The 3D figures could not be rendered (the worker process died or its render failed)."""


class RenderProcess:
    """Runs :func:`render_3d` in a worker process (``python -m reports.figures``) started at
    once, so that importing pyvista/VTK and starting OpenGL (about 1 s) overlap the inspection on
    another core. Requests and replies are pickled over the worker's stdin/stdout."""

    def __init__(self):
        import subprocess
        import sys

        self._proc = subprocess.Popen([sys.executable, "-m", "reports.figures"],
                                      stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                      stderr=subprocess.DEVNULL, cwd=_project_root())
        self._pending = 0

    def submit(self, nominal_points, triangles, feet, normals, d, tol, worst, **kw):
        """Send a :func:`render_3d` request; the returned object's ``result()`` waits for the
        views. The request (megabytes for a big nominal) is written by a thread: the worker may
        still be warming up, and the caller works on meanwhile."""
        import pickle
        import threading

        request = (nominal_points, triangles, feet, normals, d,
                   Zone(float(tol.lower), float(tol.upper)), worst, kw)
        failure = []

        def send():
            try:
                pickle.dump(request, self._proc.stdin, protocol=pickle.HIGHEST_PROTOCOL)
                self._proc.stdin.flush()
            except OSError as e:
                failure.append(e)

        sender = threading.Thread(target=send, daemon=True)
        sender.start()
        self._pending += 1
        return _Reply(self, sender, failure)

    def close(self):
        if self._pending:
            # A request nobody will read (the caller failed meanwhile): the worker would block
            # writing its reply, so stop it now.
            self._proc.kill()
        try:
            self._proc.stdin.close()
            self._proc.wait(timeout=10)
        except Exception:  # closing must never mask the caller's own outcome
            self._proc.kill()
            self._proc.wait()
        finally:
            self._proc.stdout.close()


class _Reply:
    def __init__(self, owner, sender, failure):
        self._owner, self._sender, self._failure = owner, sender, failure

    def result(self) -> list[View]:
        import pickle

        proc = self._owner._proc
        self._sender.join()
        try:
            if self._failure:
                raise self._failure[0]
            ok, value = pickle.load(proc.stdout)
            self._owner._pending -= 1
        except (OSError, EOFError, pickle.UnpicklingError) as e:
            raise RenderError(f"the 3D rendering process failed "
                              f"(exit code {proc.poll()})") from e
        if not ok:
            raise RenderError(f"3D rendering failed: {value}")
        return value


class InProcessRenderer:
    """:class:`RenderProcess`'s interface, rendering in this process when asked."""

    def submit(self, *args, **kw):
        import concurrent.futures

        f = concurrent.futures.Future()
        f.set_result(render_3d(*args, **kw))
        return f

    def close(self):
        pass


def _project_root() -> str:
    return os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _serve() -> None:
    """The worker's loop: warm up, then answer requests until stdin closes."""
    import pickle
    import sys
    import traceback

    z = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    try:
        render_3d(z, np.array([[0, 1, 2]]), z, np.tile([0.0, 0.0, 1.0], (3, 1)), np.zeros(3),
                  Zone(-1.0, 1.0), [], size=(64, 48))
    except Exception:
        pass  # the real request will report the problem
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    while True:
        try:
            pts, tris, feet, normals, d, zone, worst, kw = pickle.load(inp)
        except EOFError:
            out.flush()
            os._exit(0)  # skip VTK's slow teardown; nothing is left to write
        try:
            reply = (True, render_3d(pts, tris, feet, normals, d, zone, worst, **kw))
        except Exception as e:
            reply = (False, f"{type(e).__name__}: {e}\n{traceback.format_exc(limit=3)}")
        pickle.dump(reply, out, protocol=pickle.HIGHEST_PROTOCOL)
        out.flush()


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


# ---------------------------------------------------------------------------- vector drawings
def nice_step(span: float, target: int = 6) -> float:
    """A 1-2-5 step that divides ``span`` into about ``target`` intervals."""
    raw = span / max(target, 1)
    mag = 10 ** math.floor(math.log10(raw))
    for m in (1, 2, 5, 10):
        if m * mag >= raw:
            return m * mag
    return 10 * mag


def histogram(d: np.ndarray, tol: "Tolerance", width: float, height: float):
    """Histogram of deviations (bars coloured by band) with the tolerance limits drawn."""
    from reportlab.graphics.shapes import Drawing, Line, Rect, String
    from reportlab.lib import colors

    lo, hi = tol.lower, tol.upper
    s = (hi - lo) / 4
    x0, x1 = min(float(d.min()), lo - s), max(float(d.max()), hi + s)
    nb = 48
    counts, edges = np.histogram(d, bins=nb, range=(x0, x1))
    ml, mb, mr, mt = 46, 34, 10, 22
    pw, ph = width - ml - mr, height - mb - mt
    ymax = max(int(counts.max()), 1)
    ystep = nice_step(ymax, 4)
    ytop = math.ceil(ymax / ystep) * ystep

    def X(v):
        return ml + (v - x0) / (x1 - x0) * pw

    def Y(c):
        return mb + c / ytop * ph

    g = Drawing(width, height)
    grey = colors.Color(0.55, 0.55, 0.55)
    for k in range(0, int(round(ytop / ystep)) + 1):
        y = Y(k * ystep)
        g.add(Line(ml, y, ml + pw, y, strokeColor=colors.Color(0.9, 0.9, 0.9), strokeWidth=0.5))
        g.add(String(ml - 4, y - 3, f"{int(k * ystep)}", fontName="Helvetica", fontSize=7,
                     textAnchor="end"))
    band_of = band_index(0.5 * (edges[:-1] + edges[1:]), tol)
    table = bands(tol)
    for k in range(nb):
        if counts[k]:
            c = colors.Color(*table[band_of[k]].rgb)
            # A single point must stay visible next to a bin of thousands.
            g.add(Rect(X(edges[k]), mb, X(edges[k + 1]) - X(edges[k]),
                       max(Y(counts[k]) - mb, 1.5),
                       fillColor=c, strokeColor=colors.white, strokeWidth=0.3))
    g.add(Line(ml, mb, ml + pw, mb, strokeColor=grey, strokeWidth=0.8))
    step = nice_step(x1 - x0, 7)
    v = math.ceil(x0 / step) * step
    while v <= x1 + 1e-12:
        g.add(Line(X(v), mb, X(v), mb - 3, strokeColor=grey, strokeWidth=0.8))
        g.add(String(X(v), mb - 12, f"{v:+.3g}" if abs(v) > 1e-12 else "0",
                     fontName="Helvetica", fontSize=7, textAnchor="middle"))
        v += step
    for val, name in ((lo, "LTL"), (hi, "UTL")):
        g.add(Line(X(val), mb, X(val), mb + ph + 4, strokeColor=colors.black, strokeWidth=1.1,
                   strokeDashArray=[3, 2]))
        g.add(String(X(val), mb + ph + 8, f"{name} {val:+.3f}", fontName="Helvetica-Bold",
                     fontSize=7.5, textAnchor="middle"))
    g.add(String(ml + pw / 2, 3, "deviation (mm)", fontName="Helvetica", fontSize=8,
                 textAnchor="middle"))
    g.add(String(4, height - 10, "points", fontName="Helvetica", fontSize=8))
    return g


def legend(tol: "Tolerance", d: np.ndarray, width: float, height: float):
    """The colour scale as a vertical stack of bands, with limits and point counts."""
    from reportlab.graphics.shapes import Drawing, Line, Rect, String
    from reportlab.lib import colors

    table = bands(tol)
    counts = np.bincount(band_index(d, tol), minlength=len(table))
    g = Drawing(width, height)
    top, bottom = height - 14, 6
    h = (top - bottom) / len(table)
    g.add(String(0, height - 8, "Deviation (mm)", fontName="Helvetica-Bold", fontSize=8))
    for k, b in enumerate(reversed(table)):
        kk = len(table) - 1 - k
        y = top - (k + 1) * h
        g.add(Rect(0, y, 16, h, fillColor=colors.Color(*b.rgb), strokeColor=colors.white,
                   strokeWidth=0.5))
        g.add(String(21, y + h / 2 - 3, band_label(b), fontName="Helvetica", fontSize=7))
        g.add(String(width - 2, y + h / 2 - 3, f"{int(counts[kk])}", fontName="Helvetica",
                     fontSize=7, textAnchor="end"))
    # Bracket the in-tolerance bands.
    inside = [k for k, b in enumerate(table) if b.in_tolerance]
    y_hi = top - (len(table) - 1 - inside[-1]) * h
    y_lo = top - (len(table) - inside[0]) * h
    for y in (y_hi, y_lo):
        g.add(Line(0, y, width, y, strokeColor=colors.black, strokeWidth=1.0))
    g.add(String(width - 2, top + 1, "points", fontName="Helvetica", fontSize=6.5,
                 textAnchor="end"))
    return g


# ---------------------------------------------------------------------------- map furniture
def colour_bar(tol: "Tolerance", width: float, height: float, title: str = "mm"):
    """The colour scale as a vertical bar to stand beside a map: the zone's steps to scale,
    the two colours beyond each limit as blocks above and below, the limits and 0 labelled."""
    from reportlab.graphics.shapes import Drawing, Line, Rect, String
    from reportlab.lib import colors

    table = bands(tol)
    inside = [b for b in table if b.in_tolerance]
    g = Drawing(width, height)
    g.add(String(0, height - 8, title, fontName="Helvetica-Bold", fontSize=7.5))
    bw, top, bottom = 11.0, height - 16, 4.0
    block = 0.07 * (top - bottom)
    z0, z1 = bottom + 2 * block, top - 2 * block  # the zone, to scale

    def Y(v):
        return z0 + (v - tol.lower) / (tol.upper - tol.lower) * (z1 - z0)

    spans = [(bottom, bottom + block), (bottom + block, z0)]
    spans += [(Y(b.lower), Y(b.upper)) for b in inside]
    spans += [(z1, z1 + block), (z1 + block, top)]
    for b, (y0, y1) in zip(table, spans):
        g.add(Rect(0, y0, bw, y1 - y0, fillColor=colors.Color(*b.rgb), strokeColor=None))
    g.add(Rect(0, bottom, bw, top - bottom, fillColor=None, strokeColor=colors.black,
               strokeWidth=0.4))
    s = (tol.upper - tol.lower) / 4
    n = inside[0].digits
    ticks = [(z0, tol.lower, "LTL ", True), (z1, tol.upper, "UTL ", True),
             (bottom + block, tol.lower - s, "", False), (z1 + block, tol.upper + s, "", False)]
    if tol.lower < 0 < tol.upper and min(Y(0) - z0, z1 - Y(0)) > 9:
        ticks.append((Y(0.0), 0.0, "", True))
    for y, v, name, strong in ticks:
        g.add(Line(0 if strong else bw - 3, y, bw + 3, y, strokeColor=colors.black,
                   strokeWidth=0.9 if strong else 0.4))
        text = "0" if v == 0 else f"{name}{v:+.{n}f}"
        g.add(String(bw + 5, y - 2.5, text, fontName="Helvetica-Bold" if strong else "Helvetica",
                     fontSize=6.5))
    return g


TRIAD_RGB = ((0.80, 0.10, 0.10), (0.10, 0.55, 0.10), (0.10, 0.25, 0.85))
"""X, Y, Z arrows of the axis triad."""


def _triad(g, view: View, x: float, y: float, length: float) -> None:
    """The nominal's axes as seen in ``view``, drawn from (x, y)."""
    from reportlab.graphics.shapes import Circle, Line, String
    from reportlab.lib import colors

    from .mapviews import ViewSpec, camera_basis

    _, right, up = camera_basis(ViewSpec(view.name, view.direction, view.up))
    for k, name in enumerate("XYZ"):
        u, v = right[k], up[k]
        c = colors.Color(*TRIAD_RGB[k])
        if math.hypot(u, v) < 0.2:  # along the line of sight: a dot, the label beside it
            g.add(Circle(x, y, 1.6, fillColor=c, strokeColor=None))
            g.add(String(x + 3 + 6 * k, y - 9, name, fontName="Helvetica-Bold", fontSize=6.5,
                         fillColor=c))
            continue
        g.add(Line(x, y, x + length * u, y + length * v, strokeColor=c, strokeWidth=1.2))
        g.add(String(x + (length + 4) * u - 2, y + (length + 4) * v - 2.5, name,
                     fontName="Helvetica-Bold", fontSize=6.5, fillColor=c))


def map_overlay(view: View, labels: dict[int, str], width: float, height: float):
    """What the certificate draws over a rendered view of ``width`` x ``height`` points: its
    name, the axis triad and the callouts (label boxes with leader lines placed by
    reports.callouts.place_labels, never overlapping). labels : point index -> text (lines
    split by newlines)."""
    from reportlab.graphics.shapes import Drawing, String
    from reportlab.pdfbase.pdfmetrics import stringWidth

    g = Drawing(width, height)
    g.add(String(4, height - 10, view.name, fontName="Helvetica-Bold", fontSize=8))
    _triad(g, view, 16, 16, 11)
    kx, ky = width / RENDER_SIZE[0], height / RENDER_SIZE[1]
    title = (0, height - 14, 4 + stringWidth(view.name, "Helvetica-Bold", 8) + 4, height)
    _callouts(g, [(i, x * kx, height - y * ky) for i, x, y in view.anchors], labels,
              np.array([(x * kx, height - y * ky) for x, y in view.avoid]).reshape(-1, 2),
              blocked=(title, (0, 0, 34, 34)))
    return g


def _callouts(g, anchors, labels: dict[int, str], avoid: np.ndarray, blocked) -> None:
    """Flags on drawing ``g``: for each (point index, x, y) of ``anchors`` with a label, a box
    with its text and a leader line to the point, placed by reports.callouts.place_labels."""
    from reportlab.graphics.shapes import Circle, Line, Rect, String
    from reportlab.lib import colors
    from reportlab.pdfbase.pdfmetrics import stringWidth

    from .callouts import leader_end, place_labels

    shown = [(i, x, y) for i, x, y in anchors if i in labels]
    texts = [labels[i].split("\n") for i, _, _ in shown]
    sizes = [(max(stringWidth(t, "Helvetica", 6.5) for t in lines) + 5, 8 * len(lines) + 2)
             for lines in texts]
    places = place_labels(np.array([(x, y) for _, x, y in shown]).reshape(-1, 2), sizes,
                          g.width, g.height, avoid, blocked=blocked)
    for (i, x, y), lines, (w, h), at in zip(shown, texts, sizes, places):
        if at is None:
            continue
        ex, ey = leader_end((x, y), (at[0], at[1], at[0] + w, at[1] + h))
        g.add(Line(x, y, ex, ey, strokeColor=colors.black, strokeWidth=0.6))
        g.add(Circle(x, y, 1.3, fillColor=colors.black, strokeColor=None))
        g.add(Rect(*at, w, h, fillColor=colors.Color(1, 1, 1, alpha=0.9),
                   strokeColor=colors.black, strokeWidth=0.5))
        for k, t in enumerate(lines):
            g.add(String(at[0] + 2.5, at[1] + h - 8 * (k + 1), t, fontName="Helvetica",
                         fontSize=6.5))


def map_flowable(view: View, labels: dict[int, str], width: float, height: float):
    """A platypus flowable: the view's picture with :func:`map_overlay` drawn over it."""
    from reportlab.graphics import renderPDF
    from reportlab.lib.utils import ImageReader
    from reportlab.platypus import Flowable

    overlay = map_overlay(view, labels, width, height)

    class MapView(Flowable):
        def wrap(self, aw, ah):
            return width, height

        def draw(self):
            self.canv.drawImage(ImageReader(io.BytesIO(view.png)), 0, 0, width, height)
            renderPDF.draw(overlay, self.canv, 0, 0)

    return MapView()


def primitive_points(template, i: int, step_deg: float = 3.0, min_points: int = 4
                     ) -> np.ndarray:
    """(k, 2) points along primitive ``i`` of a 2D template, in drawing order: a segment's two
    ends, an arc in steps of at most ``step_deg`` degrees (at least ``min_points`` points)."""
    from engine.contour import SEGMENT

    if template.kind[i] == SEGMENT:
        return np.array([template.start[i], template.end[i]])
    n = max(min_points, math.ceil(abs(template.sweep[i]) / math.radians(step_deg)) + 1)
    a = template.angle0[i] + np.linspace(0, template.sweep[i], n)
    return template.centre[i] + template.radius[i] * np.column_stack([np.cos(a), np.sin(a)])


def template_polylines(template) -> list[np.ndarray]:
    """Each contour of a 2D template as one (k, 2) polyline (arcs in steps of at most 3°)."""
    polylines = []
    for c in range(template.closed.size):
        pts = []
        for i in np.flatnonzero(template.contour == c):
            seg = primitive_points(template, i)
            pts.append(seg if not pts else seg[1:])
        polylines.append(np.vstack(pts))
    return polylines


def whisker_factor(extent: float, max_d: float, share: float = 0.06) -> float:
    """The 1-2-5 magnification that draws the largest deviation as about ``share`` of the
    part's extent (1 when there is nothing to magnify)."""
    if not max_d > 0:
        return 1.0
    raw = share * extent / max_d
    factor = 10 ** math.floor(math.log10(raw))
    for m in (5, 2, 1):
        if m * factor <= raw:
            return m * factor
    return factor


def contour_map(template, feet: np.ndarray, normals: np.ndarray, d: np.ndarray,
                tol: "Tolerance", worst: list[tuple[int, str]], width: float, height: float):
    """The 2D template with each point's deviation as a whisker from its foot along the
    contour normal, magnified by a stated 1-2-5 factor. Returns (drawing, factor)."""
    from reportlab.graphics.shapes import Circle, Drawing, Line, PolyLine, String
    from reportlab.lib import colors

    polylines = template_polylines(template)
    allp = np.vstack(polylines + [feet[:, :2]])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    extent = float(max(hi - lo))
    max_d = float(np.abs(d).max()) if d.size else 0.0
    factor = whisker_factor(extent, max_d)
    pad = 0.08 * extent + factor * max_d
    lo, hi = lo - pad, hi + pad
    k = min((width - 4) / (hi[0] - lo[0]), (height - 16) / (hi[1] - lo[1]))
    height = k * (hi[1] - lo[1]) + 16  # no empty band above and below a wide part
    ox = (width - k * (hi[0] - lo[0])) / 2
    oy = 14

    def P(xy):
        return ox + k * (xy[..., 0] - lo[0]), oy + k * (xy[..., 1] - lo[1])

    g = Drawing(width, height)
    for pl in polylines:
        x, y = P(pl)
        g.add(PolyLine(list(np.column_stack([x, y]).ravel()), strokeColor=colors.Color(
            0.25, 0.25, 0.28), strokeWidth=0.9))
    tips = feet[:, :2] + factor * d[:, None] * normals[:, :2]
    rgb = band_rgb(d, tol) / 255.0
    fx, fy = P(feet[:, :2])
    tx, ty = P(tips)
    for i in range(d.size):
        c = colors.Color(*rgb[i])
        g.add(Line(fx[i], fy[i], tx[i], ty[i], strokeColor=c, strokeWidth=0.8))
        g.add(Circle(tx[i], ty[i], 1.1, fillColor=c, strokeColor=None))
    _callouts(g, [(i, tx[i], ty[i]) for i, _ in worst], dict(worst),
              np.column_stack([tx, ty])[(d < tol.lower) | (d > tol.upper)],
              blocked=((0, 0, width, 12),))
    g.add(String(2, 2, f"Whiskers: deviation × {factor:g} along the contour normal "
                       "(outward = excess material)", fontName="Helvetica-Oblique",
                 fontSize=7.5))
    return g, factor


if __name__ == "__main__":
    # Serve from the imported module, so replies pickle as reports.figures.View.
    from reports.figures import _serve as serve

    serve()
