"""A measured scene holding more than the part, end to end: the extent warning reaches the user
(stderr, the JSON's ``warnings``), ``--crop`` and ``--remove-plane`` keep the part's points and
the results say how many went, bad values are usage errors, ``verify`` re-runs with them, and
the real SICK 3D-camera scene."""

import json
import os

import numpy as np
import pytest

from engine.pose import apply_transform, make_transform
from engine.pipeline import run_files
from engine.settings import InspectionSettings
from qa_app.cli import main
from reports.verify import recheck
from surfaces import height, height_normal, random_rotation, write_grid_nominal

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SICK = os.path.join(ROOT, "tests", "data", "sick")

N_PART, N_TABLE, N_CLUTTER = 300, 61 * 61, 200


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """The height-surface part (300 points, deviations 2 µm) in a random pose, on a table: a
    61 x 61 grid every 20 mm in the plane 25 mm below the part's lowest point, all inside the
    crop box; and 200 points of clutter 2 m away, outside it. Returns the folder and the box."""
    d = tmp_path_factory.mktemp("scene")
    write_grid_nominal(d / "nominal.csv", 150, 100)
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-240, 240, N_PART), rng.uniform(-115, 115, N_PART)
    q = np.column_stack([x, y, height(x, y)]) + rng.normal(0, 0.002, (N_PART, 1)) * \
        height_normal(x, y)
    part = apply_transform(make_transform(random_rotation(rng), [500.0, -200.0, 80.0]), q)
    lo, hi = part.min(axis=0), part.max(axis=0)
    c = (lo + hi) / 2
    g = np.arange(-30, 31) * 20.0
    gx, gy = np.meshgrid(g, g)
    table = np.c_[c[0] + gx.ravel(), c[1] + gy.ravel(), np.full(gx.size, lo[2] - 25.0)]
    clutter = rng.uniform(-100, 100, (N_CLUTTER, 3)) + [2500.0, 2500.0, 0.0]
    scene_pts = np.vstack([part, table, clutter])
    np.savetxt(d / "part.xyz", part, fmt="%.6f")
    np.savetxt(d / "scene.xyz", scene_pts, fmt="%.6f")
    box = np.r_[c[:2] - 650.0, lo[2] - 50.0, c[:2] + 650.0, hi[2] + 10.0]
    return d, box


def run(*args):
    return main([str(a) for a in args])


def test_a_scene_far_larger_than_the_part_is_warned_about(scene, capsys):
    d, _ = scene
    code = run("inspect", d / "nominal.csv", d / "scene.xyz", "--tol", "0.05", "--json",
               d / "scene.json")
    err = capsys.readouterr().err
    doc = json.loads((d / "scene.json").read_text())
    assert code in (1, 2)  # the table and the clutter are not the part
    assert len(doc["warnings"]) == 1 and doc["warnings"][0].startswith(
        "the measured points span")
    assert "crop them" in doc["warnings"][0] and "--crop" in doc["warnings"][0]
    assert f"qa-inspect: warning: {doc['warnings'][0]}" in err
    assert "scene" not in doc and "crop" not in doc["settings"]


def test_the_part_alone_is_not_warned_about(scene, capsys):
    d, _ = scene
    code = run("inspect", d / "nominal.csv", d / "part.xyz", "--tol", "0.05", "--json",
               d / "part.json")
    assert code == 0 and "warning" not in capsys.readouterr().err
    assert json.loads((d / "part.json").read_text())["warnings"] == []


