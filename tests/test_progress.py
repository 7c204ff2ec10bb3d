"""Progress reports and cancellation of a run (what the desktop app's progress bar and Cancel
button rely on)."""

import os

import numpy as np
import pytest

from engine.errors import Cancelled
from engine.pipeline import run_files
from engine.settings import InspectionSettings

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = os.path.join(ROOT, "samples")


def _files(name):
    d = os.path.join(SAMPLES, name)
    if name == "fuselage_frame":
        return os.path.join(d, "template.dxf"), os.path.join(d, "measured.csv")
    return os.path.join(d, "nominal.csv"), os.path.join(d, "measured.csv")


@pytest.mark.parametrize("sample,tol", [("belly_fairing", 0.25), ("fuselage_frame", 0.05)])
def test_stages_are_reported_and_do_not_change_the_result(sample, tol):
    nominal, measured = _files(sample)
    seen = []
    followed = run_files(nominal, measured, InspectionSettings(-tol, tol),
                         progress=lambda stage, f: seen.append((stage, f)))
    plain = run_files(nominal, measured, InspectionSettings(-tol, tol))
    stages = [s for s, _ in seen]
    assert stages[0] == "loading the nominal" and stages[-1] == "judging"
    assert any("global search" in s for s in stages)
    assert all(0.0 <= f <= 1.0 for _, f in seen)
    if sample == "belly_fairing":
        assert any("ICP iteration" in s for s in stages)
        assert any("point-to-surface fit" in s for s in stages)
    np.testing.assert_array_equal(followed.result.deviations.signed,
                                  plain.result.deviations.signed)
    assert followed.result.verdict == plain.result.verdict


def test_cancel_stops_the_run_with_no_result():
    nominal, measured = _files("belly_fairing")
    calls = []

    def cancel_in_the_icp(stage, fraction):
        calls.append(stage)
        if "ICP iteration" in stage:
            raise Cancelled()

    with pytest.raises(Cancelled):
        run_files(nominal, measured, InspectionSettings(-0.25, 0.25), progress=cancel_in_the_icp)
    assert "ICP iteration" in calls[-1]
    # The next run, without a listener, is not affected by the cancelled one.
    assert run_files(nominal, measured, InspectionSettings(-0.25, 0.25)).result.verdict == \
        "ACCEPT"


def _bracket_plan(tmp_path, n):
    """The seat bracket sample and its plan's characteristics repeated to ``n`` (new ids)."""
    import re

    d = os.path.join(SAMPLES, "seat_bracket")
    with open(os.path.join(d, "plan.toml")) as f:
        head, *chars = f.read().split("[[characteristic]]")
    plan = tmp_path / f"plan{n}.toml"
    plan.write_text(head + "".join("[[characteristic]]" + re.sub(
        r'id = "\d+"', f'id = "{k + 1}"', chars[k % len(chars)]) for k in range(n)))
    return os.path.join(d, "nominal.xyz"), os.path.join(d, "measured.csv"), str(plan)


def test_a_plans_characteristics_move_the_progress_over_their_share(tmp_path):
    """Issue 22: 100,000 characteristics ran for minutes with nothing to show. They are judged
    one by one in view: after the registration, over the plan's share of the bar (50 of them
    against a registration's 100: a third), with no step back."""
    from engine.pipeline import PLAN_WEIGHT, inspection_settings, plan_share

    nominal, measured, plan = _bracket_plan(tmp_path, 50)
    settings = inspection_settings(None, plan)
    seen = []
    followed = run_files(nominal, measured, settings, lambda stage, f: seen.append((stage, f)))
    share = plan_share(followed.plan)
    assert share == pytest.approx(50 / (50 + PLAN_WEIGHT))
    first = next(k for k, (s, _) in enumerate(seen) if "plan's characteristics" in s)
    assert all(f <= 1 - share + 1e-12 for _, f in seen[:first])
    plan_part = [f for _, f in seen[first:]]
    assert plan_part == sorted(plan_part) and plan_part[0] == pytest.approx(1 - share)
    stages = [s for s, _ in seen[first:]]
    assert "judging characteristic 1 of 50" in stages
    assert "judging characteristic 50 of 50" in stages
    plain = run_files(nominal, measured, settings)
    assert [r.value for r in followed.result.plan.characteristics] == \
        [r.value for r in plain.result.plan.characteristics]


class _Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def test_the_progress_line_waits_two_seconds_then_draws_and_is_erased():
    import io

    from qa_app.progress import StageLine

    clock, out = _Clock(), io.StringIO()
    line = StageLine(out, clock)
    line("global search", 0.1)
    clock.now += 1.9
    line("ICP iteration 3", 0.4)
    assert out.getvalue() == ""  # a quick run draws nothing
    clock.now += 0.2
    line("judging characteristic 3,501 of 10,000", 0.35)
    assert out.getvalue() == "\r[#######.............]  35%  judging characteristic 3,501 of " \
                             "10,000"
    clock.now += 0.05
    line("judging characteristic 3,502 of 10,000", 0.36)  # too soon: not redrawn
    clock.now += 0.1
    line("judging", 1.0)
    last = out.getvalue().rsplit("\r", 1)[1]
    assert last.startswith("[####################] 100%  judging ") and last.strip() == \
        "[####################] 100%  judging"  # spaces over the longer line before
    line.close()
    assert out.getvalue().endswith("\r" + " " * len(last.rstrip()) + "\r")


class _Terminal:
    """Standard error as a terminal, recording what is written."""

    def __init__(self):
        import io

        self.buffer = io.StringIO()

    def isatty(self):
        return True

    def write(self, text):
        return self.buffer.write(text)

    def flush(self):
        pass


@pytest.mark.parametrize("quiet", [False, True])
def test_inspect_draws_the_progress_line_on_a_terminal(tmp_path, monkeypatch, capsys, quiet):
    import sys

    import qa_app.progress
    from qa_app.cli import main

    nominal, measured, plan = _bracket_plan(tmp_path, 20)
    monkeypatch.setattr(qa_app.progress, "DELAY_S", 0.0)  # draw at once: the run is quick
    err = _Terminal()
    monkeypatch.setattr(sys, "stderr", err)
    code = main(["inspect", nominal, measured, "--plan", plan] + (["--quiet"] if quiet else []))
    assert code == 1  # the sample's plan rejects the part
    drawn = err.buffer.getvalue()
    assert ("judging characteristic" in drawn) != quiet
    assert capsys.readouterr().out.startswith("REJECT: ")
