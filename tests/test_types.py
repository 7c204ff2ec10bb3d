"""The type checker stays at zero: mypy (pinned in the test extra) over the files [tool.mypy]
names in pyproject.toml (engine and reports) finds no error. Its cache, .mypy_cache at the
root, makes a rerun take seconds; a cold run takes about half a minute."""

import os
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_mypy_finds_no_error_in_engine_and_reports(monkeypatch):
    from mypy import api

    config = os.path.join(ROOT, "pyproject.toml")
    with open(config, "rb") as f:
        assert {"engine", "reports"} <= set(tomllib.load(f)["tool"]["mypy"]["files"])
    monkeypatch.chdir(ROOT)  # the configured files are relative to the root
    out, err, status = api.run(["--config-file", config])
    errors = [line for line in out.splitlines() if ": error:" in line]
    assert status == 0 and not errors, (f"mypy found {len(errors)} errors:\n" + out + err)
    assert out.splitlines()[-1].startswith("Success: no issues found"), out + err
