"""Statistical process control of a lot (engine.spc, reports.spc): the I-MR chart and capability
indices against hand computation and Montgomery's published examples, each of Nelson's rules 1-4
on a series built to break exactly it (and one point short of it), the drift warning on a lot that
passes but heads for a limit, parts without a value, one-sided limits, too few values, a constant
series, and the PDF (pages, text, same bytes twice)."""

import json
import math
import re
import subprocess

import numpy as np
import pytest

from engine import spc
from engine.errors import InputError, SettingsError

Z975 = 1.959964  # standard normal 97.5 % point (table)


def series(values, lower=None, upper=None, name="x"):
    values = np.asarray(values, dtype=float)
    return spc.Series(name, "mm", values, [f"S{k:03d}" for k in range(len(values))], lower, upper)


# --- I-MR chart and capability ---------------------------------------------------------------

def test_chart_and_capability_of_a_small_series_by_hand():
    a = spc.analyse(series([10.0, 12.0, 11.0, 14.0, 13.0], lower=5.0, upper=17.0))
    # By hand: mean 60/5 = 12; moving ranges 2, 1, 3, 1 -> MR̄ 7/4; sigma = MR̄ / d2 (1.128).
    sigma = 1.75 / 1.128
    c = a.chart
    assert c.n == 5 and c.centre == pytest.approx(12.0)
    assert c.mr_centre == pytest.approx(1.75)
    assert c.sigma_within == pytest.approx(sigma)
    assert (c.lcl, c.ucl) == pytest.approx((12 - 3 * sigma, 12 + 3 * sigma))
    assert (c.mr_lcl, c.mr_ucl) == pytest.approx((0.0, 3.267 * 1.75))
    # sample std: squared deviations 4 + 0 + 1 + 4 + 1 = 10 over n - 1 = 4
    assert c.std_overall == pytest.approx(math.sqrt(10 / 4))
    cap = a.capability
    cp, cpu, cpl = 12 / (6 * sigma), 5 / (3 * sigma), 7 / (3 * sigma)
    assert (cap.cp.value, cap.cpu.value, cap.cpl.value) == pytest.approx((cp, cpu, cpl))
    assert cap.cpk.value == pytest.approx(cpu)  # nearer the upper limit
    # Cp: chi-square interval with 4 degrees of freedom; table values chi2_0.025 = 0.4844,
    # chi2_0.975 = 11.143.
    assert cap.cp.ci == pytest.approx((cp * math.sqrt(0.4844 / 4), cp * math.sqrt(11.143 / 4)),
                                      rel=2e-4)
    # Cpk: Bissell, Cpk [1 -+ z sqrt(1 / (9 n Cpk²) + 1 / (2 (n - 1)))]
    half = Z975 * math.sqrt(1 / (9 * 5 * cpu ** 2) + 1 / (2 * 4))
    assert cap.cpk.ci == pytest.approx((cpu * (1 - half), cpu * (1 + half)), rel=1e-5)
    assert a.violations == () and a.out_of_tolerance == 0


def test_individuals_chart_matches_montgomery_example():
    """Montgomery, Introduction to Statistical Quality Control (6th ed.), Example 6.5: the cost
    of processing mortgage loan applications over 20 weeks; published centre 300.5,
    MR̄ 7.79, UCL 321.22, LCL 279.78, MR chart UCL 25.45."""
    cost = [310, 288, 297, 298, 307, 303, 294, 297, 308, 306,
            294, 299, 297, 299, 314, 295, 293, 306, 301, 304]
    c = spc.individuals_chart(np.array(cost, dtype=float))
    assert round(c.centre, 2) == 300.5 and round(c.mr_centre, 2) == 7.79
    assert (round(c.ucl, 2), round(c.lcl, 2)) == (321.22, 279.78)
    assert round(c.mr_ucl, 2) == 25.45


