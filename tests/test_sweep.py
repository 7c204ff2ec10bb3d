"""The registration sweep, small: three real NIST parts (tests/data/step, public domain) x four
defects x two random poses, each inspected from its arbitrary pose at +-0.05 mm against the
truth of tests/sweep.py (the least-squares pose from the known pose, OpenCascade's exact
distances). No case may be wrong (a confident verdict at a wrong pose, or the wrong verdict);
every case that covers the whole part must be right. benchmarks/bench_sweep.py runs the large
version over every NIST file.

Before the registration sampled CAD tessellations by area, CTC-01 with its largest face bowed
came back REJECT at a pose 25 mm off the truth, "converged".
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from engine.inspection import Tolerance, inspect
from engine.io.step import read_step
from engine.nominal import Nominal
from engine.pose import apply_transform
from engine.step_model import ExactDistances
from sweep import judge, make_case, truth

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "step")
PARTS = ["nist_ctc_01_asme1_ap203.stp", "nist_ftc_06_asme1_rd.stp",
         "nist_ctc_03_asme1_ap242-e2.stp"]
DEFECTS = ["none", "bow1.0", "outliers2", "cover30"]
TOL = 0.05


@pytest.mark.parametrize("name", PARTS)
def test_sweep_over_a_real_part(name):
    part = read_step(os.path.join(DATA, name))
    rows = []
    for k, defect in enumerate(DEFECTS):
        for pose in range(2):
            case = make_case(part, defect, seed=100 * pose + k)
            d_true = truth(part, case)
            nominal = Nominal.from_point_set(part.point_set)
            res = inspect(nominal, case["measured"], Tolerance.symmetric(TOL),
                          surface=ExactDistances(part, nominal))
            outcome, err = judge(res, d_true, TOL)
            rows.append((defect, pose, res.verdict, outcome, round(err, 4)))
    wrong = [r for r in rows if r[3] == "wrong"]
    assert not wrong, rows
    full = [r for r in rows if r[0] != "cover30"]
    assert all(r[3] == "right" for r in full), rows
    # The truth is not trivial: a bow of 1 mm is a REJECT, a perfect part an ACCEPT.
    assert {r[2] for r in rows if r[0] == "bow1.0"} == {"REJECT"}
    assert {r[2] for r in rows if r[0] == "none"} == {"ACCEPT"}


@pytest.mark.parametrize("seed", [None, 1, 2])
def test_a_plain_block_with_a_hole_a_boss_and_a_slot_is_accepted_from_any_pose(tmp_path, seed):
    """Issue 21: exact points on a synthetic block (tests/step_models.featured_block), in the
    nominal pose (seed None) and in random poses, were INCONCLUSIVE "only 12-19% of the points
    lie within 1.53 mm of the nominal" while the fit's rms was 0.003 mm: the registration
    measured them against the tessellation's vertices, and a large plane has vertices on its
    boundary only. Their distances to the solid are checked first by OpenCascade's
    BRepExtrema, one point at a time (independently of the engine's exact distance)."""
    from step_models import distance_to_shape, featured_block, random_pose, write_step
    from sweep import on_part

    shape = featured_block()
    part = read_step(write_step(shape, tmp_path / "block.stp"))
    rng = np.random.default_rng(5)
    P, _, _ = on_part(part, rng, 600)
    assert np.max(distance_to_shape(shape, P[::20])) < 1e-6
    measured = P
    if seed is not None:
        R, t = random_pose(seed)
        measured = P @ R.T + t
    nominal = Nominal.from_point_set(part.point_set)
    res = inspect(nominal, measured, Tolerance.symmetric(TOL),
                  surface=ExactDistances(part, nominal))
    assert res.verdict == "ACCEPT", res.reasons
    assert res.registration.converged
    assert np.max(np.abs(res.deviations.signed)) < 1e-4
    assert np.max(np.abs(distance_to_shape(shape, res.registered[::20]))) < 1e-4


def test_the_truth_is_the_known_pose_for_a_perfect_part():
    """The sweep's truth itself: with no defect and no noise its deviations are zero (the
    least-squares pose from the known pose is the known pose)."""
    part = read_step(os.path.join(DATA, PARTS[1]))
    case = make_case(part, "none", seed=3, n=300, noise=0.0)
    assert np.max(np.abs(truth(part, case))) < 1e-6


def _inspect_case(name, defect, seed, judged=True, n=2000, noise=0.002):
    part = read_step(os.path.join(DATA, name))
    case = make_case(part, defect, seed=seed, n=n, noise=noise)
    nominal = Nominal.from_point_set(part.point_set)
    res = inspect(nominal, case["measured"], Tolerance.symmetric(TOL),
                  surface=ExactDistances(part, nominal))
    return res, judge(res, truth(part, case), TOL) if judged else None


def test_a_30_percent_patch_lands_where_it_was_measured():
    """CTC-03, 600 points on a 30% patch (benchmarks/bench_sweep.py's case of seed 5). Two root
    causes. The registration's finest ICP level was the tessellation's nodes, none inside a
    plane: the global search's best pose, 1.4 mm from the truth, left at 11 mm and the answer
    was a confident REJECT 24 mm off. Then, at the right pose, the tessellation's chordal error
    (0.065 mm) made a pose 24 mm away (0.090 mm) a near tie: INCONCLUSIVE. Exactly, they score
    0.0019 and 0.048 mm."""
    res, (outcome, err) = _inspect_case("nist_ctc_03_asme1_ap242-e2.stp", "cover30", 5)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.runner_up_score > 10 * res.registration.score


def test_an_exact_fit_cycling_between_two_poses_settles():
    """FTC-06 (AP242) with its largest face bowed 1 mm: the exact least squares stepped back and
    forth between two poses 0.38 um apart for all its 20 steps (a point's foot flipping between
    two faces), and the verdict was INCONCLUSIVE, "did not settle". A step that does not lower
    the sum of squares is now halved and the fit settles (at the truth, 0.3 um off:
    benchmarks/bench_sweep.py)."""
    res, _ = _inspect_case("nist_ftc_06_asme1_ap242-e1.stp", "bow1.0", 3, judged=False)
    assert res.registration.converged, res.registration.message
    assert res.verdict == "REJECT", res.reasons


def test_an_exact_fit_stalled_inside_its_own_scatter_has_settled():
    """CTC-01 (AP203) with its largest face bowed 1 mm (benchmarks/bench_sweep.py --seed 7): the
    exact least squares stalled at the truth (0.2 um off) on steps of 1.29 um that no fraction
    of lowered the sum of squares, just over the 1 um (1% of the zone) a stall was allowed,
    and a plain REJECT was INCONCLUSIVE, "did not settle". Those steps promised a decrease of
    0.00027 mm^2 against a residual variance of 0.071 mm^2 (the bow is in the fit): inside the
    pose's own 1-sigma ellipsoid, the fit has settled."""
    res, (outcome, err) = _inspect_case("nist_ctc_01_asme1_ap203.stp", "bow1.0", 10)
    assert res.registration.converged, res.registration.message
    assert outcome == "right" and res.verdict == "REJECT", (outcome, err, res.reasons)



def test_a_patch_slid_along_its_free_direction_is_brought_back_by_the_points_it_left_out():
    """CTC-03, 600 points on a 30% patch (seed 103, tests/sweep.py's truth). The least squares
    came to rest 16.9 mm from the truth along the one direction its kept points leave free (a
    patch of prismatic faces), 13 points of the distinguishing edge 5 mm off and left out as
    gross outliers, the other 587 at the noise: INCONCLUSIVE only because the registration's
    runner-up, 7 mm off and wrong too, happened to score better (taken as the pose, a confident
    REJECT of a perfect part). The pose is scanned along that direction with the points left
    out (engine.weak_search) and the truth fits all 600 at the noise."""
    res, (outcome, err) = _inspect_case("nist_ctc_03_asme1_ap242-e2.stp", "cover30", 103)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    reg = res.registration
    assert reg.inlier.all() and reg.rms < 0.003
    # The pose it was is kept as the runner-up, and it scores ten times worse.
    assert reg.runner_up_score > 10 * reg.score


def test_a_better_runner_up_turned_about_a_free_axis_becomes_the_pose():
    """FTC-11, a part of revolution, with 2% mis-probes (benchmarks/bench_sweep.py --seed 7):
    the runner-up, turned 32 degrees about the axis, scored 2.6e-4 better (0.0048303 against
    0.0048316 mm, beyond the tie) with every deviation within 6e-5 mm of the chosen pose's; the
    verdict was INCONCLUSIVE, "another pose fits better". Fitted on every point it still scores
    better, and it is the pose; the pose chosen before, its runner-up, moves no deviation by a
    tenth of the zone (not ambiguous), and the verdict is the truth's."""
    res, (outcome, err) = _inspect_case("nist_ftc_11_asme1_ap242-e1.stp", "outliers2", 13)
    assert outcome == "right" and res.verdict == "REJECT", (outcome, err, res.reasons)
    reg = res.registration
    assert reg.runner_up_score > reg.score and not res.ambiguous
    assert not any("fits better" in r for r in res.reasons)


def test_a_runner_up_fitting_the_exact_faces_better_becomes_the_pose():
    """FTC-07 (AP242) with its largest face bowed 1 mm (benchmarks/bench_sweep.py --seed 7): the
    tessellation chose a pose 10 mm off the truth. On the exact faces its runner-up, at the
    truth, fitted better (0.0769 against 0.0858 mm), and the verdict was INCONCLUSIVE,
    "another pose fits better than the one found". The runner-up is now the pose, fitted on
    every point, and the pose chosen before its runner-up. (First made so in 5f1cd0c and taken
    back: CTC-03's patch above then took a runner-up slid along its free direction, a confident
    wrong REJECT; engine.weak_search brings that one home.)"""
    res, (outcome, err) = _inspect_case("nist_ftc_07_asme1_ap242-e2.stp", "bow1.0", 10)
    assert outcome == "right" and res.verdict == "REJECT", (outcome, err, res.reasons)
    reg = res.registration
    assert reg.converged and reg.runner_up_score > reg.score
    # The runner-up, the pose chosen before, puts the points some 10 mm from where they are.
    D = reg.runner_up_T @ np.linalg.inv(reg.T_nominal_measured)
    moved = np.linalg.norm(apply_transform(D, res.registered) - res.registered, axis=1)
    assert moved.max() > 5.0


@pytest.mark.parametrize("seed", [6105, 1905])
def test_a_least_squares_stalled_against_an_edge_is_slid_home(seed):
    """CTC-03, 600 points on a 30% patch (seed 6105, benchmarks/bench_sweep.py --defects cover30
    --poses 10 --seed 100). The exact runner-up, taken as the pose, came to rest 1.23 mm from
    the truth along the patch's free direction: 28 points past an edge 0.06-1.2 mm off, kept by
    the gross-outlier rule, held it there (no fraction of a step lowered the sum of squares, rms
    0.18 mm against the truth's 0.002 mm), and 29 points out made a confident REJECT of a
    perfect part. The points beyond the fit's robust cut count as left out for the slide
    (engine.weak_search), and a better pose is kept even within the 1% that tells poses apart.
    Seed 1905 (bench_sweep --poses 3 --seed 900) was wrong so before any slide: REJECT 1.54 mm
    off, 6 points out."""
    res, (outcome, err) = _inspect_case("nist_ctc_03_asme1_ap242-e2.stp", "cover30", seed)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


def test_one_point_left_out_pins_a_sparse_patch_slid_along_its_free_direction():
    """CTC-03, 90 points on a 30% patch (seed 505, bench_sweep --points 300): the pose found was
    slid 6.9 mm along the patch's free direction, 89 points at the noise and one 1.06 mm off, a
    confident REJECT of a perfect part. That point lies on a face all along 18 mm of the slide,
    where the nominal's sample (a CAD tessellation's long facets) put it 2.4 mm off: the slide
    is scanned on the exact faces, with kept points that say where the patch leaves the part."""
    res, (outcome, err) = _inspect_case("nist_ctc_03_asme1_ap242-e2.stp", "cover30", 505, n=300)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)


