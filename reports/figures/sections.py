"""A planar section as a vector drawing (reportlab), in the manner of :func:`.drawings.contour_map`:
the nominal's section curve, the measured points' feet on it, each deviation as a whisker
magnified by a stated 1-2-5 factor along the nominal's normal in the plane, the tolerance
envelope (the zone's limits offset along the curve's normals, magnified the same), the plane's
coordinates along the frame, and a legend with the magnification and a scale bar.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .colours import band_rgb
from .drawings import nice_step, whisker_factor

if TYPE_CHECKING:
    from engine.section import Section

CURVE_RGB = (0.18, 0.18, 0.22)
ENVELOPE_RGB = (0.35, 0.35, 0.40)
AXIS_NAMES = {"x": ("y", "z"), "y": ("x", "z"), "z": ("x", "y")}
"""The plane's 2D axes, named by the nominal's axes they are (engine.section.axis_plane)."""


WHISKER_SHARE = 0.03
"""The magnification (a 1-2-5 factor) draws the tolerance zone's farther limit as about this
share of the section's extent: the envelope stays clear of a part's smaller features ..."""
WHISKER_MAX_SHARE = 0.15
"""... and the largest deviation as at most this share."""
MITRE_LIMIT = 0.2
"""An envelope's corner is mitred (its offset lines meet) where 1 + cos(turn) exceeds this (a
turn under about 143 degrees); a sharper one is bevelled."""


def _closed(p: np.ndarray, closed: bool) -> np.ndarray:
    return np.vstack([p, p[:1]]) if closed else p


def offset_polyline(p: np.ndarray, normals: np.ndarray, closed: bool, delta: float
                    ) -> np.ndarray:
    """The polyline ``p`` (k, 2) offset by ``delta`` along its outward side (given by its vertex
    normals (k, 2)): each chord moved square to itself by delta, consecutive chords' offsets
    meeting at their mitre (a straight edge's offset is parallel to it at delta, not short of
    it at a corner), bevelled at a turn sharper than ``MITRE_LIMIT`` allows."""
    q = _closed(p, closed)
    t = np.diff(q, axis=0)
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    c = np.column_stack([t[:, 1], -t[:, 0]])  # square to each chord
    side = normals + np.roll(normals, -1, axis=0) if closed else normals[:-1] + normals[1:]
    c[np.einsum("ij,ij->i", c, side) < 0] *= -1
    before = np.roll(c, 1, axis=0) if closed else np.vstack([c[:1], c])
    after = c if closed else np.vstack([c, c[-1:]])
    out = []
    for x, a, b in zip(p, before, after):
        s = 1.0 + float(a @ b)
        if s > MITRE_LIMIT:
            out.append(x + delta * (a + b) / s)
        else:
            out += [x + delta * a, x + delta * b]
    return np.array(out)


def section_map(section: "Section", width: float, height: float):
    """The drawing of ``section`` within ``width`` x ``height`` points (the height shrinks to
    the section's aspect). Returns (drawing, factor): the whiskers' and envelope's
    magnification."""
    from reportlab.graphics.shapes import Circle, Drawing, Line, PolyLine, String
    from reportlab.lib import colors

    plane, tol, d = section.plane, section.tolerance, section.signed
    curves = [plane.to_2d(p) for p in section.curve.polylines]
    allp = np.vstack(curves + [section.foot.reshape(-1, 2)])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    extent = float(max(hi - lo)) or 1.0
    zone = max(abs(tol.lower), abs(tol.upper))
    worst = float(np.abs(d).max()) if d.size else 0.0
    factor = min(whisker_factor(extent, zone, WHISKER_SHARE),
                 whisker_factor(extent, worst, WHISKER_MAX_SHARE))
    reach = max(zone, worst)
    pad = 0.04 * extent + factor * reach
    lo, hi = lo - pad, hi + pad
    ml, mb, top, legend_h = 30.0, 16.0, 4.0, 40.0  # frame margins, legend band below
    k = min((width - ml - 4) / (hi[0] - lo[0]), (height - mb - top - legend_h) / (hi[1] - lo[1]))
    plot_w, plot_h = k * (hi[0] - lo[0]), k * (hi[1] - lo[1])
    height = plot_h + mb + top + legend_h
    ox, oy = ml + (width - ml - 4 - plot_w) / 2, legend_h + mb

    def P(xy):
        return ox + k * (xy[..., 0] - lo[0]), oy + k * (xy[..., 1] - lo[1])

    g = Drawing(width, height)
    _frame(g, lo, hi, P, k, plane)
    dash = colors.Color(*ENVELOPE_RGB)
    for c, n, closed in zip(curves, section.curve.normals, section.curve.closed):
        for limit in (tol.lower, tol.upper):
            x, y = P(_closed(offset_polyline(c, n, closed, factor * limit), closed))
            g.add(PolyLine(list(np.column_stack([x, y]).ravel()), strokeColor=dash,
                           strokeWidth=0.5, strokeDashArray=[2.5, 1.8]))
        x, y = P(_closed(c, closed))
        g.add(PolyLine(list(np.column_stack([x, y]).ravel()),
                       strokeColor=colors.Color(*CURVE_RGB), strokeWidth=1.0))
    tips = section.foot + factor * d[:, None] * section.direction
    rgb = band_rgb(d, tol) / 255.0
    fx, fy = P(section.foot)
    tx, ty = P(tips)
    for i in range(d.size):
        c = colors.Color(*rgb[i])
        g.add(Line(fx[i], fy[i], tx[i], ty[i], strokeColor=c, strokeWidth=0.8))
        g.add(Circle(fx[i], fy[i], 0.7, fillColor=colors.black, strokeColor=None))
        g.add(Circle(tx[i], ty[i], 1.1, fillColor=c, strokeColor=None))
    for i, word in _extremes(d):  # labelled beside the tip, on the side with room
        right = tx[i] < ox + 0.8 * plot_w
        g.add(String(tx[i] + (2.5 if right else -2.5), ty[i] + 2.5, f"{word} {d[i]:+.3f}",
                     fontName="Helvetica-Bold", fontSize=6.5,
                     textAnchor="start" if right else "end"))
    _legend(g, section, factor, k, width, legend_h)
    return g, factor


def _extremes(d: np.ndarray) -> list[tuple[int, str]]:
    """The points of the largest and the smallest deviation (one when they are the same)."""
    if not d.size:
        return []
    hi, lo = int(np.argmax(d)), int(np.argmin(d))
    return [(hi, "max")] + ([(lo, "min")] if lo != hi else [])


def _frame(g, lo, hi, P, k: float, plane) -> None:
    """A thin frame round the plot with the plane's coordinates (mm) ticked along its bottom
    and left edges, and the axes named."""
    from reportlab.graphics.shapes import Line, Rect, String
    from reportlab.lib import colors

    grey = colors.Color(0.55, 0.55, 0.58)
    x0, y0 = P(np.asarray(lo))
    x1, y1 = P(np.asarray(hi))
    g.add(Rect(x0, y0, x1 - x0, y1 - y0, fillColor=None, strokeColor=grey, strokeWidth=0.4))
    names = AXIS_NAMES.get(plane.axis or "", ("u", "v"))
    for axis in (0, 1):
        step = nice_step(float(hi[axis] - lo[axis]), 6)
        v = np.ceil(lo[axis] / step) * step
        while v <= hi[axis] + 1e-9:
            q = np.array(lo, dtype=float)
            q[axis] = v
            x, y = P(q)
            text = f"{v:g}"
            if axis == 0:
                g.add(Line(x, y0, x, y0 - 3, strokeColor=grey, strokeWidth=0.5))
                g.add(String(x, y0 - 10, text, fontName="Helvetica", fontSize=6.5,
                             textAnchor="middle"))
            else:
                g.add(Line(x0 - 3, y, x0, y, strokeColor=grey, strokeWidth=0.5))
                g.add(String(x0 - 4, y - 2.3, text, fontName="Helvetica", fontSize=6.5,
                             textAnchor="end"))
            v += step
    g.add(String(x1, y0 - 19, f"{names[0]} (mm)", fontName="Helvetica-Bold", fontSize=6.5,
                 textAnchor="end"))
    g.add(String(x0 + 3, y1 - 9, f"{names[1]} (mm)", fontName="Helvetica-Bold", fontSize=6.5))


def _legend(g, section: "Section", factor: float, k: float, width: float, h: float) -> None:
    """The legend under the plot: the curve, the feet, the whiskers and the envelope, with the
    magnification; a scale bar of the drawing and one of the magnified deviations."""
    from reportlab.graphics.shapes import Circle, Line, String
    from reportlab.lib import colors

    tol = section.tolerance
    y = h - 12
    dark, grey = colors.Color(*CURVE_RGB), colors.Color(*ENVELOPE_RGB)
    g.add(Line(4, y + 2.5, 22, y + 2.5, strokeColor=dark, strokeWidth=1.0))
    g.add(String(26, y, f"nominal section curve ({section.curve.source}"
                        + (f", chords within {section.curve.chord_mm * 1000:g} µm)"
                           if section.curve.chord_mm else ", exact cut of its triangles)"),
                 fontName="Helvetica", fontSize=7))
    g.add(Line(4, y - 9.5, 22, y - 9.5, strokeColor=grey, strokeWidth=0.5,
               strokeDashArray=[2.5, 1.8]))
    g.add(String(26, y - 12, f"tolerance envelope: limits {tol.lower:+.3f} / {tol.upper:+.3f} "
                             f"mm × {factor:g} along the curve's normal", fontName="Helvetica",
                 fontSize=7))
    g.add(Circle(13, y - 21.5, 0.8, fillColor=colors.black, strokeColor=None))
    g.add(Line(13, y - 21.5, 21, y - 21.5, strokeColor=colors.Color(0.22, 0.68, 0.24),
               strokeWidth=0.8))
    g.add(String(26, y - 24, f"whiskers: deviation × {factor:g} from each foot along the "
                             "nominal's outward normal in the plane (outward = excess material)",
                 fontName="Helvetica-Oblique", fontSize=7))
    # Scale bars, right: the drawing's and the magnified deviations'.
    x1 = width - 6
    length = nice_step(0.18 * (width - 200) / k, 1)
    dev = nice_step(max(abs(tol.lower), abs(tol.upper)), 1)
    for row, (mm_len, text) in enumerate(((length, f"{length:g} mm"),
                                          (dev, f"{dev:g} mm deviation (× {factor:g})"))):
        bar = k * mm_len * (1.0 if row == 0 else factor)
        yy = y - 12 * row
        g.add(Line(x1 - bar, yy + 2.5, x1, yy + 2.5, strokeColor=colors.black, strokeWidth=1.2))
        for xx in (x1 - bar, x1):
            g.add(Line(xx, yy, xx, yy + 5, strokeColor=colors.black, strokeWidth=0.8))
        g.add(String(x1 - bar - 4, yy, text, fontName="Helvetica", fontSize=7,
                     textAnchor="end"))
