"""A defect on one feature of a part inspected with its QIF plan (issue 25): points sampled on
the NIST CTC-01 part's exact B-rep faces (tests/data/step, its QIF in tests/data/qif), a random
pose, 0.1 µm noise, then one feature moved, enlarged or tilted past its tolerance. Exactly the
characteristics on that feature REJECT, with the value the planted defect gives; a moved datum
feature REJECTs only characteristics whose datum reference frame uses it. The faces of each
feature are named here from the part's geometry (the normals printed below), and checked
against the faces the plan mapped. A characteristic whose verdict rests on which of two faces
some points were measured on is INCONCLUSIVE, saying both (engine.step_model.face_rivals)."""

import json
import os
import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from qa_app.cli import main

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
QIF = os.path.join(DATA, "qif", "NISTmodels__nist_ctc_01_asme1_ap242.qif")
STP = os.path.join(DATA, "step", "nist_ctc_01_asme1_ap242-e1.stp")
# CTC-01's features (B-rep face ids), with the characteristics the QIF puts on them.
SLOT_X = ("qif:2159", (38, 42))   # a slot whose faces face -x and +x: position 1443 (⌀0.75)
HOLE_20 = ("qif:2175", (53, 54))  # a ⌀20 -0.1/+0.05 hole: size 1479 only
WALL = ("qif:2162", (25,))        # a side wall, normal +x: perpendicularity 1467 to A (1.5)
DATUM_B = ("qif:2156", (90, 91))  # datum B, a ⌀35 hole: size 1473 (on its limit)
DATUM_A = ("qif:2154", (98,))     # datum A, the plate's top: flatness 1470 (0.2)
ANGLE = (("qif:2180/1296", (18,)), ("qif:2180/1314", (16,)))  # the two faces of the 60° angle
# (QIF feature 2180, opposite angled planes): angle 1491, 60° ±0.5°


@pytest.fixture(scope="module")
def planted():
    """(points (n, 3) on the exact faces, outward normals, face ids, the measured frame's R, t),
    nominal frame, 0.1 µm of noise along the normals."""
    from engine.io.step import read_step
    from step_models import random_pose
    from sweep import on_part

    step = read_step(STP)
    rng = np.random.default_rng(7)
    P, N, F = on_part(step, rng, 12000)
    P = P + rng.normal(0.0, 1e-4, len(P))[:, None] * N
    R, t = random_pose(11)
    return P, N, np.asarray(F), R, t


def inspect(tmp_path, P, R, t) -> dict:
    np.savetxt(tmp_path / "m.csv", P @ R.T + t, delimiter=",", header="x,y,z", comments="",
               fmt="%.9f")
    main(["inspect", STP, str(tmp_path / "m.csv"), "--plan", QIF, "--json",
          str(tmp_path / "r.json"), "--quiet"])
    return json.loads((tmp_path / "r.json").read_text())


def rejected(doc) -> dict:
    """{id: value} of the REJECTed characteristics, less sizes planted on a limit (CTC-01's
    ⌀35 -0.2/+0: 0.1 µm of noise puts it on either side, and the result says so)."""
    out = {}
    for c in doc["characteristics"]:
        if c["verdict"] != "REJECT":
            continue
        on_limit = c["type"] == "size" and min(abs(c["lower"]), abs(c["upper"])) == 0.0 \
            and abs(c["value"] - c["nominal"]) < 1e-4
        if not on_limit:
            out[c["id"]] = c["value"]
    return out


def in_doubt(doc) -> dict:
    """{id: reason} of the INCONCLUSIVE characteristics."""
    return {c["id"]: c["reason"] for c in doc["characteristics"]
            if c["verdict"] == "INCONCLUSIVE"}


def faces_mapped(doc, feature) -> None:
    region, faces = feature
    assert sorted(doc["plan_faces"]["regions"][region]) == sorted(faces)


def test_a_slot_moved_past_its_position_tolerance_rejects_its_position_only(tmp_path, planted):
    P, N, F, R, t = planted
    on = np.isin(F, SLOT_X[1])
    assert np.allclose(np.abs(N[on][:, 0]), 1.0)  # the slot's width runs along x
    moved = P.copy()
    moved[on, 0] += 1.0
    doc = inspect(tmp_path, moved, R, t)
    faces_mapped(doc, SLOT_X)
    # Its centre plane 1 mm off: a position zone of width 2 x 1 mm.
    assert rejected(doc) == {"1443": pytest.approx(2.0, abs=0.01)}
    assert in_doubt(doc) == {}


def test_a_hole_enlarged_past_its_size_rejects_its_size_only(tmp_path, planted):
    P, N, F, R, t = planted
    on = np.isin(F, HOLE_20[1])
    bigger = P.copy()
    bigger[on] -= 0.1 * N[on]  # the outward normal of a hole's wall points at its axis
    doc = inspect(tmp_path, bigger, R, t)
    faces_mapped(doc, HOLE_20)
    assert rejected(doc) == {"1479": pytest.approx(20.2, abs=0.001)}
    assert in_doubt(doc) == {}