def test_a_candidate_the_sample_ranked_below_the_runner_up_is_judged_on_the_exact_faces():
    """FTC-07 (AP242), 90 points on a 30% patch (seed 1505, bench_sweep --points 300): the
    registration carried a candidate 0.27 mm from the truth to its end, but the sample (a CAD
    tessellation's chordal error) ranked it below a pose 283 mm off (chosen, 4 points 1.2-3.7 mm
    out: a confident REJECT of a perfect part) and a runner-up 151 mm off; only those two were
    judged on the exact faces. Every candidate is now fitted and scored there too."""
    res, (outcome, err) = _inspect_case("nist_ftc_07_asme1_ap242-e2.stp", "cover30", 1505, n=300)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


@pytest.mark.parametrize("name, seed", [("nist_ctc_01_asme1_ap203.stp", 505),
                                        ("nist_ftc_06_asme1_ap242-e1.stp", 3505)])
def test_a_sparse_patch_without_a_planar_neighbourhood_is_found(name, seed):
    """90 points on a 30% patch (bench_sweep --points 300 --seed 500): no 8 neighbours of a point
    near the centroid lie on one face, so the reference normal the global search turns onto
    the nominal's was 37-88 degrees off, no start came within 20 mm of the truth, and the
    answers were confident REJECTs 23 mm (CTC-01, 30 points out) and 30 mm (FTC-06, 66 points
    out) off. A patch also gets evenly spread rotations at every anchor. The score reported is
    the exact one: CTC-01's was the sample's at the handover pose, 1.29 mm."""
    res, (outcome, err) = _inspect_case(name, "cover30", seed, n=300)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003 and res.registration.score < 0.01