def test_capability_intervals_match_montgomery_examples():
    """Montgomery (6th ed.) §8.3.5: Cp = 2.29 from n = 20 gives 1.57 <= Cp <= 3.01; Cpk = 1.33
    from n = 20 gives 0.88 <= Cpk <= 1.78 (Bissell's approximation)."""
    assert [round(v, 2) for v in spc.cp_interval(2.29, 20)] == [1.57, 3.01]
    assert [round(v, 2) for v in spc.cpk_interval(1.33, 20)] == [0.88, 1.78]


def test_one_sided_limit_gives_cpu_only():
    a = spc.analyse(series([0.020, 0.024, 0.021, 0.025, 0.022, 0.023], upper=0.05))
    sigma = ((0.004 + 0.003 + 0.004 + 0.003 + 0.001) / 5) / 1.128
    cap = a.capability
    assert cap.cp.value is None and "both" in cap.cp.reason
    assert cap.cpl.value is None and cap.cpl.reason
    assert cap.cpu.value == pytest.approx((0.05 - 0.0225) / (3 * sigma))
    assert cap.cpk == cap.cpu and cap.cpk.ci is not None
    lower_only = spc.analyse(series([1.0, 1.2, 0.9, 1.1], lower=0.0)).capability
    assert lower_only.cpk.value == pytest.approx(1.05 / (3 * (0.2 + 0.3 + 0.2) / 3 / 1.128))


# --- kinds of quantity -----------------------------------------------------------------------

def test_a_quantity_the_fit_forces_to_zero_is_information_only():
    """The issue's lot: mean d after a least-squares fit, ~1e-6 mm with µm noise, against a
    +-0.25 mm zone. As a process variable it gets Cpk in the tens of thousands and run rules on
    the noise; as FORCED (what mean_deviation_kind says of the lsq fit) it keeps its values and
    mean, and nothing is judged."""
    rng = np.random.default_rng(22)
    x = rng.normal(1e-6, 4e-6, 20)
    x[5:14] = np.abs(x[5:14]) + 6e-6  # nine in a row above the mean: rule 2 on noise
    x[16] = 4e-5
    s = spc.Series("mean d", "mm", x, [f"SN{k}" for k in range(20)], -0.25, 0.25)
    as_process = spc.analyse(s)
    assert as_process.capability.cpk.value > 1000 and {2, 1} <= {v.rule for v in
                                                                  as_process.violations}
    assert spc.mean_deviation_kind("lsq") is spc.Kind.FORCED
    forced = spc.analyse(spc.Series(*[getattr(s, f) for f in ("name", "unit", "values",
                                                              "serials", "lower", "upper")],
                                    spc.mean_deviation_kind("lsq")))
    c = forced.chart
    assert c.centre == pytest.approx(sum(x) / 20) and c.n == 20
    assert (c.ucl, c.lcl, c.sigma_within, c.mr_ucl) == (None, None, None, None)
    assert "information only" in c.reason
    cap = forced.capability
    assert [i.value for i in (cap.cp, cap.cpk, cap.cpu, cap.cpl)] == [None] * 4
    assert "information only" in cap.cpk.reason
    assert forced.violations == () and forced.flags == []
    assert forced.drift.slope is None and not forced.drift.warning
    doc = spc.to_json(forced)
    assert doc["kind"] == "forced" and doc["capability"]["cpk"]["value"] is None
    json.dumps(doc, allow_nan=False)


def test_mean_deviation_kind_by_fit():
    assert spc.mean_deviation_kind("lsq") is spc.Kind.FORCED
    assert spc.mean_deviation_kind("minimax") is spc.Kind.MEASURED  # centres the extremes
    with pytest.raises(SettingsError, match="unknown fit"):
        spc.mean_deviation_kind("rps")


