"""``qa-inspect faces`` and ``qa-inspect plan`` (qa_app.model_commands): the faces of NIST STEP
models counted in the STEP text and checked against OpenCascade's own surfaces, the NIST CTC-01
and FTC-08 QIF plans listed characteristic by characteristic, written as TOML plans that read
back to the same plan and judge planted points exactly as the QIF plan does, and bad input
refused with the file named."""

import contextlib
import csv
import io
import json
import math
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from qa_app.cli import main

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
STEP_DIR = os.path.join(DATA, "step")
QIF_DIR = os.path.join(DATA, "qif")
CTC01 = os.path.join(STEP_DIR, "nist_ctc_01_asme1_ap242-e1.stp")
FTC06 = os.path.join(STEP_DIR, "nist_ftc_06_asme1_ap242-e1.stp")  # in inches
PARTS = {
    "CTC-01": (os.path.join(QIF_DIR, "NISTmodels__nist_ctc_01_asme1_ap242.qif"), CTC01),
    "FTC-08": (os.path.join(QIF_DIR, "NISTmodels__nist_ftc_08_asme1_ap242-1.qif"),
               os.path.join(STEP_DIR, "nist_ftc_08_asme1_ap242-e1.stp")),
}
QIF3 = "{http://qifstandards.org/xsd/qif3}"


def advanced_faces(path: str) -> int:
    """The ADVANCED_FACE instances of a STEP file, counted in its text."""
    with open(path, encoding="latin-1") as f:
        return len(re.findall(r"^#\d+\s*=\s*ADVANCED_FACE\s*\(", f.read(), re.M))


def run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


class _Runs(dict):
    """{model: (exit code, stdout, CSV rows)} of ``faces MODEL --csv OUT``, run on first use."""

    def __init__(self, folder):
        super().__init__()
        self.folder = folder

    def __missing__(self, path):
        target = self.folder / (os.path.basename(path) + ".csv")
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            code = main(["faces", path, "--csv", str(target)])
        with open(target, newline="") as f:
            rows = list(csv.DictReader(f))
        self[path] = (code, buf.getvalue(), rows)
        return self[path]


@pytest.fixture(scope="module")
def faces_runs(tmp_path_factory):
    return _Runs(tmp_path_factory.mktemp("faces"))


