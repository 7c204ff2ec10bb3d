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

**Kinds of quantity** (:class:`Kind`, a property of the series, not of its name): what SPC may
say about a quantity depends on what it is.

* ``MEASURED``, a value of the part against its tolerance limits (a diameter): all of the above.
* ``BOUNDED``, a value that is >= 0 by definition with an upper limit only (max |d|, a profile,
  flatness or position value): all of the above, its one index Cpu = (USL - X̄) / (3 sigma) (a
  one-sided Cpk against the upper limit; 0 is a natural bound, not a specification limit, so no
  Cpl). Such a value is skewed near its bound (a zone width of a good process piles up at 0, the
  largest of many |d| follows an extreme-value law), and Cpu is a normal-theory index: it is given
  only when the Shapiro-Wilk test (D'Agostino-Pearson beyond 5000 values) does not reject
  normality at ``NORMALITY_ALPHA`` (0.01); otherwise it is None with the p value in its reason,
  rather than a number that misstates the tail (Minitab would fit a non-normal law there; a lot
  is rarely long enough to choose one).
* ``COUNT``, a count per part (the points out of tolerance): a c chart (Montgomery §7.3.1):
  centre c̄ = mean count, sigma = sqrt(c̄) (Poisson), UCL = c̄ + 3 sqrt(c̄), LCL = max(0, c̄ - 3
  sqrt(c̄)); no capability index, no moving-range chart, no trend test, and rule 1 only: rules 2-4
  count runs, and a count that is mostly 0 makes runs by chance (nine zeros in a row below
  c̄ = 0.3 happen in 7 % of windows).
* ``FORCED``, a quantity the fit forces to ~0 (the mean deviation after a least-squares fit,
  :func:`mean_deviation_kind`): information only. Its values and mean are kept for the chart,
  but no control limits, capability index, run rule or trend is derived from it: they would
  judge the solver's tolerance (a lot's mean d of 1e-6 mm with sigma 4e-6 mm had Cpk 20,000).

Undefined numbers are None with the reason in words (:class:`Index`, :class:`ControlChart`);
:func:`to_json` gives all of it as a NaN-free dict.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import Enum

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
NORMALITY_ALPHA = 0.01
"""A BOUNDED quantity's Cpu is given only when normality is not rejected at this level."""
SHAPIRO_MAX = 5000
"""Above this many values scipy's Shapiro-Wilk p value is not accurate: D'Agostino-Pearson."""
RULES = {1: "one point beyond 3 sigma", 2: "9 points in a row on one side of the centre",
         3: "6 points in a row rising or falling", 4: "14 points in a row alternating"}


class Kind(str, Enum):
    """What a tracked quantity is (module docstring, "Kinds of quantity"): MEASURED, BOUNDED
    (>= 0, upper limit only), COUNT (a whole number per part) or FORCED (set to ~0 by the fit:
    information only)."""

    MEASURED = "measured"
    BOUNDED = "bounded"
    COUNT = "count"
    FORCED = "forced"

    @property
    def rules(self) -> tuple[int, ...]:
        """Nelson's rules applied to it."""
        return {Kind.COUNT: (1,), Kind.FORCED: ()}.get(self, (1, 2, 3, 4))

    @property
    def process(self) -> bool:
        """Whether it is judged as a process variable (I-MR limits, capability, trend)."""
        return self in (Kind.MEASURED, Kind.BOUNDED)

    @property
    def note(self) -> str:
        """What the reader must know about its chart, in words ("" when nothing)."""
        return {Kind.COUNT: "a count per part: c chart, rule 1 only, no capability index",
                Kind.FORCED: "information only: the fit sets it to ~0, so no control limits, "
                             "capability index, run rule or trend is derived from it"
                }.get(self, "")


def mean_deviation_kind(fit: str) -> Kind:
    """What the mean signed deviation over a part's points is after the pose fit ``fit``.

    "lsq": FORCED. The least-squares fit leaves its residuals orthogonal to every motion of the
    part; where a motion moves every point along its normal alike (a translation along the
    normal of a plate, or of a fairing measured from one side) the mean deviation is therefore
    zero up to the solver's tolerance. On a part measured all round no motion does that, and the
    mean keeps a uniform offset; which case holds depends on the points' normals, which a lot's
    summary does not carry, so the mean is information only in both: the side that never
    invents a capability. "minimax": MEASURED (that fit centres the largest excursions in the
    zone, not the mean).
    """
    kinds = {"lsq": Kind.FORCED, "minimax": Kind.MEASURED}
    if fit not in kinds:
        raise SettingsError(f"unknown fit {fit!r}: expected one of {', '.join(kinds)}")
    return kinds[fit]


