"""Inspection plans on measurements that do not determine what the plan asks (a red-team
review's findings): the answer is INCONCLUSIVE or a clear refusal, never a wrong value. The seat
bracket sample is edited in its nominal frame (its truth.json pose) and written back in the
machine pose."""

import json
import os

import numpy as np
import pytest

from qa_app.cli import main

HERE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "samples",
                    "seat_bracket")


def bracket(tmp_path, edit=None, plan_edit=None, name="m.csv"):
    """The seat bracket's measured file edited by edit(points in the nominal frame (n, 3),
    labels) -> (points, labels), and its plan edited by plan_edit(text) -> text; returns
    (measured path, plan path)."""
    with open(os.path.join(HERE, "truth.json")) as f:
        T = np.asarray(json.load(f)["T_nominal_measured"])
    with open(os.path.join(HERE, "measured.csv")) as f:
        rows = [r.split(",") for r in f.read().splitlines() if r and not r.startswith(("#", "id"))]
    labels = [r[0] for r in rows]
    M = np.array([[float(v) for v in r[1:]] for r in rows])
    P = M @ T[:3, :3].T + T[:3, 3]
    if edit is not None:
        P, labels = edit(P, labels)
    Ti = np.linalg.inv(T)
    M = P @ Ti[:3, :3].T + Ti[:3, 3]
    path = tmp_path / name
    path.write_text("id,x,y,z\n" + "".join(f"{l},{p[0]:.6f},{p[1]:.6f},{p[2]:.6f}\n"
                                           for l, p in zip(labels, M)))
    with open(os.path.join(HERE, "plan.toml")) as f:
        text = f.read()
    plan = tmp_path / "plan.toml"
    plan.write_text(plan_edit(text) if plan_edit else text)
    return str(path), str(plan)


def run(tmp_path, measured, plan, *extra):
    out = tmp_path / "r.json"
    code = main(["inspect", os.path.join(HERE, "nominal.xyz"), measured, "--plan", plan,
                 "--json", str(out), *extra])
    doc = json.loads(out.read_text()) if out.exists() else None
    return code, doc, None if doc is None else {c["id"]: c for c in doc["characteristics"]}


def test_points_at_a_datum_face_edge_join_their_own_face(tmp_path):
    """A point on the bottom 0.3 mm from the back face lies inside datum B's box, and a point on
    the back 0.45 mm above the bottom inside A's: each joins the face it lies on (the boxes'
    strips of the neighbouring faces are not their plane), so datums, flatness and position are
    what they are without them, within the datum faces' 1.5 um probing noise (the two exact
    points may become the planes' high points)."""
    def edit(P, labels):
        return np.vstack([P, [[0.3, 20.0, 0.0], [0.0, 20.0, 0.45]]]), labels + ["E1", "E2"]

    base = run(tmp_path, *bracket(tmp_path))[2]
    code, doc, c = run(tmp_path, *bracket(tmp_path, edit, name="e.csv"))
    for i in "345":
        assert c[i]["value"] == pytest.approx(base[i]["value"], abs=3e-3), i
    assert [d["n_points"] for d in doc["alignment"]["datums"]] == [17, 13, 12]


def test_a_datum_probed_along_a_line_does_not_place_the_part(tmp_path):
    """Datum A's 16 points all on the line y = 30: its tilt about that line is not measured. The
    characteristics relative to A|B|C are INCONCLUSIVE (the alignment says why), not judged at
    a pose fitted to noise; form-only ones still stand."""
    def edit(P, labels):
        a = np.array([l in {f"P{i}" for i in range(121, 137)} for l in labels])
        P[a, 1] = 30.0
        return P, labels

    code, doc, c = run(tmp_path, *bracket(tmp_path, edit))
    assert (c["1"]["verdict"], c["4"]["verdict"]) == ("INCONCLUSIVE", "INCONCLUSIVE")
    assert "do not determine" in c["1"]["reason"] and c["2"]["verdict"] == "ACCEPT"
    assert not doc["alignment"]["complete"] and code == 2


def test_flatness_of_points_along_a_line_is_inconclusive(tmp_path):
    """The bottom probed along y = 30 only, with 0.03 mm of waviness: the points do not
    determine a plane (a minimum zone would turn to contain the line, width 0)."""
    def edit(P, labels):
        a = np.array([l in {f"P{i}" for i in range(121, 137)} for l in labels])
        P[a, 1] = 30.0
        P[a, 2] = -0.015 * (1 + np.sin(P[a, 0] / 7.0))
        return P, labels

    c = run(tmp_path, *bracket(tmp_path, edit))[2]
    assert c["3"]["verdict"] == "INCONCLUSIVE" and "along a line" in c["3"]["reason"]


def test_a_gross_defect_stays_in_its_region(tmp_path):
    """One skin point 2 mm proud: the form profile of the skin rejects it (it once fell out of
    the region for lying farther than 1% of the part's size from the surface)."""
    def edit(P, labels):
        P[10] += 2.0 * np.array([0.0, 0.0, 1.0])  # P011 on the flange top, proud
        return P, labels

    code, doc, c = run(tmp_path, *bracket(tmp_path, edit))
    assert c["2"]["n_points"] == 100 and c["2"]["verdict"] == "REJECT"
    assert c["2"]["value"] > 3.0 and code == 1


def test_a_position_whose_datums_leave_the_hole_free_is_refused(tmp_path):
    """Position relative to A alone: the bottom plane leaves the hole free to slide; the plan
    is refused (65) naming the plan, the characteristic and the freedom."""
    plan_edit = (lambda t: t.replace('zone = 0.1\ndatums = ["A", "B", "C"]',
                                     'zone = 0.1\ndatums = ["A"]'))
    code, doc, _ = run(tmp_path, *bracket(tmp_path, plan_edit=plan_edit))
    assert code == 65 and doc is None


def test_a_hole_probed_on_a_narrow_arc_is_inconclusive(tmp_path):
    """The hole's 16 points moved onto a 45-degree arc of its wall: its axis is not determined
    (a least-squares cylinder turns about 45 degrees); size and position are INCONCLUSIVE."""
    def edit(P, labels):
        h = np.array([l in {f"P{i}" for i in range(149, 165)} for l in labels])
        ang = np.linspace(0, np.pi / 4, h.sum())
        r = 4.005 + np.random.default_rng(1).normal(0, 0.001, h.sum())
        P[h, 0] = 64.02 + r * np.cos(ang)
        P[h, 1] = 29.985 + r * np.sin(ang)
        return P, labels

    c = run(tmp_path, *bracket(tmp_path, edit))[2]
    assert (c["4"]["verdict"], c["5"]["verdict"]) == ("INCONCLUSIVE", "INCONCLUSIVE")
    assert "do not determine the hole" in c["5"]["reason"]


def test_a_plan_without_characteristics_and_without_a_zone_is_refused(tmp_path):
    plan_edit = (lambda t: t[:t.index("[[characteristic]]")])
    measured, plan = bracket(tmp_path, plan_edit=plan_edit)
    code = main(["inspect", os.path.join(HERE, "nominal.xyz"), measured, "--plan", plan])
    assert code == 65
