"""What the certificate says, read back with poppler (pdftotext, pdfdetach) and lxml: the
traceability block and its QIF, the uncertainty budget and the rule in words, the alignment in
plain language, the worst excursion's sign explained, where every point is, and no page less
than half full but the last (measured from the lowest line of text on each page)."""

import csv
import json
import os
import re
import shutil
import subprocess

import numpy as np
import pytest
from lxml import etree

from qa_app.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BELLY = [os.path.join(ROOT, "samples", "belly_fairing", f) for f in ("nominal.csv",
                                                                     "measured.csv")]
BRACKET = [os.path.join(ROOT, "samples", "seat_bracket", f) for f in ("nominal.xyz",
                                                                      "measured.csv")]
FRAME = [os.path.join(ROOT, "samples", "fuselage_frame", f) for f in ("template.dxf",
                                                                      "measured.csv")]
XSD = os.path.join(ROOT, "tests", "data", "qif-3.0-xsd", "QIFDocument.xsd")
MEASUREMENT = """
[measurement]
device = "Zeiss Contura G2"
device_serial = "C-4711"
calibration_date = 2025-03-01
probe = "VAST XT gold, 3 mm ruby x 40 mm"
program = "SB-1020_C.mpp"
temperature_c = 21.0
mpe_a_um = 1.8
mpe_l_per_um = 300
probing_um = 1.9
expansion_per_k = 23e-6
"""
MM = 72 / 25.4


def tool(name: str) -> str:
    path = shutil.which(name)
    if path is None:
        pytest.fail(f"{name} is not installed (poppler-utils)", pytrace=False)
    return path


class Certificate:
    """One unsigned certificate made by the command line, read back: its text per page, its
    attachments, the JSON and CSV written beside it."""

    def __init__(self, d, files, args):
        self.pdf, j, c = d / "c.pdf", d / "r.json", d / "r.csv"
        self.code = main(["inspect", *files, *args, "--report", str(self.pdf), "--json", str(j),
                          "--csv", str(c)])
        self.doc = json.loads(j.read_text())
        with open(c, newline="") as f:
            self.rows = list(csv.DictReader(f))
        # Content-stream order: a table cell's lines stay together.
        text = subprocess.run([tool("pdftotext"), "-raw", str(self.pdf), "-"],
                              capture_output=True, text=True, check=True).stdout
        self.pages = [p for p in text.split("\f") if p.strip()]
        # One line of text per paragraph line: join them so that sentences can be searched.
        self.text = " ".join(" ".join(self.pages).split())
        subprocess.run([tool("pdfdetach"), "-saveall", "-o", str(d), str(self.pdf)],
                       check=True, capture_output=True)
        self.attached = d


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    plan = tmp_path_factory.mktemp("plan") / "plan.toml"
    with open(os.path.join(ROOT, "samples", "seat_bracket", "plan.toml")) as f:
        text = f.read()
    plan.write_text(text.replace('revision = "C"\n', 'revision = "C"\ndrawing = "SB-1020-D"\n'
                                 'cad_revision = "C.2"\n' + MEASUREMENT, 1))
    cases = {"bracket": (BRACKET, ["--plan", str(plan), "--serial", "S-1", "--probe",
                                   "TP20, M2 ruby 2 x 20 mm"]),
             "reject": (BELLY, ["--tol", "0.1"]),
             "accept": (BELLY, ["--tol", "0.25"]),
             "frame": (FRAME, ["--tol", "0.05"])}
    return {k: Certificate(tmp_path_factory.mktemp(k), files, args)
            for k, (files, args) in cases.items()}


def test_traceability_block_and_its_qif(made):
    """The plan's [part] and [measurement] fill the traceability block where the command line
    gives nothing; what it gives wins (the probe)."""
    c = made["bracket"]
    page1 = " ".join(c.pages[0].split())
    for label, value in (("Device", "Zeiss Contura G2"), ("Device serial", "C-4711"),
                         ("Calibrated on", "2025-03-01"), ("Probe / stylus", "TP20, M2 ruby"),
                         ("Temperature", "21 °C"), ("Program", "SB-1020_C.mpp"),
                         ("Drawing", "SB-1020-D"), ("CAD revision", "C.2")):
        assert re.search(re.escape(label) + r" +" + re.escape(value), page1), label
    cert = json.loads((c.attached / "results.json").read_text())["certificate"]
    assert (cert["device"], cert["device_serial"], cert["calibration_date"], cert["probe"],
            cert["temperature_c"], cert["program"], cert["drawing"], cert["cad_revision"]) == \
        ("Zeiss Contura G2", "C-4711", "2025-03-01", "TP20, M2 ruby 2 x 20 mm", 21.0,
         "SB-1020_C.mpp", "SB-1020-D", "C.2")
    schema = etree.XMLSchema(etree.parse(XSD))
    qif = etree.parse(str(c.attached / "results.qif"))
    assert schema.validate(qif), schema.error_log
    ns = {"q": "http://qifstandards.org/xsd/qif3"}
    assert qif.xpath("//q:MeasurementDevice/q:SerialNumber/text()", namespaces=ns) == ["C-4711"]
    assert qif.xpath("//q:DigitalModel/q:File/q:Version/text()", namespaces=ns) == ["C.2"]


