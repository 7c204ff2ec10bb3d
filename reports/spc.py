"""The SPC report of a lot (``DIR/spc.pdf``): a first page with the lot's facts and a table of the
characteristics (n, mean, Cpk with its confidence interval, flags), then one page per
characteristic with its individuals chart (control limits, tolerance limits, the points that break
a run rule ringed and labelled with the rule, a significant drift's trend line), its moving-range
chart, its histogram with the fitted normal and the tolerance limits, and its numbers.

Drawn with matplotlib's object API and PDF backend (no pyplot, no GUI backend), A4 landscape,
with fixed metadata: the same series give the same bytes. The numbers come from
:mod:`engine.spc`.
"""

from __future__ import annotations

import io
import math
import textwrap
from collections.abc import Iterable, Mapping

import numpy as np
from matplotlib import rc_context
from matplotlib.backends.backend_pdf import FigureCanvasPdf, PdfPages
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from engine.spc import Analysis, Series, analyse

from .messages import VERDICT_RGB, printable
from .results import SOFTWARE_NAME

A4_LANDSCAPE = (11.69, 8.27)
RC = {"pdf.fonttype": 42, "font.size": 8, "font.family": "DejaVu Sans", "axes.titlesize": 9,
      "axes.titleweight": "bold", "legend.fontsize": 7, "svg.hashsalt": "qa-inspect",
      "text.parse_math": False}
"""TrueType text (copyable, found by pdftotext) and one font whatever the user's matplotlibrc;
no mathtext: a '$' in a file name or an id is a dollar sign, not the start of a formula (an
unbalanced formula would raise)."""
TOLERANCE_RGB = (0.84, 0.37, 0.0)
CONTROL_RGB = (0.0, 0.45, 0.70)
CENTRE_RGB = (0.0, 0.55, 0.35)
FLAG_RGB = (0.80, 0.0, 0.0)
POINT_RGB = (0.15, 0.15, 0.15)
DRIFT_RGB = (0.55, 0.0, 0.55)
TABLE_ROWS = 24
"""Characteristics listed on the first page; more go on the pages after it."""
WORDS_ROWS = 9
"""Rule violations listed on a characteristic's page (the rest counted)."""
RULE_TEXT = ("Run rules (Nelson 1984): R1 a point beyond 3σ of the centre; R2 nine points in a "
             "row on one side of the centre; R3 six points in a row rising or falling; R4 "
             "fourteen points in a row alternating. Control limits mean ± 3σ within, σ within = "
             "mean moving range / 1.128; Cp, Cpk from σ within, 95 % intervals (chi-square; "
             "Bissell).")


def spc_pdf(series: Iterable[Series | Analysis | tuple], title: str,
            facts: Mapping[str, object]) -> bytes:
    """The SPC report as PDF bytes.

    series : :class:`engine.spc.Series` (or tuples of its fields: name, unit, values, serials,
    lower, upper), one per characteristic, values in measurement order; or their
    :class:`engine.spc.Analysis` when the caller has it already. title : the first line
    of every page. facts : what the first page says about the lot, in order (e.g. "parts": 30,
    "ACCEPT": 28, "REJECT": 1, "ERROR": 1, "nominal": "bracket.stl"); a key that is a verdict
    (ACCEPT, REJECT, INCONCLUSIVE) is printed in its colour.
    """
    analyses = [s if isinstance(s, Analysis) else analyse(s if isinstance(s, Series)
                                                          else Series(*s)) for s in series]
    # File names and ids, whose line breaks would break the page's lines.
    title = printable(title)
    facts = {printable(k): printable(v) if isinstance(v, str) else v for k, v in facts.items()}
    buf = io.BytesIO()
    meta = {"Title": title, "Creator": SOFTWARE_NAME, "Producer": SOFTWARE_NAME,
            "CreationDate": None}
    with rc_context(RC), PdfPages(buf, metadata=meta) as pdf:
        chunks = [analyses[k:k + TABLE_ROWS] for k in range(0, len(analyses), TABLE_ROWS)] or [[]]
        for k, chunk in enumerate(chunks):
            _save(pdf, _lot_page(title, facts if k == 0 else None, chunk, len(analyses)))
        for a in analyses:
            _save(pdf, _characteristic_page(title, a))
    return buf.getvalue()


def _save(pdf: PdfPages, fig: Figure) -> None:
    FigureCanvasPdf(fig)
    pdf.savefig(fig)