def test_a_bounded_quantity_gets_cpu_only_while_its_values_look_normal():
    """max |d| (>= 0, upper limit only): Cpu = (USL - mean) / (3 sigma_within) by hand, with the
    normality test's p value kept; a lot of equal values but one far above them (clearly not
    normal) gets no index, though a MEASURED quantity with the same values would."""
    values = [0.020, 0.024, 0.021, 0.025, 0.022, 0.023]
    a = spc.analyse(spc.Series("max |d|", "mm", values, list("abcdef"), None, 0.05,
                               spc.Kind.BOUNDED))
    sigma = ((0.004 + 0.003 + 0.004 + 0.003 + 0.001) / 5) / 1.128
    cap = a.capability
    assert cap.cpk.value == pytest.approx((0.05 - 0.0225) / (3 * sigma))
    assert cap.cpk == cap.cpu and cap.cp.value is None and cap.cpl.value is None
    assert cap.normality_p is not None and cap.normality_p >= spc.NORMALITY_ALPHA
    skewed = np.r_[np.full(19, 0.010) + 1e-5 * np.arange(19) % 3e-5, 0.045]
    serials = [str(k) for k in range(20)]
    bounded = spc.analyse(spc.Series("max |d|", "mm", skewed, serials, None, 0.05,
                                     spc.Kind.BOUNDED)).capability
    assert bounded.cpk.value is None and "not normal" in bounded.cpk.reason
    assert bounded.normality_p < 0.001
    assert spc.analyse(spc.Series("x", "mm", skewed, serials, None, 0.05)).capability.cpk.value
    json.dumps(spc.to_json(spc.analyse(spc.Series("m", "mm", skewed, serials, None, 0.05,
                                                  "bounded"))), allow_nan=False)


def test_a_count_is_a_c_chart_with_rule_one_only():
    """Points out of tolerance per part: c̄ = 14 / 20 = 0.7, UCL = 0.7 + 3 sqrt(0.7) = 3.21,
    LCL = max(0, 0.7 - 2.51) = 0 by hand; the 9 only breaks rule 1. Ten zeros in a row below c̄
    break no rule (rule 2 is not applied to a count); no capability, no trend; the parts with
    any point out (the limit is 0) are counted."""
    counts = [0, 1, 0, 2, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 9, 0, 1]
    s = spc.Series("points out", "1", counts, [f"p{k}" for k in range(20)], None, 0.0,
                   spc.Kind.COUNT)
    a = spc.analyse(s)
    c = a.chart
    assert c.centre == pytest.approx(0.7) and c.sigma_within == pytest.approx(math.sqrt(0.7))
    assert c.ucl == pytest.approx(0.7 + 3 * math.sqrt(0.7)) and c.lcl == 0.0
    assert round(c.ucl, 2) == 3.21 and c.mr_centre is None
    assert [(v.rule, v.indices) for v in a.violations] == [(1, (17,))]
    assert a.capability.cpk.value is None and "count" in a.capability.cpk.reason
    assert a.drift.slope is None and a.out_of_tolerance == 5
    assert a.flags == ["R1", "5 out of tol."]
    assert spc.c_chart(np.zeros(5)).ucl is None  # nothing out anywhere: nothing to chart


@pytest.mark.parametrize("kind, values, lower, error, words", [
    (spc.Kind.BOUNDED, [0.1, -0.01], None, InputError, "cannot be negative"),
    (spc.Kind.BOUNDED, [0.1, 0.2], 0.0, SettingsError, "upper limit only"),
    (spc.Kind.COUNT, [1.0, 2.5], None, InputError, "whole numbers"),
    (spc.Kind.COUNT, [1.0, -1.0], None, InputError, "cannot be negative"),
])
def test_a_value_its_kind_cannot_have_is_refused(kind, values, lower, error, words):
    with pytest.raises(error, match=words):
        spc.Series("q", "mm", values, ["a", "b"], lower, 1.0, kind)


# --- run rules -------------------------------------------------------------------------------

STABLE = np.array([0.5, -0.3, -0.8, 0.2, 0.9, -0.1, -0.6, 0.2] * 5)
"""A stable lot: no point beyond 3 sigma (sigma 0.63), no more than two points in a row on one
side, rising or falling, or alternating."""


def with_block(block, before, after, at=12):
    x = STABLE.copy()
    x[at - 1], x[at:at + len(block)], x[at + len(block)] = before, block, after
    return x


