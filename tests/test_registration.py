"""Pose recovery from arbitrary poses: full and partial coverage, two faces, outliers, a cube
with a boss (faces that fit at 24 poses)."""

import numpy as np
import pytest

from engine.pose import apply_transform, make_transform
from engine.inspection import Tolerance, inspect
from engine.nominal import Nominal
from engine.registration import register
from engine.registration_types import RegistrationSettings
from engine.verdict import ACCEPT, REJECT
from surfaces import (CUBE_BOSS, bracket_two_faces, cube_face, cube_with_small_boss, height,
                      height_grid, height_normal, point_set, random_rotation, upper_hemisphere)

import samples.generate as gen


@pytest.fixture(scope="module")
def fairing():
    pts, nrm, grid = height_grid(300, 200)
    return Nominal.from_point_set(point_set(pts, nrm, grid))


def _patch(rng, m, xr, yr, noise=0.004):
    x, y = rng.uniform(*xr, m), rng.uniform(*yr, m)
    q = np.column_stack([x, y, height(x, y)])
    return q + rng.normal(0, noise, m)[:, None] * height_normal(x, y)


def _pose(rng):
    return make_transform(random_rotation(rng), rng.uniform(-3000, 3000, 3))


def _max_error(res, measured, truth_nominal_frame):
    return float(np.max(np.linalg.norm(apply_transform(res.T_nominal_measured, measured)
                                       - truth_nominal_frame, axis=1)))


COVERAGE = {  # name: (points, x range, y range)
    "full": (1100, (-245, 245), (-120, 120)),
    "quarter": (400, (0, 245), (0, 120)),
    "tenth": (400, (-200, -50), (-120, -40)),
}


@pytest.mark.parametrize("coverage", list(COVERAGE))
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_pose_recovered_from_random_pose(fairing, coverage, seed):
    rng = np.random.default_rng(100 * seed + len(coverage))
    m, xr, yr = COVERAGE[coverage]
    q = _patch(rng, m, xr, yr)
    T = _pose(rng)
    measured = apply_transform(T, q)
    res = register(fairing, measured)
    assert res.converged
    # Noise 4 um; a small patch of a smooth surface can slide a little along its weak directions.
    limit = {"full": 0.01, "quarter": 0.03, "tenth": 0.3}[coverage]
    assert _max_error(res, measured, q) < limit
    assert res.rms < 0.006
    assert res.hypotheses > 50


def test_gross_outliers_do_not_move_the_pose(fairing):
    rng = np.random.default_rng(9)
    q = _patch(rng, 1100, (-245, 245), (-120, 120))
    T = _pose(rng)
    clean = register(fairing, apply_transform(T, q))
    bad = q.copy()
    idx = rng.choice(len(q), 12, replace=False)
    x, y = bad[idx, 0], bad[idx, 1]
    bad[idx] += rng.choice([-10.0, 10.0], 12)[:, None] * height_normal(x, y)  # mis-probed 10 mm
    dirty = register(fairing, apply_transform(T, bad))
    assert dirty.converged and dirty.n_inliers == len(q) - 12
    assert not dirty.inlier[idx].any()
    moved = apply_transform(dirty.T_nominal_measured, apply_transform(T, q)) \
        - apply_transform(clean.T_nominal_measured, apply_transform(T, q))
    assert np.max(np.linalg.norm(moved, axis=1)) < 1e-3


def test_two_faces_of_a_bracket_cover_a_small_part():
    rng = np.random.default_rng(21)
    nom, q, _ = bracket_two_faces(rng, 60_000)
    for trial in range(3):
        T = _pose(rng)
        res = register(nom, apply_transform(T, q))
        assert res.converged
        assert _max_error(res, apply_transform(T, q), q) < 0.02, trial


def test_deterministic(fairing):
    rng = np.random.default_rng(5)
    q = _patch(rng, 400, (0, 245), (0, 120))
    measured = apply_transform(_pose(rng), q)
    a, b = register(fairing, measured), register(fairing, measured)
    assert np.array_equal(a.T_nominal_measured, b.T_nominal_measured)
    assert a.rms == b.rms and a.iterations == b.iterations and a.score == b.score


@pytest.mark.parametrize("coverage, noise_mm",
                         [(c, None) for c in COVERAGE] + [("quarter", 0.004)])