def _fmt(x: float | None, digits: int = 4) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{x:.{digits}g}"


def _index_text(i) -> str:
    if i.value is None:
        return "—"
    ci = "" if i.ci is None else f" [{i.ci[0]:.2f}, {i.ci[1]:.2f}]"
    return f"{i.value:.2f}{ci}"


def _lot_page(title: str, facts: Mapping[str, object] | None, rows: list[Analysis],
              total: int) -> Figure:
    fig = Figure(figsize=A4_LANDSCAPE)
    fig.text(0.04, 0.955, title, fontsize=14, weight="bold", va="top")
    fig.text(0.04, 0.915, "Statistical process control of the lot" if facts is not None
             else "Characteristics (continued)", fontsize=10, va="top")
    y = 0.87
    if facts is not None:
        for key, value in facts.items():
            colour = VERDICT_RGB.get(str(key), POINT_RGB)
            fig.text(0.04, y, f"{key}", fontsize=10, va="top", color=colour, weight="bold")
            fig.text(0.20, y, f"{value}", fontsize=10, va="top", color=colour)
            y -= 0.03
        fig.text(0.04, y - 0.01, f"{total} characteristic{'s' * (total != 1)}", fontsize=10,
                 va="top", weight="bold")
        y -= 0.05
    _table(fig, rows, top=y)
    fig.text(0.04, 0.03, RULE_TEXT, fontsize=7, va="bottom", wrap=True, color=(0.3, 0.3, 0.3))
    return fig


def _table(fig: Figure, rows: list[Analysis], top: float) -> None:
    """The characteristics' table: one row each, a flagged row in the flag colour."""
    head = ("characteristic", "unit", "n", "mean", "σ within", "tolerance", "Cpk [95 % CI]",
            "flags")
    xs = (0.04, 0.27, 0.32, 0.37, 0.45, 0.53, 0.65, 0.77)
    for x, h in zip(xs, head):
        fig.text(x, top, h, fontsize=9, weight="bold", va="top")
    fig.add_artist(Line2D([0.04, 0.96], [top - 0.025, top - 0.025], color=POINT_RGB, lw=0.6))
    y = top - 0.035
    for a in rows:
        s, c = a.series, a.chart
        flags = a.flags
        cells = (printable(s.name), s.unit, f"{c.n}/{len(s.values)}", _fmt(c.centre), _fmt(c.sigma_within),
                 _limits_text(s), _index_text(a.capability.cpk), ", ".join(flags) or "—")
        colour = FLAG_RGB if flags else POINT_RGB
        for x, cell in zip(xs, cells):
            fig.text(x, y, cell, fontsize=8.5, va="top", color=colour)
        y -= 0.026


def _limits_text(s: Series) -> str:
    if s.lower is not None and s.upper is not None:
        return f"{_fmt(s.lower)} … {_fmt(s.upper)}"
    if s.upper is not None:
        return f"≤ {_fmt(s.upper)}"
    return "—" if s.lower is None else f"≥ {_fmt(s.lower)}"


def _characteristic_page(title: str, a: Analysis) -> Figure:
    s = a.series
    fig = Figure(figsize=A4_LANDSCAPE)
    fig.text(0.04, 0.965, title, fontsize=9, va="top", color=(0.3, 0.3, 0.3))
    fig.text(0.04, 0.94, f"{printable(s.name)} ({s.unit})", fontsize=14, weight="bold", va="top")
    if a.flags:
        fig.text(0.96, 0.94, "  ".join(a.flags), fontsize=11, weight="bold", va="top",
                 ha="right", color=FLAG_RGB)
    grid = fig.add_gridspec(3, 3, left=0.06, right=0.97, top=0.86, bottom=0.07, hspace=0.45,
                            wspace=0.28, height_ratios=(1.3, 0.8, 1.2))
    individuals = fig.add_subplot(grid[0:2, 0:2])
    _individuals_chart(individuals, a)
    _moving_range_chart(fig.add_subplot(grid[2, 0:2], sharex=individuals), a)
    _histogram(fig.add_subplot(grid[0, 2]), a)
    _numbers(fig, a, top=0.52)
    return fig


def _flagged(a: Analysis) -> dict[int, list[int]]:
    """The rules each flagged point breaks, by index."""
    out: dict[int, list[int]] = {}
    for v in a.violations:
        for i in v.indices:
            out.setdefault(i, [])
            if v.rule not in out[i]:
                out[i].append(v.rule)
    return out