def rules(values):
    return [(v.rule, v.indices) for v in spc.analyse(series(values, -6, 6)).violations]


@pytest.mark.parametrize("block, before, after, rule, text", [
    ([4.0], 0.0, 0.0, 1, "part 13 above the upper control limit"),
    ([-4.0], 0.0, 0.0, 1, "part 13 below the lower control limit"),
    ([0.5, 0.3, 0.4, 0.6, 0.9, 0.4, 0.3, 0.7, 0.8], -0.7, -0.7, 2,
     "9 points in a row above the centre line (parts 13-21)"),
    ([-0.5, -0.3, -0.4, -0.6, -0.9, -0.4, -0.3, -0.7, -0.8], 0.7, 0.7, 2,
     "9 points in a row below the centre line (parts 13-21)"),
    ([-0.9, -0.5, -0.1, 0.3, 0.7, 1.1], 0.5, -0.5, 3, "6 points in a row rising (parts 13-18)"),
    ([1.1, 0.7, 0.3, -0.1, -0.5, -0.9], -0.5, 0.5, 3, "6 points in a row falling (parts 13-18)"),
    ([0.6, -0.6] * 7, 0.9, -0.8, 4, "14 points in a row alternating up and down (parts 13-26)"),
])
def test_each_rule_fires_on_exactly_its_pattern(block, before, after, rule, text):
    assert rules(STABLE) == []
    found = spc.analyse(series(with_block(block, before, after), -6, 6)).violations
    assert [(v.rule, v.indices) for v in found] == [(rule, tuple(range(12, 12 + len(block))))]
    assert found[0].text.startswith(text)


@pytest.mark.parametrize("block, before, after", [
    ([0.5, 0.3, 0.4, 0.6, 0.9, 0.4, 0.3, 0.7], -0.7, -0.7),  # 8 on one side
    ([-0.9, -0.5, -0.1, 0.3, 0.7], 0.5, -0.5),  # 5 rising
    ([0.6, -0.6] * 6 + [0.6], 0.9, 0.8),  # 13 alternating
])
def test_one_point_short_of_a_rule_is_not_flagged(block, before, after):
    assert rules(with_block(block, before, after)) == []


def test_a_seeded_stable_normal_lot_breaks_no_rule_and_does_not_drift():
    x = np.random.default_rng(2).normal(0.0, 0.01, 40)
    a = spc.analyse(series(x, -0.05, 0.05))
    assert a.violations == () and not a.drift.significant and not a.drift.warning


def test_rule_sentences_name_the_parts_and_runs_are_maximal():
    x = np.concatenate([STABLE[:10], [-1.0, -0.6, -0.2, 0.2, 0.6, 1.0, 1.4], STABLE[:10] - 0.9])
    (v,) = [v for v in spc.analyse(series(x, -6, 6)).violations if v.rule == 3]
    assert v.text == "7 points in a row rising (parts 11-17)" and v.indices == tuple(range(10, 17))


# --- drift -----------------------------------------------------------------------------------

@pytest.mark.parametrize("start, per_part", [(0.5, 0.015), (0.4, 0.02)])
def test_a_passing_lot_that_drifts_towards_a_limit_is_flagged(start, per_part):
    """30 parts, all in tolerance, the value rising by 1.5-2 % of the zone per part: the line
    reaches the upper limit (1 - start - 29 per_part) / per_part parts after the last one
    (4.3 and 1.0 parts by hand; noise moves the fitted line a little)."""
    zone = 0.1
    rng = np.random.default_rng(5)
    x = -0.05 + zone * (start + per_part * np.arange(30)) + rng.normal(0, 0.002 * zone, 30)
    assert np.all((x > -0.05) & (x < 0.05))  # every part passes
    d = spc.analyse(series(x, -0.05, 0.05)).drift
    by_hand = (1 - start - 29 * per_part) / per_part
    assert d.significant and d.warning and d.limit == "upper"
    assert abs(d.parts_to_limit - by_hand) <= 1.5
    assert d.slope == pytest.approx(zone * per_part, rel=0.05)
    assert f"upper limit is reached in {d.parts_to_limit} more part" in d.text
    falling = spc.analyse(series(-x, -0.05, 0.05)).drift
    assert falling.warning and falling.limit == "lower"
    assert falling.parts_to_limit == d.parts_to_limit


