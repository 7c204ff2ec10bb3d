"""The engine as a library: the README's "Use as a library" section runs as a doctest, the
public names are the ones ``engine.__all__`` lists, and importing the package loads nothing."""

import doctest
import os
import re
import subprocess
import sys

import engine

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_the_readme_library_section_runs(monkeypatch):
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        text = f.read()
    section = re.search(r"^## Use as a library\n(.*?)^## ", text, re.S | re.M).group(1)
    assert section.count(">>>") >= 5
    monkeypatch.chdir(ROOT)  # the example names the samples relative to the checkout
    test = doctest.DocTestParser().get_doctest(section, {}, "README: Use as a library",
                                               "README.md", 0)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    runner.run(test)
    assert runner.summarize(verbose=False).failed == 0


def test_every_public_name_resolves_and_nothing_else_is_offered():
    for name in engine.__all__:
        assert getattr(engine, name) is not None, name
    assert engine.Tolerance.__module__ == "engine.tolerance"
    try:
        engine.registration_internals  # noqa: B018
    except AttributeError as e:
        assert "has no attribute" in str(e)
    else:
        raise AssertionError("an unknown name resolved")


def test_importing_the_engine_loads_none_of_its_rooms():
    code = ("import sys, engine; print(sorted(m for m in sys.modules if m.startswith('engine.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, check=True).stdout
    assert out.strip() == "[]"


def test_the_choices_are_typed_and_written_as_their_words():
    """Verdict, fit and decision rule are string enums: a word given becomes its member, and a
    member is written (JSON, f-strings, str) as its word, so the outputs keep their bytes."""
    import json

    from engine.choices import DecisionRule, Fit, Verdict
    from engine.settings import InspectionSettings

    s = InspectionSettings(-0.1, 0.1, fit="minimax", decision_rule="guarded")
    assert s.fit is Fit.MINIMAX and s.decision_rule is DecisionRule.GUARDED
    assert InspectionSettings.from_json(json.loads(json.dumps(s.to_json()))) == s
    assert json.dumps({"verdict": Verdict.REJECT}) == '{"verdict": "REJECT"}'
    assert f"{Verdict.INCONCLUSIVE}: x" == "INCONCLUSIVE: x" and str(Fit.LSQ) == "lsq"
    assert InspectionSettings(-0.1, 0.1, fit="bogus").fit == "bogus"  # refused by the check


def test_a_zone_knows_its_width_and_centre():
    z = engine.Tolerance(-0.1, 0.3)
    assert z.width == 0.3 - (-0.1) and z.centre == 0.5 * (-0.1 + 0.3)
    assert engine.Tolerance.symmetric(0.05).centre == 0.0


def test_settings_that_leave_the_zone_to_their_plan_inspect_as_the_plan_alone_does():
    """InspectionSettings(None, None, plan=P) (the fields' own way of saying "no --tol") ended
    in a TypeError from numpy deep in the pipeline; it now inspects as inspect_files(plan=P)
    does, the plan's zone recorded outside the verdict. A zone half given, or neither a zone
    nor a plan: a SettingsError saying so."""
    import pytest

    from engine.pipeline import run_files

    nominal, measured, plan = (os.path.join(ROOT, "samples", "seat_bracket", f)
                               for f in ("nominal.xyz", "measured.csv", "plan.toml"))
    by_plan = engine.inspect_files(nominal, measured, plan=plan)
    run = run_files(nominal, measured, engine.InspectionSettings(None, None, plan=plan))
    assert run.settings == by_plan.settings and not run.settings.zone_in_verdict
    assert run.result.verdict == by_plan.result.verdict
    assert [(c.characteristic.id, c.value, c.verdict) for c in run.result.plan.characteristics] == \
        [(c.characteristic.id, c.value, c.verdict) for c in by_plan.result.plan.characteristics]
    for half in ((None, 0.1), (-0.1, None)):
        with pytest.raises(engine.SettingsError, match="needs both its limits"):
            run_files(nominal, measured, engine.InspectionSettings(*half, plan=plan))
    with pytest.raises(engine.SettingsError, match="a tolerance zone or an inspection plan"):
        run_files(nominal, measured, engine.InspectionSettings(None, None))
