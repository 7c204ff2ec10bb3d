"""The certificate's vector drawings (reportlab): the histogram of deviations, the colour
scale as a legend and as a bar beside a map, a rendered view with its name, axis triad and
callouts drawn over it, and the 2D contour with magnified deviation whiskers.
"""

from __future__ import annotations

import io
import math
from typing import TYPE_CHECKING

import numpy as np

from .colours import band_index, band_label, band_rgb, bands
from .render import RENDER_SIZE, View

if TYPE_CHECKING:
    from engine.inspection import Tolerance


def fmt_mm(v: float, signed: bool = True) -> str:
    return f"{v:+.3f}" if signed else f"{v:.3f}"


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

    from ..mapviews import ViewSpec, camera_basis

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

    from ..callouts import leader_end, place_labels

    shown = [(i, x, y) for i, x, y in anchors if i in labels]
    texts = [labels[i].split("\n") for i, _, _ in shown]
    sizes = [(max(stringWidth(t, "Helvetica", 6.5) for t in lines) + 5, 8 * len(lines) + 2)
             for lines in texts]
    places = place_labels(np.array([(x, y) for _, x, y in shown]).reshape(-1, 2),
                          np.array(sizes, dtype=float).reshape(-1, 2),
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
        pts: list[np.ndarray] = []
        for i in np.flatnonzero(template.contour == c):
            seg = primitive_points(template, int(i))
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