def test_a_finish_that_gains_nothing_is_given_up_and_the_answer_stays(fairing, coverage,
                                                                       noise_mm, monkeypatch):
    """A candidate's finish after the best one's is given up once it scores no better than
    where it started (surface_fit.Watch): the pose, its score and whether the runner-up is a
    competitor stay those of every finish run to its budget (the twin: a watch that never gives
    up), with fewer evaluations of the deviations; also when the measurement's noise is known
    (a scene's), where steps that do not lower the sum of squares are shortened. Before the
    watch, the belly fairing's second candidate went from a score of 1.3 mm to 637 mm in 11
    evaluations."""
    import engine.surface_fit as sf
    from engine.verdict import AMBIGUITY_SCORE_RATIO

    rng = np.random.default_rng(40 + len(coverage))
    m, xr, yr = COVERAGE[coverage]
    q = _patch(rng, m, xr, yr)
    measured = apply_transform(_pose(rng), q)
    evaluations = []
    evaluate = sf.point_to_surface
    monkeypatch.setattr(sf, "point_to_surface",
                        lambda *a, **k: evaluations.append(a[1].shape[0]) or evaluate(*a, **k))
    runs = {}
    for lost_after in (sf.LOST_AFTER, 10 ** 9):
        monkeypatch.setattr(sf, "LOST_AFTER", lost_after)
        evaluations.clear()
        runs[lost_after] = (register(fairing, measured, RegistrationSettings(noise_mm=noise_mm),
                                     zone_width=0.1), sum(evaluations))
    (watched, fewer), (twin, more) = runs.values()
    # The same pose: two candidates that finish there may tie to 1e-13 mm and swap.
    assert np.max(np.abs(apply_transform(watched.T_nominal_measured, measured)
                         - apply_transform(twin.T_nominal_measured, measured))) < 1e-6
    assert watched.score == pytest.approx(twin.score, abs=1e-9)
    assert watched.converged and twin.converged
    assert _max_error(watched, measured, q) < 0.03
    assert watched.runner_up_score is not None and twin.runner_up_score is not None
    assert watched.runner_up_score > AMBIGUITY_SCORE_RATIO * watched.score
    assert twin.runner_up_score > AMBIGUITY_SCORE_RATIO * twin.score
    assert fewer < more


@pytest.mark.parametrize("scores, beat, gives_up_at, best", [
    ([1.0] * 8, 0.1, 5, 0),                      # stuck above the best: given up at LOST_AFTER
    ([1.0, 0.8, 0.6, 0.5, 0.4, 0.3, 0.2], 0.1, None, 6),  # gaining: never
    ([1.0, 1.5, 1.5, 1.5, 1.5, 1.5], 2.0, None, 0),       # worse, but still better than the best
    ([1.0, 0.5, 0.9, 0.95, 0.99, 1.0, 1.2], 0.1, 6, 1),   # back where it started
])
def test_a_watch_gives_up_a_finish_that_has_not_gained_on_its_start(scores, beat, gives_up_at,
                                                                     best):
    import engine.surface_fit as sf
    from types import SimpleNamespace

    assert sf.LOST_AFTER == 5
    watch = sf.Watch(scale=1e-9, beat=beat)
    said = [watch.sees(np.full((4, 4), k), SimpleNamespace(signed=np.full(7, v)), 0.0)
            for k, v in enumerate(scores)]
    if gives_up_at is None:
        assert not any(said)
    else:  # from that evaluation on, and not before
        assert said == [False] * (gives_up_at - 1) + [True] * (len(scores) - gives_up_at + 1)
    assert watch.best[1][0, 0] == best and watch.best[0] == pytest.approx(scores[best])


def test_without_a_zone_a_dent_stays_and_mis_probed_points_go(fairing):
    """The registration on its own (no tolerance zone): the gross threshold's floor is 0.1% of
    the nominal's diagonal; a 0.6 mm dent stays in the least-squares fit, 10 mm mis-probes go."""
    rng = np.random.default_rng(31)
    q = _patch(rng, 1100, (-245, 245), (-120, 120))
    x, y = q[:, 0], q[:, 1]
    dent = -0.6 * np.exp(-((x - 80) ** 2 + (y - 20) ** 2) / (2 * 18.0**2))
    q = q + dent[:, None] * height_normal(x, y)
    idx = np.sort(rng.choice(len(q), 11, replace=False))
    q[idx] += rng.choice([-10.0, 10.0], idx.size)[:, None] * height_normal(x[idx], y[idx])
    res = register(fairing, apply_transform(_pose(rng), q))
    rule = res.gross_rule
    assert rule.zone_width_mm is None
    assert rule.floor_mm == pytest.approx(1e-3 * fairing.diagonal)
    assert res.outlier_cut == rule.threshold_mm
    assert np.array_equal(np.flatnonzero(~res.inlier), idx)


# A 50 mm cube (a corner at the origin) with a hemispherical boss R10 on its top: its faces fit
# at 24 poses, and only the boss's points (a quarter of them) tell the right one from the others.
BOSS_R = 10.0


