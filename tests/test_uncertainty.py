"""Measurement uncertainty in the decision (ISO 14253-1): the budget against a hand computation
(a plane's least-squares pose uncertainty is the textbook regression prediction variance; the
instrument terms are the GUM's rectangular and normal divisors), the guarded decision at each
side of a limit, the command line's --uncertainty and the plan's [measurement] instrument."""

import csv
import json
import os

import numpy as np
import pytest

from engine.errors import InputError
from engine.inspection import Tolerance, inspect
from engine.io.plan import read_plan
from engine.nominal import Nominal
from engine.trust import conditioning
from engine.uncertainty import Instrument, budget, expanded_at
from engine.verdict import ACCEPT, INCONCLUSIVE, REJECT
from engine.pose import apply_transform, make_transform
from qa_app.cli import main
from surfaces import height, height_grid, height_normal, point_set, random_rotation

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BELLY = [os.path.join(ROOT, "samples", "belly_fairing", f) for f in ("nominal.csv",
                                                                     "measured.csv")]


def _plane_fit(rng, n=400):
    """Points scattered about a plane, at the least-squares plane's pose (that plane is z = 0):
    (points (n, 3), normals, the in-plane design matrix [1, x, y], residual RMS)."""
    x, y = rng.uniform(-200, 200, n), rng.uniform(-100, 100, n)
    z = rng.normal(0, 0.01, n) + 0.002 * x - 0.001 * y
    A = np.column_stack([np.ones(n), x, y])
    residual = z - A @ np.linalg.lstsq(A, z, rcond=None)[0]
    X = np.column_stack([x, y, residual])
    return X, np.tile([0.0, 0.0, 1.0], (n, 1)), A, float(np.sqrt(np.mean(residual ** 2)))


def test_budget_against_a_hand_computation():
    rng = np.random.default_rng(11)
    X, normals, A, rms = _plane_fit(rng)
    n = len(X)
    margin = rng.uniform(0.0, 0.004, n)
    ins = Instrument(mpe_a_um=1.8, mpe_l_per_um=300.0, probing_um=2.2, temperature_c=22.5,
                     expansion_per_k=23e-6)
    b = budget(X, normals, np.ones(n, bool), rms, conditioning(X, normals, rms), margin, ins)
    # By hand. A plane fitted by least squares moves along its normal by a + b x + c y (the
    # shifts within it and the turn about its normal are free: no variance): the prediction
    # variance of a linear regression, s^2 a_i (A^T A)^-1 a_i^T, s^2 = RSS / (n - 3).
    s2 = n * rms ** 2 / (n - 3)
    pose = np.sqrt(s2 * np.einsum("ij,jk,ik->i", A, np.linalg.inv(A.T @ A), A))
    L = np.linalg.norm(X - X.mean(axis=0), axis=1)
    by_hand = {"length": (1.8 + L / 300.0) / 1000.0 / np.sqrt(3.0),  # MPE_E, rectangular
               "probing": np.full(n, 2.2 / 1000.0 / np.sqrt(3.0)),  # MPE_P, rectangular
               "temperature": L * 23e-6 * 2.5 / np.sqrt(3.0),  # 2.5 K from 20 °C, rectangular
               "pose": pose, "sampling": margin / np.sqrt(3.0)}
    got = {t.key: t.u for t in b.terms}
    assert list(got) == list(by_hand)
    for key, u in by_hand.items():
        np.testing.assert_allclose(got[key], u, rtol=1e-9, atol=1e-15, err_msg=key)
    U = 2.0 * np.sqrt(sum(u * u for u in by_hand.values()))
    np.testing.assert_allclose(b.expanded, U, rtol=1e-9)
    np.testing.assert_allclose(b.length_mm, L, rtol=1e-12)
    # A stated expanded uncertainty (k = 2) replaces the instrument's three terms.
    stated = budget(X, normals, np.ones(n, bool), rms, conditioning(X, normals, rms), None,
                    Instrument(uncertainty_mm=0.01))
    assert [t.key for t in stated.terms] == ["stated", "pose", "sampling"]
    np.testing.assert_allclose(stated.expanded, 2.0 * np.sqrt(0.005 ** 2 + pose ** 2),
                               rtol=1e-9)


