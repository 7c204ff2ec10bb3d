"""The drawing symbols of the characteristics (ASME Y14.5 / ISO 1101; their characters:
engine.gdt.plan.SYMBOLS) as strokes, for the certificate (reportlab) and the app (Qt) to draw
alike: the fonts at hand lack most of the glyphs (⌖, ⌭, ⌯, ⌰).

A symbol is drawn in a 12 x 12 box, y up, as a list of strokes:

* ``("line", (x0, y0, x1, y1, ...), closed)``: a polyline, closed or not;
* ``("circle", cx, cy, r)``: a circle, not filled;
* ``("fill", (x0, y0, ...))``: a filled polygon (an arrow's head);
* ``("text", x, y, text, size)``: a letter (a sphere's S), its baseline at y.
"""

from __future__ import annotations

import math

BOX = 12.0
"""The symbols' box: 0 .. BOX in x and y."""


def _arc(cx: float, cy: float, r: float, a0: float, a1: float, step: float = 15.0):
    """Points of an arc (degrees, counter-clockwise), flattened."""
    n = max(1, int(round(abs(a1 - a0) / step)))
    return tuple(v for k in range(n + 1)
                 for v in (cx + r * math.cos(math.radians(a0 + (a1 - a0) * k / n)),
                           cy + r * math.sin(math.radians(a0 + (a1 - a0) * k / n))))


def _arrow(x0: float, y0: float, x1: float, y1: float) -> list:
    """A line with a filled head at (x1, y1)."""
    ux, uy = x1 - x0, y1 - y0
    n = math.hypot(ux, uy)
    ux, uy = ux / n, uy / n
    head = (x1, y1, x1 - 3 * ux - 1.4 * uy, y1 - 3 * uy + 1.4 * ux,
            x1 - 3 * ux + 1.4 * uy, y1 - 3 * uy - 1.4 * ux)
    return [("line", (x0, y0, x1, y1), False), ("fill", head)]


def symbol_strokes(kind: str, feature: str | None = None) -> list:
    """The strokes of characteristic type ``kind``'s symbol (module docstring). A size's
    ``feature``: a cylinder's ⌀ (None), a sphere's S⌀, a width's none (a drawing gives a width
    no sign). Raises ValueError for a type with no symbol."""
    if kind == "profile":  # a half circle on its diameter
        return [("line", _arc(6, 3, 5, 0, 180), True)]
    if kind == "line_profile":  # a half circle, open
        return [("line", _arc(6, 3, 5, 0, 180), False)]
    if kind == "flatness":  # a parallelogram
        return [("line", (1, 3, 8, 3, 11, 9, 4, 9), True)]
    if kind == "straightness":  # a line
        return [("line", (1, 6, 11, 6), False)]
    if kind == "circularity":  # a circle
        return [("circle", 6, 6, 4)]
    if kind == "cylindricity":  # a circle between two parallel slanted lines
        return [("circle", 6, 6, 3.2), ("line", (0.5, 1, 5.2, 11), False),
                ("line", (6.8, 1, 11.5, 11), False)]
    if kind == "position":  # a circle and its cross
        return [("circle", 6, 6, 3.6), ("line", (0.5, 6, 11.5, 6), False),
                ("line", (6, 0.5, 6, 11.5), False)]
    if kind in ("coaxiality", "concentricity"):  # two concentric circles
        return [("circle", 6, 6, 4.6), ("circle", 6, 6, 2.2)]
    if kind == "symmetry":  # three lines, the middle one longer
        return [("line", (3, 3, 9, 3), False), ("line", (1, 6, 11, 6), False),
                ("line", (3, 9, 9, 9), False)]
    if kind == "parallelism":  # two parallel slanted lines
        return [("line", (1.5, 1, 6, 11), False), ("line", (6, 1, 10.5, 11), False)]
    if kind == "perpendicularity":  # an upright on its base
        return [("line", (1, 1.5, 11, 1.5), False), ("line", (6, 1.5, 6, 11), False)]
    if kind == "angularity":  # an angle of 30 degrees on its base
        return [("line", (11, 1.5, 1, 1.5, 10, 1.5 + 9 * math.tan(math.radians(30))), False)]
    if kind == "circular_runout":  # one slanted arrow
        return _arrow(2, 1.5, 9.5, 10.5)
    if kind == "total_runout":  # two slanted arrows on a base
        return [("line", (0.5, 1.5, 11.5, 1.5), False), *_arrow(1, 1.5, 5.5, 10.5),
                *_arrow(6, 1.5, 10.5, 10.5)]
    if kind == "size" and feature == "width":
        return []
    if kind == "size" and feature == "sphere":  # S and the diameter sign
        return [("text", 0, 3, "S", 7), ("circle", 8, 6, 3.2),
                ("line", (4.5, 2.5, 11.5, 9.5), False)]
    if kind == "size":  # the diameter sign
        return [("circle", 6, 6, 4), ("line", (1.5, 1.5, 10.5, 10.5), False)]
    if kind == "radius":  # R, a sphere's SR (as a drawing writes them before the value)
        return [("text", 0.5, 3, "SR", 7)] if feature == "sphere" else [("text", 3, 3, "R", 8)]
    if kind == "angle":  # an angle with its arc (an angular dimension)
        return [("line", (11, 1.5, 1, 1.5, 7, 11.5), False),
                ("line", _arc(1, 1.5, 7, 0, 58), False)]
    if kind == "distance":  # a two-headed arrow between two lines (a linear dimension)
        return [("line", (0.5, 1, 0.5, 11), False), ("line", (11.5, 1, 11.5, 11), False),
                *_arrow(6, 6, 11.2, 6), *_arrow(6, 6, 0.8, 6)]
    raise ValueError(f"no symbol is drawn for a {kind} characteristic")