@pytest.mark.parametrize("name, seed", [("nist_ctc_01_asme1_ap242-e1.stp", 2705),
                                        ("nist_ftc_06_asme1_ap242-e1.stp", 2705)])
def test_a_sparse_patch_far_from_every_anchor_is_found(name, seed):
    """90 points on a 30% patch (bench_sweep --defects cover30 --poses 10 --points 300 --seed
    1700): the normal-aligned starts put the reference point on anchors one per tenth of the
    measured extent, and the nearest with its normal lay 27 mm (CTC-01, a 500 mm patch) and
    36 mm (FTC-06) from its true place; no start came within 20 mm, and the answers were
    confident REJECTs 275 and 129 mm off, 85 and 90 of 90 points out. A patch whose best pose
    leaves the typical point out of the zone (score over the zone's width) is searched again
    with anchors one per twentieth."""
    res, (outcome, err) = _inspect_case(name, "cover30", seed, n=300)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


@pytest.mark.parametrize("seed", [2705, 7705, 6705, 6305, 12555])
def test_a_patch_resting_a_few_millimetres_off_is_found_where_its_left_out_points_fit(seed):
    """CTC-03, 90 points on a 30% patch (bench_sweep --defects cover30 --poses 10 --points 300
    --seed 1700), each a confident REJECT of a perfect part at a pose where every point but
    two to four fits at the noise, no direction free:
    * seed 2705, 1.9 mm off along a thin wall's normal: five points of its one side fitted its
      other side (unsigned distances fit both), two points of the next face 1.91 mm off. The
      pose jumped along those points' normals by their deviation fits all 90;
    * seed 7705, 3.5 mm off along the extrusion, held there by one point that lands on a side
      face: a grid of shifts, scored on the exact faces, finds the truth;
    * seed 6705, 7.5 mm off along the extrusion, which the scan along it did not bring home:
      the shift does;
    * seed 6305 (the same with --seed 2300), 6.6 mm off, 3 points out: the shift brings it
      within 1.2 mm, where a direction is weak, and the slide home (two rounds);
    * seed 12555 (--seed 3550), 1.97 mm off along a wall's normal, one side of the wall fitted
      on its other side, 10 points out: the truth's basin, 0.3 mm wide, lay between the grid's
      places, 0.74 mm apart; the places along the left-out points' normals, 0.14 mm apart,
      find it."""
    res, (outcome, err) = _inspect_case("nist_ctc_03_asme1_ap242-e2.stp", "cover30", seed, n=300)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003



