"""The type checker stays at zero: mypy (pinned in the test extra) over the files [tool.mypy]
names in pyproject.toml (engine and reports) finds no error. Its cache, .mypy_cache at the
root, makes a rerun take seconds; a cold run takes under a minute.

mypy runs in a child process, not through mypy.api.run: in this process it would raise the
recursion limit (sys.setrecursionlimit) and the garbage collector's thresholds for every test
after it (a plan nested too deeply would then parse instead of being refused)."""

import os
import subprocess
import sys
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_mypy_finds_no_error_in_engine_and_reports():
    config = os.path.join(ROOT, "pyproject.toml")
    with open(config, "rb") as f:
        assert {"engine", "reports"} <= set(tomllib.load(f)["tool"]["mypy"]["files"])
    # The configured files are relative to the root.
    r = subprocess.run([sys.executable, "-m", "mypy", "--config-file", config], cwd=ROOT,
                       capture_output=True, text=True)
    errors = [line for line in r.stdout.splitlines() if ": error:" in line]
    assert r.returncode == 0 and not errors, (f"mypy found {len(errors)} errors:\n"
                                              + r.stdout + r.stderr)
    assert r.stdout.splitlines()[-1].startswith("Success: no issues found"), r.stdout + r.stderr