@dataclass(frozen=True, eq=False)
class Series:
    """One characteristic over a lot, in measurement order.

    values : (n,) float, in ``unit``; NaN for a part without a value. serials : n names of the
    parts. lower, upper : the tolerance limits in ``unit``, either may be None (max |d| has an
    upper limit only). kind : what the quantity is (:class:`Kind`): a BOUNDED one has values
    >= 0 and no lower limit, a COUNT whole numbers >= 0.
    """

    name: str
    unit: str
    values: np.ndarray
    serials: tuple[str, ...]
    lower: float | None = None
    upper: float | None = None
    kind: Kind = Kind.MEASURED

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
        object.__setattr__(self, "kind", Kind(self.kind))
        self._check_kind(v[~np.isnan(v)])

    def _check_kind(self, present: np.ndarray) -> None:
        if self.kind in (Kind.BOUNDED, Kind.COUNT) and np.any(present < 0):
            raise InputError(f"{self.name}: a {self.kind.value} quantity cannot be negative")
        if self.kind is Kind.BOUNDED and self.lower is not None:
            raise SettingsError(f"{self.name}: a bounded quantity (>= 0) has an upper limit only")
        if self.kind is Kind.COUNT and np.any(present != np.round(present)):
            raise InputError(f"{self.name}: a count must hold whole numbers")


@dataclass(frozen=True, eq=False)
class ControlChart:
    """The I-MR chart (a COUNT's c chart: ``sigma_within`` is then the Poisson sigma sqrt(c̄) and
    the moving-range fields are None; a FORCED quantity's chart has its centre only). Limits are
    None when undefined (``reason`` says why: fewer than two values, no variation, information
    only). ``moving_ranges`` (n,) has NaN where a part has no value or no predecessor with
    one."""

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
    """The indices; ``normality_p`` the normality test's p value where one was made (a BOUNDED
    quantity's, see the module docstring)."""

    cp: Index
    cpk: Index
    cpu: Index
    cpl: Index
    confidence: float
    normality_p: float | None = None


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
    """The whole SPC of one characteristic, as its kind allows (see the module docstring)."""
    if not isinstance(series, Series):
        series = Series(*series)
    v, lo, hi, kind = series.values, series.lower, series.upper, series.kind
    if kind is Kind.COUNT:
        chart = c_chart(v)
    elif kind is Kind.FORCED:
        chart = information_chart(v, kind.note)
    else:
        chart = individuals_chart(v)
    if kind.process:
        cap = capability(chart, lo, hi, confidence)
        if kind is Kind.BOUNDED:
            cap = _normal_or_none(cap, v)
        drift = trend(v, lo, hi, alpha=drift_alpha, horizon=horizon)
    else:
        none = Index(None, None, kind.note)
        cap = Capability(none, none, none, none, confidence)
        drift = Drift(None, None, None, False, None, None, False, "", kind.note)
    viol = tuple(run_rules(v, chart.centre, chart.sigma_within, kind.rules))
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


def c_chart(counts: np.ndarray) -> ControlChart:
    """The c chart of ``counts`` (n,) (whole numbers, NaN skipped): c̄ ± 3 sqrt(c̄), LCL at
    least 0 (module docstring)."""
    v = np.asarray(counts, dtype=float)
    x = v[~np.isnan(v)]
    n = len(x)
    mr = np.full(len(v), np.nan)
    if n < 2:
        return ControlChart(n, float(x[0]) if n else None, None, None, None, None, None, None,
                            None, mr, "no values" if n == 0 else "one value: no control limits")
    c = float(np.mean(x))
    std = float(np.std(x, ddof=1))
    if c == 0:
        return ControlChart(n, 0.0, None, None, None, None, None, None, std, mr,
                            "every count is 0: nothing to chart")
    sigma = math.sqrt(c)
    return ControlChart(n, c, sigma, c + 3 * sigma, max(0.0, c - 3 * sigma), None, None, None,
                        std, mr)


def information_chart(values: np.ndarray, note: str) -> ControlChart:
    """The values' centre and spread without limits (a FORCED quantity: information only)."""
    chart = individuals_chart(values)
    return replace(chart, sigma_within=None, ucl=None, lcl=None, mr_centre=None, mr_ucl=None,
                   mr_lcl=None, reason=note)