def test_a_temperature_that_contradicts_the_budget_is_refused(made, tmp_path, capsys):
    bracket_plan = [a for a in json.loads((made["bracket"].attached / "results.json")
                                          .read_text())["inputs"] if a["role"] == "plan"][0]
    code = main(["inspect", *BRACKET, "--plan", bracket_plan["path"], "--temperature", "23",
                 "--report", str(tmp_path / "c.pdf")])
    assert code == 64 and not (tmp_path / "c.pdf").exists()
    assert "temperature_c = 21 °C that its uncertainty budget uses" in capsys.readouterr().err
    assert main(["inspect", *BRACKET, "--plan", bracket_plan["path"], "--calibration-date",
                 "2025-02-30", "--report", str(tmp_path / "c.pdf")]) == 64


def test_uncertainty_budget_and_rule_in_words(made):
    c = made["bracket"]
    unc = c.doc["uncertainty"]
    assert "Measurement uncertainty budget" in c.text
    for term in unc["terms"]:
        name = term["name"][:1].upper() + term["name"][1:]
        assert name in c.text
    assert re.search(r"Expanded U k = 2 x root-sum-of-squares of the terms, per point "
                     rf"{unc['expanded_max_mm']:.4f} {unc['expanded_mean_mm']:.4f}", c.text)
    assert "shrunk by its expanded measurement uncertainty U" in c.text
    assert "outside when a point lies outside the zone grown by it (ISO 14253-1" in c.text
    # Without an instrument and with the simple rule there is no budget, and it says so.
    accept = made["accept"]
    assert "Measurement uncertainty budget" not in accept.text
    assert "Measurement uncertainty is not deducted from the zone (simple acceptance)." in \
        accept.text


def test_alignment_in_plain_words(made):
    c = made["accept"]
    reg = c.doc["registration"]
    ratio = reg["runner_up_score"] / reg["score"]
    assert ("Best fit over all points: it checks form only, not location (no datums place the "
            "part") in c.text
    assert (f"{reg['hypotheses']:,} starting poses were tried; the second-best distinct pose "
            f"fits {ratio:.1f} times worse") in c.text
    assert "All 1,100 points lie within" in c.text and "so the points are of this part" in c.text
    for jargon in ("Pose score", "runner-up pose", "Near the nominal"):
        assert jargon not in c.text
    assert "then placed by the plan's datums" in made["bracket"].text


def test_the_worst_excursion_sign_is_explained(made):
    c = made["reject"]
    d = np.array([float(r["deviation"]) for r in c.rows])
    worst = int(np.argmax(np.maximum(d - 0.1, -0.1 - d)))
    assert d[worst] < -0.1  # the dent: material missing, below the lower limit
    label = c.rows[worst]["label"]
    assert (f"the worst, point {label}, lies {-0.1 - d[worst]:.4f} mm below the lower limit: "
            f"its deviation {d[worst]:+.4f} mm is negative, material missing (the measured "
            "surface lies inside the nominal, into the material)") in c.text
    assert "positive where the measured surface lies outside the nominal (excess material)" \
        in c.text


def test_every_point_is_listed_or_the_csv_is_named(made):
    small = made["bracket"]  # 176 points: every one in the table
    assert f"This table lists all {len(small.rows)} measured points" in small.text
    listed = small.text.split("9 Measured points", 1)[1]
    assert all(f" {r['label']} " in listed for r in small.rows)
    big = made["accept"]  # 1100 points: the attached CSV is the complete list
    assert ("This table lists 25 of the 1,100 measured points. The complete list of all 1,100 "
            "points, each with its input and registered coordinates, deviation and result, is "
            "the attached file points.csv") in big.text
    with open(big.attached / "points.csv") as f:
        assert sum(1 for _ in f) == 1101


def page_fill(pdf) -> list[float]:
    """Per page, how far down the body the lowest line of text reaches (0 top, 1 bottom): the
    body between the running header (30 mm) and the footer (22 mm); the diagonal UNSIGNED DRAFT
    watermark's letters (70 pt) are no text of the page."""
    xml = subprocess.run([tool("pdftotext"), "-bbox", str(pdf), "-"], capture_output=True,
                         text=True, check=True).stdout
    fills = []
    for height, body in re.findall(r'<page width="[\d.]+" height="([\d.]+)">(.*?)</page>', xml,
                                   re.S):
        bottom = float(height) - 22 * MM
        ys = [float(y1) for y0, y1 in re.findall(r'<word xMin="[\d.]+" yMin="([\d.]+)" '
                                                  r'xMax="[\d.]+" yMax="([\d.]+)"', body)
              if 30 * MM < float(y0) and float(y1) < bottom and float(y1) - float(y0) < 20]
        fills.append((max(ys) - 30 * MM) / (bottom - 30 * MM) if ys else 0.0)
    return fills


@pytest.mark.parametrize("case", ["bracket", "reject", "accept", "frame"])
def test_no_page_is_less_than_half_full_but_the_last(made, case):
    fills = page_fill(made[case].pdf)
    assert len(fills) >= 3
    assert all(f >= 0.5 for f in fills[:-1]), fills


def test_json_and_csv_number_points_from_one_with_their_labels(made):
    """Like the app: the CSV's first column is the point's number from 1; every point the JSON
    names carries that number and the file's label (the deviations' worst, a characteristic's
    worst)."""
    c = made["bracket"]
    assert [r["point"] for r in c.rows] == [str(k) for k in range(1, len(c.rows) + 1)]
    named = c.doc["deviations"]["worst"] + [w for ch in c.doc["characteristics"]
                                            for w in ch["worst"]]
    assert len(named) > 10
    for w in named:
        row = c.rows[w["point"] - 1]
        assert w["label"] == row["label"] != ""
    for w in c.doc["deviations"]["worst"]:
        assert float(c.rows[w["point"] - 1]["deviation"]) == pytest.approx(w["deviation"],
                                                                           abs=5e-7)
