"""Real drawings (tests/data/dxf, see SOURCE.txt): points sampled exactly on their contours, in a
random pose, come back exactly and are accepted at ±0.01 mm.

The drawings span what a 2D template meets in practice: a 1.2 mm open polyline measured by a
laser meter, a sheet of 40 contours with flattened ellipses, a plate with slots and a spline,
involute gears, and site drawings in metres whose coordinates reach 3 x 10^5 mm. The truth is
the known pose: every deviation must be (numerically) zero, none of the points left out.
"""

import functools
import os

import numpy as np
import pytest

from engine.contour import ContourIndex, deviations_2d, points_on
from engine.inspection import Tolerance, inspect_2d
from engine.pose import apply_transform, pose_2d
from engine.io.templates import read_dxf_template
from engine.verdict import ACCEPT

DATA = os.path.join(os.path.dirname(__file__), "data", "dxf")
DRAWINGS = ["leica_disto_s910.dxf", "forms.dxf", "sample_jamesbremner.dxf", "polylines_site.dxf",
            "closed_loop_with_arcs.dxf", "plate_HFP1JZ.dxf", "gear_z20.dxf",
            "gear_z20_a14.5.dxf", "gear_z24.dxf"]
EXACT = 2e-3  # mm: every deviation of an exact point within 2 um
ZONE = Tolerance.symmetric(0.01)


@functools.lru_cache(maxsize=None)
def drawing(name):
    """(template, its ContourIndex) as the command line reads the file (its own units)."""
    t = read_dxf_template(os.path.join(DATA, name)).template
    return t, ContourIndex(t)


def measure(t, q, rng, far: bool):
    """q (n, 2) turned by a random angle and shifted: by up to 500 mm, or (far) by up to
    2 x 10^5 mm; as 3D points of a 2D measurement (z = 0)."""
    shift = rng.uniform(-2e5, 2e5, 2) if far else rng.uniform(-500.0, 500.0, 2)
    meas = apply_transform(pose_2d(rng.uniform(0.0, 2.0 * np.pi), shift), q)
    return np.column_stack([meas, np.zeros(len(meas))])


def assert_exact(name, res, q):
    d = res.deviations.signed
    assert np.max(np.abs(d)) <= EXACT, (name, np.max(np.abs(d)))
    assert res.registration.inlier.all(), (name, int((~res.registration.inlier).sum()))
    assert res.verdict == ACCEPT, (name, res.verdict, res.reasons)
    # Independent check of the pose: the registered points lie on the template.
    t, idx = drawing(name)
    assert np.max(np.abs(deviations_2d(idx, res.registered[:, :2]).signed)) <= EXACT


@pytest.mark.parametrize("name", DRAWINGS)
@pytest.mark.parametrize("seed, far", [(0, False), (1, False), (2, True)])
def test_exact_points_on_real_drawings_come_back_exactly(name, seed, far):
    t, idx = drawing(name)
    rng = np.random.default_rng(seed)
    q = points_on(t, 300, rng)
    res = inspect_2d(t, measure(t, q, rng, far), 2, ZONE, index=idx)
    assert_exact(name, res, q)


def contour_lengths(t):
    L = np.where(t.kind == 0, np.linalg.norm(t.end - t.start, axis=1), np.abs(t.sweep) * t.radius)
    return np.bincount(t.contour, weights=L, minlength=t.closed.size)


@pytest.mark.parametrize("name", [n for n in DRAWINGS if n not in ("leica_disto_s910.dxf",
                                                                   "closed_loop_with_arcs.dxf")])
@pytest.mark.parametrize("seed", [3, 9])
def test_a_measured_set_covering_some_contours_only(name, seed):
    # The longest contour and a random half of the others, densely measured (1,000 points).
    t, idx = drawing(name)
    assert t.closed.size > 1
    rng = np.random.default_rng(seed)
    others = np.flatnonzero(np.arange(t.closed.size) != np.argmax(contour_lengths(t)))
    chosen = np.r_[np.argmax(contour_lengths(t)), rng.permutation(others)[: others.size // 2]]
    q = points_on(t, 1000, rng, np.isin(t.contour, chosen).astype(float))
    res = inspect_2d(t, measure(t, q, rng, far=False), 2, ZONE, index=idx)
    assert_exact(name, res, q)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_an_open_contour_alone(seed):
    # The laser meter's open polyline: ten lines 1.2 mm across, nearly straight, their order
    # along it told by a few short kinks; 300 points, at a near and a far shift.
    name = "leica_disto_s910.dxf"
    t, idx = drawing(name)
    assert not t.closed.any()
    rng = np.random.default_rng(seed)
    q = points_on(t, 300, rng)
    for far in (False, True):
        res = inspect_2d(t, measure(t, q, rng, far), 2, ZONE, index=idx)
        assert_exact(name, res, q)