@pytest.mark.parametrize("name, seed", [("nist_ctc_03_asme1_ap242-e2.stp", 11305),
                                        ("nist_ctc_01_asme1_ap242-e1.stp", 9455)])
def test_a_runner_up_near_the_truth_is_searched_from(name, seed):
    """CTC-03, 90 points on a 30% patch (seed 11305, bench_sweep --defects cover30 --poses 10
    --points 300 --seed 2300): the pose chosen lay 313 mm off (a confident REJECT of a perfect
    part, 6 points out, 0.052 mm exactly), its runner-up 0.49 mm from the truth; the sample
    scored that one 0.174 mm (a tessellation's chordal error), so it was never fitted on the
    exact faces. CTC-01 (AP242), seed 9455 (--seed 4450): the pose 643 mm off, 8 points out,
    0.096 mm; the runner-up 3.25 mm from the truth but 13 x worse, 1.30 mm. When the pose leaves
    points out, the runner-up is fitted and searched from too, however it scores, and it fits
    all 90 at the noise."""
    res, (outcome, err) = _inspect_case(name, "cover30", seed, n=300)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


def test_a_candidate_near_the_truth_is_not_dropped_for_the_chosen_pose_s_finish():
    """CTC-05 (AP203), 90 points on a 30% patch (seed 11305, bench_sweep --defects cover30
    --poses 10 --points 300 --seed 2300): a candidate 1.0 mm from the truth reached the final
    fit at 0.231 mm on the sample (a tessellation's chordal error), the pose chosen 400 mm off
    at 0.394 mm; finished, the chosen one scored 0.067 mm, and the candidates kept for the exact
    faces were those within 3 x that: the near one was dropped, and the answer was a confident
    REJECT, 1 point out. Candidates within 3 x the chosen pose's score before its finish are
    kept too."""
    res, (outcome, err) = _inspect_case("nist_ctc_05_asme1_ap203.stp", "cover30", 11305, n=300)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