def test_a_slow_or_one_sided_trend_is_not_a_warning():
    x = 0.01 * np.arange(30) / 29 + np.random.default_rng(3).normal(0, 0.0005, 30)
    d = spc.analyse(series(x, -1.0, 1.0)).drift  # significant but ~3000 parts from the limit
    assert d.significant and not d.warning and d.parts_to_limit > 1000
    falling = spc.analyse(series(0.05 - x, None, 0.06)).drift  # max |d| falling: no lower limit
    assert falling.significant and falling.limit is None and not falling.warning
    short = spc.analyse(series(x, -1.0, 1.0), horizon=10_000).drift
    assert short.warning


# --- missing values, too few, constant -------------------------------------------------------

def test_parts_without_a_value_are_skipped_but_keep_their_place():
    x = with_block([-0.9, -0.5, -0.1, 0.3, 0.7, 1.1], 0.5, -0.5)
    holes = np.insert(x, [3, 14, 14], np.nan)  # NaN at 3, 15, 16: one before the run, two in it
    a, b = spc.analyse(series(holes, -6, 6)), spc.analyse(series(x, -6, 6))
    for field in ("n", "centre", "sigma_within", "ucl", "lcl", "mr_centre", "std_overall"):
        assert getattr(a.chart, field) == pytest.approx(getattr(b.chart, field))
    assert a.capability.cpk.value == pytest.approx(b.capability.cpk.value)
    assert np.flatnonzero(np.isnan(a.chart.moving_ranges)).tolist() == [0, 3, 15, 16]
    assert a.chart.moving_ranges[17] == pytest.approx(abs(x[14] - x[13]))  # joins the gap
    (v,) = a.violations
    assert v.rule == 3 and v.indices == (13, 14, 17, 18, 19, 20)  # the original positions
    assert v.text == "6 points in a row rising (parts 14-21)"
    doc = spc.to_json(a)
    json.dumps(doc, allow_nan=False)
    assert doc["n"] == 40 and doc["parts"] == 43
    assert doc["violations"][0]["serials"] == ["S013", "S014", "S017", "S018", "S019", "S020"]


@pytest.mark.parametrize("values", [[], [np.nan, np.nan], [0.02, np.nan]])
def test_fewer_than_two_values_give_reasons_not_numbers(values):
    a = spc.analyse(series(values, -0.05, 0.05))
    assert a.chart.ucl is None and a.chart.lcl is None and a.chart.reason
    assert a.capability.cpk.value is None and a.capability.cpk.reason
    assert a.drift.slope is None and not a.drift.warning and a.drift.reason
    assert a.violations == ()
    json.dumps(spc.to_json(a), allow_nan=False)


def test_a_constant_series_has_no_control_limits_and_no_flags():
    a = spc.analyse(series([0.1] * 30, -0.05, 0.2))
    c = a.chart
    assert c.mr_centre == 0.0 and c.sigma_within is None and c.ucl is None
    assert "equal" in c.reason and c.centre == 0.1
    assert a.capability.cp.value is None and a.capability.cp.reason
    assert a.violations == () and not a.drift.significant and a.flags == []
    doc = spc.to_json(a)
    json.dumps(doc, allow_nan=False)
    assert doc["individuals"]["ucl"] is None and doc["capability"]["cpk"]["value"] is None


def test_invalid_series_raise():
    with pytest.raises(InputError, match="3 values but 2 serials"):
        spc.Series("x", "mm", [1.0, 2.0, 3.0], ["a", "b"])
    with pytest.raises(SettingsError, match="empty"):
        series([1.0, 2.0], lower=0.1, upper=0.1)
    with pytest.raises(InputError, match="finite"):
        series([1.0, np.inf])


# --- the PDF ---------------------------------------------------------------------------------