def _exact(face):
    """(kind, values) of a face from OpenCascade's BRepAdaptor_Surface, computed here."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import (GeomAbs_Cone, GeomAbs_Cylinder, GeomAbs_Plane, GeomAbs_Sphere,
                             GeomAbs_Torus)

    s = BRepAdaptor_Surface(face)
    t = s.GetType()
    v = lambda p: np.array(p.Coord())  # noqa: E731
    if t == GeomAbs_Plane:
        return "plane", {"point": v(s.Plane().Location()),
                         "dir": v(s.Plane().Axis().Direction())}
    if t == GeomAbs_Cylinder:
        c = s.Cylinder()
        return "cylinder", {"point": v(c.Location()), "dir": v(c.Axis().Direction()),
                            "diameter": 2 * c.Radius()}
    if t == GeomAbs_Cone:
        c = s.Cone()
        return "cone", {"point": v(c.Apex()), "dir": v(c.Axis().Direction()),
                        "half_angle_deg": math.degrees(abs(c.SemiAngle()))}
    if t == GeomAbs_Sphere:
        c = s.Sphere()
        return "sphere", {"point": v(c.Location()), "diameter": 2 * c.Radius()}
    if t == GeomAbs_Torus:
        c = s.Torus()
        return "torus", {"point": v(c.Location()), "dir": v(c.Axis().Direction()),
                         "diameter": 2 * c.MajorRadius(), "minor_diameter": 2 * c.MinorRadius()}
    return "other", {}


def _row_vector(row, prefix):
    return np.array([float(row[f"{prefix}_{a}"]) for a in "xyz"])


@pytest.mark.parametrize("path", [CTC01, FTC06], ids=["CTC-01", "FTC-06"])
def test_faces_lists_every_face_of_the_step_file(path, faces_runs):
    """One row per ADVANCED_FACE of the file, in the table and in the CSV, ids 1..N."""
    code, out, rows = faces_runs[path]
    n = advanced_faces(path)
    assert code == 0 and n > 100
    assert [int(r["id"]) for r in rows] == list(range(1, n + 1))
    table = [line for line in out.splitlines() if re.match(r"^\s*\d+\s+[a-z]+\s+[\d.]+\s", line)]
    assert [int(line.split()[0]) for line in table] == list(range(1, n + 1))
    assert f"{n} faces" in out.splitlines()[0]


@pytest.mark.parametrize("path", [CTC01, FTC06], ids=["CTC-01", "FTC-06"])
def test_face_geometry_agrees_with_opencascades_surfaces(path, faces_runs):
    """Each face's printed kind and geometry (CSV, and the table's rounded numbers) against
    OpenCascade's BRepAdaptor_Surface of the same face, computed here: a plane's normal and
    a point on it, a cylinder's axis and diameter, a cone's apex, axis and half-angle, a
    sphere's centre and diameter, a torus' radii."""
    from engine.io.step import read_step

    _, out, rows = faces_runs[path]
    step = read_step(path)
    lines = {int(line.split()[0]): line for line in out.splitlines()
             if re.match(r"^\s*\d+\s+[a-z]+\s", line)}
    checked: dict[str, int] = {}
    for row in rows:
        fid = int(row["id"])
        kind, truth = _exact(step.face_shape(fid))
        assert row["type"] == (kind if kind != "other" else row["type"]), row
        if kind == "other":
            continue
        checked[kind] = checked.get(kind, 0) + 1
        p = _row_vector(row, "point")
        if "dir" in truth:
            d = _row_vector(row, "dir")
            assert abs(abs(float(d @ truth["dir"])) - 1.0) < 1e-9, (fid, d, truth["dir"])
        if kind == "plane":
            assert abs(float((p - truth["point"]) @ truth["dir"])) < 1e-9
        elif kind == "cylinder":
            off = p - truth["point"]
            a = truth["dir"]
            assert np.linalg.norm(off - (off @ a) * a) < 1e-9
        else:
            assert np.allclose(p, truth["point"], atol=1e-9)
        if kind == "cone":
            # The axis points from the apex into the cone: the face's points lie that way.
            assert float(_row_vector(row, "dir") @ (step.point_set.points[
                np.asarray(step.face_ids) == fid].mean(axis=0) - p)) > 0
        for key in ("diameter", "minor_diameter", "half_angle_deg"):
            if key in truth:
                assert float(row[key]) == pytest.approx(truth[key], abs=1e-9)
        # The table's numbers are the same to their 6 decimals.
        words = lines[fid].split("  ")[-1]
        numbers = [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?", words)]
        if kind in ("cylinder", "sphere", "torus"):
            shown = float(re.search(r"⌀(\d+(?:\.\d+)?)", words).group(1))
            assert shown == pytest.approx(truth["diameter"], abs=1e-6)
        if kind == "plane":
            assert np.allclose(numbers[:3], p, atol=1e-6)
    assert checked.get("plane", 0) > 20 and checked.get("cylinder", 0) > 20
    assert checked.get("cone", 0) >= 4


def test_faces_are_in_mm_for_a_model_in_inches(faces_runs):
    """FTC-08's geometry is in inches (its representation context's unit, #6, is
    CONVERSION_BASED_UNIT('INCH')): its CYLINDRICAL_SURFACE radii, x 25.4, are the cylinder
    rows' radii."""
    path = PARTS["FTC-08"][1]
    with open(path, encoding="latin-1") as f:
        text = f.read()
    assert "#6=(CONVERSION_BASED_UNIT('INCH'" in text
    assert re.search(r"GLOBAL_UNIT_ASSIGNED_CONTEXT\s*\(\(#6,", text)
    radii = {round(float(r) * 25.4, 6) for r in
             re.findall(r"CYLINDRICAL_SURFACE\s*\(\s*'[^']*'\s*,\s*#\d+\s*,\s*([-\d.E+]+)\s*\)",
                        text)}
    rows = faces_runs[path][2]
    got = {round(float(r["diameter"]) / 2, 6) for r in rows if r["type"] == "cylinder"}
    assert len(radii) >= 5 and radii == got


