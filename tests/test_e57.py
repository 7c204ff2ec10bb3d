"""E57 scanner files (engine.io.e57): every scan moved by its pose into the file's frame, metres
made mm, intensity and normals where present; damaged, truncated and foreign files refused with
the product's error (65), never a crash."""

import os
import subprocess

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from e57files import write_e57
from engine.errors import InputError
from engine.pose import apply_transform, make_transform
from engine.io import formats, load_point_set
from qa_app.cli import main
from surfaces import height, height_normal, random_rotation, write_grid_nominal


def cloud(n, seed=0):
    return np.random.default_rng(seed).uniform(-0.05, 0.05, (n, 3))  # metres


@pytest.fixture
def points_only(tmp_path):
    p = cloud(40)
    write_e57(tmp_path / "scan.e57", [{"points": p}])
    return tmp_path / "scan.e57", p


def test_a_scan_of_points_only_is_read_in_mm(points_only):
    path, p = points_only
    ps = load_point_set(path)
    assert ps.n == 40 and ps.normals is None and ps.intensity is None and ps.labels is None
    assert np.allclose(ps.points, p * 1000.0, atol=1e-3)  # written as float32 metres
    assert formats.kind_of("SCAN.E57") == formats.E57 and ".e57" in formats.MEASURED_SUFFIXES


def test_two_scans_are_moved_by_their_poses_with_their_intensities(tmp_path):
    a, b = cloud(30, 1), cloud(25, 2)
    qa = Rotation.from_rotvec([0.1, -0.4, 0.7])
    qb = Rotation.from_rotvec([-1.2, 0.3, 0.2])
    invalid = np.arange(25) % 5 == 0  # cartesianInvalidState 2: left out
    write_e57(tmp_path / "two.e57", [
        {"points": a, "intensity": np.linspace(0, 1, 30),
         "rotation": np.roll(qa.as_quat(), 1), "translation": (1.0, 2.0, 3.0)},
        {"points": b, "intensity": np.linspace(1, 2, 25), "invalid": invalid,
         "rotation": np.roll(qb.as_quat(), 1), "translation": (-4.0, 0.5, 0.0)}])
    ps = load_point_set(tmp_path / "two.e57")
    want = np.vstack([qa.apply(a) + [1.0, 2.0, 3.0], qb.apply(b[~invalid]) + [-4.0, 0.5, 0.0]])
    assert ps.n == 30 + 20
    assert np.allclose(ps.points, want * 1000.0, atol=1e-2)
    assert np.allclose(ps.intensity, np.r_[np.linspace(0, 1, 30),
                                           np.linspace(1, 2, 25)[~invalid]], atol=1e-6)


def test_normals_are_turned_by_the_pose(tmp_path):
    p = cloud(20, 3)
    n = np.random.default_rng(4).normal(size=(20, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    q = Rotation.from_rotvec([0.3, 0.2, -0.9])
    write_e57(tmp_path / "n.e57", [{"points": p, "normals": n,
                                    "rotation": np.roll(q.as_quat(), 1),
                                    "translation": (0.1, 0.2, 0.3)}])
    ps = load_point_set(tmp_path / "n.e57")
    assert np.allclose(ps.points, (q.apply(p) + [0.1, 0.2, 0.3]) * 1000.0, atol=1e-6)
    assert np.allclose(ps.normals, q.apply(n), atol=1e-6)  # float32 on file
    assert np.allclose(np.linalg.norm(ps.normals, axis=1), 1.0)


def test_what_one_scan_lacks_is_left_out_for_all(tmp_path):
    write_e57(tmp_path / "mixed.e57", [{"points": cloud(10, 5), "intensity": np.ones(10)},
                                       {"points": cloud(10, 6)}])
    ps = load_point_set(tmp_path / "mixed.e57")
    assert ps.n == 20 and ps.intensity is None


def bad(path, capsys):
    """(exit code, stderr) of ``qa-inspect inspect`` with ``path`` as MEASURED."""
    nominal = os.path.join(os.path.dirname(path), "nominal.csv")
    write_grid_nominal(nominal, 20, 10)
    code = main(["inspect", nominal, str(path), "--tol", "0.1"])
    return code, capsys.readouterr().err


def test_a_truncated_file_is_refused(points_only, capsys):
    path, _ = points_only
    raw = path.read_bytes()
    cut = path.with_name("cut.e57")
    cut.write_bytes(raw[:len(raw) - 1500])
    with pytest.raises(InputError, match=rf"truncated: the header declares {len(raw):,} bytes, "
                                         rf"the file holds {len(raw) - 1500:,}"):
        load_point_set(cut)
    code, err = bad(cut, capsys)
    assert code == 65 and "cut.e57" in err and "truncated" in err and "Traceback" not in err


@pytest.mark.parametrize("content", [
    np.random.default_rng(0).bytes(4096),
    b"ASTM-E57" + bytes(40),
    b"x y z\n1 2 3\n",
])
def test_a_file_that_is_no_e57_is_refused(tmp_path, capsys, content):
    path = tmp_path / "random.e57"
    path.write_bytes(content)
    with pytest.raises(InputError, match="random.e57"):
        load_point_set(path)
    code, err = bad(path, capsys)
    assert code == 65 and "random.e57" in err and "Traceback" not in err


@pytest.mark.parametrize("where", [0.3, 0.5, 0.8])
def test_a_damaged_page_is_refused_by_the_reader(points_only, capsys, where):
    """One byte flipped inside the file: its page's CRC no longer holds (libE57Format reads in
    the child process and says so)."""
    path, _ = points_only
    raw = bytearray(path.read_bytes())
    i = int(where * len(raw))
    raw[i] ^= 0x5A
    damaged = path.with_name("damaged.e57")
    damaged.write_bytes(bytes(raw))
    with pytest.raises(InputError, match="damaged.e57: damaged or unreadable E57 file: checksum mismatch"):
        load_point_set(damaged)


def test_a_crash_of_the_native_reader_is_bad_input(points_only, monkeypatch):
    """Should libE57Format crash on a file, the child's death is the file's fault, not ours."""
    path, _ = points_only
    real = subprocess.run

    def crashing(cmd, *args, **kw):
        if "engine.io.e57" in cmd:
            return subprocess.CompletedProcess(cmd, -11, "", "")
        return real(cmd, *args, **kw)

    monkeypatch.setattr(subprocess, "run", crashing)
    with pytest.raises(InputError, match=r"damaged: the E57 reader crashed reading it "
                                         r"\(signal 11\)"):
        load_point_set(path)


def test_an_e57_scan_is_inspected(tmp_path, capsys):
    """A scan of the height surface (metres, in a scanner's pose) inspected against its mm
    nominal: the same ACCEPT as the point file gives."""
    write_grid_nominal(tmp_path / "nominal.csv", 150, 100)
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-240, 240, 300), rng.uniform(-115, 115, 300)
    q = np.column_stack([x, y, height(x, y)]) + rng.normal(0, 0.002, (300, 1)) * \
        height_normal(x, y)
    part = apply_transform(make_transform(random_rotation(rng), [500.0, -200.0, 80.0]), q)
    write_e57(tmp_path / "part.E57", [{"points": part / 1000.0}])
    code = main(["inspect", str(tmp_path / "nominal.csv"), str(tmp_path / "part.E57"),
                 "--tol", "0.05"])
    assert code == 0, capsys.readouterr()
