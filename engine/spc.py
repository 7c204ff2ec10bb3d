"""Statistical process control of a lot: one characteristic's values in measurement order judged
as a process (numbers only; the charts are drawn by :mod:`reports.spc`).

For each characteristic (:class:`Series`: its values in measurement order, NaN for a part without a
value, e.g. one whose inspection failed, and its tolerance limits, either of which may be None):

* **Individuals and moving-range chart (I-MR)** (Montgomery, *Introduction to Statistical
  Quality Control*, 6th ed., §6.4): centre X̄ = mean of the values; moving ranges
  MR_i = |x_i - x_(i-1)| of consecutive values; sigma_within = MR̄ / d2 (d2 = 1.128, subgroups
  of two); control limits X̄ ± 3 sigma_within; the MR chart's centre MR̄, UCL = D4 MR̄
  (D4 = 3.267), LCL = D3 MR̄ = 0. Also the overall mean and sample standard deviation (n - 1).
  A NaN part is skipped for every statistic (the moving range joins the values either side of it:
  a failed inspection is not a sample of the process) but keeps its position on the chart.
* **Capability** from sigma_within (the chart's short-term sigma, Minitab's "potential (within)"
  convention): Cp = (USL - LSL) / (6 sigma), Cpu = (USL - X̄) / (3 sigma),
  Cpl = (X̄ - LSL) / (3 sigma), Cpk = min(Cpu, Cpl), or the one index a one-sided limit gives
  (Cp is undefined then). 95 % confidence intervals (Montgomery §8.3.5, after Bissell 1990,
  "How reliable is your capability index?", Applied Statistics 39, 331-340) with n values:

  - Cp:  [Cp sqrt(chi2_(a/2, n-1) / (n-1)),  Cp sqrt(chi2_(1-a/2, n-1) / (n-1))], chi2_q the
    q-quantile of the chi-square distribution with n - 1 degrees of freedom;
  - Cpk, Cpu, Cpl (Bissell's normal approximation):
    Cpk ± z_(1-a/2) sqrt(1 / (9 n) + Cpk² / (2 (n - 1))), which is Montgomery's
    Cpk [1 ± z sqrt(1 / (9 n Cpk²) + 1 / (2 (n - 1)))] written so that it holds at Cpk <= 0.

  Both intervals are derived for the sample standard deviation (n - 1 degrees of freedom); the
  moving-range sigma has fewer effective degrees of freedom, so with it they are a little narrow.
* **Run rules**: Nelson's tests 1-4 (L. S. Nelson, "The Shewhart control chart - tests for
  special causes", J. Quality Technology 16 (1984) 237-239) on the individuals chart:

  1. one point beyond a control limit (more than 3 sigma_within from the centre);
  2. nine points in a row on one side of the centre line (a point on it ends the run);
  3. six points in a row steadily rising or steadily falling (an equal neighbour ends the run);
  4. fourteen points in a row alternating up and down.

  Each :class:`Violation` is one maximal run (or, for rule 1, one point), with the indices of all
  its points and a sentence naming the parts by their 1-based position in the lot.
* **Drift**: the least-squares line of value against position in the lot, its slope tested
  against zero by the t test (t = b / se(b), n - 2 degrees of freedom, two-sided); when the slope
  is significant (p < ``alpha``, 0.01) and points towards a tolerance limit, the number of
  further parts after which the line reaches that limit; a warning when that is within
  ``horizon`` parts (default: as many parts again as the lot has).

Undefined numbers are None with the reason in words (:class:`Index`, :class:`ControlChart`);
:func:`to_json` gives all of it as a NaN-free dict.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from .errors import InputError, SettingsError

D2 = 1.128
"""E(R) / sigma for the range of two normal values (the moving range of an individuals chart)."""
D4 = 3.267
"""UCL factor of the moving-range chart, subgroups of two (D3 = 0: its LCL is 0)."""
CONFIDENCE = 0.95
MIN_CAPABILITY_VALUES = 3
"""Capability needs at least this many values (two give one moving range: a sigma, and indices
with intervals wider than any conclusion)."""
DRIFT_ALPHA = 0.01
RULE_RUN = {2: 9, 3: 6, 4: 14}
"""Points in a row that break Nelson's rules 2, 3 and 4."""
RULES = {1: "one point beyond 3 sigma", 2: "9 points in a row on one side of the centre",
         3: "6 points in a row rising or falling", 4: "14 points in a row alternating"}


