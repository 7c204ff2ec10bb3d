"""Section 2 of the certificate, the result: the verdict with its reasons, an inspection
plan's characteristics (balloon, symbol, requirement, measured value, result) and the
statistics."""

from __future__ import annotations

from engine.gdt.plan import DIMENSIONS
from engine.verdict import ACCEPT, INCONCLUSIVE

from .. import figures
from ..messages import VERDICT_RGB, VERDICT_WORD, limits_text
from ..symbols import BOX, symbol_strokes
from .layout import Layout, esc


def result(c: Layout) -> list:
    """2  Result: the verdict block with its reasons, and the statistics (placed early: the
    answer comes first)."""
    from reportlab.lib import colors
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph as P
    from reportlab.platypus import Spacer, Table

    S, W, res = c.styles, c.width, c.res
    st = res.statistics
    reasons = c.reasons_shown
    vb = Table([[P(VERDICT_WORD[res.verdict],
                   S["verdict_long" if res.verdict == INCONCLUSIVE else "verdict"]),
                 P(esc(reasons[:1].upper() + reasons[1:]), S["verdict_sub"])]],
               colWidths=[62 * mm, W - 62 * mm],
               style=[("BACKGROUND", (0, 0), (-1, -1), colors.Color(*VERDICT_RGB[res.verdict])),
                      ("VALIGN", (0, 0), (-1, -1), "MIDDLE"),
                      ("TOPPADDING", (0, 0), (-1, -1), 8), ("BOTTOMPADDING", (0, 0), (-1, -1), 8),
                      ("LEFTPADDING", (0, 0), (-1, -1), 10)])
    stats_rows = [["Points", "Out of tol.", "Min", "Max", "Mean", "Std dev", "RMS",
                   "Max |d|"],
                  [f"{st.count}", f"{st.n_out}", *(figures.fmt_mm(v) for v in
                                                   (st.min, st.max, st.mean)),
                   *(figures.fmt_mm(v, False) for v in (st.std, st.rms, st.max_abs))]]
    return [P("2  Result", S["h"]), vb, Spacer(1, 3 * mm), *_plan_table(c),
            c.table(stats_rows, [W / 8] * 8,
                    styles=[("ALIGN", (0, 0), (-1, -1), "CENTER"),
                            ("FONT", (0, 1), (-1, 1), "Vera-Bold", 8.5)]),
            P("Deviations in mm, positive where the measured surface lies outside the nominal "
              "(excess material), negative inside it (material missing); statistics over every "
              "measured point, points excluded "
              "from the alignment included" + ("." if c.plan is None else
                                               f", at the plan's alignment, against the zone "
                                               f"{c.zone} of the statistics (section 3)."),
              S["small"])]


TYPE_WORDS = {"profile": "surface profile", "flatness": "flatness", "position": "position",
               "size": "size (diameter)", "straightness": "straightness",
               "circularity": "circularity", "cylindricity": "cylindricity",
               "parallelism": "parallelism", "perpendicularity": "perpendicularity",
               "angularity": "angularity", "circular_runout": "circular runout",
               "total_runout": "total runout", "line_profile": "line profile",
               "coaxiality": "coaxiality", "concentricity": "concentricity",
               "symmetry": "symmetry", "radius": "radius", "angle": "angle (degrees)",
               "distance": "distance"}
"""Every characteristic type of the plan layer (engine.gdt.plan.CHARACTERISTICS) in words."""


def type_word(c: Layout, kind: str, feature: str | None = None) -> str:
    """A characteristic's type in words (a profile of a 2D contour is a line profile; a size,
    of its ``feature``: a cylinder's diameter by default, a width, a sphere's diameter)."""
    if kind == "size" and feature in ("width", "sphere"):
        return "size (width)" if feature == "width" else "size (sphere diameter)"
    return "line profile" if kind == "profile" and c.is_2d else TYPE_WORDS[kind]
VALUE_WORDS = {
    "profile": "profile: the width of the smallest zone, centred like its tolerance zone, that "
               "holds every point of its region (form: after the region is fitted alone, "
               "whatever the datums)",
    "flatness": "flatness: the distance between the two closest parallel planes that hold the "
                "face's points",
    "position": "position: the diameter of the smallest cylinder about the true position (from "
                "the datums) that holds the hole's fitted axis",
    "size": "size: the diameter of the least-squares fit to the hole's points",
    "straightness": "straightness: the diameter of the smallest cylinder holding the median "
                    "line, or the largest distance between two parallel lines holding a line "
                    "element",
    "circularity": "circularity: the largest radial distance between two concentric circles "
                   "holding a cross-section",
    "cylindricity": "cylindricity: the radial distance between two coaxial cylinders holding "
                    "the surface",
    **{k: f"{k}: the width (an axis: the diameter) of the smallest zone at the basic angle to "
          "the datums holding the face (the axis)"
       for k in ("parallelism", "perpendicularity", "angularity")},
    "circular_runout": "circular runout: the largest full indicator movement of a section turned "
                       "about the datum axis (radial on a cylinder, axial on a face normal to it)",
    "total_runout": "total runout: the full indicator movement over the whole surface turned "
                    "about the datum axis",
    "line_profile": "line profile: the largest, over the cross-sections every 'spacing' mm, of "
                    "the width of the smallest zone centred like its tolerance zone holding the "
                    "section (form only: each section refitted in its plane)",
    **{k: f"{k}: the diameter of the smallest cylinder about the datum axis that holds the "
          "feature's fitted axis" for k in ("coaxiality", "concentricity")},
    "symmetry": "symmetry: the width of the smallest zone centred on the datum plane that holds "
                "the width's fitted centre plane",
    "radius": "radius: half the diameter of the least-squares cylinder or sphere",
    "angle": "angle: between the least-squares planes or axes of its two regions, in degrees "
             "(value and requirement in degrees, not mm)",
    "distance": "distance: between the least-squares planes, axes or centres of its two "
                "regions"}


