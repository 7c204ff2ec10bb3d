"""Sections 7 and 8 of the certificate: the deviation map (the 3D views or the 2D
contour, with the colour bar) and the colour scale with the histogram of deviations."""

from __future__ import annotations

from .. import figures
from .layout import GRID_RGB, Layout
from .points import worst_labels


def deviation_map(c: Layout) -> list:
    """7  Deviation map: the 2D contour map drawn here, or the two 3D renders (on the
    registration's page when they fit there, with section 8)."""
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether, Table
    from reportlab.platypus import Paragraph as P

    S, W, res, run, views = c.styles, c.width, c.res, c.run, c.views
    # The heading, the map and its caption together, on this page when they fit (a page
    # break before a fixed height would leave the page above half empty).
    out = [P("7  Deviation map", S["h"])]
    if run.template is not None:  # 2D
        bar_w = 24 * mm
        drawing, factor = figures.contour_map(run.template.template, res.deviations.foot,
                                              res.deviations.normal, res.deviations.signed,
                                              res.tolerance, worst_labels(run),
                                              W - bar_w, 128 * mm)
        bar = figures.colour_bar(res.tolerance, bar_w - 2 * mm,
                                 min(drawing.height, 95 * mm), "Deviation (mm)")
        out.append(Table([[drawing, bar]], colWidths=[W - bar_w, bar_w],
                         style=[("VALIGN", (0, 0), (-1, -1), "MIDDLE"),
                                ("LEFTPADDING", (0, 0), (-1, -1), 0),
                                ("RIGHTPADDING", (0, 0), (-1, -1), 0)]))
        out.append(P(f"Template (dark lines) and every measured point at its foot on the "
                     f"contour, with its deviation drawn as a whisker magnified {factor:g} "
                     "times, coloured on the scale at the right; " + _FLAGS_WORDS, S["small"]))
        return [KeepTogether(out)]
    out.append(_map_grid(c, views, W))
    out.append(P(_views_caption(views) + " Parallel projection, nominal frame; every measured "
                 "point drawn at its foot on the nominal surface (shaded), coloured by "
                 "deviation on the scale at the right; " + _FLAGS_WORDS +
                 ("" if c.plan is None else " The part at the plan's alignment "
                  "(section 6), coloured against the zone of the statistics "
                  "(section 3)."), S["small"]))
    return [KeepTogether(out)]


_FLAGS_WORDS = ("flags on the worst point of each separate cluster of out-of-tolerance points "
                "(of the largest deviations when every point is in tolerance).")


def _views_caption(views) -> str:
    names = [v.name for v in views]
    where = (["Left", "right"] if len(views) == 2 else
             ["Top left", "top right", "bottom left", "bottom right"][:len(views)])
    if len(views) == 1:
        return f"{names[0]}."
    return "; ".join(f"{w}: {n}" for w, n in zip(where, names)) + "."


def _map_grid(c: Layout, views, W: float):
    """The views two to a row with the colour bar beside them."""
    from reportlab.lib import colors
    from reportlab.lib.units import mm
    from reportlab.platypus import Table

    bar_w = 24 * mm
    iw = (W - bar_w - 2 * mm) / 2
    ih = iw * figures.RENDER_SIZE[1] / figures.RENDER_SIZE[0]
    labels = dict(worst_labels(c.run))
    cells = [figures.map_flowable(v, labels, iw, ih) for v in views]
    rows = [cells[k:k + 2] + [""] * (k + 2 - len(cells)) for k in range(0, len(cells), 2)]
    bar = figures.colour_bar(c.res.tolerance, bar_w - 2 * mm, min(len(rows) * ih, 95 * mm),
                             "Deviation (mm)")
    grid = Table([r + [bar if k == 0 else ""] for k, r in enumerate(rows)],
                 colWidths=[iw, iw, bar_w + 2 * mm], rowHeights=[ih] * len(rows),
                 style=[("GRID", (0, 0), (1, -1), 0.4, colors.Color(*GRID_RGB)),
                        ("SPAN", (2, 0), (2, -1)), ("VALIGN", (2, 0), (2, -1), "MIDDLE"),
                        ("LEFTPADDING", (0, 0), (-1, -1), 0),
                        ("RIGHTPADDING", (0, 0), (-1, -1), 0),
                        ("TOPPADDING", (0, 0), (-1, -1), 0),
                        ("BOTTOMPADDING", (0, 0), (-1, -1), 0),
                        ("LEFTPADDING", (2, 0), (2, -1), 3 * mm)])
    return grid


def histogram(c: Layout) -> list:
    """8  Colour scale and histogram of deviations."""
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether, Table
    from reportlab.platypus import Paragraph as P

    W, tol, d = c.width, c.res.tolerance, c.res.deviations.signed
    legend = figures.legend(tol, d, 50 * mm, 62 * mm)
    hist = figures.histogram(d, tol, W - 56 * mm, 62 * mm)
    return [KeepTogether([P("8  Colour scale and histogram of deviations", c.styles["h"]),
            Table([[legend, hist]], colWidths=[54 * mm, W - 54 * mm],
                  style=[("VALIGN", (0, 0), (-1, -1), "TOP"),
                         ("LEFTPADDING", (0, 0), (-1, -1), 0)]),
            P("Green bands: inside the tolerance zone; blue: below the lower limit "
              "(missing material); red: above the upper limit (excess material). Dashed "
              "lines: the tolerance limits (LTL, UTL).", c.styles["small"])])]
