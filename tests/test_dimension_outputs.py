"""The dimensions' values in every output, with their units: the NIST CTC-01 part's plan
written from its QIF (qa-inspect plan --toml), a radius and a distance added by hand, run on
points sampled on its exact faces in a random pose: the JSON (unit, nominal, features), the
console summary and the certificate (an angle in degrees, never mm), the QIF results (Angle in
the degree the file declares, DistanceBetween with its feature pair, Radius; valid against
the XSD) and the lot summary's limits; each value against the STEP faces' own geometry."""

import csv
import json
import os
import shutil
import subprocess

import numpy as np
import pytest
from lxml import etree

from qa_app.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
QIF = os.path.join(ROOT, "tests", "data", "qif", "NISTmodels__nist_ctc_01_asme1_ap242.qif")
STP = os.path.join(ROOT, "tests", "data", "step", "nist_ctc_01_asme1_ap242-e1.stp")
XSD = os.path.join(ROOT, "tests", "data", "qif-3.0-xsd", "QIFDocument.xsd")
Q = "{http://qifstandards.org/xsd/qif3}"
# CTC-01: the ⌀20 hole (QIF feature 2175, faces 53 and 54, axis along y) and the side wall
# (2162, face 25, normal +x) it stands 430 mm from.
ADDED = """
[[characteristic]]
id = "R20"
type = "radius"
region = "qif:2175"
nominal = 10
lower = -0.05
upper = 0.025

[[characteristic]]
id = "D430"
type = "distance"
regions = ["qif:2162", "qif:2175"]
nominal = 430
lower = -0.1
upper = 0.1
features = ["plane", "cylinder"]
"""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """(the JSON document, the console output, the plan, the folder) of the run."""
    from step_models import random_pose
    from sweep import on_part

    from engine.io.step import read_step

    tmp = tmp_path_factory.mktemp("dims")
    plan = tmp / "plan.toml"
    assert main(["plan", QIF, "--nominal", STP, "--toml", str(plan)]) == 0
    plan.write_text(plan.read_text("utf-8") + ADDED, "utf-8")
    step = read_step(STP)
    rng = np.random.default_rng(7)
    P, N, _ = on_part(step, rng, 12000)
    P = P + rng.normal(0.0, 1e-4, len(P))[:, None] * N
    R, t = random_pose(11)
    np.savetxt(tmp / "m.csv", P @ R.T + t, delimiter=",", header="x,y,z", comments="",
               fmt="%.9f")
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        main(["inspect", STP, str(tmp / "m.csv"), "--plan", str(plan), "--json",
              str(tmp / "r.json"), "--csv", str(tmp / "r.csv"), "--report", str(tmp / "r.pdf")])
    return json.loads((tmp / "r.json").read_text()), out.getvalue(), step, tmp


def test_the_json_gives_each_dimension_its_value_unit_and_nominal(run):
    doc, _, step, _ = run
    chars = {c["id"]: c for c in doc["characteristics"]}
    wall, hole = step.faces[25 - 1].geometry, step.faces[53 - 1].geometry
    assert step.faces[25 - 1].id == 25 and step.faces[53 - 1].id == 53
    across = np.asarray(hole["point"]) - np.asarray(wall["point"])
    expected = abs(float(across @ np.asarray(wall["normal"])))
    assert expected == pytest.approx(430.0, abs=1e-9)
    d, r, a = chars["D430"], chars["R20"], chars["1491"]
    assert d["value"] == pytest.approx(expected, abs=1e-4) and d["verdict"] == "ACCEPT"
    assert d["unit"] == "mm" and d["features"] == ["plane", "cylinder"] and d["nominal"] == 430
    assert d["regions"] == ["qif:2162", "qif:2175"]
    assert r["value"] == pytest.approx(hole["radius"], abs=2e-4) and r["verdict"] == "ACCEPT"
    assert r["unit"] == "mm" and r["feature"] == "cylinder" and r["symbol"] == "R"
    assert a["unit"] == "degree" and a["value"] == pytest.approx(60.0, abs=1e-3)
    assert (a["zone"], a["lower"], a["upper"], a["nominal"]) == (1.0, -0.5, 0.5, 60.0)
    assert "60.0000° -0.5000/+0.5000°" not in a["reason"]  # the reason says the value
    assert "° within [59.5000, 60.5000]°" in a["reason"] and " mm" not in a["reason"]
    assert "'degree' for an angle" in doc["dimension_value_definition"]
    assert not any("not judged" in reason for reason in doc["reasons"])


