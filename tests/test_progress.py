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