def test_an_mpe_without_its_length_part_is_a_term_per_point():
    """MPE_E = A alone (no K) is still an (n,) term, so a characteristic's U at some of the
    points (expanded_at) can be taken from it: it was a float, and indexing it raised."""
    rng = np.random.default_rng(11)
    X, normals, _, rms = _plane_fit(rng)
    n = len(X)
    b = budget(X, normals, np.ones(n, bool), rms, conditioning(X, normals, rms), None,
               Instrument(mpe_a_um=1.8))
    length = next(t for t in b.terms if t.key == "length")
    np.testing.assert_allclose(length.u, np.full(n, 1.8 / 1000.0 / np.sqrt(3.0)), rtol=1e-12)
    idx = np.array([0, 5, 17])
    np.testing.assert_allclose(expanded_at(b, idx), b.expanded[idx], rtol=1e-12)


@pytest.fixture(scope="module")
def fairing():
    pts, nrm, grid = height_grid(150, 100)
    return Nominal.from_point_set(point_set(pts, nrm, grid))


def _two_high_points(seed=7, m=800):
    """A clean fairing measured in a random pose, point 0 standing 0.1 mm proud, point 1 sunk
    0.1 mm."""
    rng = np.random.default_rng(seed)
    dev = rng.normal(0, 0.002, m)
    dev[:2] = 0.1, -0.1
    x, y = rng.uniform(-240, 240, m), rng.uniform(-115, 115, m)
    q = np.column_stack([x, y, height(x, y)]) + dev[:, None] * height_normal(x, y)
    return apply_transform(make_transform(random_rotation(rng), rng.uniform(-1e3, 1e3, 3)), q)


EPS = 0.005
"""How far each side of limit +- U the point is put (U ~ 0.021 mm here)."""


@pytest.mark.parametrize("side", ["upper", "lower"])
def test_guarded_decision_at_each_side_of_a_limit(fairing, side):
    """ISO 14253-1: conformance is proven inside the zone shrunk by U, non-conformance outside
    the zone grown by U; between, neither (whichever side of the limit the point is)."""
    measured = _two_high_points()
    ins = Instrument(uncertainty_mm=0.02)
    first = inspect(fairing, measured, Tolerance.symmetric(0.2), decision_rule="guarded",
                    instrument=ins)
    k = 0 if side == "upper" else 1
    d, U = first.deviations.signed[k], first.uncertainty.expanded[k]
    assert 0.02 <= U < 0.025  # the stated U dominates; the pose and sampling add a little
    for outside, want in ((-U - EPS, ACCEPT), (-U + EPS, INCONCLUSIVE), (U - EPS, INCONCLUSIVE),
                          (U + EPS, REJECT)):
        # The limit placed so that point k lies ``outside`` beyond it (negative: inside).
        tol = Tolerance(-0.2, d - outside) if side == "upper" else Tolerance(d + outside, 0.2)
        res = inspect(fairing, measured, tol, decision_rule="guarded", instrument=ins)
        assert res.deviations.signed[k] == pytest.approx(d, abs=1e-4)
        assert res.verdict == want, (outside, res.reasons)
        # The simple rule sees only the limit itself.
        simple = inspect(fairing, measured, tol)
        assert simple.verdict == (ACCEPT if outside < 0 else REJECT)


