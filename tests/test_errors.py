"""One exception family: every error the product (engine, reports, qa_app) defines derives from
engine.errors.QAError, so a caller can catch "anything qa-inspect raises on purpose" in one
clause; the builtin second parents (ValueError, FileExistsError, RuntimeError...) keep the
callers that catch those working. And the engine's public warm-up loads what the first inspection
needs."""

import importlib
import inspect
import json
import os
import pkgutil
import subprocess
import sys

import pytest

from engine.errors import QAError

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGES = ("engine", "reports", "qa_app")


def _product_modules():
    """Every module of the product's packages, found on disk (a new file is walked too)."""
    names = []
    for pkg in PACKAGES:
        names.append(pkg)
        path = [os.path.join(ROOT, pkg)]
        for info in pkgutil.walk_packages(path, prefix=pkg + "."):
            if info.name.rsplit(".", 1)[-1] != "__main__":  # running it would start the app
                names.append(info.name)
    return names


def _exception_classes():
    found = []
    for name in _product_modules():
        module = importlib.import_module(name)
        for _, cls in inspect.getmembers(module, inspect.isclass):
            if cls.__module__ == name and issubclass(cls, BaseException):
                found.append(cls)
    return found


def test_the_walk_sees_every_package():
    names = _product_modules()
    for expected in ("engine.io.points", "reports.signing", "qa_app.cli", "qa_app.desktop.window"):
        assert expected in names


def test_every_exception_the_product_defines_is_a_qa_error():
    named = {f"{c.__module__}.{c.__qualname__}": c for c in _exception_classes()}
    strays = sorted(n for n, c in named.items() if not issubclass(c, QAError))
    assert not strays, f"exceptions outside the QAError family: {strays}"
    # The walk found the classes it should (a walk that found nothing would pass vacuously).
    assert {"engine.errors.InputError", "qa_app.usage.UsageError",
            "reports.signing.OutputExistsError", "reports.figures.process.RenderError"} <= set(named)


@pytest.mark.parametrize("cls, builtin", [
    ("qa_app.usage.UsageError", ValueError),
    ("reports.signing.OutputExistsError", FileExistsError),
    ("reports.figures.RenderError", RuntimeError),
])
def test_the_second_parent_keeps_builtin_callers_working(cls, builtin):
    module, name = cls.rsplit(".", 1)
    error = getattr(importlib.import_module(module), name)
    assert issubclass(error, QAError) and issubclass(error, builtin)


def test_output_exists_error_keeps_its_message_and_path():
    from reports.messages import user_message
    from reports.signing import OutputExistsError

    e = OutputExistsError("keys/ca.pem")
    assert str(e) == "keys/ca.pem already exists; not overwritten"
    assert user_message(e) == str(e) and e.path == "keys/ca.pem"


def test_warm_up_loads_the_pipeline_and_the_compiled_kernels():
    # A fresh interpreter: in this one the kernels may have run already.
    code = ("import json, sys, engine\n"
            "assert 'engine.pipeline' not in sys.modules\n"
            "engine.warm_up()\n"
            "from engine import icp_kernels, kernels\n"
            "assert 'engine.pipeline' in sys.modules\n"
            "assert 'PySide6' not in sys.modules\n"
            "print(json.dumps([n for m in (kernels, icp_kernels) for n in dir(m)\n"
            "                  if getattr(getattr(m, n), 'signatures', None)]))\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    compiled = json.loads(r.stdout.strip().splitlines()[-1])
    # The measurement's and the registration's kernels are loaded (numba compiles or loads a
    # kernel on first call): the global search's, the coarse-to-fine levels' and the nominal's.
    for kernel in ("best_in_stars", "phong_finish", "icp_poses", "icp_paired", "shape_fit",
                   "grid_triangles", "longest_edges", "farthest_points", "distinct_first"):
        assert kernel in compiled, (kernel, compiled)