def pdf_text(path) -> str:
    return subprocess.run(["pdftotext", "-raw", str(path), "-"], capture_output=True, text=True,
                          check=True).stdout


def pages(path) -> int:
    info = subprocess.run(["pdfinfo", str(path)], capture_output=True, text=True, check=True)
    return int(next(ln.split()[-1] for ln in info.stdout.splitlines() if ln.startswith("Pages:")))


def lot():
    rng = np.random.default_rng(11)
    drift = -0.05 + 0.1 * (0.5 + 0.015 * np.arange(30)) + rng.normal(0, 0.0002, 30)
    maxd = np.abs(rng.normal(0.03, 0.004, 30))
    maxd[7] = np.nan
    alternating = with_block([0.6, -0.6] * 7, 0.9, -0.8)[:30] * 0.01
    serials = [f"P{k:03d}" for k in range(30)]
    return [spc.Series("profile A", "mm", drift, serials, -0.05, 0.05),
            ("max |d|", "mm", maxd, serials, None, 0.05),
            spc.Series("flatness B", "mm", alternating, serials, None, 0.04)]


def test_spc_pdf_pages_text_and_same_bytes(tmp_path):
    from reports.spc import spc_pdf

    facts = {"parts": 30, "ACCEPT": 29, "ERROR": 1}
    data = spc_pdf(lot(), "Lot 7 bracket", facts)
    assert data == spc_pdf(lot(), "Lot 7 bracket", facts)  # deterministic
    # Analyses made already (the batch's summary.json has them) draw the same report.
    made = [spc.analyse(s if isinstance(s, spc.Series) else spc.Series(*s)) for s in lot()]
    assert spc_pdf(made, "Lot 7 bracket", facts) == data
    path = tmp_path / "spc.pdf"
    path.write_bytes(data)
    assert pages(path) == 1 + 3
    text = pdf_text(path)
    first = text.split("\f")[0]
    for words in ("Lot 7 bracket", "profile A", "max |d|", "flatness B", "ACCEPT 29", "ERROR 1"):
        assert words in first, words
    assert "drift→upper" in first  # the drifting lot is flagged in the table
    profile, maxd, flatness = (" ".join(page.split()) for page in text.split("\f")[1:4])
    assert "upper limit is reached in" in profile and "R3: " in profile
    assert "29 of 30 parts (1 without a value)" in maxd
    assert "R4: 14 points in a row alternating up and down (parts 13-26)" in flatness


def test_long_lots_continue_the_table(tmp_path, monkeypatch):
    from reports import spc as report

    monkeypatch.setattr(report, "TABLE_ROWS", 2)
    path = tmp_path / "spc.pdf"
    path.write_bytes(report.spc_pdf(lot(), "Lot 7", {"parts": 30}))
    assert pages(path) == 2 + 3
    assert "flatness B" in pdf_text(path).split("\f")[1]


def test_lots_too_small_for_capability_say_so_and_draw_without_warnings():
    """Two values give one moving range: no capability index (its interval would span
    thousands), with the reason; a lot of one part, or of parts without values, draws its
    pages without a warning (pytest turns warnings into errors)."""
    from engine.spc import Series, analyse
    from reports.spc import spc_pdf

    two = analyse(Series("d", "mm", np.array([0.01, 0.02]), ["a", "b"], -0.05, 0.05))
    assert two.capability.cpk.value is None and "at least 3" in two.capability.cpk.reason
    three = analyse(Series("d", "mm", np.array([0.01, 0.02, 0.012]), ["a", "b", "c"], -0.05,
                           0.05))
    assert three.capability.cpk.value is not None
    for values in ([0.01], [np.nan, np.nan]):
        serials = [f"p{i}" for i in range(len(values))]
        assert spc_pdf([Series("d", "mm", np.array(values), serials, None, 0.05)], "t",
                       {"parts": len(values)}).startswith(b"%PDF")


# --- the PDF's layout ------------------------------------------------------------------------