@dataclass(frozen=True, eq=False)
class Series:
    """One characteristic over a lot, in measurement order.

    values : (n,) float, in ``unit``; NaN for a part without a value. serials : n names of the
    parts. lower, upper : the tolerance limits in ``unit``, either may be None (max |d| has an
    upper limit only).
    """

    name: str
    unit: str
    values: np.ndarray
    serials: tuple[str, ...]
    lower: float | None = None
    upper: float | None = None

    def __post_init__(self):
        v = np.array(self.values, dtype=float).reshape(-1)
        if np.isinf(v).any():
            raise InputError(f"{self.name}: values must be finite numbers or NaN (no value)")
        v.setflags(write=False)
        object.__setattr__(self, "values", v)
        object.__setattr__(self, "serials", tuple(str(s) for s in self.serials))
        if len(self.serials) != len(v):
            raise InputError(f"{self.name}: {len(v)} values but {len(self.serials)} serials")
        for side in ("lower", "upper"):
            limit = getattr(self, side)
            if limit is not None:
                if not math.isfinite(limit):
                    raise SettingsError(f"{self.name}: the {side} limit must be a finite number")
                object.__setattr__(self, side, float(limit))
        if self.lower is not None and self.upper is not None and not self.lower < self.upper:
            raise SettingsError(f"{self.name}: the tolerance zone is empty: lower limit "
                                f"{self.lower:g} is not below upper limit {self.upper:g}")


@dataclass(frozen=True, eq=False)
class ControlChart:
    """The I-MR chart. Limits are None when undefined (``reason`` says why: fewer than two values,
    or no variation). ``moving_ranges`` (n,) has NaN where a part has no value or no predecessor
    with one."""

    n: int
    centre: float | None
    sigma_within: float | None
    ucl: float | None
    lcl: float | None
    mr_centre: float | None
    mr_ucl: float | None
    mr_lcl: float | None
    std_overall: float | None
    moving_ranges: np.ndarray = field(repr=False)
    reason: str | None = None


@dataclass(frozen=True)
class Index:
    """A capability index with its confidence interval; None and the reason when undefined."""

    value: float | None
    ci: tuple[float, float] | None = None
    reason: str | None = None


@dataclass(frozen=True)
class Capability:
    cp: Index
    cpk: Index
    cpu: Index
    cpl: Index
    confidence: float


@dataclass(frozen=True)
class Violation:
    """One breach of a run rule: the rule's number, the 0-based indices into the lot's parts of
    every point involved, and a sentence ("6 points in a row rising (parts 12-17)")."""

    rule: int
    indices: tuple[int, ...]
    text: str


@dataclass(frozen=True)
class Drift:
    """The least-squares trend of value against position (slope in unit per part). ``limit`` is
    the side ("upper"/"lower") the significant trend heads for and ``parts_to_limit`` how many
    parts after the last one its line reaches it (0: already there); ``warning`` when that is
    within the horizon. ``reason`` when no trend could be fitted."""

    slope: float | None
    intercept: float | None
    p_value: float | None
    significant: bool
    limit: str | None
    parts_to_limit: int | None
    warning: bool
    text: str
    reason: str | None = None


@dataclass(frozen=True)
class Analysis:
    series: Series
    chart: ControlChart
    capability: Capability
    violations: tuple[Violation, ...]
    drift: Drift
    out_of_tolerance: int

    @property
    def flags(self) -> list[str]:
        """Short flags for a table: each broken rule with its count, the drift, parts out."""
        rules = sorted({v.rule for v in self.violations})
        out = [f"R{r}" + (f"×{c}" if (c := sum(v.rule == r for v in self.violations)) > 1 else "")
               for r in rules]
        if self.drift.warning:
            out.append(f"drift→{self.drift.limit} in {self.drift.parts_to_limit}")
        if self.out_of_tolerance:
            out.append(f"{self.out_of_tolerance} out of tol.")
        return out


def analyse(series: Series, *, confidence: float = CONFIDENCE, drift_alpha: float = DRIFT_ALPHA,
            horizon: int | None = None) -> Analysis:
    """The whole SPC of one characteristic (see the module docstring)."""
    if not isinstance(series, Series):
        series = Series(*series)
    v, lo, hi = series.values, series.lower, series.upper
    chart = individuals_chart(v)
    cap = capability(chart, lo, hi, confidence)
    viol = tuple(run_rules(v, chart.centre, chart.sigma_within))
    drift = trend(v, lo, hi, alpha=drift_alpha, horizon=horizon)
    present = v[~np.isnan(v)]
    out = int(np.sum(present > hi)) if hi is not None else 0
    out += int(np.sum(present < lo)) if lo is not None else 0
    return Analysis(series, chart, cap, viol, drift, out)