def _hline(ax, y: float | None, colour, style: str, label: str) -> None:
    if y is not None:
        ax.axhline(y, color=colour, ls=style, lw=1.1, label=f"{label} {_fmt(y)}")


def _individuals_chart(ax, a: Analysis) -> None:
    s, c, d = a.series, a.chart, a.drift
    pos = np.arange(1, len(s.values) + 1)
    ok = ~np.isnan(s.values)
    ax.plot(pos[ok], s.values[ok], "-o", color=POINT_RGB, ms=3.5, lw=0.8, zorder=3)
    _hline(ax, s.upper, TOLERANCE_RGB, "-", "USL")
    _hline(ax, s.lower, TOLERANCE_RGB, "-", "LSL")
    _hline(ax, c.ucl, CONTROL_RGB, "--", "UCL")
    _hline(ax, c.centre, CENTRE_RGB, "-", "mean")
    _hline(ax, c.lcl, CONTROL_RGB, "--", "LCL")
    for i in np.flatnonzero(~ok):
        ax.axvspan(i + 0.6, i + 1.4, color=(0.85, 0.85, 0.85), lw=0, zorder=0)
    ends: dict[int, list[str]] = {}  # a run's label sits on the point that completes it
    for run in a.violations:
        ends.setdefault(run.indices[-1], []).append(f"R{run.rule}")
    for last, labels in ends.items():
        ax.annotate(" ".join(dict.fromkeys(labels)), (last + 1, s.values[last]), xytext=(0, 7),
                    textcoords="offset points", ha="center", fontsize=7, weight="bold",
                    color=FLAG_RGB, zorder=5)
    flagged = sorted(_flagged(a))
    if flagged:
        ax.plot(np.array(flagged) + 1, s.values[flagged], "o", ms=8, mfc="none", mew=1.3,
                color=FLAG_RGB, zorder=4, label="run rule broken")
    if d.significant and d.slope is not None:
        _trend_line(ax, a)
    ax.set_title("Individuals" + ("" if c.reason is None else f" — {c.reason}"), loc="left")
    ax.set_ylabel(s.unit)
    ax.grid(True, color=(0.9, 0.9, 0.9), lw=0.5)
    _legend(ax, loc="lower left", bbox_to_anchor=(0.0, 1.06), ncol=7, frameon=False, fontsize=7,
              borderaxespad=0.0, handlelength=2.2)


def _trend_line(ax, a: Analysis) -> None:
    """The drift's least-squares line over the lot and, when it warns, on to the limit."""
    d, n = a.drift, len(a.series.values)
    end = n + (d.parts_to_limit if d.warning else 0)
    t = np.array([1.0, float(n), float(end)])
    y = d.intercept + d.slope * (t - 1)
    ax.plot(t[:2], y[:2], "-", color=DRIFT_RGB, lw=1.2, zorder=2,
            label=f"trend {d.slope:+.3g}/part")
    if d.warning:
        ax.plot(t[1:], y[1:], ":", color=DRIFT_RGB, lw=1.6, zorder=2)
        # where the lot started: away from its latest points, inside the tolerance lines
        ax.text(0.01, 0.88 if d.slope > 0 else 0.12, f"drift towards the {d.limit} limit: "
                f"reached in {d.parts_to_limit} more parts at this rate", transform=ax.transAxes,
                va="top" if d.slope > 0 else "bottom", fontsize=9, weight="bold",
                color=DRIFT_RGB, bbox={"facecolor": "white", "edgecolor": DRIFT_RGB, "lw": 0.8},
                zorder=6)


def _moving_range_chart(ax, a: Analysis) -> None:
    c = a.chart
    mr = c.moving_ranges
    pos = np.arange(1, len(mr) + 1)
    ok = ~np.isnan(mr)
    ax.plot(pos[ok], mr[ok], "-o", color=POINT_RGB, ms=3, lw=0.8, zorder=3)
    if c.mr_ucl is not None:
        high = ok & (np.nan_to_num(mr) > c.mr_ucl)
        ax.plot(pos[high], mr[high], "o", ms=7, mfc="none", mew=1.2, color=FLAG_RGB, zorder=4)
    _hline(ax, c.mr_ucl, CONTROL_RGB, "--", "UCL")
    _hline(ax, c.mr_centre, CENTRE_RGB, "-", "mean MR")
    ax.set_title("Moving range", loc="left")
    ax.set_xlabel("part (measurement order)")
    ax.set_ylabel(a.series.unit)
    ax.grid(True, color=(0.9, 0.9, 0.9), lw=0.5)
    _legend(ax, loc="lower right", bbox_to_anchor=(1.0, 1.02), ncol=2, frameon=False, fontsize=7,
              borderaxespad=0.0)