@pytest.mark.parametrize("path", [CTC01, FTC06], ids=["CTC-01", "FTC-06"])
def test_face_areas_match_their_tessellation(path, faces_runs):
    """Each face's area against the sum of its triangles' (the model's tessellation, chordal
    deflection at most 10 µm): within 0.2 % and 0.5 mm² ."""
    from engine.io.step import read_step
    from sweep import face_areas

    rows = faces_runs[path][2]
    area, face = face_areas(read_step(path))
    meshed = np.bincount(face, weights=area, minlength=len(rows) + 1)[1:]
    exact = np.array([float(r["area_mm2"]) for r in rows])
    assert np.all(np.abs(exact - meshed) <= 2e-3 * exact + 0.5), np.abs(exact - meshed).max()


def test_faces_refuses_what_is_no_step_model_and_an_output_onto_its_input(tmp_path, capsys):
    points = tmp_path / "part.csv"
    points.write_text("x,y,z\n0,0,0\n")
    code, _, err = run(capsys, ["faces", str(points)])
    assert code == 65 and "part.csv" in err and "STEP" in err and "Traceback" not in err
    broken = tmp_path / "broken.stp"
    broken.write_bytes(Path(CTC01).read_bytes()[:20000])
    code, _, err = run(capsys, ["faces", str(broken)])
    assert code == 65 and "broken.stp" in err and "Traceback" not in err
    code, _, err = run(capsys, ["faces", str(tmp_path / "none.stp")])
    assert code == 66 and "none.stp" in err
    # A folder is no input file (66, as `inspect` says it), whatever its name.
    for folder in (tmp_path, tmp_path / "models.stp"):
        folder.mkdir(exist_ok=True)
        code, _, err = run(capsys, ["faces", str(folder)])
        assert code == 66 and "is a folder" in err and "Traceback" not in err
    code, _, err = run(capsys, ["faces", CTC01, "--csv", CTC01])
    assert code == 64 and "never replaces an input" in err


# ------------------------------------------------------------------------------------ plan

def test_a_part_name_that_is_a_spreadsheet_formula_is_written_as_text(tmp_path, capsys):
    """A STEP product named '=HYPERLINK(...)' (names are free text in the file) is written to
    the faces CSV's part column with a leading apostrophe, so that a spreadsheet opening it
    shows the text and runs nothing; the terminal table shows the name as it is."""
    with open(CTC01, encoding="latin-1") as f:
        text = f.read()
    formula = '=HYPERLINK("http://x.invalid","open")'
    text = text.replace("'NIST Complex Test Case 1'", f"'{formula}'")
    model = tmp_path / "named.stp"
    model.write_text(text, encoding="latin-1")
    out = tmp_path / "faces.csv"
    code, stdout, err = run(capsys, ["faces", str(model), "--csv", str(out)])
    assert code == 0, err
    with open(out, newline="") as f:
        parts = {r["part"] for r in csv.DictReader(f)}
    assert parts == {"'" + formula}
    code, stdout, err = run(capsys, ["faces", str(model)])
    assert code == 0 and f"part {formula}" in stdout, err


def xml_characteristics(path: str) -> dict[str, str]:
    """{id: kind} of the QIF file's characteristic nominals (the standard library's parser)."""
    root = ET.parse(path).getroot()
    (noms,) = root.iter(QIF3 + "CharacteristicNominals")
    return {e.get("id"): e.tag[len(QIF3):-len("CharacteristicNominal")] for e in noms}


HELD_BACK = {"CTC-01": set(), "FTC-08": {"4101", "4108", "4136", "4163", "7515"}}
"""Characteristics of a kind the plan layer has a type for that stay not judged (a datum of
two features, datums at MMC, an MMC perpendicularity, a reference dimension without
tolerance: tests/test_qif_plan.py's HELD_BACK)."""
SUPPORTED = {"SurfaceProfile", "Flatness", "Straightness", "Circularity", "Cylindricity",
             "Parallelism", "Perpendicularity", "Angularity", "Position", "Coaxiality",
             "Concentricity", "Symmetry", "CircularRunout", "TotalRunout", "Diameter", "Width",
             "SphericalDiameter", "Angle", "DistanceBetween", "Radius", "SphericalRadius"}