def test_candidates_that_stall_on_a_few_points_are_fitted_on_every_point():
    """CTC-05 (AP242), 600 points on a 30% patch (seed 8855, bench_sweep --poses 3 --seed
    8850): the pose chosen lay 372 mm off (a confident REJECT of a perfect part, 19 points
    out, 0.051 mm exactly), and two candidates 28.5 and 20.6 mm off, fitted on the screen's 128
    points, stalled 27.4 and 15.2 mm off (0.17 and 0.14 mm), so neither was taken further.
    Fitted on all 600, each comes home at the noise. When a patch's pose still calls points
    gross outliers, the other candidates are fitted on every point."""
    res, (outcome, err) = _inspect_case("nist_ctc_05_asme1_ap242-e1.stp", "cover30", 8855)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


def test_a_look_alike_under_the_zone_s_width_that_leaves_points_off_is_searched_again():
    """CTC-05 (AP242), 90 points on a 30% patch (seed 5555, bench_sweep --defects cover30
    --poses 10 --points 300 --seed 3550): no start came within 50 mm of the truth, and the
    pose chosen, a look-alike 402 mm off, fitted 85 of 90 points on the nominal's sample at
    0.072 mm, under the zone's width, so the search with denser anchors did not run: a
    confident REJECT of a perfect part, 2 points out. A patch whose pose still calls points
    gross outliers on the exact faces is searched again too; that search's answer, 0.2 mm from
    the truth, scores 0.0021 mm there against the look-alike's 0.036."""
    res, (outcome, err) = _inspect_case("nist_ctc_05_asme1_ap242-e1.stp", "cover30", 5555, n=300)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


def test_a_candidate_turned_about_a_hinge_of_points_at_the_noise_comes_home():
    """FTC-08 (AP242), 90 points on a 30% patch (seed 5455, bench_sweep --defects cover30
    --poses 10 --points 300 --seed 4450): the pose chosen lay 279 mm off (a confident REJECT of
    a perfect part, 12 points out, 0.054 mm exactly); its one candidate near the truth, 1.53 mm
    off, fitted on every point, rested 1.33 mm off at 0.25 mm: turned 2 degrees, a flange's
    underside on its top face, no point beyond its robust cut (2.4 mm), so nothing said where
    to look. Its 12 points at the pose's noise lie along a hinge; turned about it a short way,
    it comes home."""
    res, (outcome, err) = _inspect_case("nist_ftc_08_asme1_ap242-e1.stp", "cover30", 5455, n=300)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


