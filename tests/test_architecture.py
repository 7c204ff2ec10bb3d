"""The layering the product card fixes, checked by import-linter (contracts in pyproject.toml): the
rooms are layered qa_app > reports > engine; engine has no Qt, reportlab or pyHanko, and only
engine.io may import pyvista/VTK or ezdxf; reports has no Qt; the command line has no Qt; the
desktop app's session model and controller are Qt-free."""

import os
import shutil
import subprocess
import sys
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_import_contracts_hold():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        contracts = tomllib.load(f)["tool"]["importlinter"]["contracts"]
    assert {"layers", "forbidden"} <= {c["type"] for c in contracts}
    layers = next(c for c in contracts if c["type"] == "layers")
    assert layers["layers"] == ["qa_app", "reports", "engine"]
    exe = shutil.which("lint-imports", path=os.path.dirname(sys.executable)) or "lint-imports"
    r = subprocess.run([exe, "--no-cache"], cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    assert f"{len(contracts)} kept, 0 broken" in r.stdout
