"""The SPC report of a lot (``DIR/spc.pdf``): a first page with the lot's facts and a table of the
characteristics (n, mean, Cpk with its confidence interval, flags), then one page per
characteristic with its individuals chart (control limits, tolerance limits, the points that break
a run rule ringed and labelled with the rule, a significant drift's trend line), its moving-range
chart, its histogram with the fitted normal and the tolerance limits, and its numbers; the charts'
x axis names the parts by serial. A count has its c chart instead of the two, and a quantity the
fit forces to ~0 its values only, labelled information only (:class:`engine.spc.Kind`).

The table's columns are as wide as their widest cell, measured in the page's font, so that no
column runs into the next (a long name is cut short with "…", long flags wrap onto more lines).

Drawn with matplotlib's object API and PDF backend (no pyplot, no GUI backend), A4 landscape,
with fixed metadata: the same series give the same bytes. The numbers come from
:mod:`engine.spc`.
"""

from __future__ import annotations

import io
import math
import textwrap
from collections.abc import Iterable, Mapping
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib import rc_context
from matplotlib.backends.backend_pdf import FigureCanvasPdf, PdfPages
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties
from matplotlib.lines import Line2D
from matplotlib.textpath import TextToPath
from matplotlib.ticker import MaxNLocator
from matplotlib.transforms import offset_copy

from engine.spc import Analysis, Kind, Series, analyse

from .messages import VERDICT_RGB, printable
from .results import SOFTWARE_NAME

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType

