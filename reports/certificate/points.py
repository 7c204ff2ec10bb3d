"""Section 9 of the certificate, the measured points: every out-of-tolerance point and
those nearest a limit (AS9102 Form 3 style), and the points' names and flags the other sections
share."""

from __future__ import annotations

from engine.pipeline import Run
from engine.verdict import INCONCLUSIVE

from .. import callouts
from ..messages import printable
from .layout import Layout, esc
from .policy import registration_trusted


WORST_ROWS = 25
"""In-tolerance points listed after every out-of-tolerance point, worst first."""
MAX_OUT_ROWS = 1000
"""Out-of-tolerance rows printed; the attached CSV always holds every point."""
APPENDIX_POINTS = 250
"""Up to this many measured points, section 9 lists every one (about five pages); beyond, it
lists the out-of-tolerance points and those nearest a limit and says that the complete list is
the attached points.csv."""


def characteristics(c: Layout) -> list:
    """9  Characteristic accountability (AS9102 Form 3 style): every out-of-tolerance point,
    then the in-tolerance points nearest to a limit; without a trusted pose the largest
    deviations, not judged. With a plan (whose characteristics are in section 2): the measured
    points against the zone of the statistics, with their regions."""
    from reportlab.lib import colors
    from reportlab.lib.units import mm
    from reportlab.platypus import CondPageBreak, Spacer
    from reportlab.platypus import Paragraph as P

    S, W, res, run = c.styles, c.width, c.res, c.run
    st, order, d = res.statistics, run.worst_order, res.deviations.signed
    out_idx = order[: min(st.n_out, MAX_OUT_ROWS)]
    near = order.size - st.n_out if order.size <= APPENDIX_POINTS else WORST_ROWS
    rows_idx = list(out_idx) + [i for i in order[st.n_out: st.n_out + near]]
    judged = res.verdict != INCONCLUSIVE if c.plan is None else registration_trusted(res)
    if not judged:  # no pose to trust: the points are listed, not judged
        out_idx = order[:0]
        rows_idx = list(order[:max(near, WORST_ROWS)])
    title, header, words, intro = _point_list_words(c, len(out_idx),
                                                    len(rows_idx) - len(out_idx), judged)
    rows = [header]
    res_styles: list[tuple] = []  # reportlab table style commands
    for k, i in enumerate(rows_idx):
        p = res.registered[i]
        ok = bool(res.in_tolerance[i])
        result = words[ok] if judged else "not judged"
        name = (P(esc(point_name(run, i)) + "<br/><font size=6>excluded from the alignment "
                  f"(gross outlier, d = {d[i]:+.4f} mm)</font>", S["cell"]) if res.outlier[i]
                else point_name(run, i))
        rows.append([f"{k + 1}", name, c.zone if c.plan is None else
                     P(esc(c.plan.regions[i] or "—"), S["cell"]),
                     f"{p[0]:.3f}", f"{p[1]:.3f}", f"{p[2]:.3f}", f"{d[i]:+.4f}", result])
        if judged and not ok:
            res_styles.append(("TEXTCOLOR", (7, k + 1), (7, k + 1), colors.Color(0.72, 0.1, 0.1)))
            res_styles.append(("FONT", (7, k + 1), (7, k + 1), "Vera-Bold", 7.5))
    return [CondPageBreak(60 * mm), P(title, S["h"]), P(esc(intro), S["small"]),
            P(esc(_every_point_words(c, len(rows_idx))), S["cellb"]), Spacer(1, 2 * mm),
            c.table(rows, [15 * mm, 24 * mm, 30 * mm, 22 * mm, 22 * mm, 22 * mm, 22 * mm,
                           W - 157 * mm], zebra=True,
                    styles=[("ALIGN", (3, 1), (6, -1), "RIGHT"),
                            ("ALIGN", (7, 0), (7, -1), "CENTER"), *res_styles])]


def _every_point_words(c: Layout, listed: int) -> str:
    """Where every measured point is: this table, or the attached CSV."""
    n = c.res.statistics.count
    if listed == n:
        return (f"This table lists all {n} measured points (they are also in the attached "
                "points.csv, section 10).")
    return (f"This table lists {listed} of the {n:,} measured points. The complete list of "
            f"all {n:,} points, each with its input and registered coordinates, deviation and "
            "result, is the attached file points.csv (section 10), covered by the signature.")


def _point_list_words(c: Layout, n_out: int, n_near: int, judged: bool):
    """Section 9's title, header row, result words (by in-tolerance) and introduction."""
    n_all = c.res.statistics.n_out
    listed = f"; the worst {MAX_OUT_ROWS} are listed" if n_all > MAX_OUT_ROWS else ""
    tail = (" A point excluded from the alignment (a gross outlier: see section 4) is judged "
            "like every other.")
    if not judged:
        head = (f"The registration cannot be trusted, so no point is judged; the {n_near} "
                "largest deviations at the best pose found are listed for diagnosis.")
    elif c.plan is None:
        head = (f"Every point out of tolerance ({n_all}{listed}), then the {n_near} "
                "in-tolerance points nearest to a limit, worst first.")
    else:
        head = (f"Every point outside the zone of the statistics {c.zone} ({n_all}{listed}), "
                f"then the {n_near} inside it nearest to a limit, worst first, with the regions "
                "of the plan they belong to (—: none). " + (
                    "That zone is also characteristic 'tol' (judged at the best fit over all "
                    "points)." if c.plan.zone_in_verdict else
                    "That zone is not part of the verdict: the characteristics in section 2 "
                    "are."))
    if c.plan is None:
        return ("9  Characteristic accountability (AS9102 Form 3 style)",
                ["Char. No.", "Point", "Requirement", "X (mm)", "Y (mm)", "Z (mm)",
                 "Deviation", "Result"], {True: "PASS", False: "FAIL"},
                head + " Coordinates of the registered points in the nominal frame." + tail)
    return ("9  Measured points", ["No.", "Point", "Region", "X (mm)", "Y (mm)", "Z (mm)",
                                   "Deviation", "In zone"], {True: "inside", False: "outside"},
            head + " Coordinates at the plan's alignment (section 6), in the nominal frame."
            + tail)


def point_name(run: Run, i: int) -> str:
    """Point ``i``'s label (printable: a table cell or callout would break a line at a line
    break in it), or its number."""
    labels = run.measured.labels
    return printable(labels[i]) if labels is not None and str(labels[i]) else f"#{i + 1}"


def worst_labels(run: Run) -> list[tuple[int, str]]:
    """The flagged points (reports.callouts.callout_points) and their labels."""
    res = run.result
    d, tol = res.deviations.signed, res.tolerance
    idx = callouts.callout_points(res.deviations.foot, d, tol.lower, tol.upper)
    return [(i, f"{point_name(run, i)}\n{d[i]:+.3f}") for i in idx]