def test_command_line_uncertainty_decides_and_reports_the_budget(tmp_path):
    j, c = tmp_path / "r.json", tmp_path / "r.csv"
    # The belly fairing's worst point lies 0.132 mm deep: inside +-0.14 by 0.008 mm.
    assert main(["inspect", *BELLY, "--tol", "0.14"]) == 0
    code = main(["inspect", *BELLY, "--tol", "0.14", "--uncertainty", "0.02", "--json", str(j),
                 "--csv", str(c)])
    assert code == 2  # within U of the limit: neither conformance nor non-conformance proven
    doc = json.loads(j.read_text())
    assert doc["decision_rule"] == "guarded" and doc["verdict"] == INCONCLUSIVE
    unc = doc["uncertainty"]
    assert unc["k"] == 2 and unc["used_by_decision_rule"] is True
    assert [t["term"] for t in unc["terms"]] == ["stated", "pose", "sampling"]
    assert unc["terms"][0]["u_max_mm"] == pytest.approx(0.01)
    assert doc["settings"]["instrument"]["uncertainty_mm"] == 0.02
    with open(c) as f:
        rows = list(csv.DictReader(f))
    U = np.array([float(r["uncertainty"]) for r in rows])
    m = np.array([float(r["margin"]) for r in rows])
    assert U.max() == pytest.approx(unc["expanded_max_mm"], abs=1e-6)
    # Each U holds the stated 0.02 and its sampling margin (rectangular) at least.
    assert np.all(U ** 2 >= 0.02 ** 2 + 4 * m ** 2 / 3 - 1e-9)
    # The simple rule, asked for, keeps its verdict; the budget is still reported.
    assert main(["inspect", *BELLY, "--tol", "0.14", "--uncertainty", "0.02",
                 "--decision-rule", "simple", "--json", str(j)]) == 0
    doc = json.loads(j.read_text())
    assert doc["uncertainty"]["used_by_decision_rule"] is False


def test_command_line_refuses_a_uncertainty_that_is_not_positive(capsys):
    assert main(["inspect", *BELLY, "--tol", "0.14", "--uncertainty", "0"]) == 64
    assert "--uncertainty must be positive" in capsys.readouterr().err


MEASUREMENT = """\
[measurement]
device = "CMM Contura G2"
device_serial = "C-4711"
calibration_date = 2025-03-01
probe = "VAST XT gold, stylus 3 mm ruby x 40 mm"
program = "BF-1100_rev7.mpp"
temperature_c = 22.0
mpe_a_um = 1.8
mpe_l_per_um = 300
probing_um = 1.9
expansion_per_k = 23e-6
"""
CHARACTERISTIC = """
[[region]]
name = "skin"
box = [[-300, -200, -100], [300, 200, 100]]

[[characteristic]]
id = "1"
type = "profile"
region = "skin"
zone = 0.5
"""


def test_plan_measurement_states_the_instrument(tmp_path):
    plan = tmp_path / "plan.toml"
    plan.write_text(MEASUREMENT + CHARACTERISTIC)
    read = read_plan(str(plan)).measurement
    assert (read.device, read.device_serial, read.calibration_date, read.temperature_c) == \
        ("CMM Contura G2", "C-4711", "2025-03-01", 22.0)
    assert read.instrument == Instrument(mpe_a_um=1.8, mpe_l_per_um=300.0, probing_um=1.9,
                                         temperature_c=22.0, expansion_per_k=23e-6)
    j = tmp_path / "r.json"
    assert main(["inspect", *BELLY, "--plan", str(plan), "--json", str(j)]) == 0
    doc = json.loads(j.read_text())
    assert doc["decision_rule"] == "guarded"  # an instrument stated: the guarded rule
    terms = {t["term"]: t for t in doc["uncertainty"]["terms"]}
    assert list(terms) == ["length", "probing", "temperature", "pose", "sampling"]
    L = doc["uncertainty"]["length_max_mm"]
    assert terms["temperature"]["u_max_mm"] == pytest.approx(L * 23e-6 * 2 / np.sqrt(3),
                                                             rel=1e-9)
    assert terms["length"]["u_max_mm"] == pytest.approx((1.8 + L / 300) / 1000 / np.sqrt(3),
                                                        rel=1e-9)
    # --uncertainty replaces the plan's instrument.
    assert main(["inspect", *BELLY, "--plan", str(plan), "--uncertainty", "0.01",
                 "--json", str(j)]) == 0
    assert [t["term"] for t in json.loads(j.read_text())["uncertainty"]["terms"]] == \
        ["stated", "pose", "sampling"]