def test_a_nearly_symmetric_part_s_twin_pose_is_turned_back():
    """CTC-05 (AP203), 90 points on a 30% patch (seed 7855, bench_sweep --defects cover30
    --poses 10 --points 300 --seed 6850): the pose chosen was the truth turned 180 degrees about
    the part's z axis, a near-symmetry: 89 points at the noise and one, on the feature that
    breaks the symmetry, 2.65 mm off (a confident REJECT of a perfect part). No candidate lay
    near the truth. Turned half way back about the z axis through the nominal's bounding-box
    centre, the pose lands on the truth and fits all 90."""
    res, (outcome, err) = _inspect_case("nist_ctc_05_asme1_ap203.stp", "cover30", 7855, n=300)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


def test_a_patch_slid_along_a_free_direction_that_every_point_s_basis_mixes_is_slid_home():
    """CTC-03, 90 points on a 30% patch (seed 13855, bench_sweep --defects cover30 --poses 10
    --points 300 --seed 6850): the pose 3.6 mm off along y, which the 89 points at the noise
    leave free, and one point 3.15 mm off (a confident REJECT of a perfect part). The kept
    points' weak directions are that slide and a turn about z; every point's basis mixes them
    into two screws, each scanned alone, and the truth, a pure slide, lies on neither. Scanned
    along the kept points' own directions too, the slide comes home."""
    res, (outcome, err) = _inspect_case("nist_ctc_03_asme1_ap242-e2.stp", "cover30", 13855, n=300)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


@pytest.mark.parametrize("seed, noise", [(5105, 0.01), (16855, 0.002)])
def test_a_thin_wall_s_wrong_side_is_found_along_the_direction_the_kept_points_leave_weakest(
        seed, noise):
    """CTC-03, 90 points on a 30% patch, the pose about 1.9 mm off along x, one side of a thin
    wall fitted on its other side, few points on faces facing x:
    * seed 5105 with 10 µm noise (bench_sweep --noise 0.01 --poses 2 --points 300 --seed
      4100): 2 of the 86 points kept face x, and the 4 left out lie on faces whose normals
      point 14-76 degrees from x, so neither the grid (places 1.25 mm apart) nor the lines
      along their normals reach the truth's basin (0.25 mm wide);
    * seed 16855 (--defects cover30 --poses 10 --points 300 --seed 8850), 1.94 mm off, the 2
      points left out 0.09 and 0.13 mm off: the grid reached 0.26 mm.
    The line along the direction the kept points constrain least, out to 2 % of the nominal's
    diagonal, finds it."""
    res, (outcome, err) = _inspect_case("nist_ctc_03_asme1_ap242-e2.stp", "cover30", seed, n=300,
                                        noise=noise)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 1.2 * noise


def test_the_second_search_s_runner_up_is_fitted_on_the_exact_faces_too():
    """FTC-07, 90 points on a 30% patch with 10 µm noise (seed 12705, bench_sweep --noise 0.01
    --defects cover30 --poses 10 --points 300 --seed 4700): the pose 10.2 mm off, two points
    1.1 and 4.4 mm off (a confident REJECT of a perfect part); a candidate 5.4 mm off stalls
    there fitted. The search with denser anchors chose the same pose on the sample and ranked
    one 0.06 mm from the truth second (the sample's chordal error); fitted exactly, that one
    comes home."""
    res, (outcome, err) = _inspect_case("nist_ftc_07_asme1_ap242-e2.stp", "cover30", 12705,
                                        n=300, noise=0.01)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.012


@pytest.mark.parametrize("seed", [12601, 12604])
def test_a_look_alike_one_pocket_away_is_found_where_the_point_left_out_crosses_a_face(seed):
    """FTC-07, 90 points on a 15% patch (bench_sweep --defects cover15 --poses 5 --points 600
    --seed 12600): the pose 15.0 mm (seed 12601) and 14.8 mm (12604) off along x, a pocket's
    look-alike, every point at the noise but one or two 2-4.6 mm off (a confident REJECT of a
    perfect part). At most one kept point faces x; the truth's basin is 0.5 mm wide, and the
    lines and the grid reached 8.1 mm. Along that direction the point left out crosses a face
    at the truth."""
    res, (outcome, err) = _inspect_case("nist_ftc_07_asme1_ap242-e2.stp", "cover15", seed,
                                        n=600)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