def _cube_with_boss(rng):
    """The nominal: 1,500 random points on each face, 2,000 on the boss, with normals."""
    faces = [cube_face(rng, axis, side, 1500, 0.0, 50.0, BOSS_R)
             for axis in range(3) for side in (0.0, 1.0)]
    s = upper_hemisphere(rng, 2000)
    pts = np.vstack([p for p, _ in faces] + [CUBE_BOSS + BOSS_R * s])
    return Nominal.from_point_set(point_set(pts, np.vstack([n for _, n in faces] + [s])))


def _cube_measured(rng, boss_r=BOSS_R, boss_shift=0.0):
    """About 110 points (0.001 mm noise) in the cube's frame: 20 on each of the bottom, the
    sides x = 0 and y = 0 and the top (5 mm or more from every edge and the boss), the rest
    (1 mm or more above the top) on a boss of radius ``boss_r`` moved ``boss_shift`` along x."""
    faces = [cube_face(rng, axis, side, 80, 5.0, 45.0, BOSS_R + 5)
             for axis, side in ((2, 0.0), (0, 0.0), (1, 0.0), (2, 1.0))]
    s = upper_hemisphere(rng, 30)
    s = s[s[:, 2] > 0.1]
    q = np.vstack([p[:20] for p, _ in faces] + [CUBE_BOSS + [boss_shift, 0.0, 0.0] + boss_r * s])
    n = np.vstack([n[:20] for _, n in faces] + [s])
    return q + rng.normal(0.0, 0.001, len(q))[:, None] * n


@pytest.mark.parametrize("seed, boss_r, boss_shift, pose_mm", [
    (23, BOSS_R, 0.0, 0.005), (37, BOSS_R, 0.0, 0.005), (39, BOSS_R, 0.0, 0.005),
    (64, BOSS_R + 0.01, 0.02, 0.05), (19, BOSS_R + 0.01, 0.02, 0.05),
    (3, BOSS_R + 0.01, 0.02, 0.05)])
def test_a_cube_with_a_boss_is_found_at_its_pose(seed, boss_r, boss_shift, pose_mm):
    """A good cube with a boss in an arbitrary pose, its boss as drawn or 0.01 mm larger and
    0.02 mm off (within the +-0.025 zone): the registration finds the pose (within what the
    boss's offset pulls the least-squares fit) and the part is accepted; no other pose found
    scores better.

    Before, the global search scored each pose by its best 75% of points, which left the boss
    out, and by where it stood one ICP step earlier, so that the right pose lost to the
    wrong ones that fit the faces; the candidates were then compared with a cut set by the
    tightest of them, a wrong pose fitting three quarters of the points exactly: seeds 23 and 64
    came back REJECT at a wrong pose (most points out of tolerance), 37, 39 and 19 INCONCLUSIVE
    at a wrong pose, 3 INCONCLUSIVE at the right pose (a wrong runner-up taken for a
    competitor)."""
    rng = np.random.default_rng(seed)
    nominal = _cube_with_boss(rng)
    q = _cube_measured(rng, boss_r, boss_shift)
    T = make_transform(random_rotation(rng), rng.uniform(-300, 300, 3))
    res = inspect(nominal, apply_transform(T, q), Tolerance.symmetric(0.025))
    reg = res.registration
    assert _max_error(reg, apply_transform(T, q), q) < pose_mm
    assert res.verdict == ACCEPT, res.reasons
    assert reg.runner_up_score is None or reg.runner_up_score >= reg.score


@pytest.mark.parametrize("seed, radius", [(25, 2.0), (120, 1.5)])
def test_candidates_that_tie_on_the_spread_points_are_ranked_on_more(seed, radius):
    """A 50 mm cube with a small boss on its top, sampled at random (10,000 points a face, 3,000
    on the boss), measured with some 1,210 points of which about 11 on the boss, in an arbitrary
    pose (benchmarks/bench_lookalike.py). Seed 25, an R2 boss: the 125 spread points of the
    registration's second level had none on the boss, 29 poses fit them equally (1.04e-6
    mm^2), and the 8 kept, by the order of ties, held none of the right one; the good part was
    rejected at a pose 62.6 mm off, its 11 boss points out (registration.TIE). Seed 120, an
    R1.5 boss: the level's samples, 1.9 mm apart, cannot represent the boss, and the right pose
    scored 7.1e-4 mm^2 against the look-alikes' 1.1e-6; rejected 62.4 mm off
    (registration.TIE_SPACING). Ties beyond what a level keeps are ranked on more points."""
    rng = np.random.default_rng(seed)
    pts, nrm, q = cube_with_small_boss(rng, radius=radius)
    assert 1205 <= len(q) <= 1212
    measured = apply_transform(make_transform(random_rotation(rng), rng.uniform(-300, 300, 3)), q)
    res = inspect(Nominal.from_point_set(point_set(pts, nrm)), measured,
                  Tolerance.symmetric(0.025))
    assert res.verdict == ACCEPT
    assert _max_error(res.registration, measured, q) < 0.005