@pytest.mark.parametrize("change, message", [
    (("calibration_date = 2025-03-01", 'calibration_date = "1 March 2025"'),
     "[measurement]: 'calibration_date' must be a date YYYY-MM-DD"),
    (("probing_um = 1.9", "probing_um = 1.9\nuncertainty_mm = 0.003"),
     "[measurement]: 'mpe_a_um' and 'uncertainty_mm' are both given"),
    (("probing_um = 1.9", "probing_um = -1.9"),
     "[measurement]: 'probing_um' must not be negative"),
    (("mpe_l_per_um = 300", "mpe_l_per_um = 0"), "[measurement]: 'mpe_l_per_um'"),
    (("temperature_c = 22.0\n", ""), "[measurement]: 'expansion_per_k' needs temperature_c"),
    (("mpe_a_um = 1.8\nmpe_l_per_um = 300\nprobing_um = 1.9\nexpansion_per_k = 23e-6\n",
      "uncertainty_mm = 0\n"), "[measurement]: 'uncertainty_mm' must be > 0"),
    (("probe = ", "stylus = "), "'stylus' is not a key of [measurement]"),
    (("temperature_c = 22.0", 'temperature_c = "warm"'), "'temperature_c' must be a number"),
])
def test_plan_measurement_errors_name_the_table_and_key(tmp_path, change, message):
    plan = tmp_path / "plan.toml"
    plan.write_text(MEASUREMENT.replace(*change) + CHARACTERISTIC)
    with pytest.raises(InputError) as e:
        read_plan(str(plan))
    assert message in str(e.value) and str(plan) in str(e.value)


def test_verify_re_runs_a_certificate_older_than_uncertainty_budgets():
    """tests/data/results_before_uncertainty.json is the results document qa-inspect wrote
    before this change (the belly fairing at +-0.137 mm, guarded rule: then guarded by each
    point's nominal-sampling margin alone, ACCEPT). Its settings carry no instrument: verify
    re-runs it with that rule and confirms it; the same part judged today is guarded by U
    (pose and sampling), as ISO 14253-1 applied to its reported deviations and U decides."""
    from engine.pipeline import run_files
    from engine.settings import InspectionSettings
    from reports.verify import recheck

    with open(os.path.join(ROOT, "tests", "data", "results_before_uncertainty.json")) as f:
        old = json.load(f)
    assert "instrument" not in old["settings"] and old["verdict"] == ACCEPT
    checks = recheck(old, {"nominal": BELLY[0], "measured": BELLY[1], "plan": None})
    assert all(c.passed for c in checks)
    assert checks[-1].subject == "re-run" and checks[-1].message.startswith("re-run: ACCEPT")
    today = InspectionSettings.from_json(dict(old["settings"], instrument=None))
    assert today.guard == "uncertainty"
    res = run_files(*BELLY, today).result
    assert res.verdict == _iso_14253(res.deviations.signed, res.uncertainty.expanded,
                                     res.tolerance)


def _iso_14253(d: np.ndarray, U: np.ndarray, tol: Tolerance) -> str:
    """The decision of ISO 14253-1 applied to reported deviations and their expanded U (the
    rule written out: the naive twin of the guarded decision)."""
    if np.any((d > tol.upper + U) | (d < tol.lower - U)):
        return REJECT
    if np.all((d <= tol.upper - U) & (d >= tol.lower + U)):
        return ACCEPT
    return INCONCLUSIVE


def _few_points(proud: float, m: int = 40, defect: float | None = None):
    """40 points on the fairing, 5 um noise, in a random pose; point 0 stands ``proud`` mm."""
    rng = np.random.default_rng(3)
    x, y = rng.uniform(-240, 240, m), rng.uniform(-115, 115, m)
    dev = rng.normal(0, 0.005, m)
    dev[0] = proud
    if defect is not None:
        dev[1] = defect
    q = np.column_stack([x, y, height(x, y)]) + dev[:, None] * height_normal(x, y)
    return apply_transform(make_transform(random_rotation(rng), rng.uniform(-1e3, 1e3, 3)), q)


def test_the_pose_counts_once_the_verdict_is_iso_14253_of_the_reported_d_and_u(fairing):
    """The expanded U already holds the pose's uncertainty: the guarded verdict is ISO 14253-1
    applied to the reported deviations and U, for a point swept across the upper limit on a
    part measured at 40 points (where the pose's uncertainty is large), not the pose probed
    again at +-3 sigma against limits already widened by U (which made INCONCLUSIVE what ISO
    rejects or accepts)."""
    tol, ins = Tolerance.symmetric(0.1), Instrument(uncertainty_mm=0.01)
    seen = set()
    for proud in np.linspace(0.05, 0.2, 16):
        res = inspect(fairing, _few_points(proud), tol, decision_rule="guarded", instrument=ins)
        want = _iso_14253(res.deviations.signed, res.uncertainty.expanded, tol)
        assert res.verdict == want, (proud, res.reasons)
        seen.add(want)
    assert seen == {ACCEPT, INCONCLUSIVE, REJECT}