def test_a_look_alike_along_an_axis_the_kept_points_leave_weakest_but_one_degree_off():
    """CTC-03, 90 points on a 15% patch (seed 13600, bench_sweep --defects cover15 --poses 5
    --points 600 --seed 13600) came to rest 20.7 mm off along y, three points 0.29-0.5 mm off
    (a confident REJECT of a perfect part). The kept points constrain least a direction 1
    degree off y: a point left out crosses its face 20.75 mm along it, 0.35 mm off along x,
    which the kept points pin. From that pose the search hands back the place refined to where
    its points fit best, within 0.01 mm of the truth (unrefined: 0.11 mm); inspected from its
    arbitrary pose, the patch is right."""
    from engine.pose import make_transform
    from engine.weak_search import shifted_poses

    part = read_step(os.path.join(DATA, "nist_ctc_03_asme1_ap242-e2.stp"))
    case = make_case(part, "cover15", seed=13600, n=600, noise=0.002)
    nominal = Nominal.from_point_set(part.point_set)
    surface = ExactDistances(part, nominal)
    M, R, t = case["measured"], case["R"], case["t"]
    T_true = make_transform(R.T, -R.T @ t)
    T = make_transform(np.eye(3), [0.0, 20.742, 0.0]) @ T_true
    dev = surface.deviations(apply_transform(T, M))
    kept = np.abs(dev.signed) <= TOL
    assert np.count_nonzero(~kept) == 3
    off = [np.sqrt(np.mean(np.sum((apply_transform(P, M) - apply_transform(T_true, M)) ** 2, 1)))
           for P in shifted_poses(nominal, M, T, dev, kept, surface, 1e-4 * nominal.diagonal)]
    assert min(off) < 0.01, off

    res, (outcome, err) = _inspect_case("nist_ctc_03_asme1_ap242-e2.stp", "cover15", 13600,
                                        n=600)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


def test_a_third_turn_of_a_twin_pair_that_fits_better_is_found():
    """CTC-05 (AP203), 90 points on a 15% patch (seed 19601, bench_sweep --defects cover15
    --poses 5 --points 600 --seed 19600): the pose and its runner-up, 150 and 30 degrees about
    z from the truth on a rim of features 30 degrees apart, tie at 3.26 µm; every point fits
    within 0.014 mm, so nothing is left out to search from, and the deviations were up to
    0.0136 mm off the truth's (ACCEPT, but at a wrong pose). The truth, 1.94 µm, lies on the
    turn about the axis between the twins."""
    res, (outcome, err) = _inspect_case("nist_ctc_05_asme1_ap203.stp", "cover15", 19601, n=600)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.0025


def test_a_look_alike_along_the_frame_axis_nearest_the_weakest_direction_is_found():
    """FTC-07, 90 points on a 10% patch (seed 25001, bench_sweep --defects cover10 --poses 5
    --points 900 --seed 25000): the pose 56.9 mm off along x, one point 1.13 mm off (a
    confident REJECT of a perfect part). The kept points constrain x and y weakly (0.66 and
    3.66 of 84.7), and their weakest direction is 8.6 degrees off x: walked 57 mm along it, the
    point left out passes 8.5 mm beside its face. Along x, the nominal's axis nearest it, the
    point crosses its face at the truth."""
    res, (outcome, err) = _inspect_case("nist_ftc_07_asme1_ap242-e2.stp", "cover10", 25001,
                                        n=900)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


def test_a_pose_that_leaves_a_fifth_of_a_patch_out_as_gross_outliers_is_not_trusted():
    """CTC-01 (AP242), 90 points on a 10% patch of a perfect part (seed 25004, bench_sweep
    --defects cover10 --poses 5 --points 900 --seed 25000): the search never started near the
    truth, and its best pose, 313 mm off, fit 62 points within 0.017 mm and left 21 out as gross
    outliers, 0.1-16 mm off: a confident REJECT of a perfect part. Mis-probes are rarer than a
    tenth of the points (engine.verdict.MAX_LEFT_OUT_FRACTION): such a pose is not trusted, and
    the answer is INCONCLUSIVE, saying why, unless the right pose is found (as it is since the
    denser search iterates on 64 points; tests/test_gross_outliers.py and test_trust.py hold
    the rule itself)."""
    res, (outcome, err) = _inspect_case("nist_ctc_01_asme1_ap242-e1.stp", "cover10", 25004,
                                        n=900)
    assert outcome in ("right", "INCONCLUSIVE"), (outcome, err, res.reasons)
    if outcome == "INCONCLUSIVE":
        assert any("as gross outliers" in r for r in res.reasons), res.reasons


