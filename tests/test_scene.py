"""Scenes that hold more than the part (engine.scene): the crop box, the dominant plane removed
and the extent warning, against scenes built with known counts; the settings that carry them."""

import numpy as np
import pytest

from engine.errors import SettingsError
from engine.scene import (MIN_KEPT, check_box, crop_mask, dominant_plane, extent_warning,
                          select_points, typical_spacing)
from engine.settings import InspectionSettings
from surfaces import random_rotation


def lattice(n=11):
    """Integer points 0..n-1 on each axis: (n^3, 3)."""
    g = np.arange(n, dtype=float)
    return np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)


def table_and_box(noise=0.0, seed=0):
    """A 101 x 101 mm table at z = 0 sampled every 1 mm (its points under the box left out:
    the camera cannot see them), and a 20 x 30 x 10 mm box standing on it: its top at z = 10
    and its four sides sampled every 1 mm from z = 0.5 to 9.5. Returns (points, is_table)."""
    rng = np.random.default_rng(seed)
    g = np.arange(0.0, 101.0)
    X, Y = np.meshgrid(g, g, indexing="ij")
    under = (X >= 40) & (X <= 60) & (Y >= 30) & (Y <= 60)
    table = np.c_[X[~under], Y[~under], np.zeros((~under).sum())]
    table[:, 2] += rng.uniform(-noise, noise, table.shape[0]) if noise else 0.0
    tx, ty = np.meshgrid(np.arange(40.0, 61.0), np.arange(30.0, 61.0), indexing="ij")
    top = np.c_[tx.ravel(), ty.ravel(), np.full(tx.size, 10.0)]
    z = np.arange(0.5, 10.0)
    sides = []
    for x in (40.0, 60.0):
        yy, zz = np.meshgrid(np.arange(30.0, 61.0), z, indexing="ij")
        sides.append(np.c_[np.full(yy.size, x), yy.ravel(), zz.ravel()])
    for y in (30.0, 60.0):
        xx, zz = np.meshgrid(np.arange(41.0, 60.0), z, indexing="ij")
        sides.append(np.c_[xx.ravel(), np.full(xx.size, y), zz.ravel()])
    box = np.vstack([top, *sides])
    pts = np.vstack([table, box])
    return pts, np.r_[np.ones(table.shape[0], bool), np.zeros(box.shape[0], bool)]


# ------------------------------------------------------------------------------ crop box
def test_crop_keeps_the_box_faces_included():
    p = lattice()
    m = crop_mask(p, (2, 3, 4, 5, 7, 9))
    assert m.sum() == 4 * 5 * 6  # x 2..5, y 3..7, z 4..9, faces included
    inside = p[m]
    assert inside.min(axis=0).tolist() == [2, 3, 4] and inside.max(axis=0).tolist() == [5, 7, 9]


@pytest.mark.parametrize("box, words", [
    ((0, 0, 0, 0, 1, 1), "x range 0 .. 0 is empty"),
    ((0, 5, 0, 1, 1, 1), "y range 5 .. 1 is empty"),
    ((0, 0, 0, 1, 1, float("nan")), "not finite"),
    ((0, 0, 0, 1, float("inf"), 1), "not finite"),
    ((0, 0, 0, 1, 1), "six numbers"),
    ("abc", "six numbers"),
])
def test_a_box_that_is_none_is_refused(box, words):
    with pytest.raises(SettingsError, match=words):
        check_box(box)


# ------------------------------------------------------------------------------ dominant plane
@pytest.mark.parametrize("seed", [0, 1])
def test_the_table_is_removed_and_the_part_kept_in_any_pose(seed):
    pts, is_table = table_and_box()
    rng = np.random.default_rng(seed)
    R, t = random_rotation(rng), rng.uniform(-500, 500, 3)
    moved = pts @ R.T + t
    plane = dominant_plane(moved, distance=0.75)
    # Every table point is within 0.75 mm; of the box only the side rows at z = 0.5.
    on_table_row = ~is_table & (pts[:, 2] == 0.5)
    assert np.array_equal(plane.inliers, is_table | on_table_row)
    assert abs(abs(plane.normal @ R[:, 2]) - 1) < 1e-12
    assert abs(plane.normal @ t - plane.offset) < 1e-9
    assert plane.rule == "given" and plane.distance == 0.75


def test_the_default_distance_follows_the_data():
    # A noise-free table: its points spread nothing about the plane; one point spacing (1 mm).
    pts, is_table = table_and_box()
    plane = dominant_plane(pts)
    assert plane.sigma < 1e-9 and plane.distance == pytest.approx(1.0)
    assert plane.distance == plane.spacing == pytest.approx(typical_spacing(pts))
    assert "median point spacing" in plane.rule
    assert np.array_equal(plane.inliers, is_table | (~is_table & (pts[:, 2] == 0.5)))
    # A noisy table (Gaussian, sigma 0.6 mm): three robust sigmas, about 1.8 mm, take the
    # table (all but the 0.3 % of a Gaussian beyond 3 sigma) and the box's first two rows.
    rng = np.random.default_rng(3)
    noisy = pts.copy()
    noisy[is_table, 2] += rng.normal(0, 0.6, is_table.sum())
    plane = dominant_plane(noisy)
    assert plane.sigma == pytest.approx(0.6, rel=0.1)
    assert plane.distance == pytest.approx(3 * plane.sigma)
    assert plane.inliers[is_table].mean() > 0.99
    assert set(np.unique(pts[plane.inliers & ~is_table, 2])) <= {0.5, 1.5}