def _plan_table(c: Layout) -> list:
    """The inspection plan's characteristics, as a first-article report lists them: balloon,
    symbol, what, requirement, datums, measured value, points, result (none without a plan)."""
    from reportlab.lib import colors
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph as P
    from reportlab.platypus import Spacer

    if c.plan is None:
        return []
    S, W = c.styles, c.width
    degrees = any(r.characteristic.unit == "degree" for r in c.plan.characteristics)
    rows = [["No.", "", "Characteristic", "Requirement", "Datums",
             "Measured (mm, °)" if degrees else "Measured (mm)", "Points", "Result"]]
    cmds = []
    for k, r in enumerate(c.plan.characteristics, start=1):
        ch = r.characteristic
        where = "all points" if ch.region == "(all points)" else f"region {ch.region}"
        named = f"{ch.name} (id {ch.id})" if ch.name else (
            f"id {ch.id}" if ch.designator else "")
        rows.append([_balloon(ch.balloon), symbol_drawing(ch.type, ch.kind),
                     P(f"{esc(type_word(c, ch.type, ch.kind))}<br/><font size=6.5>"
                       f"{esc(where)}" + (f"<br/>{esc(named)}" if named else "") + "</font>",
                       S["cell"]),
                     P(esc(limits_text(ch).replace("⌀", "Ø")), S["cell"]),
                     "|".join(ch.datums) or ("—" if ch.type in ("size",) + DIMENSIONS
                                             else "form"),
                     "—" if r.value is None else f"{r.value:.4f}" + (
                         "°" if ch.unit == "degree" else ""), f"{r.indices.size}",
                     VERDICT_WORD[r.verdict]])
        cmds += [("BACKGROUND", (7, k), (7, k), colors.Color(*VERDICT_RGB[r.verdict])),
                 ("TEXTCOLOR", (7, k), (7, k), colors.white),
                 ("FONT", (7, k), (7, k), "Vera-Bold", 7.5)]
    # Why each one is not accepted, unless the verdict's reasons above already say it.
    notes = [f"{r.characteristic.called[0].upper()}{r.characteristic.called[1:]}: {r.reason}."
             for r in c.plan.characteristics if r.verdict != ACCEPT and r.reason not in c.reasons]
    types = dict.fromkeys(r.characteristic.type for r in c.plan.characteristics)
    words = dict(VALUE_WORDS, **({"position": VALUE_WORDS["position"].replace(
        "cylinder", "circle").replace("axis", "centre")} if c.is_2d else {}))
    notes.append("Measured value — " + "; ".join(words[t] for t in types) + ". Datums: "
                 "the features the part is placed by (section 6); form: judged by shape alone.")
    return [P("Characteristics of the inspection plan", S["cellb"]), Spacer(1, 1 * mm),
            c.table(rows, [10 * mm, 8 * mm, 28 * mm, 46 * mm, 16 * mm, 27 * mm, 13 * mm,
                           W - 148 * mm],
                    styles=[("ALIGN", (0, 0), (1, -1), "CENTER"),
                            ("ALIGN", (4, 0), (-1, -1), "CENTER"), *cmds]),
            Spacer(1, 1 * mm), *(P(esc(n), S["small"]) for n in notes), Spacer(1, 3 * mm)]


def _balloon(text: str):
    """A drawing's balloon: the characteristic's number in a circle (a stadium when long)."""
    from reportlab.graphics.shapes import Circle, Drawing, Rect, String
    from reportlab.pdfbase.pdfmetrics import stringWidth

    tw = stringWidth(text, "Vera-Bold", 7)
    w = max(12.0, tw + 6)
    d = Drawing(w + 1, 13)
    if w <= 12.0:
        d.add(Circle(w / 2 + 0.5, 6.5, 6, fillColor=None, strokeWidth=0.7))
    else:
        d.add(Rect(0.5, 0.5, w, 12, rx=6, ry=6, fillColor=None, strokeWidth=0.7))
    d.add(String(w / 2 + 0.5, 4, text, fontName="Vera-Bold", fontSize=7, textAnchor="middle"))
    return d


def symbol_drawing(kind: str, feature: str | None = None):
    """The characteristic's symbol (reports.symbols, one drawing for the certificate and the
    app) as a reportlab drawing: the certificate's font has no glyphs for them."""
    from reportlab.graphics.shapes import Circle, Drawing, PolyLine, Polygon, String

    d = Drawing(BOX, BOX)
    for stroke in symbol_strokes(kind, feature):
        if stroke[0] == "line":
            xy = list(stroke[1]) + (list(stroke[1][:2]) if stroke[2] else [])
            d.add(PolyLine(xy, strokeWidth=0.8, fillColor=None))
        elif stroke[0] == "circle":
            d.add(Circle(*stroke[1:], fillColor=None, strokeWidth=0.8))
        elif stroke[0] == "fill":
            d.add(Polygon(list(stroke[1]), fillColor=(0, 0, 0), strokeWidth=0.4))
        else:
            d.add(String(stroke[1], stroke[2], stroke[3], fontName="Vera", fontSize=stroke[4]))
    return d