def normality_p(values: np.ndarray) -> float | None:
    """The p value of the Shapiro-Wilk test of normality of ``values`` (n,) (NaN skipped;
    D'Agostino-Pearson beyond SHAPIRO_MAX values); None for fewer than 3 values or no spread."""
    x = np.asarray(values, dtype=float)
    x = x[~np.isnan(x)]
    if len(x) < 3 or np.all(x == x[0]):
        return None
    test = stats.shapiro if len(x) <= SHAPIRO_MAX else stats.normaltest
    return float(test(x).pvalue)


def _normal_or_none(cap: Capability, values: np.ndarray) -> Capability:
    """A BOUNDED quantity's capability: its indices only when normality is not rejected."""
    if cap.cpk.value is None:
        return cap
    p = normality_p(values)
    if p is None or p >= NORMALITY_ALPHA:
        return replace(cap, normality_p=p)
    none = Index(None, None, f"values not normal (Shapiro-Wilk p = {p:.2g} < "
                             f"{NORMALITY_ALPHA:g}): a normal-theory index would misstate the "
                             "tail")
    return Capability(none, none, none, none, cap.confidence, p)


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
    if m is None:
        raise ValueError("a control chart with a sigma_within must have a centre")

    def one_sided(value: float) -> Index:
        return Index(value, cpk_interval(value, n, confidence))

    cpu_value = None if upper is None else (upper - m) / (3 * s)
    cpl_value = None if lower is None else (m - lower) / (3 * s)
    cpu = Index(None, None, "no upper limit") if cpu_value is None else one_sided(cpu_value)
    cpl = Index(None, None, "no lower limit") if cpl_value is None else one_sided(cpl_value)
    if upper is not None and lower is not None and cpu_value is not None \
            and cpl_value is not None:
        cp_value = (upper - lower) / (6 * s)
        cp = Index(cp_value, cp_interval(cp_value, n, confidence))
        cpk = one_sided(min(cpu_value, cpl_value))
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


def run_rules(values: np.ndarray, centre: float | None, sigma: float | None,
              rules: tuple[int, ...] = (1, 2, 3, 4)) -> list[Violation]:
    """Nelson's ``rules`` (of 1-4) on ``values`` (n,) with NaN skipped (a run goes on across a
    part without a value); rule 1 needs sigma, rule 2 the centre. Sorted by rule, then
    position."""
    v = np.asarray(values, dtype=float)
    idx = np.flatnonzero(~np.isnan(v))
    x = v[idx]
    out: list[Violation] = []
    if sigma and 1 in rules:  # consecutive points beyond the same limit are one violation
        for sign, word in ((1, "above the upper"), (-1, "below the lower")):
            for a, b in _runs(sign * (x - centre) > 3 * sigma):
                out.append(_run_violation(1, idx[a:b + 1], f"{word} control limit"))
    if centre is not None and 2 in rules:
        for sign, word in ((1, "above"), (-1, "below")):
            for a, b in _runs(np.sign(x - centre) == sign):
                if b - a + 1 >= RULE_RUN[2]:
                    out.append(_run_violation(2, idx[a:b + 1], f"in a row {word} the centre line"))
    steps = np.sign(np.diff(x))
    for sign, word in ((1, "rising"), (-1, "falling")):
        for a, b in _runs(steps == sign) if 3 in rules else ():
            if b - a + 2 >= RULE_RUN[3]:
                out.append(_run_violation(3, idx[a:b + 2], f"in a row {word}"))
    for a, b in _runs(steps[:-1] * steps[1:] < 0) if 4 in rules else ():
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
        "name": s.name, "unit": s.unit, "kind": s.kind.value, "note": s.kind.note,
        "parts": len(s.values), "n": c.n,
        "lower": s.lower, "upper": s.upper, "out_of_tolerance": a.out_of_tolerance,
        "individuals": {"centre": _num(c.centre), "sigma_within": _num(c.sigma_within),
                        "ucl": _num(c.ucl), "lcl": _num(c.lcl), "reason": c.reason},
        "moving_range": {"centre": _num(c.mr_centre), "ucl": _num(c.mr_ucl),
                         "lcl": _num(c.mr_lcl)},
        "overall": {"mean": _num(c.centre), "std": _num(c.std_overall)},
        "capability": {"confidence": a.capability.confidence, "sigma": "within",
                       "normality_p": _num(a.capability.normality_p),
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