@pytest.mark.parametrize("seed, boss_r, boss_shift", [(1, BOSS_R, 0.0),
                                                     (64, BOSS_R + 0.01, 0.02)])
def test_the_pose_reported_is_the_best_found_even_when_the_search_misses(seed, boss_r,
                                                                          boss_shift):
    """A global search left few starts (2 spins, 4 even rotations) may miss the cube's pose; the
    pose reported is still the best the registration found: no distinct pose it found scores
    better (the finish of the best candidate may move it somewhere worse than the runner-up:
    then the runner-up is finished too, and the better one reported). Before, seed 1 reported a
    pose scoring 0.75 mm with a runner-up at 0.44 mm, seed 64 (REJECT) 0.0094 against 0.0050."""
    rng = np.random.default_rng(seed)
    nominal = _cube_with_boss(rng)
    q = _cube_measured(rng, boss_r, boss_shift)
    T = make_transform(random_rotation(rng), rng.uniform(-300, 300, 3))
    few = RegistrationSettings(n_spins=2, n_rotations=4)
    res = inspect(nominal, apply_transform(T, q), Tolerance.symmetric(0.025), settings=few)
    reg = res.registration
    assert reg.runner_up_score is not None and reg.runner_up_score >= reg.score


def test_material_in_the_hole_is_judged_where_it_is_not_slid_away():
    """The engine benchmark's seat bracket (200,000 points) measured on its two curved faces A
    and B, 100 points, one of which lies where the flange has its through hole: material where
    the drawing has none, 1.2 mm off the nominal at the true pose. Slid 2 mm along the direction
    two curved faces fix only weakly, every point lies within 0.035 mm. The pose stays true: 99
    points at the noise and one far off fit better than every point a few hundredths off (a
    score capping each point at 1% of the part's size took the slid pose: INCONCLUSIVE, 2 mm
    off), and the part is rejected for that point alone."""
    rng = np.random.default_rng(12345)
    nom, q, nq = bracket_two_faces(rng, 200_000)
    in_hole = np.flatnonzero(np.hypot(q[:, 0] - gen.HOLE_CENTRE[0], q[:, 1] - gen.HOLE_CENTRE[1])
                             < gen.HOLE_D / 2)
    q = q + rng.normal(0.0, 0.003, len(q))[:, None] * nq
    assert in_hole.size == 1
    T = make_transform(gen.rotation([0.4, -0.7, 0.2], 137.0), np.array([1520.0, -830.0, 410.0]))
    res = inspect(nom, apply_transform(T, q), Tolerance.symmetric(0.05))
    assert _max_error(res.registration, apply_transform(T, q), q) < 0.05
    assert res.verdict == REJECT
    assert np.array_equal(np.flatnonzero(~res.in_tolerance), in_hole)


def test_coarse_levels_of_a_mesh_cover_its_area_evenly():
    """A CAD-like tessellation of a 100 x 100 mm plate face: nodes only on its border, fanned
    slivers from edge to edge. Every coarse level is spread over the face by area (a quarter of
    its points in the middle quarter of the face, with the plate's normal), not over the nodes,
    none of which lie inside."""
    from engine.nominal import Nominal
    from surfaces import point_set

    t = np.linspace(0.0, 100.0, 201)[:-1]
    border = np.concatenate([np.column_stack([t, 0 * t]), np.column_stack([100 + 0 * t, t]),
                             np.column_stack([100 - t, 100 + 0 * t]),
                             np.column_stack([0 * t, 100 - t])])
    pts = np.column_stack([border, np.zeros(len(border))])
    tris = np.array([[0, k, k + 1] for k in range(1, len(pts) - 1)])
    nominal = Nominal.from_point_set(point_set(pts, np.tile([0.0, 0.0, 1.0], (len(pts), 1)),
                                               triangles=tris))
    # The finest level too (the registration's last ICP level): area samples, not the nodes.
    for size in (200, 1000, 4000, nominal.finest_level):
        lp, ln, _ = nominal.level(size)
        assert lp.shape == (size, 3) and np.allclose(lp[:, 2], 0.0)
        assert np.allclose(ln, [0.0, 0.0, 1.0])
        middle = np.mean(np.all((lp[:, :2] > 25) & (lp[:, :2] < 75), axis=1))
        assert abs(middle - 0.25) < 4 * np.sqrt(0.25 * 0.75 / size), (size, middle)