A4_LANDSCAPE = (11.69, 8.27)
RC: dict[RcKeyType, Any] = {"pdf.fonttype": 42, "font.size": 8, "font.family": "DejaVu Sans", "axes.titlesize": 9,
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
RGB = tuple[float, float, float]
DRIFT_RGB = (0.55, 0.0, 0.55)
NOTE_RGB = (0.45, 0.45, 0.45)
TABLE_ROWS = 24
"""At most this many characteristics on a page of the table (fewer when they fill it); more
go on the pages after it."""
TABLE_FONT = 8.5
TABLE_GAP = 0.015
"""Space between two columns of the table, in page widths (about 12 pt)."""
TABLE_BOTTOM = 0.10
"""The table stops above the note at the foot of the page (figure fraction)."""
TABLE_NOTES = {Kind.FORCED: "information only (set to ~0 by the fit)",
               Kind.COUNT: "none (a count: c chart)"}
"""What the flags column says of a quantity without flags, when its kind limits the flags."""
NAME_WIDTH = 0.24
"""The widest a characteristic's name may be in the table (page widths); longer ones are cut."""
FLAGS_WIDTH = 0.16
"""The flags column's least width (page widths), made by cutting the names shorter."""
ROW_STEP, LINE_STEP = 0.026, 0.02
"""A table row's height, and each further line of its wrapped flags (figure fraction)."""
SERIAL_TICKS = 40
"""At most this many serials are written under a chart (every k-th beyond)."""
SERIAL_CHARS = 14
"""A serial longer than this is cut from the left under the chart (its end tells parts apart)."""
WORDS_ROWS = 9
"""Rule violations listed on a characteristic's page (the rest counted)."""
RULE_TEXT = ("Run rules (Nelson 1984): R1 a point beyond 3σ of the centre; R2 nine points in a "
             "row on one side of the centre; R3 six points in a row rising or falling; R4 "
             "fourteen points in a row alternating. Control limits mean ± 3σ within, σ within = "
             "mean moving range / 1.128; Cp, Cpk from σ within, 95 % intervals (chi-square; "
             "Bissell). A value ≥ 0 with an upper limit only (max |d|, form, position): Cpu only, "
             "given while Shapiro-Wilk does not reject normality (p ≥ 0.01). A count: c chart "
             "(c̄ ± 3√c̄), R1 only, no index. Information only (set to ~0 by the fit, as mean d "
             "after a least-squares fit): no limits, index or rules.")


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
        table = _Table(analyses)
        done = 0
        while done == 0 or done < len(analyses):
            fig, drawn = _lot_page(title, facts if done == 0 else None, table, done)
            _save(pdf, fig)
            done += max(drawn, 1)  # an empty lot: one page
        for a in analyses:
            _save(pdf, _characteristic_page(title, a))
    return buf.getvalue()


def _save(pdf: PdfPages, fig: Figure) -> None:
    FigureCanvasPdf(fig)
    pdf.savefig(fig)


def _fmt(x: float | None, digits: int = 4) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{x:.{digits}g}"


def _index_text(i) -> str:
    """An index and its interval to 3 significant digits (a huge index stays short)."""
    if i.value is None:
        return "—"
    ci = "" if i.ci is None else f" [{i.ci[0]:.3g}, {i.ci[1]:.3g}]"
    return f"{i.value:.3g}{ci}"


def _printable(text: object) -> str:
    return printable(str(text))


@lru_cache(maxsize=4096)
def _width(text: str, size: float = TABLE_FONT, bold: bool = False) -> float:
    """The width of ``text`` set in the report's font at ``size`` pt, in page widths."""
    prop = FontProperties(family=RC["font.family"], size=size, weight="bold" if bold else None)
    w, _, _ = TextToPath().get_text_width_height_descent(text, prop, ismath=False)
    return w / (A4_LANDSCAPE[0] * 72.0)


def _cut(text: str, width: float) -> str:
    """``text`` cut short with "…" to fit ``width`` page widths."""
    if _width(text) <= width:
        return text
    while text and _width(text + "…") > width:
        text = text[:-1]
    return text + "…"


def _lot_page(title: str, facts: Mapping[str, object] | None, table: "_Table",
              start: int) -> tuple[Figure, int]:
    """A page of the lot: the title, the facts (first page), the table from row ``start`` as
    far as it fits; the figure and how many rows it holds."""
    fig = Figure(figsize=A4_LANDSCAPE)
    fig.text(0.04, 0.955, _printable(title), fontsize=14, weight="bold", va="top",
             parse_math=False)
    fig.text(0.04, 0.915, "Statistical process control of the lot" if facts is not None
             else "Characteristics (continued)", fontsize=10, va="top")
    y = 0.87
    if facts is not None:
        for key, value in facts.items():
            colour = next((rgb for v, rgb in VERDICT_RGB.items() if v == key), POINT_RGB)
            fig.text(0.04, y, _printable(key), fontsize=10, va="top", color=colour, weight="bold",
                     parse_math=False)
            fig.text(0.20, y, _printable(value), fontsize=10, va="top", color=colour,
                     parse_math=False)
            y -= 0.03
        total = len(table.rows)
        fig.text(0.04, y - 0.01, f"{total} characteristic{'s' * (total != 1)}", fontsize=10,
                 va="top", weight="bold")
        y -= 0.05
    drawn = table.draw(fig, start, top=y)
    fig.text(0.04, 0.03, RULE_TEXT, fontsize=7, va="bottom", wrap=True, color=(0.3, 0.3, 0.3))
    return fig, drawn


class _Table:
    """The characteristics' table, laid out once for all its pages: one row each (its flags
    wrapped to the last column's width), a flagged row in the flag colour, a row whose
    quantity is information only in grey with its note."""

    HEAD = ("characteristic", "unit", "n", "mean", "σ within", "tolerance", "Cpk [95 % CI]",
            "flags")

    def __init__(self, analyses: list[Analysis]):
        self.rows = [self._cells(a) for a in analyses]
        widths = [max([_width(self.HEAD[k], 9, True)] + [_width(r[0][k]) for r in self.rows])
                  for k in range(len(self.HEAD) - 1)]
        # The name gives way (down to half its room) before the flags get narrower than
        # FLAGS_WIDTH: they are what the reader looks for.
        short = 0.04 + sum(widths[1:]) + TABLE_GAP * len(widths) + FLAGS_WIDTH - 0.96
        widths[0] = min(widths[0], max(NAME_WIDTH - max(short, 0.0), NAME_WIDTH / 2))
        self.xs = [0.04]
        for w in widths:
            self.xs.append(self.xs[-1] + w + TABLE_GAP)
        flags_width = 0.96 - self.xs[-1]
        self.lines = [self._wrap(flags, flags_width) for _, flags, _ in self.rows]
        self.cut = [_cut(cells[0], widths[0]) for cells, _, _ in self.rows]

    @staticmethod
    def _cells(a: Analysis) -> tuple[tuple[str, ...], list[str], tuple]:
        s, c, kind = a.series, a.chart, a.series.kind
        flags = a.flags or [TABLE_NOTES.get(kind, "—")]
        colour = FLAG_RGB if a.flags else NOTE_RGB if kind is Kind.FORCED else POINT_RGB
        cells = (_printable(s.name), _printable(s.unit), f"{c.n}/{len(s.values)}", _fmt(c.centre),
                 _fmt(c.sigma_within), _limits_text(s), _index_text(a.capability.cpk))
        return cells, flags, colour

    @staticmethod
    def _wrap(flags: list[str], width: float) -> list[str]:
        """The flags joined by ", " on as many lines of ``width`` as they need: a flag whole
        where it fits on a line, else broken between its words."""
        lines: list[str] = []
        for flag in flags:
            if lines and _width(f"{lines[-1]}, {flag},") <= width:
                lines[-1] += f", {flag}"
                continue
            if lines:
                lines[-1] += ","
            lines.append("")
            for word in flag.split(" "):
                if lines[-1] and _width(f"{lines[-1]} {word},") > width:
                    lines.append(word)
                else:
                    lines[-1] = f"{lines[-1]} {word}" if lines[-1] else word
        return [_cut(line, width) for line in lines] or ["—"]

    def draw(self, fig: Figure, start: int, top: float) -> int:
        """Draw the heading and the rows from ``start`` that fit above the page's foot, at
        most TABLE_ROWS; return how many."""
        for x, h in zip(self.xs, self.HEAD):
            fig.text(x, top, h, fontsize=9, weight="bold", va="top")
        fig.add_artist(Line2D([0.04, 0.96], [top - 0.025, top - 0.025], color=POINT_RGB, lw=0.6))
        y, k = top - 0.035, start
        while k < len(self.rows) and k - start < TABLE_ROWS:
            (cells, _, colour), lines = self.rows[k], self.lines[k]
            if k > start and y - ROW_STEP - LINE_STEP * (len(lines) - 1) < TABLE_BOTTOM:
                break
            for x, cell in zip(self.xs, (self.cut[k],) + cells[1:]):
                fig.text(x, y, cell, fontsize=TABLE_FONT, va="top", color=colour,
                         parse_math=False)
            for j, line in enumerate(lines):
                fig.text(self.xs[-1], y - j * LINE_STEP, line, fontsize=TABLE_FONT, va="top",
                         color=colour, parse_math=False)
            y -= ROW_STEP + LINE_STEP * (len(lines) - 1)
            k += 1
        return k - start


def _limits_text(s: Series) -> str:
    if s.lower is not None and s.upper is not None:
        return f"{_fmt(s.lower)} … {_fmt(s.upper)}"
    if s.upper is not None:
        return f"≤ {_fmt(s.upper)}"
    return "—" if s.lower is None else f"≥ {_fmt(s.lower)}"


def _characteristic_page(title: str, a: Analysis) -> Figure:
    """A characteristic's page: I-MR charts (a count's c chart, an information-only quantity's
    values, alone), the histogram and the numbers; the parts named by serial under the
    lowest chart."""
    s = a.series
    fig = Figure(figsize=A4_LANDSCAPE)
    fig.text(0.04, 0.965, _printable(title), fontsize=9, va="top", color=(0.3, 0.3, 0.3),
             parse_math=False)
    fig.text(0.04, 0.94, _printable(f"{s.name} ({s.unit})"), fontsize=14, weight="bold", va="top",
             parse_math=False)
    if a.flags:
        fig.text(0.96, 0.94, "  ".join(a.flags), fontsize=11, weight="bold", va="top",
                 ha="right", color=FLAG_RGB)
    grid = fig.add_gridspec(3, 3, left=0.06, right=0.97, top=0.86, bottom=0.15, hspace=0.45,
                            wspace=0.28, height_ratios=(1.3, 0.8, 1.2))
    if s.kind.process:
        individuals = fig.add_subplot(grid[0:2, 0:2])
        lowest = fig.add_subplot(grid[2, 0:2], sharex=individuals)
        _individuals_chart(individuals, a)
        _moving_range_chart(lowest, a)
        individuals.tick_params(labelbottom=False)  # the serials go under the lowest chart
    else:
        individuals = lowest = fig.add_subplot(grid[0:3, 0:2])
        _individuals_chart(individuals, a)
    _serial_axis(lowest, s.serials)
    _histogram(fig.add_subplot(grid[0, 2]), a)
    _numbers(fig, a, top=0.52)
    return fig


def _serial_axis(ax, serials: tuple[str, ...]) -> None:
    """Name the parts on the x axis by serial (every k-th beyond SERIAL_TICKS), upright, a
    long serial cut from the left."""
    n = len(serials)
    step = max(1, math.ceil(n / SERIAL_TICKS))
    ticks = np.arange(1, n + 1, step)
    labels = []
    for k in ticks:
        text = _printable(serials[k - 1]).replace("$", r"\$")  # no mathtext from a file name
        labels.append(text if len(text) <= SERIAL_CHARS else "…" + text[-SERIAL_CHARS + 1:])
    ax.set_xticks(ticks, labels, rotation=90, fontsize=6.5)
    ax.set_xlabel("part (serial, in measurement order)" + (f"; every {step}th named"
                                                           if step > 1 else ""))


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
    ax.set_title(_chart_title(a), loc="left")
    ax.set_ylabel(_printable(s.unit))
    ax.grid(True, color=(0.9, 0.9, 0.9), lw=0.5)
    # Above the chart's title, as far above the axes whatever their height (a c chart's and an
    # information chart's axes are taller).
    above = offset_copy(ax.transAxes, fig=ax.figure, y=14, units="points")
    _legend(ax, loc="lower left", bbox_to_anchor=(0.0, 1.0), bbox_transform=above, ncol=7,
            frameon=False, fontsize=7, borderaxespad=0.0, handlelength=2.2)
    if s.kind is Kind.COUNT:  # whole numbers, from 0
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_ylim(-0.5, max(1.0, np.nanmax(s.values, initial=0.0), c.ucl or 0.0) + 0.5)


def _chart_title(a: Analysis) -> str:
    kind, reason = a.series.kind, a.chart.reason
    if kind is Kind.FORCED:
        return "Values — information only (no control limits, no run rules)"
    name = "c chart (count per part; R1 only)" if kind is Kind.COUNT else "Individuals"
    return name + ("" if reason is None else f" — {reason}")


def _trend_line(ax, a: Analysis) -> None:
    """The drift's least-squares line over the lot and, when it warns, on to the limit."""
    d, n = a.drift, len(a.series.values)
    if d.slope is None or d.intercept is None:
        raise ValueError("a trend line needs the drift's fitted line")
    end = n + (d.parts_to_limit if d.warning and d.parts_to_limit is not None else 0)
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
    ax.set_ylabel(_printable(a.series.unit))
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
    lo, hi = float(x.min()), float(x.max())
    bins: int | np.ndarray
    span: tuple[float, float] | None
    if s.kind is Kind.COUNT:  # a bar per whole number
        bins, span = np.arange(-0.5, hi + 1.0), None
    else:
        bins = int(np.clip(math.ceil(math.sqrt(len(x))), 5, 25))
        half = 0.5 * (hi - lo) or 0.01 * (abs(lo) or 1.0)
        centre = 0.5 * (lo + hi)
        span = (centre - 1.05 * half, centre + 1.05 * half)
    counts, edges, _ = ax.hist(x, bins=bins, range=span, color=(0.75, 0.8, 0.88),
                               edgecolor=(0.35, 0.4, 0.5), lw=0.5)
    if c.std_overall and c.centre is not None and s.kind is not Kind.COUNT:  # (not normal)
        grid = np.linspace(min(edges[0], c.centre - 4 * c.std_overall),
                           max(edges[-1], c.centre + 4 * c.std_overall), 200)
        pdf = np.exp(-0.5 * ((grid - c.centre) / c.std_overall) ** 2) / (
            c.std_overall * math.sqrt(2 * math.pi))
        ax.plot(grid, pdf * len(x) * (edges[1] - edges[0]), color=CONTROL_RGB, lw=1.1,
                label="normal (mean, s)")
    for limit, name in ((s.lower, "LSL"), (s.upper, "USL")):
        if limit is not None:
            ax.axvline(limit, color=TOLERANCE_RGB, lw=1.4, label=name)
    ax.set_xlabel(_printable(s.unit))
    ax.set_ylabel("parts")
    ax.ticklabel_format(axis="x", useOffset=False)
    if s.kind is Kind.COUNT:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if ax.get_legend_handles_labels()[0]:
        _legend(ax, loc="upper right", fontsize=7, frameon=False)


def _numbers(fig: Figure, a: Analysis, top: float) -> None:
    """The numbers beside the charts: what the quantity is (when that limits what is judged),
    the chart's numbers, the capability's, the drift, the rules; each as its kind allows."""
    s, c, kind = a.series, a.chart, a.series.kind
    missing = len(s.values) - c.n
    limits = "no tolerance limits" if s.lower is None and s.upper is None else \
        f"tolerance {_limits_text(s)} {_printable(s.unit)}"
    lines: list[tuple[str, RGB | None]] = [(kind.note, NOTE_RGB)] if kind.note else []
    lines += [
        (f"n = {c.n} of {len(s.values)} parts" + (f" ({missing} without a value)" if missing
                                                  else ""), None),
        (f"{limits}; parts out of tolerance: {a.out_of_tolerance}",
         FLAG_RGB if a.out_of_tolerance else None),
        (f"mean {_fmt(c.centre)}   s overall {_fmt(c.std_overall)}", None)]
    if kind is Kind.COUNT:
        lines.append((f"σ = √c̄ {_fmt(c.sigma_within)} (Poisson)", None))
    elif kind.process:
        lines.append((f"σ within {_fmt(c.sigma_within)}   mean MR {_fmt(c.mr_centre)}   "
                      f"MR UCL {_fmt(c.mr_ucl)}", None))
    if kind is not Kind.FORCED:
        lines.append((f"UCL {_fmt(c.ucl)}   LCL {_fmt(c.lcl)}" if c.reason is None
                      else c.reason, None))
    if kind.process:
        lines += _capability_lines(a)
    lines += _rule_lines(a)
    y = top
    for text, colour in lines:
        for line in textwrap.wrap(text, 60, subsequent_indent="    "):
            fig.text(0.685, y, line, fontsize=8, va="top", color=colour or POINT_RGB)
            y -= 0.022
        y -= 0.006 if text else 0


def _capability_lines(a: Analysis) -> list[tuple[str, RGB | None]]:
    cap, d = a.capability, a.drift
    lines: list[tuple[str, RGB | None]]
    if a.series.kind is Kind.BOUNDED:  # Cp and Cpl have no meaning for it: not listed
        lines = [(f"Cpu {_index_text(cap.cpu)} (one-sided Cpk, upper limit)", None)]
    else:
        lines = [(f"Cp {_index_text(cap.cp)}   Cpk {_index_text(cap.cpk)}", None),
                 (f"Cpu {_index_text(cap.cpu)}   Cpl {_index_text(cap.cpl)}", None)]
    if cap.normality_p is not None and cap.cpk.value is not None:
        lines.append((f"normality: Shapiro-Wilk p = {cap.normality_p:.2g}", None))
    if cap.cpk.value is None:
        lines.append((f"capability: {cap.cpk.reason}", None))
    elif cap.cp.value is None and a.series.kind is not Kind.BOUNDED:
        lines.append((f"capability: {cap.cp.reason}", None))
    lines.append(("drift: " + (d.reason or d.text), DRIFT_RGB if d.warning else None))
    return lines


def _rule_lines(a: Analysis) -> list[tuple[str, RGB | None]]:
    rules = a.series.kind.rules
    if not rules:
        return [("run rules: not applied", None)]
    which = "" if rules == (1, 2, 3, 4) else f" ({', '.join(f'R{r}' for r in rules)} only)"
    words = [f"  R{v.rule}: {v.text}" for v in a.violations]
    if len(words) > WORDS_ROWS:
        words = words[:WORDS_ROWS - 1] + [f"  … and {len(words) - WORDS_ROWS + 1} more"]
    head = f"run rules{which}: none broken" if not words else f"run rules{which} broken:"
    return [(head, None)] + [(w, FLAG_RGB) for w in words]
