"""Every script in scripts/ and benchmarks/ takes ``--help`` through argparse: exit 0, its usage
on stdout, no work done and nothing written (issue 22 item 13: ``scripts/screenshots.py --help``
took ``--help`` for its output folder and wrote 13 PNGs into a folder of that name)."""

import glob
import os
import signal
import subprocess
import sys
import time

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPTS = sorted(glob.glob(os.path.join(ROOT, "scripts", "*.py"))
                 + glob.glob(os.path.join(ROOT, "benchmarks", "*.py")))
HELP_SECONDS = 60
"""--help imports at most what the parser needs: far below this even on a busy machine; a script
that takes --help for work runs into it (and is stopped, with everything it started)."""


def _repo_state() -> str:
    """What git sees changed or new in the working tree (a script writing into it shows)."""
    return subprocess.run(["git", "status", "--porcelain", "--untracked-files=all"], cwd=ROOT,
                          capture_output=True, text=True, check=True).stdout


def test_every_script_is_found():
    names = {os.path.relpath(p, ROOT) for p in SCRIPTS}
    assert {"scripts/screenshots.py", "scripts/app_screenshots.py", "benchmarks/bench_sweep.py",
            "benchmarks/bench_engine.py"} <= names and len(names) >= 14


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: os.path.relpath(p, ROOT))
def test_help_prints_usage_and_does_nothing_else(script, tmp_path):
    before = _repo_state()
    t0 = time.monotonic()
    # A session of its own: a script that starts work is stopped with every process it started.
    proc = subprocess.Popen([sys.executable, script, "--help"], cwd=tmp_path,
                            env={**os.environ, "PYTHONPATH": ROOT}, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=HELP_SECONDS)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail(f"{script} --help ran for {HELP_SECONDS} s: it took --help for work")
    assert proc.returncode == 0, err
    assert out.startswith(f"usage: {os.path.basename(script)}"), out + err
    assert time.monotonic() - t0 < HELP_SECONDS
    assert list(tmp_path.iterdir()) == []
    assert _repo_state() == before
