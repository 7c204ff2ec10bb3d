"""Plans with many characteristics (issue 22 item 6): the work of a region (its pose, fits and
deviations) is done once however many characteristics ask for it, and gives what each
characteristic judged alone gives. The seat bracket sample, registered once."""

import dataclasses
import os

import numpy as np
import pytest

from engine.gdt.characteristics import inspect_plan
from engine.inspection import Tolerance, inspect
from engine.io import load_point_set
from engine.io.plan import read_plan
from engine.nominal import Nominal
from engine.gdt.plan import Characteristic

HERE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "samples",
                    "seat_bracket")


@pytest.fixture(scope="module")
def bracket():
    nps = load_point_set(os.path.join(HERE, "nominal.xyz"))
    mps = load_point_set(os.path.join(HERE, "measured.csv"))
    nominal = Nominal.from_point_set(nps)
    res = inspect(nominal, mps.points, Tolerance.symmetric(0.05))
    return res, read_plan(os.path.join(HERE, "plan.toml")), nominal, nps, mps


def judged(bracket, characteristics):
    res, plan, nominal, nps, mps = bracket
    plan = dataclasses.replace(plan, characteristics=tuple(characteristics))
    return inspect_plan(res, plan, nominal, nps.labels, mps.points, mps.labels, False).plan


# Every type, each twice or more on one region with other zones (one sided, asymmetric, a
# minimax refit about two centres), so that shared work meets different judgements.
SEVERAL = [
    Characteristic("p1", "profile", "skin", -0.01, 0.01, ("A", "B", "C")),
    Characteristic("p2", "profile", "skin", -0.1, 0.1, ("A", "B", "C")),
    Characteristic("f1", "profile", "skin", -0.015, 0.015),
    Characteristic("f2", "profile", "skin", -0.005, 0.04),
    Characteristic("m1", "profile", "skin", -0.015, 0.015, fit="minimax"),
    Characteristic("m2", "profile", "skin", -0.002, 0.03, fit="minimax"),
    Characteristic("m3", "profile", "skin", -0.015, 0.015, fit="minimax"),
    Characteristic("fl1", "flatness", "A", 0.0, 0.01),
    Characteristic("fl2", "flatness", "A", 0.0, 0.001),
    Characteristic("x1", "position", "hole1", 0.0, 0.1, ("A", "B", "C")),
    Characteristic("x2", "position", "hole1", 0.0, 0.02, ("A", "B", "C")),
    Characteristic("s1", "size", "hole1", -0.05, 0.05, nominal=8.0),
    Characteristic("s2", "size", "hole1", -0.005, 0.005, nominal=8.0),
]


def _same(a, b, where):
    """Equal to the last bit: numbers, arrays, and dicts / lists of them."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            _same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (list, tuple)) and a and not isinstance(a[0], (int, float, str)):
        assert len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{k}]")
    elif isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        np.testing.assert_array_equal(a, b, err_msg=where)
    else:
        assert a == b, where


def test_characteristics_sharing_a_region_are_judged_as_each_alone(bracket):
    together = judged(bracket, SEVERAL)
    verdicts = {r.characteristic.id: r.verdict for r in together.characteristics}
    assert {"ACCEPT", "REJECT"} <= set(verdicts.values())  # the zones do tell them apart
    for c, r in zip(SEVERAL, together.characteristics):
        alone = judged(bracket, [c]).characteristics[0]
        assert r.characteristic == c
        for name in ("value", "verdict", "reason", "indices", "deviations", "worst", "facts"):
            _same(getattr(r, name), getattr(alone, name), f"{c.id}.{name}")


def test_the_work_of_a_region_is_done_once(bracket, monkeypatch):
    """Twenty copies of the sample's five characteristics (new ids) cost the deviations,
    cylinder fits and minimum zones of one copy: none of that work is per characteristic."""
    import engine.deviation
    import engine.gdt.features

    calls = {"deviations": 0, "cylinder fits": 0, "minimum zones": 0}

    def counted(name, f):
        def wrapper(*args, **kwargs):
            calls[name] += 1
            return f(*args, **kwargs)
        return wrapper

    monkeypatch.setattr(engine.deviation, "point_to_surface",
                        counted("deviations", engine.deviation.point_to_surface))
    monkeypatch.setattr(engine.gdt.features, "fit_cylinder_lsq",
                        counted("cylinder fits", engine.gdt.features.fit_cylinder_lsq))
    monkeypatch.setattr(engine.gdt.features, "flatness",
                        counted("minimum zones", engine.gdt.features.flatness))
    five = bracket[1].characteristics
    judged(bracket, five)
    once = dict(calls)
    calls.update(dict.fromkeys(calls, 0))
    many = judged(bracket, [dataclasses.replace(c, id=f"{c.id}.{k}")
                            for k in range(20) for c in five])
    assert len(many.characteristics) == 100
    assert all(v > 0 for v in once.values()), once
    assert calls == once


def test_a_plan_over_the_limit_is_bad_input_naming_it(tmp_path, monkeypatch, capsys):
    """More characteristics than MAX_CHARACTERISTICS (lowered to 5 here): exit 65, the message
    names the plan, the count and the limit, before any work."""
    import engine.gdt.plan
    from qa_app.cli import EX_DATAERR, main

    monkeypatch.setattr(engine.gdt.plan, "MAX_CHARACTERISTICS", 5)
    with open(os.path.join(HERE, "plan.toml")) as f:
        text = f.read()
    plan = tmp_path / "six.toml"
    plan.write_text(text + '\n[[characteristic]]\nid = "6"\ntype = "flatness"\nregion = "A"\n'
                    'zone = 0.02\n')
    code = main(["inspect", os.path.join(HERE, "nominal.xyz"), os.path.join(HERE, "measured.csv"),
                 "--plan", str(plan)])
    err = capsys.readouterr().err
    assert code == EX_DATAERR
    assert f"{plan}: holds 6 characteristics; a plan may hold at most 5" in err


def test_a_certificate_of_many_rejected_characteristics_fits_its_pages(tmp_path):
    """Sixty rejected characteristics made the verdict's block taller than a page: exit 70
    (reportlab LayoutError), no certificate. It names ten and says how many more."""
    import subprocess

    from qa_app.cli import main

    with open(os.path.join(HERE, "plan.toml")) as f:
        head, *chars = f.read().split("[[characteristic]]")
    plan = tmp_path / "sixty.toml"
    plan.write_text(head + "".join("[[characteristic]]" + chars[0].replace(
        'id = "1"', f'id = "1.{k}"') for k in range(60)))
    pdf = tmp_path / "c.pdf"
    code = main(["inspect", os.path.join(HERE, "nominal.xyz"), os.path.join(HERE, "measured.csv"),
                 "--plan", str(plan), "--report", str(pdf)])
    assert code == 1
    text = subprocess.run(["pdftotext", "-raw", str(pdf), "-"], capture_output=True, text=True,
                          check=True).stdout
    words = " ".join(text.split())
    assert "; and 50 more, listed in section 2" in words
    assert "characteristics 1.0 (surface profile of region skin)" in words
    assert "and 50 more lie outside their tolerances (section 2; 60 characteristics in all)" \
        in words