def test_crop_and_remove_plane_keep_the_part(scene, capsys):
    d, box = scene
    code = run("inspect", d / "nominal.csv", d / "scene.xyz", "--tol", "0.05", "--crop", *box,
               "--remove-plane", "--json", d / "cropped.json", "--csv", d / "cropped.csv")
    out, err = capsys.readouterr()
    assert code == 0, out + err
    doc = json.loads((d / "cropped.json").read_text())
    sc = doc["scene"]
    assert sc["n_read"] == N_PART + N_TABLE + N_CLUTTER
    assert sc["n_outside_crop"] == N_CLUTTER and sc["plane"]["n_removed"] == N_TABLE
    assert sc["n_kept"] == N_PART and doc["deviations"]["count"] == N_PART
    assert sc["crop"] == pytest.approx(list(box))
    # The table is a perfect plane: the default distance is the points' spacing (20 mm).
    assert sc["plane"]["distance_mm"] == pytest.approx(20.0)
    assert doc["settings"]["crop"] == pytest.approx(list(box))
    assert doc["settings"]["remove_plane"] is True and "plane_distance" not in doc["settings"]
    assert doc["inputs"][1]["n_points"] == sc["n_read"]
    assert doc["warnings"] == [] and "warning" not in err
    assert f"{N_PART + N_TABLE + N_CLUTTER:,} read, {N_CLUTTER:,} outside the crop box, " \
           f"{N_TABLE:,} on the dominant plane" in out
    assert len((d / "cropped.csv").read_text().splitlines()) == N_PART + 1


def test_verify_reruns_with_the_crop_and_plane(scene, capsys):
    """verify's re-run (reports.verify.recheck, what ``verify --nominal --measured`` does once the
    signatures hold) takes the crop and the plane from the certified settings."""
    d, box = scene
    settings = InspectionSettings(-0.05, 0.05, crop=tuple(box), remove_plane=True)
    from reports.results import run_document

    doc = run_document(run_files(str(d / "nominal.csv"), str(d / "scene.xyz"), settings))
    assert doc["verdict"] == "ACCEPT"
    files = {"nominal": str(d / "nominal.csv"), "measured": str(d / "scene.xyz"), "plan": None}
    checks = recheck(doc, files)
    assert all(c.passed for c in checks) and "re-run: ACCEPT" in checks[-1].message
    # The same document without its crop would not re-run to the certified result.
    plain = dict(doc, settings={k: v for k, v in doc["settings"].items()
                                if k not in ("crop", "remove_plane")})
    assert not all(c.passed for c in recheck(plain, files))


@pytest.mark.parametrize("args, text", [
    (["--crop", "1", "2", "3", "0", "5", "6"], "--crop's x range 1 .. 0 is empty"),
    (["--crop", "1", "2", "3", "4", "5", "nan"], "'nan' is not a finite number"),
    (["--crop", "1", "2", "3"], "expected 6 arguments"),
    (["--remove-plane-distance", "3"], "--remove-plane-distance applies with --remove-plane"),
    (["--remove-plane", "--remove-plane-distance", "0"], "must be a positive number of mm"),
])
def test_bad_scene_options_are_usage_errors(scene, capsys, args, text):
    d, _ = scene
    code = run("inspect", d / "nominal.csv", d / "scene.xyz", "--tol", "0.05", *args)
    err = capsys.readouterr().err
    assert code == 64 and text in err and "Traceback" not in err


def test_batch_takes_the_scene_options_and_refuses_bad_ones(scene, capsys, tmp_path):
    d, _ = scene
    code = run("batch", d / "nominal.csv", d / "scene.xyz", "--tol", "0.05", "--out",
               tmp_path / "lot", "--crop", 1, 2, 3, 4, 5, 3)
    err = capsys.readouterr().err
    assert code == 64 and "qa-inspect batch: --crop's z range 3 .. 3 is empty" in err
    assert not (tmp_path / "lot").exists()


def test_a_crop_of_nothing_is_a_usage_error_not_a_verdict(scene, capsys, tmp_path):
    d, _ = scene
    code = run("inspect", d / "nominal.csv", d / "scene.xyz", "--tol", "0.05", "--crop",
               *[9000] * 3, *[9001] * 3, "--json", tmp_path / "r.json")
    err = capsys.readouterr().err
    assert code == 64 and "only 0 of the" in err and "lie inside the crop box" in err
    assert not (tmp_path / "r.json").exists()


def test_remove_plane_does_not_apply_to_a_2d_template(scene, capsys):
    d, _ = scene
    dxf = os.path.join(ROOT, "samples", "fuselage_frame", "template.dxf")
    code = run("inspect", dxf, d / "part.xyz", "--tol", "0.05", "--remove-plane")
    assert code == 64 and "--remove-plane applies to 3D nominals" in capsys.readouterr().err