def individuals_chart(values: np.ndarray) -> ControlChart:
    """The I-MR chart of ``values`` (n,) float, NaN skipped (module docstring for the formulas)."""
    v = np.asarray(values, dtype=float)
    idx = np.flatnonzero(~np.isnan(v))
    x = v[idx]
    n = len(x)
    mr = np.full(len(v), np.nan)
    mr[idx[1:]] = np.abs(np.diff(x))
    if n == 0:
        return ControlChart(0, None, None, None, None, None, None, None, None, mr, "no values")
    # Equal values: the centre is that value exactly (a rounded mean would put them all on one
    # side of the centre line and break rule 2).
    centre = float(x[0]) if np.all(x == x[0]) else float(np.mean(x))
    if n == 1:
        return ControlChart(1, centre, None, None, None, None, None, None, None, mr,
                            "one value: no moving range, no control limits")
    std = float(np.std(x, ddof=1))
    mr_bar = float(np.mean(np.abs(np.diff(x))))
    if mr_bar == 0:
        return ControlChart(n, centre, None, None, None, 0.0, None, None, std, mr,
                            "all values are equal: no variation, control limits undefined")
    sigma = mr_bar / D2
    return ControlChart(n, centre, sigma, centre + 3 * sigma, centre - 3 * sigma, mr_bar,
                        D4 * mr_bar, 0.0, std, mr)


def cp_interval(cp: float, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The chi-square confidence interval of Cp estimated from n values (module docstring)."""
    a, dof = 1.0 - confidence, n - 1
    return (cp * math.sqrt(float(stats.chi2.ppf(a / 2, dof)) / dof),
            cp * math.sqrt(float(stats.chi2.ppf(1 - a / 2, dof)) / dof))


def cpk_interval(cpk: float, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Bissell's approximate confidence interval of Cpk (or Cpu, Cpl) from n values."""
    z = float(stats.norm.ppf(0.5 + confidence / 2))
    half = z * math.sqrt(1.0 / (9 * n) + cpk * cpk / (2 * (n - 1)))
    return cpk - half, cpk + half


def capability(chart: ControlChart, lower: float | None, upper: float | None,
               confidence: float = CONFIDENCE) -> Capability:
    """Cp, Cpk, Cpu, Cpl of the chart's centre and sigma_within against the limits."""
    if chart.sigma_within is None or chart.n < MIN_CAPABILITY_VALUES:
        why = f"no sigma: {chart.reason}" if chart.sigma_within is None else \
            f"{chart.n} values: capability needs at least {MIN_CAPABILITY_VALUES}"
        none = Index(None, None, why)
        return Capability(none, none, none, none, confidence)
    n, m, s = chart.n, chart.centre, chart.sigma_within

    def one_sided(value: float) -> Index:
        return Index(value, cpk_interval(value, n, confidence))

    cpu = one_sided((upper - m) / (3 * s)) if upper is not None else Index(
        None, None, "no upper limit")
    cpl = one_sided((m - lower) / (3 * s)) if lower is not None else Index(
        None, None, "no lower limit")
    if upper is not None and lower is not None:
        cp_value = (upper - lower) / (6 * s)
        cp = Index(cp_value, cp_interval(cp_value, n, confidence))
        cpk = one_sided(min(cpu.value, cpl.value))
    else:
        cp = Index(None, None, "Cp needs both tolerance limits")
        cpk = cpu if upper is not None else cpl
        if lower is None and upper is None:
            cpk = Index(None, None, "no tolerance limits")
    return Capability(cp, cpk, cpu, cpl, confidence)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) of each maximal run of True in a 1-D bool array."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), (np.flatnonzero(d == -1) - 1).tolist()))


def _parts(indices) -> str:
    first, last = indices[0] + 1, indices[-1] + 1
    return f"part {first}" if first == last else f"parts {first}-{last}"


def run_rules(values: np.ndarray, centre: float | None,
              sigma: float | None) -> list[Violation]:
    """Nelson's rules 1-4 on ``values`` (n,) with NaN skipped (a run goes on across a part
    without a value); rule 1 needs sigma, rule 2 the centre. Sorted by rule, then position."""
    v = np.asarray(values, dtype=float)
    idx = np.flatnonzero(~np.isnan(v))
    x = v[idx]
    out: list[Violation] = []
    if sigma:  # consecutive points beyond the same limit are one violation
        for sign, word in ((1, "above the upper"), (-1, "below the lower")):
            for a, b in _runs(sign * (x - centre) > 3 * sigma):
                out.append(_run_violation(1, idx[a:b + 1], f"{word} control limit"))
    if centre is not None:
        for sign, word in ((1, "above"), (-1, "below")):
            for a, b in _runs(np.sign(x - centre) == sign):
                if b - a + 1 >= RULE_RUN[2]:
                    out.append(_run_violation(2, idx[a:b + 1], f"in a row {word} the centre line"))
    steps = np.sign(np.diff(x))
    for sign, word in ((1, "rising"), (-1, "falling")):
        for a, b in _runs(steps == sign):
            if b - a + 2 >= RULE_RUN[3]:
                out.append(_run_violation(3, idx[a:b + 2], f"in a row {word}"))
    for a, b in _runs(steps[:-1] * steps[1:] < 0):
        if b - a + 3 >= RULE_RUN[4]:
            out.append(_run_violation(4, idx[a:b + 3], "in a row alternating up and down"))
    return sorted(out, key=lambda w: (w.rule, w.indices[0]))