@pytest.mark.parametrize("name, defect, seed, n", [
    ("nist_ctc_03_asme1_ap242-e2.stp", "cover15", 14604, 600),
    ("nist_ctc_03_asme1_ap242-e2.stp", "cover10", 20002, 900),
    ("nist_ftc_07_asme1_ap242-e2.stp", "cover10", 23000, 900)])
def test_the_denser_search_iterates_on_enough_points_to_see_what_tells_look_alikes_apart(
        name, defect, seed, n):
    """90 points on 10-15% of a perfect part (bench_sweep --defects cover15 --poses 5 --points
    600 --seed 14600; --defects cover10 --points 900 --seed 20000 and 23000): confident REJECTs
    103, 109 and 166 mm off. The search with denser anchors had starts 6 mm from the truth, but
    its ICP, on 16 then 32 spread points, slid them along the near-planar rest of the patch to
    58-67 mm off: the few points on a pocket's wall or a 1-2 mm step were not among them. It
    iterates on 32 then 64 (RegistrationSettings.patch_measured)."""
    res, (outcome, err) = _inspect_case(name, defect, seed, n=n)
    assert outcome == "right", (outcome, err, res.reasons)


@pytest.mark.parametrize("defect, seed, n", [("cover10", 26003, 900), ("cover15", 27002, 600)])
def test_every_candidate_of_the_denser_search_is_fitted_on_the_exact_faces(defect, seed, n):
    """FTC-07, 90 points on 10-15% of a perfect part (bench_sweep --defects cover10 --poses 5
    --points 900 --seed 26000; --defects cover15 --points 600 --seed 27000): confident REJECTs
    150 and 242 mm off. The search with denser anchors found poses 0.07 and 6.2 mm from the
    truth, but the sample's chordal error ranked them below its answer and runner-up, and only
    those two were fitted on the exact faces; its other candidates are now fitted too."""
    res, (outcome, err) = _inspect_case("nist_ftc_07_asme1_ap242-e2.stp", defect, seed, n=n)
    assert outcome == "right", (outcome, err, res.reasons)


def test_a_runner_up_whose_kept_points_fit_tighter_than_the_pose_s_is_searched_from():
    """CTC-03, 90 points on a 10% patch of a perfect part (seed 26004, bench_sweep --defects
    cover10 --poses 5 --points 900 --seed 26000): a confident ACCEPT at a look-alike 393 mm
    off, every point within 0.038 mm, rms 0.0046 mm, so none left out and no search ran. Its
    runner-up, 4.8 mm from the truth, fitted 89 points at 0.0021 mm and left one out 0.6 mm
    off: slid along the patch's plane. A runner-up whose kept points fit 1.5 x tighter than
    the pose's, while it leaves points out, is searched from too; the one point slides it
    home."""
    res, (outcome, err) = _inspect_case("nist_ctc_03_asme1_ap242-e2.stp", "cover10", 26004,
                                        n=900)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
    assert res.registration.rms < 0.003


@pytest.mark.parametrize("defect, seed, n", [("cover10", 26000, 900), ("cover15", 19600, 600)])
def test_a_look_alike_among_many_is_left_for_the_truth_near_a_candidate(defect, seed, n):
    """FTC-07, 90 points on 10-15% of a perfect part (bench_sweep --defects cover10 --poses 5
    --points 900 --seed 26000; --defects cover15 --points 600 --seed 19600): confident REJECTs
    136 and 165 mm off, one point out. The part repeats its pockets: a dozen candidates fit 87-89
    of the points at the noise, none the truth. Near one of them (26000: the third best, 8.2 mm
    off along x, 3 points out; 19600: the sixth best) the shifts where a point left out crosses
    a face come home."""
    res, (outcome, err) = _inspect_case("nist_ftc_07_asme1_ap242-e2.stp", defect, seed, n=n)
    assert outcome == "right" and res.verdict == "ACCEPT", (outcome, err, res.reasons)