SICK_BOX = (-130, -60, 300, 130, 300, 500)
"""The vendor sample's box: centre (0, 120, 400), size 260 x 360 x 200 mm."""
SICK_RMS_MM = 5.0
"""The camera's noise on a flat face of the part is about 2.6 mm rms: a right pose fits within
this."""


def test_sick_scene_crop_and_table():
    """The SICK 3D-camera scene (tests/data/sick/SOURCE.txt): the vendor's box holds its 3,440
    points, and the table the default distance finds is the vendor's 15 mm one, give or take."""
    from engine.io import load_point_set
    from engine.scene import extent_warning, select_points

    scene = load_point_set(os.path.join(SICK, "data.ply"))
    nominal = load_point_set(os.path.join(SICK, "V2D63xModel.ply"))
    assert extent_warning(scene.points, nominal.points).startswith(
        "the measured points span 1525 × 1142 × 738.9 mm, the nominal 46.27 × 63.1 × 113.2 mm")
    sel = select_points(scene.points, SICK_BOX, remove_plane=True)
    assert (sel.n_read, sel.n_read - sel.n_outside_box) == (24397, 3440)
    assert 10 < sel.plane.distance < 20 and abs(sel.plane.normal[2]) > 0.99
    assert sel.n_kept == 3440 - sel.n_on_plane and 0.6 < sel.n_on_plane / 3440 < 0.75


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="registration (engine/registration.py, issue 21): after "
                   "the crop and the table the vendor's box still holds other objects than the "
                   "part, and a pose is fitted only when half the points lie within 1% of the "
                   "nominal's diagonal (1.4 mm), below this camera's noise (~2.6 mm rms)")
def test_sick_scene_registers_after_crop_and_plane_removal(capsys, tmp_path):
    """The SICK scene with the vendor's box and its table removed registers to the camera's
    noise."""
    nominal, measured = os.path.join(SICK, "V2D63xModel.ply"), os.path.join(SICK, "data.ply")
    code = run("inspect", nominal, measured, "--tol", "10", "--crop", *SICK_BOX,
               "--remove-plane", "--json", tmp_path / "r.json")
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["registration"]["converged"], (code, doc["reasons"])
    assert doc["registration"]["rms"] < SICK_RMS_MM, (code, doc["reasons"])


def test_the_app_runs_with_the_crop_and_shows_the_warning(scene):
    """The desktop app's controller (no Qt) passes the session's crop and plane removal to the
    run; the extent warning is the message bar's warning; a changed crop makes the result
    stale; a saved session keeps them."""
    from qa_app.desktop.controller import Controller
    from qa_app.desktop.model import Session

    d, box = scene
    s = Session()
    messages = []
    s.message.connect(lambda level, text: messages.append((level, text)))
    c = Controller(s, synchronous=True)
    c.open_files([str(d / "nominal.csv"), str(d / "scene.xyz")])
    assert c.set_tolerance(-0.05, 0.05)
    c.inspect()
    assert messages[-1][0] == "warning" and messages[-1][1].startswith("The measured points span")
    s.set_settings(crop=tuple(box), remove_plane=True)
    assert s.stale_reasons == ["crop box changed", "plane removal changed"]
    c.inspect()
    assert s.run.result.verdict == "ACCEPT" and s.run.selection.n_kept == N_PART
    assert messages[-1][0] == "info" and not s.stale_reasons
    c.save_session(str(d / "scene.qasession"))
    saved = json.loads((d / "scene.qasession").read_text())
    assert saved["settings"]["crop"] == pytest.approx(list(box))
    assert saved["results"]["scene"]["n_kept"] == N_PART
    s2 = Session()
    c2 = Controller(s2, synchronous=True)
    c2.open_session(str(d / "scene.qasession"))
    assert s2.settings.crop == pytest.approx(tuple(box)) and s2.settings.remove_plane
    assert s2.run.selection.n_kept == N_PART
