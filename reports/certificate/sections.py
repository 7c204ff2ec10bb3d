"""The certificate's section pages (``qa-inspect inspect --section z=120``): one page per planar
section, titled "Section A-A, z = 120 mm", with its drawing (reports.figures.sections), the
colour bar, and its numbers."""

from __future__ import annotations

from .. import figures
from ..figures.sections import section_map
from .layout import Layout, esc


def section_pages(c: Layout) -> list:
    """A page for each of the certificate's sections (none without); the next section of the
    certificate starts on a new page."""
    from reportlab.lib.units import mm
    from reportlab.platypus import PageBreak, Table
    from reportlab.platypus import Paragraph as P

    S, W = c.styles, c.width
    out: list = []
    for s in c.sections:
        bar_w = 24 * mm
        drawing, factor = section_map(s, W - bar_w, 150 * mm)
        bar = figures.colour_bar(s.tolerance, bar_w - 2 * mm, min(drawing.height, 95 * mm),
                                 "Deviation (mm)")
        d = s.signed
        out += [PageBreak(), P(esc(s.title), S["h"]),
                Table([[drawing, bar]], colWidths=[W - bar_w, bar_w],
                      style=[("VALIGN", (0, 0), (-1, -1), "MIDDLE"),
                             ("LEFTPADDING", (0, 0), (-1, -1), 0),
                             ("RIGHTPADDING", (0, 0), (-1, -1), 0)]),
                P(esc(_caption(s, factor)), S["small"])]
        t = s.tolerance
        out.append(c.kv([
            ("Plane", f"{s.plane.name}, nominal frame; drawn in its ({_axes(s.plane)}) "
                      "coordinates, mm, to scale"),
            ("Nominal section curve", f"{s.curve.length:.3f} mm in {len(s.curve.polylines)} "
                                      f"polyline(s), {sum(s.curve.closed)} closed"),
            ("Measured points in the band", f"{d.size} within ±{s.band:.4g} mm of the plane"),
            ("Deviation min / max", "—" if not d.size else
             f"{float(d.min()):+.4f} mm / {float(d.max()):+.4f} mm"),
            ("Outside the zone", f"{int(((d < t.lower) | (d > t.upper)).sum())} of {d.size}"),
        ], [48 * mm, W - 48 * mm]))
    return out + [PageBreak()] if out else out


def _axes(plane) -> str:
    from ..figures.sections import AXIS_NAMES

    return ", ".join(AXIS_NAMES.get(plane.axis or "", ("u", "v")))


def _caption(s, factor: float) -> str:
    n = s.signed.size
    pts = ("No measured point lies" if n == 0 else
           f"{n} measured point{'s' if n != 1 else ''} lie{'s' if n == 1 else ''}")
    return (f"The nominal's section by the plane {s.plane.name}. {pts} within ±{s.band:.4g} mm "
            "of the plane at the registered pose; each is drawn at its foot on the nominal, "
            "projected into the plane, with its deviation (as measured by the inspection) as a "
            f"whisker magnified {factor:g} times along the nominal's outward normal, coloured on "
            "the scale at the right; the dashed lines are the limits of the zone of the "
            "statistics (section 3), magnified the same: with an inspection plan the verdict is "
            "its characteristics' (section 2), not this zone's.")