def test_the_console_and_the_certificate_print_an_angle_in_degrees(run):
    doc, out, _, tmp = run
    line = next(x for x in out.splitlines() if x.startswith("  [1491] angle "))
    assert "qif:2180/1296 & qif:2180/1314: 60.00" in line and "° " in line, line
    assert "60.0000° -0.5000/+0.5000°" in line and " mm" not in line, line
    if shutil.which("pdftotext") is None:  # poppler, as tests/test_certificate_text.py uses
        pytest.fail("pdftotext (poppler-utils) is needed to read the certificate back")
    text = subprocess.run(["pdftotext", "-layout", str(tmp / "r.pdf"), "-"], check=True,
                          capture_output=True, text=True).stdout
    assert "angle (degrees)" in text and "Measured (mm, °)" in text
    assert "60.0000° -0.5000/+0.5000°" in text
    value = next(c for c in doc["characteristics"] if c["id"] == "1491")["value"]
    assert f"{value:.4f}°" in text
    assert "R10.0000 -0.0500/+0.0250 mm" in text and "430.0000 -0.1000/+0.1000 mm" in text
    assert "in degrees (value and requirement in degrees, not mm)" in " ".join(text.split())


def test_the_qif_results_state_angle_distance_and_radius_in_their_units(run):
    from reports.qif import qif_results_document

    doc, _, _, tmp = run
    with open(tmp / "r.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    data = qif_results_document(
        doc, np.array([[float(r[k]) for k in ("x_reg", "y_reg", "z_reg")] for r in rows]),
        np.array([float(r["deviation"]) for r in rows]),
        np.array([r["in_tolerance"] == "true" for r in rows]))
    schema = etree.XMLSchema(etree.parse(XSD))
    root = etree.fromstring(data)
    assert schema.validate(etree.ElementTree(root)), "\n".join(str(e) for e in schema.error_log)
    unit = root.find(f"{Q}FileUnits/{Q}PrimaryUnits/{Q}AngularUnit")
    assert unit.findtext(f"{Q}UnitName") == "degree"
    assert float(unit.findtext(f"{Q}UnitConversion/{Q}Factor")) == pytest.approx(np.pi / 180)
    chars = {doc["characteristics"][i]["id"]: doc["characteristics"][i]
             for i in range(len(doc["characteristics"]))}
    nominal = root.find(f".//{Q}AngleCharacteristicNominal")
    assert float(nominal.findtext(f"{Q}TargetValue")) == 60.0
    assert len(nominal.findall(f"{Q}FeatureNominalIds/{Q}Id")) == 2
    measured = root.find(f".//{Q}AngleCharacteristicMeasurement")
    assert float(measured.findtext(f"{Q}Value")) == pytest.approx(chars["1491"]["value"],
                                                                   abs=1e-6)
    distance = root.find(f".//{Q}DistanceBetweenCharacteristicNominal")
    pair = distance.find(f"{Q}FeatureNominalPairs/{Q}FeaturePair")
    ids = [i.text for i in distance.findall(f"{Q}FeatureNominalIds/{Q}Id")]
    assert [pair.findtext(f"{Q}FirstFeature"), pair.findtext(f"{Q}SecondFeature")] == ids
    assert float(distance.findtext(f"{Q}TargetValue")) == 430.0
    radius = root.find(f".//{Q}RadiusCharacteristicMeasurement")
    assert float(radius.findtext(f"{Q}Value")) == pytest.approx(chars["R20"]["value"], abs=1e-6)


def test_a_lot_tracks_a_dimension_between_its_limits_in_its_unit(run):
    from engine.io.plan import read_plan
    from qa_app.lot_summary import tracked_characteristics

    _, _, _, tmp = run

    class Loaded:  # what tracked() reads of a batch's settings and plan
        plan = read_plan(str(tmp / "plan.toml"))

        class settings:
            zone_in_verdict = False
            tol_lower, tol_upper = -0.5, 0.5

    got = {t.id: t for t in tracked_characteristics(Loaded)}
    assert (got["1491"].unit, got["1491"].lower, got["1491"].upper) == ("degree", 59.5, 60.5)
    assert (got["D430"].unit, got["D430"].lower, got["D430"].upper) == ("mm", 429.9, 430.1)


def test_the_plan_table_states_the_angle_in_degrees_between_its_two_faces(capsys):
    assert main(["plan", QIF, "--nominal", STP]) == 0
    row = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("1491 "))
    assert "∡ angle" in row and "60° -0.5°/+0.5°" in row and "plane and plane" in row, row
    assert "pattern" not in row and row.rstrip().endswith("yes"), row
    assert "qif:2180/1296 -> face 18; qif:2180/1314 -> face 16" in row, row