def test_a_defect_does_not_widen_the_other_points_uncertainty(fairing):
    """The pose's share of U comes from the fit's residual scale; a real 0.6 mm defect on one
    of 40 points is no noise of the fit: the other points' U less than doubles (it grew
    fivefold when the residual RMS, defect included, was taken as the noise; what is left is
    the least-squares pose's real pull towards the defect)."""
    ins = Instrument(uncertainty_mm=0.01)

    def others(defect):
        res = inspect(fairing, _few_points(0.0, defect=defect), Tolerance.symmetric(1.0),
                      decision_rule="guarded", instrument=ins)
        return float(np.median(res.uncertainty.expanded[2:]))

    assert others(0.6) < 2.0 * others(0.0)


def test_flatness_position_and_size_are_guarded_by_their_uncertainty_too(tmp_path):
    """Under the guarded rule a value computed from points (flatness, position, size) is judged
    against its limits shrunk and grown by its uncertainty bound, twice the largest U of its
    points (ISO 14253-1), as each profile point is against its own U: with U larger than every
    tolerance no such characteristic can be accepted or rejected; with a small U the seat
    bracket's three accept as under the simple rule; the bound is the JSON's, and each verdict
    is the rule applied to it."""
    bracket = os.path.join(ROOT, "samples", "seat_bracket")
    with open(os.path.join(bracket, "plan.toml")) as f:
        text = f.read()
    head = text[:text.index("[[characteristic]]")]
    plan = tmp_path / "plan.toml"
    plan.write_text(head + '[[characteristic]]\nid = "3"\ntype = "flatness"\nregion = "A"\n'
                    'zone = 0.01\n[[characteristic]]\nid = "4"\ntype = "position"\n'
                    'region = "hole1"\nzone = 0.1\ndatums = ["A", "B", "C"]\n'
                    '[[characteristic]]\nid = "5"\ntype = "size"\nregion = "hole1"\n'
                    'nominal = 8.0\nlower = -0.05\nupper = 0.05\n')
    verdicts = {}
    for u in (0.2, 0.0005):
        out = tmp_path / f"r{u}.json"
        main(["inspect", os.path.join(bracket, "nominal.xyz"),
              os.path.join(bracket, "measured.csv"), "--plan", str(plan), "--uncertainty",
              str(u), "--json", str(out)])
        doc = json.loads(out.read_text())
        for c in doc["characteristics"]:
            g, v = c["uncertainty_bound"], c["value"]
            lo, hi = (c.get("nominal") or 0.0) + c["lower"], (c.get("nominal") or 0.0) + c["upper"]
            g_lo = 0.0 if c["type"] in ("flatness", "position") else g
            want = (REJECT if v > hi + g or v < lo - g_lo else
                    ACCEPT if lo + g_lo <= v <= hi - g else INCONCLUSIVE)
            assert c["verdict"] == want and g >= 2 * u, (u, c)
        verdicts[u] = [c["verdict"] for c in doc["characteristics"]]
    assert verdicts == {0.2: [INCONCLUSIVE] * 3, 0.0005: [ACCEPT] * 3}


def test_a_zone_narrower_than_2u_says_no_part_can_be_accepted(fairing):
    """With U larger than half the zone no point can be inside the conformance zone: the
    verdict is INCONCLUSIVE and says the measurement is not capable of the tolerance, with the
    number of points where 2U reaches the zone's width (counted here from the reported U)."""
    measured = _two_high_points()
    tol = Tolerance.symmetric(0.01)
    res = inspect(fairing, measured[2:], tol, decision_rule="guarded",
                  instrument=Instrument(uncertainty_mm=0.02))
    assert res.verdict == INCONCLUSIVE
    n = int(np.sum(2 * res.uncertainty.expanded >= 0.02))
    assert n == res.deviations.signed.size
    assert f"at {n} points 2U ≥ the zone's width 0.02 mm" in res.reasons[0]
    assert "not capable of this tolerance" in res.reasons[0]
