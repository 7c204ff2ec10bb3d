"""Every characteristic type the plan layer judges reaches the certificate: its words, what its
value measures, and its drawn symbol. A NIST CTC-05 run with its own QIF plan and --report
exited 70 (KeyError: 'concentricity'): coaxiality, concentricity and symmetry had no words."""

import json
import os
import shutil
import subprocess

import numpy as np
import pytest

from engine.gdt.plan import CHARACTERISTICS
from qa_app.cli import main
from reports.certificate.result import TYPE_WORDS, VALUE_WORDS, symbol_drawing

STP = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "step",
                   "nist_ctc_01_asme1_ap242-e1.stp")


@pytest.mark.parametrize("kind", CHARACTERISTICS)
def test_every_type_has_its_words_and_a_drawn_symbol(kind):
    assert TYPE_WORDS[kind] and VALUE_WORDS[kind].startswith(kind.replace("_", " ") + ":")
    assert len(symbol_drawing(kind).contents) >= 1


def test_a_size_is_signed_by_its_feature():
    """⌀ for a cylinder (circle and stroke), S⌀ for a sphere (one more shape: the S), nothing
    for a width."""
    assert len(symbol_drawing("size").contents) == 2
    assert len(symbol_drawing("size", "sphere").contents) == 3
    assert len(symbol_drawing("size", "width").contents) == 0


def test_a_type_without_a_symbol_is_an_error_not_a_blank():
    with pytest.raises(ValueError, match="no symbol is drawn for a wobble characteristic"):
        symbol_drawing("wobble")


# CTC-01's faces (qa-inspect faces): 98 the top plane (A); 67 and 64 two ⌀20 holes on one
# axis (x = -240, z = -60, along y); 38 and 42 a slot's walls (normals -x, +x); 25 a wall
# (normal +x).
PLAN = """
[[region]]
name = "top"
group = "face:98"
[[region]]
name = "b"
group = "face:67"
[[region]]
name = "hole"
group = "face:64"
[[region]]
name = "wall"
group = "face:25"
[[region]]
name = "slot"
group = ["face:38", "face:42"]
[[region]]
name = "h1"
group = ["face:72", "face:73"]
[[region]]
name = "h2"
group = ["face:74", "face:75"]
[[region]]
name = "hD"
group = ["face:90", "face:91"]
[[region]]
name = "hE"
group = ["face:76", "face:77"]
[[datum]]
label = "D"
region = "hD"
feature = "cylinder"
[[datum]]
label = "E"
region = "hE"
feature = "cylinder"
[[datum]]
label = "A"
region = "top"
feature = "plane"
[[datum]]
label = "B"
region = "b"
feature = "cylinder"
[[datum]]
label = "W"
region = "wall"
feature = "plane"
[[characteristic]]
id = "1"
type = "coaxiality"
region = "hole"
zone = 0.1
datums = ["B"]
[[characteristic]]
id = "2"
type = "concentricity"
region = "hole"
zone = 0.1
datums = ["B"]
[[characteristic]]
id = "3"
type = "symmetry"
region = "slot"
feature = "width"
zone = 0.1
datums = ["W"]
[[characteristic]]
id = "4"
type = "size"
region = "slot"
feature = "width"
nominal = 40.0
lower = -0.1
upper = 0.1
[[characteristic]]
id = "5"
type = "position"
regions = ["h1", "h2"]
zone = 0.75
datums = ["A", "D", "E"]
"""


def test_a_certificate_with_location_types_is_written_and_names_them(tmp_path):
    """Points on CTC-01's exact faces judged by a plan of coaxiality, concentricity, symmetry,
    a width's size and a pattern's position: the certificate is written (each was an internal
    error: the QIF it embeds joined a pattern's facts as an angle's two features), with each
    type in its words and a width's size without the diameter sign."""
    from engine.io.step import read_step
    from step_models import random_pose
    from sweep import on_part

    P, N, _ = on_part(read_step(STP), np.random.default_rng(2), 6000)
    R, t = random_pose(4)
    np.savetxt(tmp_path / "m.csv", P @ R.T + t, delimiter=",", header="x,y,z", comments="",
               fmt="%.9f")
    (tmp_path / "plan.toml").write_text(PLAN, encoding="utf-8")
    code = main(["inspect", STP, str(tmp_path / "m.csv"), "--plan", str(tmp_path / "plan.toml"),
                 "--report", str(tmp_path / "c.pdf"), "--json", str(tmp_path / "r.json"),
                 "--quiet"])
    assert code in (0, 1, 2)
    doc = json.loads((tmp_path / "r.json").read_text())
    assert {c["type"] for c in doc["characteristics"]} == {"coaxiality", "concentricity",
                                                           "symmetry", "size", "position"}
    text = subprocess.run([shutil.which("pdftotext") or "pdftotext", "-raw",
                           str(tmp_path / "c.pdf"), "-"], capture_output=True, text=True,
                          check=True).stdout
    flat = " ".join(text.split())
    for words in ("coaxiality", "concentricity", "symmetry", "size (width)",
                  "coaxiality: the diameter of the smallest cylinder about the datum axis",
                  "symmetry: the width of the smallest zone centred on the datum plane"):
        assert words in flat, words
    pattern = next(c for c in doc["characteristics"] if c["type"] == "position")
    assert pattern["verdict"] == "ACCEPT" and pattern["value"] < 0.01, pattern
    width = next(c for c in doc["characteristics"] if c["type"] == "size")
    assert "40.0000 -0.1000/+0.1000 mm" in flat and "Ø40.0000" not in flat, width


def test_a_plan_with_hundreds_of_kinds_not_judged_still_makes_its_certificate(tmp_path):
    """The seat bracket's plan and 200 [[not_judged]] kinds: REJECT (exit 1) with its
    certificate written (it was exit 70, a LayoutError: the verdict cell outgrew the page)."""
    sample = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                          "samples", "seat_bracket")
    with open(os.path.join(sample, "plan.toml"), encoding="utf-8") as f:
        text = f.read()
    text += "".join(f'\n[[not_judged]]\nid = "n{i}"\ntype = "unsupported kind {i}"\n'
                    'reason = "not judged here"\n' for i in range(200))
    (tmp_path / "plan.toml").write_text(text, encoding="utf-8")
    code = main(["inspect", os.path.join(sample, "nominal.xyz"),
                 os.path.join(sample, "measured.csv"), "--plan", str(tmp_path / "plan.toml"),
                 "--report", str(tmp_path / "c.pdf"), "--quiet"])
    assert code == 1 and (tmp_path / "c.pdf").stat().st_size > 10_000
