"""The registration's other candidates judged on the exact faces (engine.exact_fit), the scale
of the scores compared there, and the global search's starts for a sparse patch
(engine.registration). The part is tests/step_models.featured_block (120 x 80 x 30 mm, a hole
at (30, 40), a boss at (90, 40), a slot in the top); the truth is the identity pose."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from engine.exact_fit import better_candidates, on_exact_scale
from engine.io.step import read_step
from engine.neighbours import spread_subset
from engine.nominal import Nominal
from engine.outliers import gross_rule
from engine.pose import apply_transform, make_transform, rotation_from_rotvec
from engine.registration import _hypotheses
from engine.registration_types import RegistrationResult, RegistrationSettings
from engine.step_model import ExactDistances
from engine.surface import Posed
from engine.weak_search import half_turns

ZONE = 0.1


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    from step_models import featured_block, write_step
    from sweep import on_part

    part = read_step(write_step(featured_block(), tmp_path_factory.mktemp("c") / "block.stp"))
    nominal = Nominal.from_point_set(part.point_set)
    P, _, _ = on_part(part, np.random.default_rng(8), 600)
    return nominal, ExactDistances(part, nominal), P


def _result(posed, T, score, runner_T=None, runner_score=None, candidates=()):
    """A registration's result at pose T, its deviations exact there."""
    _, dev = posed.at(T)
    rule = gross_rule(dev.signed, ZONE, 0.05)
    return RegistrationResult.from_fit(
        T, dev, np.ones(dev.signed.size, bool), rule, 1.0, converged=True, iterations=1,
        score=score, hypotheses=1, runner_up_score=runner_score, runner_up_T=runner_T,
        candidates=tuple(candidates))


def test_a_candidate_near_the_truth_is_fitted_home_and_comes_first(block):
    """The pose: the block turned 180 degrees about its vertical mid-line, where its outline and
    top fit and the hole, boss and slot do not. Candidates: a pose 50 mm off, the pose again
    and the truth 0.3 mm and 0.2 degrees off. Fitted on the exact faces, the last fits at the
    rounding and comes back first, as the truth."""
    nominal, exact, P = block
    posed = Posed(exact, P)
    turn = make_transform(rotation_from_rotvec(np.array([0.0, 0.0, np.pi])), np.zeros(3))
    centre = make_transform(np.eye(3), np.array([-60.0, -40.0, 0.0]))
    T_turned = np.linalg.inv(centre) @ turn @ centre
    near = make_transform(rotation_from_rotvec(np.radians([0.0, 0.2, 0.1])),
                          np.array([0.3, -0.2, 0.1]))
    far = make_transform(np.eye(3), np.array([50.0, 0.0, 0.0]))
    reg = _result(posed, T_turned, 1.0, candidates=[far, T_turned, near])
    found = better_candidates(reg, posed, nominal.diagonal, 1e-4, ZONE, 0)
    assert 1 <= len(found) <= 3
    X = apply_transform(found[0], P)
    assert np.max(np.linalg.norm(X - P, axis=1)) < 1e-3
    # The turned pose really is wrong: its boss, hole and slot points lie millimetres off.
    assert np.max(np.abs(reg.deviations.signed)) > 5.0
    # Deterministic: the same seeded points, the same answer.
    again = better_candidates(reg, posed, nominal.diagonal, 1e-4, ZONE, 0)
    assert np.array_equal(found[0], again[0])


def test_only_the_half_turns_that_land_the_points_on_the_faces_are_fitted(block):
    """The pose turned 180 degrees about each axis of the nominal's frame through its
    bounding-box centre: about z the block's outline and top land on themselves, and most
    points fit exactly; about x and y its bottom lands 12 mm above its top (the boss raises the
    box). The turns that put at least half the points within 0.1 mm of the exact faces are the
    ones kept: a fit of the others (points millimetres off) costs tenths of a second."""
    nominal, exact, P = block
    posed = Posed(exact, P)
    box = np.array([nominal.points.min(axis=0), nominal.points.max(axis=0)])
    centre = box.mean(axis=0)
    kept = half_turns(nominal, np.eye(4), P)
    landed = []
    for axis in np.eye(3):
        R = 2.0 * np.outer(axis, axis) - np.eye(3)
        K = make_transform(R, centre - R @ centre)
        _, dev = posed.at(K)
        landed.append(np.mean(np.abs(dev.signed) < 0.1) >= 0.5)
        assert landed[-1] == any(np.allclose(K, Q) for Q in kept)
    assert landed == [False, False, True]
    assert len(kept) == 1


def test_no_candidates_no_fits(block):
    nominal, exact, P = block
    reg = _result(Posed(exact, P), np.eye(4), 0.002)
    assert better_candidates(reg, Posed(exact, P), nominal.diagonal, 1e-4, ZONE, 0) == []


def test_an_implausible_runner_up_stays_as_far_behind_on_the_exact_scale(block):
    """The sample scored the pose 0.10 mm and the runner-up 0.50 mm (5x: implausible, never
    fitted on the exact faces). Whatever the pose's exact score, 0 (exact points), 0.002 mm (the
    sample's facets cost it its chordal error) or 0.40 mm (the facets flattered it), the
    runner-up stays 0.40 mm behind: it neither becomes plausible nor scores better than the
    pose (compared as they were, 0.50 mm would beat 0.40 mm and make the verdict
    INCONCLUSIVE, "another pose fits better"; scaled by the pose's ratio, it would tie with a
    pose that fits exactly)."""
    from engine.verdict import better_runner_up, plausible_runner_up

    nominal, exact, P = block
    reg = _result(Posed(exact, P), np.eye(4), 0.10,
                  runner_T=make_transform(np.eye(3), np.array([0.0, 0.0, 5.0])),
                  runner_score=0.50)
    assert not plausible_runner_up(reg)
    for exact_score in (0.0, 0.002, 0.40):
        on = on_exact_scale(reg, exact_score, reg.score)
        assert on.score == exact_score
        assert on.runner_up_score == pytest.approx(exact_score + 0.40)
        assert not plausible_runner_up(on) and not better_runner_up(on)
    assert on_exact_scale(replace(reg, runner_up_score=None, runner_up_T=None), 0.3,
                          0.1).runner_up_score is None


def test_a_sparse_patch_without_a_planar_neighbourhood_gets_turns_at_every_anchor(block):
    """The global search's starts: points spread over the whole block, or a dense patch of its
    top, keep the starts they had; 12 points spread over one corner of the block (three
    faces, no 8 near their centroid on one) get ``n_patch_rotations`` more at each anchor."""
    nominal, _, P = block
    settings = RegistrationSettings()
    never = replace(settings, patch_flatness=np.inf)
    pts, nrm, _ = nominal.level(1000)

    def starts(measured, s):
        return _hypotheses(nominal, measured, pts, nrm, s).shape[0]

    rng = np.random.default_rng(3)
    top = np.column_stack([rng.uniform(0, 40, 400), rng.uniform(0, 30, 400),
                           np.full(400, 30.0)])
    corner = P[np.linalg.norm(P - [120.0, 80.0, 30.0], axis=1) < 45.0]
    corner = corner[spread_subset(corner, 12)]
    assert starts(P, settings) == starts(P, never)
    assert starts(top, settings) == starts(top, never)
    extra = starts(corner, settings) - starts(corner, never)
    assert extra > 0 and extra % settings.n_patch_rotations == 0
    assert extra // settings.n_patch_rotations <= settings.max_anchors