def _run_violation(rule: int, indices: np.ndarray, words: str) -> Violation:
    ind = tuple(int(i) for i in indices)
    if len(ind) == 1:  # rule 1 only
        return Violation(rule, ind, f"{_parts(ind)} {words} (beyond 3 sigma)")
    return Violation(rule, ind, f"{len(ind)} points {'in a row ' * (rule == 1)}{words} "
                                f"({_parts(ind)})")


def trend(values: np.ndarray, lower: float | None, upper: float | None, *,
          alpha: float = DRIFT_ALPHA, horizon: int | None = None) -> Drift:
    """The least-squares drift of ``values`` (n,) against their position in the lot (NaN
    skipped) towards the limits; see the module docstring for the test and the warning."""
    v = np.asarray(values, dtype=float)
    t = np.flatnonzero(~np.isnan(v)).astype(float)
    x = v[~np.isnan(v)]
    if len(x) < 3:
        return Drift(None, None, None, False, None, None, False, "",
                     f"{len(x)} values: a trend needs at least 3")
    tm, xm = t.mean(), x.mean()
    sxx = float(np.sum((t - tm) ** 2))
    slope = float(np.sum((t - tm) * (x - xm)) / sxx)
    intercept = float(xm - slope * tm)
    resid = x - (intercept + slope * t)
    se = math.sqrt(float(np.sum(resid ** 2)) / (len(x) - 2) / sxx)
    if se > 0:
        p = float(2 * stats.t.sf(abs(slope) / se, len(x) - 2))
    else:  # the values lie on a line
        p = 0.0 if slope != 0 else 1.0
    significant = p < alpha and slope != 0
    limit, k = _heading(slope, intercept + slope * (len(v) - 1), lower, upper) if significant \
        else (None, None)
    reach = len(v) if horizon is None else horizon
    warning = k is not None and k <= reach
    return Drift(slope, intercept, p, significant, limit, k, warning,
                 _drift_text(slope, p, significant, limit, k))


def _heading(slope: float, last: float, lower: float | None,
             upper: float | None) -> tuple[str | None, int | None]:
    """The limit the line heads for and after how many more parts (0: the line at the last
    part is already at or beyond it) it reaches it."""
    limit = upper if slope > 0 else lower
    if limit is None:
        return None, None
    return ("upper" if slope > 0 else "lower"), max(0, math.ceil((limit - last) / slope))


def _drift_text(slope, p, significant, limit, k) -> str:
    word = "rising" if slope > 0 else "falling"
    if not significant:
        return f"no significant trend (p = {p:.2g})"
    text = f"{word} {abs(slope):.3g} per part (p = {p:.1g})"
    if limit is None:
        return text + ", away from the tolerance limits"
    if k == 0:
        return text + f"; the trend has reached the {limit} limit"
    return text + f"; at this rate the {limit} limit is reached in {k} more part" + \
        ("s" if k != 1 else "")


def _num(x) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def _index_json(i: Index) -> dict:
    return {"value": _num(i.value), "ci": None if i.ci is None else [_num(c) for c in i.ci],
            "reason": i.reason}


def to_json(a: Analysis) -> dict:
    """The analysis as a JSON-ready dict, no NaN (None where undefined). Indices are 0-based
    positions in the lot."""
    s, c, d = a.series, a.chart, a.drift
    return {
        "name": s.name, "unit": s.unit, "parts": len(s.values), "n": c.n,
        "lower": s.lower, "upper": s.upper, "out_of_tolerance": a.out_of_tolerance,
        "individuals": {"centre": _num(c.centre), "sigma_within": _num(c.sigma_within),
                        "ucl": _num(c.ucl), "lcl": _num(c.lcl), "reason": c.reason},
        "moving_range": {"centre": _num(c.mr_centre), "ucl": _num(c.mr_ucl),
                         "lcl": _num(c.mr_lcl)},
        "overall": {"mean": _num(c.centre), "std": _num(c.std_overall)},
        "capability": {"confidence": a.capability.confidence, "sigma": "within",
                       **{k: _index_json(getattr(a.capability, k))
                          for k in ("cp", "cpk", "cpu", "cpl")}},
        "violations": [{"rule": w.rule, "indices": list(w.indices),
                        "serials": [s.serials[i] for i in w.indices], "text": w.text}
                       for w in a.violations],
        "drift": {"slope": _num(d.slope), "intercept": _num(d.intercept),
                  "p_value": _num(d.p_value), "significant": d.significant, "limit": d.limit,
                  "parts_to_limit": d.parts_to_limit, "warning": d.warning, "text": d.text,
                  "reason": d.reason},
        "flags": a.flags,
    }