def pdf_words(path, page: int) -> list[tuple[str, float, float, float, float]]:
    """(text, xMin, yMin, xMax, yMax) in points of each word on ``page`` (1-based), by
    poppler's pdftotext -bbox: where the PDF really put it."""
    import html

    out = subprocess.run(["pdftotext", "-bbox", "-f", str(page), "-l", str(page), str(path),
                          "-"], capture_output=True, text=True, check=True).stdout
    return [(html.unescape(m[5]), *map(float, m.groups()[:4])) for m in re.finditer(
        r'<word xMin="([\d.]+)" yMin="([\d.]+)" xMax="([\d.]+)" yMax="([\d.]+)">(.*?)</word>',
        out)]


TABLE_HEAD = ("characteristic", "unit", "n", "mean", "σ", "tolerance", "Cpk", "flags")
PAGE_WIDTH = 11.69 * 72


def table_cells(path, page: int):
    """The table of a lot page as laid out: the heading words' x (each column's start) and
    every word of the rows below it, above the note at the page's foot."""
    words = pdf_words(path, page)
    flags = next(w for w in words if w[0] == "flags")
    heading = [w for w in words if abs(w[2] - flags[2]) < 1.0]
    starts = [next(w[1] for w in heading if w[0] == h) for h in TABLE_HEAD]
    foot = next(w[2] for w in words if w[0] == "Run" and w[2] > flags[2])
    rows = [w for w in words if flags[4] + 1.0 < w[2] and w[4] < foot]
    return starts, rows, foot


def test_no_column_of_the_lot_table_runs_into_the_next(tmp_path):
    """Issue 22 item 12: the Cpk column of page 1 ran into the flags ("20178.12 [13762.52,
    26593.71]" over them). A lot whose first characteristic has Cpk in the tens of thousands
    (µm noise in a ±0.25 mm zone), a long name, and long flags (every rule, a drift, parts out
    of tolerance): each word of each row ends before the next column's heading starts (1 pt
    apart at least), and the flags end inside the page's right margin."""
    from reports.spc import spc_pdf

    rng = np.random.default_rng(12)
    serials = [f"P{k:03d}" for k in range(30)]
    noise = rng.normal(0.0, 2e-6, 30)
    wild = np.r_[np.tile([-0.004, 0.004], 7) - 0.02, -0.02, -0.01, 0.0, 0.005, 0.01, 0.015,
                 0.02, 0.025, 0.03, 0.06, 0.07, 0.02, 0.025, 0.03, 0.035, 0.04]
    lot_ = [spc.Series("size of the bore in the left-hand mounting bracket, as drawn", "mm",
                       noise, serials, -0.25, 0.25),
            spc.Series("profile of the flange", "mm", wild, serials, -0.05, 0.05)] + lot()[:1]
    a = spc.analyse(lot_[0])
    assert a.capability.cpk.value > 10_000 and len(", ".join(spc.analyse(lot_[1]).flags)) > 40
    path = tmp_path / "spc.pdf"
    path.write_bytes(spc_pdf(lot_, "SB-1020: 30 parts", {"parts": 30}))
    starts, rows, _ = table_cells(path, 1)
    assert rows
    for text, x0, _, x1, _ in rows:
        column = max(k for k, s in enumerate(starts) if s <= x0 + 0.5)
        end = starts[column + 1] if column + 1 < len(starts) else 0.97 * PAGE_WIDTH
        assert x1 <= end - 1.0, (text, TABLE_HEAD[column], x1, end)