def test_the_plane_is_the_same_every_run():
    pts, _ = table_and_box(noise=0.2)
    a, b = dominant_plane(pts), dominant_plane(pts)
    assert np.array_equal(a.normal, b.normal) and a.offset == b.offset
    assert np.array_equal(a.inliers, b.inliers) and a.distance == b.distance


def test_collinear_points_hold_no_plane():
    line = np.c_[np.arange(10.0), np.zeros(10), np.zeros(10)]
    with pytest.raises(ValueError, match="collinear"):
        dominant_plane(line)


# ------------------------------------------------------------------------------ selection
def test_crop_then_plane_counts():
    pts, is_table = table_and_box()
    clutter = np.random.default_rng(5).uniform(200, 300, (50, 3))  # outside the box
    scene = np.vstack([pts, clutter])
    box = (30, 20, -5, 70, 70, 20)  # the box and the table around it, 41 x 51 points of it
    sel = select_points(scene, box, remove_plane=True, plane_distance=0.75)
    in_box_table = (np.abs(pts[:, 0] - 50) <= 20) & (np.abs(pts[:, 1] - 45) <= 25) & is_table
    n_box = (~is_table).sum()
    assert in_box_table.sum() == 41 * 51 - 21 * 31  # the table in the box, less under the box
    assert sel.n_read == scene.shape[0]
    assert sel.n_outside_box == scene.shape[0] - in_box_table.sum() - n_box
    assert sel.n_on_plane == in_box_table.sum() + (~is_table & (pts[:, 2] == 0.5)).sum()
    assert sel.n_kept == n_box - (~is_table & (pts[:, 2] == 0.5)).sum()
    assert np.all(scene[sel.kept, 2] >= 1.5) and np.all(sel.kept < pts.shape[0])
    assert sel.n_kept + sel.n_on_plane + sel.n_outside_box == sel.n_read


def test_without_options_every_point_is_kept():
    pts, _ = table_and_box()
    sel = select_points(pts)
    assert sel.n_kept == pts.shape[0] and sel.plane is None and sel.box is None


def test_a_crop_leaving_too_few_points_is_an_error():
    pts, _ = table_and_box()
    with pytest.raises(SettingsError, match=rf"only 0 of the {pts.shape[0]:,} measured points "
                                            r"lie inside the crop box \[200 200 200 300 300 300\]"
                                            rf".*at least {MIN_KEPT}.*x 0 .. 100"):
        select_points(pts, (200, 200, 200, 300, 300, 300))
    flat = np.c_[np.random.default_rng(0).uniform(0, 10, (40, 2)), np.zeros(40)]
    with pytest.raises(SettingsError, match="off the dominant plane"):
        select_points(np.vstack([flat, [[5, 5, 3.0]]]), remove_plane=True)


def test_kept_points_on_one_line_are_an_error():
    pts = np.r_[lattice(5), np.c_[np.arange(10.0) + 20, np.zeros(10), np.zeros(10)]]
    with pytest.raises(SettingsError, match="one straight line"):
        select_points(pts, (19, -1, -1, 40, 1, 1))
    # One point many times over is one point, not a line (issue 22 item 10).
    pts = np.r_[lattice(5), np.tile([[20.1, 0.3, 0.7]], (1000, 1))]
    with pytest.raises(SettingsError, match="the 1,000 measured points kept by the crop and "
                                            "plane removal are all the same point"):
        select_points(pts, (19, -1, -1, 40, 1, 1))


# ------------------------------------------------------------------------------ extent warning
def test_extent_warning_for_a_scene_and_not_for_a_part():
    nominal = lattice() * [4.6, 6.3, 11.3]  # 46 x 63 x 113 mm
    part = nominal[::7] @ random_rotation(np.random.default_rng(0)).T + 400.0
    assert extent_warning(part, nominal) is None
    scene = np.vstack([part, [[-759, -496, 0], [766, 646, 739]]])
    said = extent_warning(scene, nominal)
    assert said.startswith("the measured points span 1525 × 1142 × 739 mm, the nominal "
                           "46 × 63 × 113 mm")
    assert "--crop" in said and "--remove-plane" in said


# ------------------------------------------------------------------------------ settings
def test_scene_settings_round_trip_and_are_off_when_absent():
    s = InspectionSettings(-0.1, 0.1, crop=(-130.0, -60.0, 300.0, 130.0, 300.0, 500.0),
                           remove_plane=True, plane_distance=15.0)
    d = s.to_json()
    assert d["crop"] == [-130.0, -60.0, 300.0, 130.0, 300.0, 500.0]
    assert d["remove_plane"] is True and d["plane_distance"] == 15.0
    assert InspectionSettings.from_json(d) == s
    plain = InspectionSettings(-0.1, 0.1)
    # Off, they are not written: settings without them read as they did before they existed.
    assert not {"crop", "remove_plane", "plane_distance"} & set(plain.to_json())
    back = InspectionSettings.from_json(plain.to_json())
    assert back == plain and back.crop is None and not back.remove_plane
    assert back.plane_distance is None


def test_the_docstring_examples_run():
    import doctest

    import engine.scene

    assert doctest.testmod(engine.scene).failed == 0