@pytest.mark.parametrize("part", sorted(PARTS))
def test_plan_lists_every_characteristic_of_the_qif_with_supported_yes_or_no(part, capsys):
    qif, stp = PARTS[part]
    kinds = xml_characteristics(qif)
    code, out, err = run(capsys, ["plan", qif, "--nominal", stp])
    assert code == 0, err
    rows = {}
    for line in out.splitlines():
        m = re.match(r"^(\d+)(\.\d+)?\s{2}", line)
        if m:
            rows.setdefault(m.group(1), []).append(line)
    assert set(rows) == set(kinds)
    expected_no = {i for i, k in kinds.items() if k not in SUPPORTED} | HELD_BACK[part]
    assert bool(expected_no) == (part == "FTC-08")  # CTC-01's every one is judged
    for cid, lines in rows.items():
        no = [line for line in lines if re.search(r"\s{2}no: \S", line)]
        yes = [line for line in lines if line.rstrip().endswith("  yes")]
        assert len(no) + len(yes) == len(lines), lines
        assert bool(no) == (cid in expected_no), (cid, lines)
    assert f"{len(kinds)} characteristics in {os.path.basename(qif)}" in out


def test_plan_shows_the_faces_each_feature_maps_to(capsys):
    """CTC-01's datum A (QIF feature 2154, the plane z = 0) maps to the one face of the model
    on that plane, found here from the faces' geometry."""
    from engine.io.step import read_step

    qif, stp = PARTS["CTC-01"]
    code, out, _ = run(capsys, ["plan", qif, "--nominal", stp])
    step = read_step(stp)
    down = [f.id for f in step.faces if f.surface == "plane"
            and abs(f.geometry["point"][2]) < 1e-9 and abs(f.geometry["normal"][2]) > 0.999]
    assert len(down) == 1
    assert f"A: plane (tangent), qif:2154 -> face {down[0]}" in out


def _toml_of(part, tmp_path, capsys) -> str:
    qif, stp = PARTS[part]
    out = tmp_path / f"{part}.toml"
    code, stdout, err = run(capsys, ["plan", qif, "--nominal", stp, "--toml", str(out)])
    assert code == 0, err
    assert f"TOML plan written to {out}" in stdout
    return str(out)


@pytest.mark.parametrize("part", sorted(PARTS))
def test_the_written_toml_plan_reads_back_as_the_qif_plan(part, tmp_path, capsys):
    """The TOML read with the ordinary TOML plan reader: the same characteristics (every
    field), datums, alignment and part; each region the STEP faces of its QIF features; each
    characteristic left out a [[not_judged]] table with its id, kind, name and reason."""
    from engine.io.plan import read_plan
    from engine.io.qif_plan import qif_face_groups, read_qif_plan
    from engine.io.step import read_step

    qif, stp = PARTS[part]
    path = _toml_of(part, tmp_path, capsys)
    source, written = read_qif_plan(qif), read_plan(path)
    assert written.characteristics == source.characteristics
    assert written.datums == source.datums
    assert written.alignment == source.alignment and written.part == source.part
    groups = qif_face_groups(qif, read_step(stp))
    assert [r.name for r in written.regions] == [r.name for r in source.regions]
    for r, s in zip(written.regions, source.regions):
        assert r.group == tuple(f"face:{i}" for i in groups[s.group])
    # Each characteristic left out is a [[not_judged]] table, read back as the source's.
    assert written.not_judged == source.not_judged
    assert bool(source.not_judged) == (part == "FTC-08")  # CTC-01's every one is judged
    # The count of the source's characteristics is the QIF's, though one on several features
    # is one per feature in the TOML ("ID.1", "ID.2", each naming its QIF source): FTC-06's
    # TOML said "14 of 70", its QIF "14 of 47".
    assert written.n_stated == source.n_stated == source.n_source
    assert written.not_judged_summary.replace(os.path.basename(path), "F") == \
        source.not_judged_summary.replace(os.path.basename(qif), "F")
    text = Path(path).read_text("utf-8")
    assert len(re.findall(r"^\[\[characteristic\]\]", text, re.M)) == len(
        source.characteristics)
    assert len(re.findall(r"^\[\[not_judged\]\]", text, re.M)) == len(source.not_judged)