def test_a_datum_feature_moved_rejects_only_what_its_frame_locates(tmp_path, planted):
    """Datum B moved 1 mm along x: the slot across x, located from B, is 1 mm off (a zone of
    about 2 mm); whatever else REJECTs uses B in its datum reference frame."""
    P, N, F, R, t = planted
    moved = P.copy()
    moved[np.isin(F, DATUM_B[1]), 0] += 1.0
    doc = inspect(tmp_path, moved, R, t)
    faces_mapped(doc, DATUM_B)
    using_b = {c["id"] for c in doc["characteristics"]
               if any("B" in d for d in c["datums"] or ())}
    out = rejected(doc)
    assert "1443" in out and out["1443"] == pytest.approx(2.0, abs=0.05)
    assert set(out) <= using_b, (out, using_b)
    assert set(in_doubt(doc)) <= using_b | {"1470"}  # A's flatness: the hole's points, below


def test_a_wall_tilted_past_its_perpendicularity_rejects_that_and_puts_its_edge_in_doubt(
        tmp_path, planted):
    """The wall (normal +x) turned about y through its centre until its edges are 3 mm off: its
    perpendicularity to A REJECTs with the zone the turn gives. Datum A is untouched, but the
    wall's points near their shared edge now lie nearer A's face than their own: they fit the
    wall as its other points show it moved, and A's flatness with them is 1.56 mm, without them
    0.0006 mm. It is INCONCLUSIVE, saying so, never REJECT (it was REJECT, 1.56 mm)."""
    P, N, F, R, t = planted
    on = np.isin(F, WALL[1])
    c = P[on].mean(axis=0)
    lever = float(np.max(np.abs(P[on, 2] - c[2])))
    turned = P.copy()
    turned[on] = (P[on] - c) @ Rotation.from_rotvec([0.0, -3.0 / lever, 0.0]).as_matrix().T + c
    doc = inspect(tmp_path, turned, R, t)
    faces_mapped(doc, WALL)
    faces_mapped(doc, DATUM_A)
    out = rejected(doc)
    assert set(out) == {"1467"}, out
    # The wall's x now spans the turn x its height: the zone perpendicular to A holding it.
    assert out["1467"] == pytest.approx(3.0 / lever * np.ptp(P[on, 2]), rel=0.03)
    doubt = in_doubt(doc)
    assert set(doubt) == {"1470"}, doubt
    assert re.search(r"near another face as their own \(faces? (\d+, )*25\b", doubt["1470"])
    assert "judged with them REJECT" in doubt["1470"]
    assert "without them ACCEPT" in doubt["1470"]
    assert doc["verdict"] == "REJECT"


def test_an_angle_face_turned_past_its_limit_rejects_that_angle_only(tmp_path, planted):
    """One face of CTC-01's 60° ±0.5° angle turned by 1.0° (0.5° past its limit) about the
    line the two faces' normals are both square to, through its centre: the angle 1491
    REJECTs, its value the angle between the first face's normal and the second's turned
    (computed here from the planted normals), and nothing else does."""
    P, N, F, R, t = planted
    a, b = (np.isin(F, faces) for _, faces in ANGLE)
    na, nb = (N[m].mean(axis=0) / np.linalg.norm(N[m].mean(axis=0)) for m in (a, b))
    assert np.degrees(np.arccos(abs(na @ nb))) == pytest.approx(60.0, abs=1e-6)
    axis = np.cross(na, nb) / np.linalg.norm(np.cross(na, nb))
    turn = Rotation.from_rotvec(np.radians(1.0) * axis).as_matrix()
    c = P[b].mean(axis=0)
    turned = P.copy()
    turned[b] = (P[b] - c) @ turn.T + c
    doc = inspect(tmp_path, turned, R, t)
    for feature in ANGLE:
        faces_mapped(doc, feature)
    expected = float(np.degrees(np.arccos(abs(na @ (turn @ nb)))))
    assert abs(expected - 60.0) == pytest.approx(1.0, abs=1e-9)
    assert rejected(doc) == {"1491": pytest.approx(expected, abs=1e-3)}
    angle = next(c for c in doc["characteristics"] if c["id"] == "1491")
    assert angle["unit"] == "degree" and "°" in angle["reason"], angle
    assert in_doubt(doc) == {}
    assert doc["verdict"] == "REJECT"


def test_faces_within_a_reach_are_every_face_opencascade_puts_there(planted):
    """StepNominal.faces_within against its naive twin: OpenCascade's distance from each point
    to every face of the part, one at a time: planted points moved off their faces by up to
    2 mm, reaches of 2-8 mm (faces round an edge, a hole, a corner)."""
    from engine.io.step import read_step

    step = read_step(STP)
    P, N, F, _, _ = planted
    rng = np.random.default_rng(3)
    pick = rng.choice(len(P), 80, replace=False)
    X = P[pick] + rng.uniform(-2.0, 2.0, (80, 1)) * N[pick]
    own = step.deviations(X)[3]
    reach = rng.uniform(2.0, 8.0, 80)
    pairs, dist = step.faces_within(X, reach, own, lambda f, g: np.ones(len(f), bool))
    got = {(int(i), int(g)): d for (i, g), d in zip(pairs, dist)}
    truth = {}
    for g in range(1, step.n_faces + 1):
        d = step.face_distances(g, X)
        for i in np.flatnonzero((d <= reach) & (own != g)):
            truth[(int(i), g)] = d[i]
    assert len(truth) >= 15 and set(got) == set(truth)
    for key, d in truth.items():
        assert got[key] == pytest.approx(d, abs=1e-7)
