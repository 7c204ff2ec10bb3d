"""engine.weak_search: a pose slid along the direction its kept points leave free is found again
where the points it left out meet the part. The geometry is tests/step_models.featured_block
(120 x 80 x 30 mm, a boss of radius 10 at (90, 40) on top), its points written from the
primitives' dimensions here; the truth is the identity pose."""

from __future__ import annotations

import numpy as np
import pytest

from engine.io.step import read_step
from engine.nominal import Nominal
from engine.pose import make_transform
from engine.surface_fit import pose_score
from engine.step_model import ExactDistances
from engine.surface import Posed
from engine.weak_search import slid_poses


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    from step_models import featured_block, write_step

    part = read_step(write_step(featured_block(), tmp_path_factory.mktemp("b") / "block.stp"))
    nominal = Nominal.from_point_set(part.point_set)
    return nominal, ExactDistances(part, nominal)


def _prismatic_patch_and_boss(rng):
    """(points, kept): 300 points on the top face (z 30) and the front face (y 0) in the band
    x 25-70, both invariant along x, and 12 on the boss's cylinder (the only points that fix
    x), the boss's last."""
    n = 150
    top = np.column_stack([rng.uniform(25, 70, n), rng.uniform(5, 28, n), np.full(n, 30.0)])
    front = np.column_stack([rng.uniform(25, 70, n), np.zeros(n), rng.uniform(3, 27, n)])
    a = rng.uniform(0.0, 2 * np.pi, 12)
    boss = np.column_stack([90 + 10 * np.cos(a), 40 + 10 * np.sin(a), rng.uniform(32, 40, 12)])
    P = np.vstack([top, front, boss])
    kept = np.ones(len(P), bool)
    kept[-12:] = False
    return P, kept


@pytest.mark.parametrize("shift", [15.0, -22.0])
def test_a_pose_slid_along_the_free_direction_is_found_where_the_left_out_points_fit(block,
                                                                                      shift):
    nominal, exact = block
    P, kept = _prismatic_patch_and_boss(np.random.default_rng(4))
    T = make_transform(np.eye(3), np.array([shift, 0.0, 0.0]))
    posed = Posed(exact, P)
    _, dev = posed.at(T)
    # At the slid pose the kept points fit exactly and the boss's are off by up to millimetres.
    assert np.max(np.abs(dev.signed[kept])) < 1e-6
    assert np.min(np.abs(dev.signed[~kept])) > 0.5 and np.median(np.abs(dev.signed[~kept])) > 2
    scale = 1e-4 * nominal.diagonal
    found = slid_poses(nominal, P, T, dev, kept, 0.0, exact, scale)
    assert found
    best = found[0]
    assert np.allclose(best[:3, :3], np.eye(3), atol=1e-6)
    assert np.allclose(best[:3, 3], 0.0, atol=0.01), best[:3, 3]
    assert pose_score(posed.deviations_at(best, np.arange(len(P))), scale) < 0.01


@pytest.mark.parametrize("reach, home", [(8.0, False), (20.0, True)])
def test_a_short_slide_reaches_no_further_than_it_is_told(block, reach, home):
    """A slide given a reach scans only that far (engine.exact_fit's short slide of a
    candidate): the pose slid 15 mm comes home with a reach of 20 mm, not with one of 8 mm."""
    nominal, exact = block
    P, kept = _prismatic_patch_and_boss(np.random.default_rng(4))
    T = make_transform(np.eye(3), np.array([15.0, 0.0, 0.0]))
    _, dev = Posed(exact, P).at(T)
    found = slid_poses(nominal, P, T, dev, kept, 0.0, exact, 1e-4 * nominal.diagonal, reach)
    at_home = [F for F in found if np.allclose(F[:3, 3], 0.0, atol=0.01)]
    assert bool(at_home) == home, [F[:3, 3] for F in found]
    assert all(abs(F[0, 3] - 15.0) <= reach + 1e-6 for F in found)


def test_nothing_is_searched_when_no_point_was_left_out_or_nothing_is_free(block):
    nominal, exact = block
    P, kept = _prismatic_patch_and_boss(np.random.default_rng(4))
    T = make_transform(np.eye(3), np.array([15.0, 0.0, 0.0]))
    posed = Posed(exact, P)
    _, dev = posed.at(T)
    scale = 1e-4 * nominal.diagonal
    every = np.ones(len(P), bool)
    assert slid_poses(nominal, P, T, dev, every, 0.0, exact, scale) == []
    # The boss kept: the fit's points constrain every direction.
    assert slid_poses(nominal, P, np.eye(4), posed.at(np.eye(4))[1], every, 0.0, exact,
                      scale) == []


def _inclined_cylinder(rng, n=400):
    """Points and outward normals on a cylinder of radius 20 about an inclined axis through
    (5, -3, 2), 60 long: analytic."""
    from scipy.spatial.transform import Rotation

    R = Rotation.from_rotvec([0.4, -0.7, 0.3]).as_matrix()
    t = rng.uniform(0, 2 * np.pi, n)
    z = rng.uniform(0, 60, n)
    radial = np.column_stack([np.cos(t), np.sin(t), np.zeros(n)])
    P = (20 * radial + np.column_stack([np.zeros((n, 2)), z])) @ R.T + [5.0, -3.0, 2.0]
    return P, radial @ R.T


def test_a_turn_and_a_slide_that_no_point_constrains_are_not_scanned():
    """A cylinder measured all round about an inclined axis leaves two motions free for every
    point, kept or not: the turn about the axis and the slide along it. The eigenvalue solver
    mixes them into screws; neither mixture may be scanned (nothing along it can fit better)."""
    from engine.weak_search import scan_directions

    P, N = _inclined_cylinder(np.random.default_rng(2))
    kept = np.ones(len(P), bool)
    kept[:8] = False  # "left out": on the same cylinder, so they pin nothing either
    twists, cond = scan_directions(P, N, kept, 0.001)
    assert len(cond.weak) == 2 and twists == []


def test_the_motion_the_left_out_points_pin_is_the_one_scanned():
    """The featured block's prismatic patch (top and front faces, free along x) with its boss's
    points left out: the one motion scanned is the slide along x."""
    from engine.weak_search import scan_directions

    P, kept = _prismatic_patch_and_boss(np.random.default_rng(4))
    N = np.zeros_like(P)
    N[:150] = [0, 0, 1]
    N[150:300] = [0, -1, 0]
    N[300:] = (P[300:] - [90, 40, P[300, 2]]) * [1, 1, 0] / 10.0
    twists, _ = scan_directions(P, N, kept, 0.001)
    assert len(twists) == 1
    v = twists[0]
    assert np.linalg.norm(v[:3]) < 1e-9 and abs(abs(v[3]) - 1.0) < 1e-9


def test_twins_a_slide_apart_have_no_axis_to_turn_about(block):
    """weak_search.twin_turns scans the turn between a pose and its tied twin; twins that only
    slide apart (along the block's length, its top and front faces fitting both) have none, and
    nothing is handed back, whatever the points would score turned about an arbitrary axis."""
    from engine.weak_search import twin_turns

    nominal, surface = block
    P, _ = _prismatic_patch_and_boss(np.random.default_rng(2))
    dev = surface.deviations(P)
    twin = make_transform(np.eye(3), [5.0, 0.0, 0.0])
    assert twin_turns(nominal, P, np.eye(4), dev, twin, surface, 0.01) == []