def test_the_toml_plan_judges_planted_points_as_the_qif_plan_does(tmp_path, capsys):
    """Points on CTC-01's exact faces in a random pose, one hole (QIF feature 2175, ⌀20
    -0.1/+0.05) made 0.2 mm larger: inspected with the QIF plan and with its TOML, every
    characteristic has the same value and verdict, and that hole's size is REJECT in both."""
    from engine.io.qif_plan import qif_face_groups
    from engine.io.step import read_step
    from step_models import random_pose
    from sweep import on_part

    qif, stp = PARTS["CTC-01"]
    path = _toml_of("CTC-01", tmp_path, capsys)
    step = read_step(stp)
    rng = np.random.default_rng(5)
    P, N, face = on_part(step, rng, 5000)
    P = P + rng.normal(0.0, 1e-4, len(P))[:, None] * N
    hole = np.isin(face, qif_face_groups(qif, step)["qif:2175"])
    assert hole.sum() > 20
    P[hole] -= 0.1 * N[hole]  # a hole's outward normal points to its axis: 0.2 mm larger
    R, t = random_pose(3)
    np.savetxt(tmp_path / "m.csv", P @ R.T + t, delimiter=",", header="x,y,z", comments="",
               fmt="%.9f")
    docs = []
    for plan in (qif, path):
        out = tmp_path / f"r{len(docs)}.json"
        main(["inspect", stp, str(tmp_path / "m.csv"), "--plan", plan, "--json", str(out)])
        docs.append(json.loads(out.read_text()))
    capsys.readouterr()
    a, b = ({c["id"]: c for c in d["characteristics"]} for d in docs)
    assert set(a) == set(b) and len(a) == 14
    for cid in a:
        assert a[cid]["verdict"] == b[cid]["verdict"], cid
        assert a[cid]["type"] == b[cid]["type"]
        if a[cid]["value"] is None:
            assert b[cid]["value"] is None, cid
        else:
            assert a[cid]["value"] == pytest.approx(b[cid]["value"], abs=1e-9), cid
    # The 60° angle (1491) is judged with either plan, in degrees; the hole rejects the part.
    assert docs[0]["verdict"] == docs[1]["verdict"] == "REJECT"
    assert a["1491"]["value"] == pytest.approx(60.0, abs=1e-3)
    assert a["1491"]["verdict"] == "ACCEPT" and a["1491"]["unit"] == "degree"
    assert a["1479"]["verdict"] == "REJECT"
    assert a["1479"]["value"] == pytest.approx(20.2, abs=2e-3)
    assert sum(c["verdict"] == "ACCEPT" for c in a.values()) >= 9


def test_plan_of_a_toml_plan_and_its_toml_round_trip(tmp_path, capsys):
    """The seat bracket's hand-written plan listed (every characteristic supported) and
    written back to an equal plan."""
    from engine.io.plan import read_plan

    source = os.path.join(os.path.dirname(DATA), "..", "samples", "seat_bracket", "plan.toml")
    out = tmp_path / "again.toml"
    code, stdout, _ = run(capsys, ["plan", source, "--toml", str(out)])
    assert code == 0
    a, b = read_plan(source), read_plan(str(out))
    for name in ("characteristics", "regions", "datums", "alignment", "part", "measurement",
                 "rps"):
        assert getattr(a, name) == getattr(b, name), name
    ids = [line.split()[0] for line in stdout.splitlines() if line.rstrip().endswith(" yes")]
    assert ids == [c.id for c in a.characteristics]