def _legend(ax, **kwargs) -> None:
    """The axes' legend, when anything on them has a label (a lot of one part has no limits
    to label: matplotlib would warn)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**kwargs)


def _histogram(ax, a: Analysis) -> None:
    s, c = a.series, a.chart
    x = s.values[~np.isnan(s.values)]
    ax.set_title("Histogram", loc="left")
    if len(x) == 0:
        return
    bins = int(np.clip(math.ceil(math.sqrt(len(x))), 5, 25))
    lo, hi = float(x.min()), float(x.max())
    half = 0.5 * (hi - lo) or 0.01 * (abs(lo) or 1.0)
    centre = 0.5 * (lo + hi)
    counts, edges, _ = ax.hist(x, bins=bins, range=(centre - 1.05 * half, centre + 1.05 * half),
                               color=(0.75, 0.8, 0.88), edgecolor=(0.35, 0.4, 0.5), lw=0.5)
    if c.std_overall:
        grid = np.linspace(min(edges[0], c.centre - 4 * c.std_overall),
                           max(edges[-1], c.centre + 4 * c.std_overall), 200)
        pdf = np.exp(-0.5 * ((grid - c.centre) / c.std_overall) ** 2) / (
            c.std_overall * math.sqrt(2 * math.pi))
        ax.plot(grid, pdf * len(x) * (edges[1] - edges[0]), color=CONTROL_RGB, lw=1.1,
                label="normal (mean, s)")
    for limit, name in ((s.lower, "LSL"), (s.upper, "USL")):
        if limit is not None:
            ax.axvline(limit, color=TOLERANCE_RGB, lw=1.4, label=name)
    ax.set_xlabel(s.unit)
    ax.set_ylabel("parts")
    ax.ticklabel_format(axis="x", useOffset=False)
    if ax.get_legend_handles_labels()[0]:
        _legend(ax, loc="upper right", fontsize=7, frameon=False)


def _numbers(fig: Figure, a: Analysis, top: float) -> None:
    """The numbers beside the charts: the chart's, the capability's, the drift, the rules."""
    s, c, cap, d = a.series, a.chart, a.capability, a.drift
    missing = len(s.values) - c.n
    lines = [
        (f"n = {c.n} of {len(s.values)} parts" + (f" ({missing} without a value)" if missing
                                                  else ""), None),
        (f"tolerance {_limits_text(s)} {s.unit}; out of tolerance: {a.out_of_tolerance}",
         FLAG_RGB if a.out_of_tolerance else None),
        (f"mean {_fmt(c.centre)}   s overall {_fmt(c.std_overall)}", None),
        (f"σ within {_fmt(c.sigma_within)}   mean MR {_fmt(c.mr_centre)}   "
         f"MR UCL {_fmt(c.mr_ucl)}", None),
        (f"UCL {_fmt(c.ucl)}   LCL {_fmt(c.lcl)}" if c.reason is None else c.reason, None),
        (f"Cp {_index_text(cap.cp)}   Cpk {_index_text(cap.cpk)}", None),
        (f"Cpu {_index_text(cap.cpu)}   Cpl {_index_text(cap.cpl)}", None),
        ("capability: " + (cap.cpk.reason or cap.cp.reason) if cap.cpk.value is None
         or cap.cp.value is None else "", None),
        ("drift: " + (d.reason or d.text), DRIFT_RGB if d.warning else None),
    ]
    words = [f"  R{v.rule}: {v.text}" for v in a.violations]
    if len(words) > WORDS_ROWS:
        words = words[:WORDS_ROWS - 1] + [f"  … and {len(words) - WORDS_ROWS + 1} more"]
    lines += [("run rules: none broken" if not words else "run rules broken:", None)]
    lines += [(w, FLAG_RGB) for w in words]
    y = top
    for text, colour in lines:
        for line in textwrap.wrap(text, 60, subsequent_indent="    "):
            fig.text(0.685, y, line, fontsize=8, va="top", color=colour or POINT_RGB)
            y -= 0.022
        y -= 0.006 if text else 0
