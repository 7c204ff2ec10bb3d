"""The bundled samples: reproducible from their generator, and inspected to their ground truth."""

import hashlib
import json
import math
import os
import re
from pathlib import Path

import numpy as np
import pytest

import samples.generate as gen
from engine.pose import apply_transform
from engine.inspection import Tolerance, inspect, inspect_2d
from engine.nominal import Nominal
from engine.io import load_point_set
from engine.io.templates import read_dxf_template

SAMPLES = os.path.dirname(os.path.abspath(gen.__file__))

_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_TOKENS = re.compile(r"[^,;\s]+|[,;\s]+")


def _last_place(token: str) -> float:
    """One unit in the last printed decimal place of a number as written ("1.2345" -> 1e-4)."""
    mantissa, _, exponent = token.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 10.0 ** (int(exponent or 0) - decimals)


def assert_same_text_numbers(a: str, b: str, where: str) -> None:
    """Text files equal token for token, numbers within one unit of their last printed digit:
    the generator's floating point may differ in the last bit between CPUs (BLAS kernels), which
    can move a rounded digit by one; anything else must be identical."""
    la, lb = a.splitlines(), b.splitlines()
    assert len(la) == len(lb), (where, len(la), len(lb))
    for n, (x, y) in enumerate(zip(la, lb), 1):
        if x == y:
            continue
        tx, ty = _TOKENS.findall(x), _TOKENS.findall(y)
        assert len(tx) == len(ty), (where, n, x, y)
        for u, v in zip(tx, ty):
            if u == v:
                continue
            assert _NUMBER.fullmatch(u) and _NUMBER.fullmatch(v), (where, n, u, v)
            unit = max(_last_place(u), _last_place(v))
            assert abs(float(u) - float(v)) <= 1.01 * unit, (where, n, u, v)


def assert_same_json_numbers(a, b, where: str, rel: float = 1e-9, abs_: float = 1e-12) -> None:
    """JSON documents equal, floats within a relative 1e-9 (the last bits differ between CPUs)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), where
        for k in a:
            assert_same_json_numbers(a[k], b[k], f"{where}.{k}", rel, abs_)
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            assert_same_json_numbers(x, y, f"{where}[{k}]", rel, abs_)
    elif isinstance(a, float) or isinstance(b, float):
        assert isinstance(a, (int, float)) and isinstance(b, (int, float)), where
        assert math.isclose(a, b, rel_tol=rel, abs_tol=abs_), (where, a, b)
    else:
        assert a == b, (where, a, b)


def test_number_comparison_tolerates_the_last_digit_only():
    assert_same_text_numbers("P1,1.2345,-0.0001\n", "P1,1.2346,0.0000\n", "t")
    for other in ("P1,1.2347,-0.0001\n", "P2,1.2345,-0.0001\n", "P1,1.2345,-0.0001,\n"):
        with pytest.raises(AssertionError):
            assert_same_text_numbers("P1,1.2345,-0.0001\n", other, "t")
    assert_same_json_numbers({"a": [-0.7253137127654614]}, {"a": [-0.7253137127654616]}, "t")
    with pytest.raises(AssertionError):
        assert_same_json_numbers({"a": [-0.7253137]}, {"a": [-0.7253138]}, "t")


@pytest.mark.parametrize("name, make", [("belly_fairing", gen.make_fairing),
                                        ("seat_bracket", gen.make_bracket),
                                        ("fuselage_frame", gen.make_frame)])
def test_generator_reproduces_committed_samples(tmp_path, name, make):
    make(str(tmp_path))
    for f in os.listdir(tmp_path):
        committed = os.path.join(SAMPLES, name, f)
        if f.endswith(".dxf"):
            # ezdxf writes its CLASSES section in set order (Python's hash seed decides); the
            # geometry is what must be the same.
            a, b = read_dxf_template(tmp_path / f).template, read_dxf_template(committed).template
            for field in ("kind", "start", "end", "centre", "radius", "angle0", "sweep",
                          "contour", "closed", "side"):
                assert np.array_equal(getattr(a, field), getattr(b, field)), (f, field)
        elif f.endswith(".qasession"):
            # The session cites the files' SHA-256: a DXF's bytes vary as said above, and a
            # point file's last digit may vary between CPUs. The committed session must cite the
            # committed files.
            a, b = (json.loads((p).read_text()) for p in (tmp_path / f, Path(committed)))
            for rec in b["inputs"]:
                data = Path(SAMPLES, name, rec["relative_path"]).read_bytes()
                assert rec["sha256"] == hashlib.sha256(data).hexdigest(), (f, rec)
            for doc in (a, b):
                for rec in doc["inputs"]:
                    rec["sha256"] = None
            assert_same_json_numbers(a, b, f)
        elif f.endswith(".json"):
            assert_same_json_numbers(json.loads((tmp_path / f).read_text()),
                                     json.loads(Path(committed).read_text()), f)
        else:
            assert_same_text_numbers((tmp_path / f).read_text(), Path(committed).read_text(), f)


@pytest.mark.parametrize("name, nominal_file, pose_tol, dev_tol", [
    # The fairing's broad +0.06 mm rise is partly absorbed by the least-squares pose; the
    # bracket's uniform +0.012 mm offset on two faces at right angles is absorbed along their
    # bisector. Both are what a best fit does; the bounds say how much.
    ("belly_fairing", "nominal.csv", 0.15, 0.03),
    ("seat_bracket", "nominal.xyz", 0.05, 0.02),
])
def test_sample_inspects_to_its_truth(name, nominal_file, pose_tol, dev_tol):
    folder = os.path.join(SAMPLES, name)
    with open(os.path.join(folder, "truth.json")) as f:
        truth = json.load(f)
    nom = Nominal.from_point_set(load_point_set(os.path.join(folder, nominal_file)))
    measured = load_point_set(os.path.join(folder, "measured.csv"))
    res = inspect(nom, measured.points, Tolerance.symmetric(truth["tolerance_mm"]))
    assert res.verdict == truth["expected_verdict"]
    T_true = np.array(truth["T_nominal_measured"])
    drift = apply_transform(res.registration.T_nominal_measured, measured.points) \
        - apply_transform(T_true, measured.points)
    assert np.max(np.linalg.norm(drift, axis=1)) < pose_tol
    planted = np.array(truth["planted_deviation_mm"])
    assert np.max(np.abs(res.deviations.signed - planted)) < dev_tol


def test_frame_template_sample_inspects_to_its_truth():
    folder = os.path.join(SAMPLES, "fuselage_frame")
    with open(os.path.join(folder, "truth.json")) as f:
        truth = json.load(f)
    tpl = read_dxf_template(os.path.join(folder, "template.dxf"))
    assert tpl.ignored == {"TEXT": 1} and tpl.flattened == 1
    measured = load_point_set(os.path.join(folder, "measured.csv"))
    res = inspect_2d(tpl.template, measured.points, measured.dim,
                     Tolerance.symmetric(truth["tolerance_mm"]))
    assert res.verdict == truth["expected_verdict"]
    T_true = np.array(truth["T_nominal_measured"])
    drift = apply_transform(res.registration.T_nominal_measured, measured.points) \
        - apply_transform(T_true, measured.points)
    assert np.max(np.linalg.norm(drift[:, :2], axis=1)) < 0.02
    planted = np.array(truth["planted_deviation_mm"])
    assert np.max(np.abs(res.deviations.signed - planted)) < 0.005
