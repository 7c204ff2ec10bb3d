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


def _part_beside_a_box(folder):
    """A scanner's view of a table (every 10 mm) holding the part (the height surface every
    8 mm, 2 µm of noise, a 0.5 mm dent) and beside it a box (300 x 150 x 60 mm, its top and
    sides every 8 mm); the nominal and the scene written to ``folder``. Returns (table, part,
    box, dent: the planted deviation of each part point)."""
    write_grid_nominal(folder / "nominal.csv", 150, 100)
    rng = np.random.default_rng(5)
    gx, gy = np.meshgrid(np.arange(-240, 241, 8.0), np.arange(-112, 113, 8.0))
    x, y = gx.ravel(), gy.ravel()
    dent = -0.5 * np.exp(-((x - 100) ** 2 + (y - 20) ** 2) / (2 * 12.0 ** 2))
    q = np.column_stack([x, y, height(x, y)]) + (dent + rng.normal(0, 0.002, x.size))[:, None] \
        * height_normal(x, y)
    part = apply_transform(make_transform(random_rotation(rng), [0.0, 0.0, 300.0]), q)
    lo, hi = part.min(axis=0), part.max(axis=0)
    floor = lo[2] - 25.0
    t = np.arange(-800, 801, 10.0)
    tx, ty = np.meshgrid(t, t)
    table = np.c_[tx.ravel(), ty.ravel(), np.full(tx.size, floor)]
    box = _box_surface(np.array([hi[0] + 200.0, 0.0, floor]), (300.0, 150.0, 60.0), 8.0)
    np.savetxt(folder / "scene.xyz", np.vstack([table, part, box]), fmt="%.6f")
    return table, part, box, dent


def test_another_object_on_the_table_is_not_the_part(tmp_path, capsys):
    """The part beside a box on a table: with --remove-plane the box goes as another object,
    whole, and the dent stays: the part is REJECTed for its dent and for nothing else."""
    table, part, box, dent = _part_beside_a_box(tmp_path)
    code = run("inspect", tmp_path / "nominal.csv", tmp_path / "scene.xyz", "--tol", "0.05",
               "--remove-plane", "--json", tmp_path / "r.json", "--csv", tmp_path / "r.csv")
    out = capsys.readouterr().out
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["scene"]["plane"]["n_removed"] == table.shape[0]
    assert doc["scene"]["objects"]["n_other_objects_points"] == box.shape[0]
    assert doc["scene"]["n_kept"] == part.shape[0]
    assert f"{box.shape[0]:,} on other objects than the part" in out
    assert code == 1 and doc["verdict"] == "REJECT"
    d = np.loadtxt(tmp_path / "r.csv", delimiter=",", skiprows=1, usecols=8)
    # Every deviation is the planted one, to 5% of the dent (the least-squares fit takes a
    # share of the dent, and the nominal is a 150 x 100 grid).
    assert np.abs(d - dent).max() < 0.025
    out_of_zone = np.abs(d) > 0.05
    assert out_of_zone.any() and np.all(dent[out_of_zone] < -0.04)


def test_objects_found_on_a_spread_of_a_dense_scene_are_the_same(tmp_path, monkeypatch):
    """A dense scan's objects are found on a voxel spread of its points (engine.scene_part's
    OBJECT_POINTS), each point taking its nearest one's object: with the spread at a third of
    the points the part's points kept are the same as with all of them."""
    import engine.scene_part as scene_part
    from engine.io import load_point_set
    from engine.nominal import Nominal

    table, part, box, _ = _part_beside_a_box(tmp_path)
    on_table = np.vstack([part, box])
    nominal = Nominal.from_point_set(load_point_set(str(tmp_path / "nominal.csv")))
    whole = scene_part.part_in_scene(nominal, on_table, 0.0, 0.1)
    monkeypatch.setattr(scene_part, "OBJECT_POINTS", on_table.shape[0] // 3)
    spread = scene_part.part_in_scene(nominal, on_table, 0.0, 0.1)
    assert np.array_equal(whole.kept, np.arange(part.shape[0]))
    assert whole.n_objects == 2 and np.array_equal(spread.kept, whole.kept)


def _box_surface(base_centre: np.ndarray, size, step: float) -> np.ndarray:
    """Points every ``step`` mm on the top and the four sides of a box of ``size`` (x, y, z) mm
    standing on the plane z = base_centre[2], centred at base_centre in x and y (the sides from
    2 x ``step`` up)."""
    sx, sy, sz = size
    u = lambda length: np.arange(-length / 2, length / 2 + 1e-9, step)  # noqa: E731
    a, b = np.meshgrid(u(sx), u(sy))
    faces = [np.c_[a.ravel(), b.ravel(), np.full(a.size, sz)]]
    zs = np.arange(2 * step, sz + 1e-9, step)  # the lowest row above the table's removal
    for along, half, axis in ((u(sx), sy / 2, 1), (u(sy), sx / 2, 0)):
        a, z = np.meshgrid(along, zs)
        for side in (-half, half):
            f = np.zeros((a.size, 3))
            f[:, 1 - axis], f[:, axis], f[:, 2] = a.ravel(), side, z.ravel()
            faces.append(f)
    return np.vstack(faces) + base_centre


SICK_BOX = (-130, -60, 300, 130, 300, 500)
"""The vendor sample's box: centre (0, 120, 400), size 260 x 360 x 200 mm."""
SICK_NOISE_RATIO = 1.5
"""The camera's noise is the spread of the table's points about their plane (robust standard
deviation, 5.3 mm): a right pose fits the part's points to about it, its mixed pixels at the
part's edges included."""


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
def test_sick_scene_registers_after_crop_and_plane_removal(capsys, tmp_path):
    """The SICK scene with the vendor's box and its table removed: the other objects on the
    table go, and the part's view (some 320 points) registers to the camera's noise, measured on
    the table in the same run."""
    nominal, measured = os.path.join(SICK, "V2D63xModel.ply"), os.path.join(SICK, "data.ply")
    code = run("inspect", nominal, measured, "--tol", "10", "--crop", *SICK_BOX,
               "--remove-plane", "--json", tmp_path / "r.json")
    doc = json.loads((tmp_path / "r.json").read_text())
    noise = doc["scene"]["plane"]["sigma_mm"]
    assert 4 < noise < 7
    assert doc["registration"]["converged"], (code, doc["reasons"])
    assert doc["registration"]["rms"] < SICK_NOISE_RATIO * noise, (code, doc["reasons"])
    assert 300 <= doc["scene"]["n_kept"] <= 400
    assert doc["scene"]["objects"]["n_other_objects_points"] >= 700
    # The device lies on the table: a pose that puts the housing through it is not the part's,
    # and no verdict stands there. (Seen from above through 5 mm of noise, the housing's tilt
    # is loose: the least-squares pose sinks it some 20 mm into the table.)
    from engine.io import load_point_set

    T = np.linalg.inv(np.array(doc["transform"]))
    plane = doc["scene"]["plane"]
    side = np.asarray(plane["normal"])
    heights = apply_transform(T, load_point_set(nominal).points) @ side - plane["offset_mm"]
    if heights.min() < -plane["distance_mm"]:
        assert code == 2 and doc["verdict"] == "INCONCLUSIVE"
        assert doc["reasons"][0].startswith(
            f"at the pose found the nominal reaches {-heights.min():.3g} mm through the plane "
            "removed as the table")


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