def test_a_long_table_stops_above_the_foot_of_its_page(tmp_path, monkeypatch):
    """Thirty characteristics after eight facts: every row on a page of the table ends above
    the note at its foot, and each characteristic is listed once over the pages (their own
    pages left blank: only the table is looked at)."""
    from matplotlib.figure import Figure

    from reports import spc as report

    monkeypatch.setattr(report, "_characteristic_page", lambda title, a: Figure())
    spc_pdf = report.spc_pdf

    serials = [f"P{k:03d}" for k in range(12)]
    rng = np.random.default_rng(30)
    lot_ = [spc.Series(f"flatness F{k:02d}", "mm", np.abs(rng.normal(0.02, 0.002, 12)),
                       serials, None, 0.05) for k in range(30)]
    facts = {"part number": "SB-1020", "parts": 12, "ACCEPT": 12, "REJECT": 0,
             "INCONCLUSIVE": 0, "ERROR": 0, "nominal": "/data/sb1020.stp", "plan": "sb.toml"}
    path = tmp_path / "spc.pdf"
    path.write_bytes(spc_pdf(lot_, "SB-1020: 12 parts", facts))
    names = []
    for page in range(1, pages(path) - 30 + 1):
        _, _, foot = table_cells(path, page)
        listed = [w for w in pdf_words(path, page) if re.fullmatch(r"F\d\d", w[0])]
        assert all(w[4] < foot for w in listed), page
        names += [w[0] for w in listed]
    assert names == [f"F{k:02d}" for k in range(30)]  # none drawn off the page


def test_the_charts_name_the_parts_by_serial_and_text_from_files_is_escaped(tmp_path):
    """Each characteristic's page names the parts under its chart by serial (every k-th beyond
    40 parts); a line break in a serial or in the title is shown escaped, never as a line of
    its own (a forged "ACCEPT" line)."""
    from reports.spc import spc_pdf

    serials = [f"SN{k:04d}" for k in range(1, 31)]
    serials[4] = "S5\nACCEPT"  # escaped, as many characters as a chart shows
    values = np.random.default_rng(8).normal(0.02, 0.002, 30)
    path = tmp_path / "spc.pdf"
    path.write_bytes(spc_pdf([spc.Series("max |d|", "mm", values, serials, None, 0.05)],
                             "SB-1020\nACCEPT: 30 parts", {"parts": 30}))
    text = pdf_text(path)
    chart = text.split("\f")[1]
    for s in serials[:4] + serials[5:]:
        assert s in chart, s
    assert "S5\\nACCEPT" in chart and "SB-1020\\nACCEPT: 30 parts" in text
    assert not any(line.strip() == "ACCEPT" for line in text.splitlines())
    many = [f"SN{k:04d}" for k in range(100)]
    path.write_bytes(spc_pdf([spc.Series("max |d|", "mm", np.full(100, 0.02), many, None,
                                         0.05)], "t", {}))
    named = {w[0] for w in pdf_words(path, 2) if w[0].startswith("SN")}
    assert named == {f"SN{k:04d}" for k in range(0, 100, 3)}  # ceil(100 / 40) = every 3rd


def test_a_forced_quantity_and_a_count_are_drawn_as_what_they_are(tmp_path):
    """The lot table says "information only" for mean d after a least-squares fit and gives it
    no Cpk; its page has no control limit, index or rule; the count's page is a c chart with
    its limits (c̄ = 0.7, UCL = 3.21 by hand) and rule 1 only."""
    from reports.spc import spc_pdf

    serials = [f"p{k:02d}" for k in range(20)]
    mean = np.random.default_rng(4).normal(1e-6, 4e-6, 20)
    counts = [0, 1, 0, 2, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 9, 0, 1]
    path = tmp_path / "spc.pdf"
    path.write_bytes(spc_pdf([spc.Series("mean d", "mm", mean, serials, None, None,
                                         spc.mean_deviation_kind("lsq")),
                              spc.Series("points out", "points", counts, serials, None, 0.0,
                                         spc.Kind.COUNT)], "BF-1: 20 parts", {}))
    lot_page, forced, count = (" ".join(p.split()) for p in pdf_text(path).split("\f")[:3])
    assert "mean d mm 20/20" in lot_page and "information only" in lot_page
    assert "information only" in forced and "run rules: not applied" in forced
    for word in ("UCL", "LCL", "Cpk", "σ within", "drift"):
        assert word not in forced, word
    assert "c chart" in count and "UCL 3.21" in count and "LCL 0" in count
    assert "R1: part 18 above the upper control limit" in count
    assert "run rules (R1 only) broken" in count and "Cpk" not in count