def test_bad_plan_sources_are_refused_with_the_file_named(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[[region]]\nname = "a"\nbox = [[0, 0, 0], [1, 1, 1]\n')
    code, _, err = run(capsys, ["plan", str(bad)])
    assert code == 65 and "bad.toml:" in err and "Traceback" not in err
    broken = tmp_path / "part.qif"
    broken.write_bytes(Path(PARTS["CTC-01"][0]).read_bytes()[:4000])
    code, _, err = run(capsys, ["plan", str(broken)])
    assert code == 65 and "part.qif" in err and "not valid XML" in err
    other = tmp_path / "plan.txt"
    other.write_text("x")
    code, _, err = run(capsys, ["plan", str(other)])
    assert code == 65 and "plan.txt" in err
    code, _, err = run(capsys, ["plan", str(tmp_path / "missing.toml")])
    assert code == 66 and "missing.toml" in err
    qif, stp = PARTS["CTC-01"]
    code, _, err = run(capsys, ["plan", qif, "--toml", str(tmp_path / "o.toml")])
    assert code == 64 and "--nominal" in err
    code, _, err = run(capsys, ["plan", str(bad), "--toml", str(bad)])
    assert code == 64 and "never replaces an input" in err
    code, _, err = run(capsys, ["plan", qif, "--nominal", str(bad)])
    assert code == 65 and "bad.toml" in err


EVERY_KEY = """[part]
number = "P-1"
drawing = "D-7"
[measurement]
device = "CMM"
calibration_date = 2025-03-01
temperature_c = 21.5
mpe_a_um = 1.8
mpe_l_per_um = 300
probing_um = 1.9
expansion_per_k = 23e-6
[[region]]
name = "A"
box = [[-1.0, -1.0, -0.5], [121.0, 61.0, 0.5]]
[[region]]
name = "B"
group = "face:2"
measured_labels = "B*"
[[region]]
name = "C"
labels = "c_*"
[[region]]
name = "h1"
group = ["face:5", "face:6"]
[[region]]
name = "h2"
group = ["face:7"]
[[region]]
name = "slot"
group = ["face:9", "face:10"]
[[region]]
name = "skin"
group = "face:11"
[[region]]
name = "ax2"
group = "face:12"
[[region]]
name = "r1"
group = "face:13"
[[region]]
name = "r2"
group = "face:14"
[[region]]
name = "ball"
group = "face:15"
[[datum]]
label = "A"
region = "A"
feature = "plane"
[[datum]]
label = "B"
region = "B"
feature = "cylinder"
fit = "lsq"
[[datum]]
label = "C"
region = "C"
feature = "cylinder"
[alignment]
method = "datums"
reference = ["A", "B"]
best_fit_regions = ["skin"]
[[characteristic]]
id = "1"
type = "profile"
region = "skin"
lower = -0.02
upper = 0.05
all_around = true
[[characteristic]]
id = "2"
type = "profile"
region = "skin"
zone = 0.1
fit = "minimax"
[[characteristic]]
id = "3"
type = "size"
region = "h1"
nominal = 8.0
lower = -0.05
upper = 0.1
method = "two-point"
[[characteristic]]
id = "3b"
type = "size"
region = "h2"
nominal = 8.0
lower = -0.05
upper = 0.1
[[characteristic]]
id = "4"
type = "position"
regions = ["h1", "h2"]
zone = 0.1
datums = ["A", "B"]
modifier = "MMC"
[[characteristic]]
id = "5"
type = "size"
region = "slot"
feature = "width"
nominal = 10
lower = -0.1
upper = 0.1
[[characteristic]]
id = "6"
type = "symmetry"
region = "slot"
zone = 0.05
datums = ["A"]
[[characteristic]]
id = "7"
type = "straightness"
region = "A"
zone = 0.01
direction = [1, 1, 0]
sections = 5
[[characteristic]]
id = "8"
type = "angularity"
region = "ax2"
zone = 0.05
datums = ["A"]
diametral = true
angle = 30
[[characteristic]]
id = "9"
type = "circular_runout"
region = "skin"
zone = 0.05
datums = ["B-C"]
sections = 4
[[characteristic]]
id = "10"
type = "line_profile"
region = "skin"
lower = -0.05
upper = 0.05
direction = [0, 0, 1]
spacing = 2.5
datums = ["A"]
[[characteristic]]
id = "11"
type = "circularity"
region = "h1"
zone = 0.01
[[characteristic]]
id = "12"
type = "radius"
region = "ball"
nominal = 4.0
lower = -0.1
upper = 0.05
feature = "sphere"
[[characteristic]]
id = "13"
type = "angle"
regions = ["r1", "r2"]
nominal = 60
lower = -0.5
upper = 0.25
[[characteristic]]
id = "14"
type = "distance"
regions = ["r1", "h2"]
nominal = 25.4
lower = -0.1
upper = 0.1
features = ["plane", "cylinder"]
[[characteristic]]
id = "15"
type = "perpendicularity"
region = "slot"
zone = 0.05
datums = ["A"]
feature = "width"
"""
"""A plan using every table and most keys of the TOML contract (engine.io.plan), the regions'
groups STEP faces."""
RPS = """[measurement]
uncertainty_mm = 0.004
[[region]]
name = "all"
box = [[-1000, -1000, -1000], [1000, 1000, 1000]]
[alignment]
method = "rps"
[[rps]]
label = "R1"
nominal = [0, 0, 0]
lock = ["x", "z"]
[[rps]]
label = "R2"
nominal = [10, 0, 0]
lock = ["y", "z"]
[[rps]]
label = "R3"
nominal = [0, 10, 0]
lock = ["z"]
[[characteristic]]
id = "1"
type = "profile"
region = "all"
zone = 0.2
"""


@pytest.mark.parametrize("text", [EVERY_KEY, RPS], ids=["datums", "rps"])
def test_every_key_of_a_toml_plan_survives_plan_toml(text, tmp_path, capsys):
    """Written with --toml and read back: every field of every table equal, exactly (the
    straightness' direction (1, 1, 0) included: normalised once more it must not move by an
    ulp)."""
    from engine.io.plan import read_plan

    source, out = tmp_path / "source.toml", tmp_path / "out.toml"
    source.write_text(text, "utf-8")
    code, stdout, err = run(capsys, ["plan", str(source), "--toml", str(out)])
    assert code == 0, err
    a, b = read_plan(str(source)), read_plan(str(out))
    for name in ("characteristics", "regions", "datums", "alignment", "part", "measurement",
                 "rps"):
        assert getattr(a, name) == getattr(b, name), name
    assert len(a.characteristics) == (16 if text is EVERY_KEY else 1)
    if text is EVERY_KEY:
        row = next(line for line in stdout.splitlines() if line.startswith("4 "))
        assert "MMC, pattern of 2" in row and "h1 -> faces 5-6; h2 -> face 7" in row
        row = next(line for line in stdout.splitlines() if line.startswith("15 "))
        assert "median plane of a width" in row


def test_faces_gives_the_names_the_file_gives(tmp_path, capsys):
    """An assembly of two placed instances of a box with a hole whose top face is named
    MOUNTING_FACE in the file (tests/step_models.py): both instances' top faces carry the
    name, in the table and the CSV, with the part's product name."""
    import step_models as sm

    part = sm.box_with_hole()
    top = next(k for k, f in enumerate(sm.faces_of(part), 1)
               if abs(sm.face_centre(f)[2] - sm.BOX[2]) < 1e-9)
    path = sm.write_assembly(part, "BRACKET", {top: "MOUNTING_FACE"},
                             [sm.random_pose(21), sm.random_pose(22)], tmp_path / "a.step")
    code, out, err = run(capsys, ["faces", str(path), "--csv", "-"])
    assert code == 0, err
    rows = list(csv.DictReader(io.StringIO(out)))
    assert len(rows) == 14 and {r["part"] for r in rows} == {"BRACKET"}
    named = [int(r["id"]) for r in rows if r["name"] == "MOUNTING_FACE"]
    assert len(named) == 2 and all(rows[i - 1]["type"] == "plane" for i in named)
    code, out, _ = run(capsys, ["faces", str(path)])
    assert sum("MOUNTING_FACE" in line for line in out.splitlines()) == 2


def test_the_table_of_a_written_toml_plan_lists_what_it_does_not_judge(tmp_path, capsys):
    """`plan` on the TOML that `plan --toml` wrote for FTC-08: its 5 characteristics not judged
    are rows with their reasons, and counted (the table had none of them, and counted
    43 characteristics, 38 supported)."""
    from engine.io.plan import read_plan

    path = _toml_of("FTC-08", tmp_path, capsys)
    plan = read_plan(path)
    code, out, _ = run(capsys, ["plan", path])
    assert code == 0
    from engine.io.qif_plan import read_qif_plan

    n, k = read_qif_plan(PARTS["FTC-08"][0]).n_source, len(plan.not_judged)
    assert k == 5
    assert f"{n} characteristics in FTC-08.toml: {n - k} supported, {k} not" in out
    assert sum(" no: " in line for line in out.splitlines()) == k
    for nj in plan.not_judged:
        assert any(line.startswith(nj.id + " ") and nj.reason[:40] in line
                   for line in out.splitlines()), nj.id
