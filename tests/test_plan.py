"""Inspection plans end to end (engine.gdt.characteristics over the real registration): a block with a
sloped skin and a hole, measured in a random pose with planted deviations, judged by datums,
against analytic truth and independent linear programs."""

import os

import numpy as np
import pytest

from engine.gdt.characteristics import inspect_plan
from engine.pose import make_transform, rotation_from_rotvec
from engine.inspection import Tolerance, inspect
from engine.nominal import Nominal
from engine.gdt.plan import (Alignment, Characteristic, Datum, Part, Plan, Region, RpsPoint)
from engine.pointset import PointSet
from engine.verdict import ACCEPT, INCONCLUSIVE, REJECT
from naive import rigid_motion
from plan_runs import by_id

# A block [0, 100] x [0, 60] x [0, top(x)] with a sloped top ("skin") z = 20 + 0.1 x and a
# vertical through hole of radius 4 at (64, 30). Outward normals.
SLOPE, HOLE_XY, HOLE_R = 0.1, np.array([64.0, 30.0]), 4.0


def top(x):
    return 20.0 + SLOPE * x


def _outside_hole(p):
    return np.linalg.norm(p[:, :2] - HOLE_XY, axis=1) > HOLE_R


def sample_face(face, k, rng, margin=0.0):
    """(k, 3) points and (k, 3) outward normals on a face; ``margin`` keeps them off edges."""
    m = margin
    u, v = rng.uniform(m, 1 - m, (2, 4 * k))
    if face == "A":
        p = np.column_stack([100 * u, 60 * v, 0 * u])
        n = [0, 0, -1.0]
    elif face == "B":
        p = np.column_stack([0 * u, 60 * v, top(0) * u])
        n = [-1.0, 0, 0]
    elif face == "C":
        x = 100 * u
        p = np.column_stack([x, 0 * u, top(x) * v])
        n = [0, -1.0, 0]
    elif face == "D":  # the other end, y = 60
        x = 100 * u
        p = np.column_stack([x, 60 + 0 * u, top(x) * v])
        n = [0, 1.0, 0]
    elif face == "E":  # x = 100
        p = np.column_stack([100 + 0 * u, 60 * v, top(100) * u])
        n = [1.0, 0, 0]
    elif face == "skin":
        x = 100 * u
        p = np.column_stack([x, 60 * v, top(x)])
        n = np.array([-SLOPE, 0, 1.0]) / np.hypot(SLOPE, 1.0)
    else:  # the hole's wall, normals into the hole (the material is outside it)
        a = 2 * np.pi * u
        r = np.column_stack([np.cos(a), np.sin(a)])
        # Measured (m > 0): below the skin region's box (z >= 19.5), which cannot cut the
        # hole's top out.
        z = 2.0 + 16.0 * v if m else top(HOLE_XY[0] - HOLE_R) * v
        p = np.column_stack([HOLE_XY + HOLE_R * r, z])
        return p[:k], np.column_stack([-r, 0 * a])[:k]
    if face in ("A", "skin"):
        p = p[_outside_hole(p) & (np.linalg.norm(p[:, :2] - HOLE_XY, axis=1) > HOLE_R + 30 * m)]
    return p[:k], np.broadcast_to(np.asarray(n, float), (k, 3)).copy()


@pytest.fixture(scope="module")
def nominal():
    rng = np.random.default_rng(11)
    faces = {"A": 6000, "B": 1200, "C": 1500, "D": 1500, "E": 1200, "skin": 6000, "hole": 1500}
    P, N = zip(*(sample_face(f, k, rng) for f, k in faces.items()))
    return Nominal.from_point_set(PointSet(np.vstack(P), np.vstack(N)))


def measure(rng, counts, planted=None, hole_shift=(0.0, 0.0), hole_dr=0.0):
    """Measured points on faces (true part: nominal + planted excess along the normal; the hole
    moved and resized), their labels and faces, and the pose they are measured in."""
    planted = planted or {}
    P, faces = [], []
    for f, k in counts.items():
        p, n = sample_face(f, k, rng, margin=0.15)
        if f == "hole":
            r = p[:, :2] - HOLE_XY
            p[:, :2] = HOLE_XY + np.asarray(hole_shift) + r * (HOLE_R + hole_dr) / HOLE_R
        else:
            p = p + planted.get(f, 0.0) * n
        P.append(p)
        faces += [f] * k
    R = rotation_from_rotvec(rng.uniform(-np.pi, np.pi, (1, 3)))[0]
    T_measured_nominal = make_transform(R, rng.uniform(-400, 400, 3))
    P = np.vstack(P)
    M = P @ T_measured_nominal[:3, :3].T + T_measured_nominal[:3, 3]
    labels = np.array([f"{f}{i}" for i, f in enumerate(faces)])
    return M, labels, np.array(faces), P


REGIONS = (Region("A", box=((-1, -1, -0.5), (101, 61, 0.5))),
           Region("B", box=((-0.5, -1, -1), (0.5, 61, 40))),
           Region("C", box=((-1, -0.5, -1), (101, 0.5, 40))),
           Region("skin", box=((0.5, 0.5, 19.5), (99.5, 59.5, 31))),
           Region("hole", box=((59.5, 25.5, 1.0), (68.5, 34.5, 25.0))))
DATUMS = (Datum("A", "A", "plane"), Datum("B", "B", "plane"), Datum("C", "C", "plane"))


def plan_of(*characteristics, alignment=Alignment("datums", ("A", "B", "C")), rps=()):
    return Plan("plan.toml", "0" * 64, Part(), REGIONS, DATUMS, alignment,
                tuple(characteristics), rps)


def run(nominal, M, labels, plan, tol=Tolerance.symmetric(0.5), zone_in_verdict=False):
    res = inspect(nominal, M, tol)
    return inspect_plan(res, plan, nominal, None, M, labels, zone_in_verdict)


COUNTS = {"A": 40, "B": 25, "C": 25, "skin": 80, "hole": 24, "D": 10, "E": 10}


def test_profile_relative_to_datums_sees_a_uniform_offset_that_the_form_profile_absorbs(
        nominal):
    """The skin 0.012 mm proud of a true datum frame: the profile relative to A|B|C is 2 x
    0.012 (REJECT in a 0.02 zone) while the form profile (the skin refitted alone) is ~0."""
    rng = np.random.default_rng(1)
    delta = 0.012
    M, labels, faces, _ = measure(rng, COUNTS, planted={"skin": delta})
    plan = plan_of(Characteristic("1", "profile", "skin", -0.01, 0.01, ("A", "B", "C")),
                   Characteristic("2", "profile", "skin", -0.01, 0.01))
    res = run(nominal, M, labels, plan)
    datum, form = by_id(res, "1"), by_id(res, "2")
    assert datum.value == pytest.approx(2 * delta, abs=2e-6)
    assert datum.verdict == REJECT and form.verdict == ACCEPT and form.value < 2e-5
    assert res.verdict == REJECT and "characteristic 1" in res.reasons[0]
    assert datum.indices.size == COUNTS["skin"] and set(faces[datum.indices]) == {"skin"}
    # The per-point outputs are at the datum pose: the skin reads +delta, the datums 0.
    d = res.deviations.signed
    assert np.allclose(d[faces == "skin"], delta, atol=2e-6)
    assert np.allclose(d[faces == "A"], 0.0, atol=2e-6)
    assert res.plan.alignment.free == () and res.plan.alignment.complete


def test_flatness_matches_an_independent_linear_program(nominal):
    """Datum face A measured with a known form error (a dome of 8 um and noise): the plan's
    flatness equals the minimum zone computed here as a linear program in the plane's own
    parameters, on the true (unposed) points."""
    from scipy.optimize import linprog

    rng = np.random.default_rng(2)
    M, labels, faces, P = measure(rng, COUNTS)
    A = faces == "A"
    x, y = P[A, 0], P[A, 1]
    form = 0.008 * np.exp(-((x - 50) ** 2 + (y - 30) ** 2) / 400) + rng.normal(0, 0.001, x.size)
    P[A, 2] -= form  # excess below the bottom face
    T = _pose_of(M, P, faces)
    M[A] = P[A] @ T[:3, :3].T + T[:3, 3]
    plan = plan_of(Characteristic("3", "flatness", "A", 0.0, 0.02))
    res = run(nominal, M, labels, plan)
    # Variables (a, b, c, w): |z - (a x + b y + c)| <= w/2 ... as z - p <= h, p - z <= h.
    G = np.column_stack([x, y, np.ones_like(x), -np.ones_like(x)])
    z = P[A, 2]
    lp = linprog([0, 0, 0, 1], A_ub=np.vstack([G * [-1, -1, -1, 1], G * [1, 1, 1, 1]]),
                 b_ub=np.concatenate([-z, z]), bounds=[(None, None)] * 3 + [(0, None)],
                 method="highs")
    a, b = lp.x[:2]
    width = 2 * lp.x[3] / np.sqrt(1 + a * a + b * b)
    assert by_id(res, "3").value == pytest.approx(width, abs=1e-7)
    assert by_id(res, "3").verdict == ACCEPT


def _pose_of(M, P, faces):
    """The rigid transform taking true points P to measured M (from the unplanted faces)."""
    k = faces != "A"
    return rigid_motion(P[k], M[k])


@pytest.mark.parametrize("seed", [3, 4])
def test_position_and_size_of_a_hole_moved_by_a_known_vector(nominal, seed):
    rng = np.random.default_rng(seed)
    shift = rng.uniform(-0.04, 0.04, 2)
    M, labels, faces, _ = measure(rng, COUNTS, hole_shift=shift, hole_dr=0.006)
    plan = plan_of(Characteristic("4", "position", "hole", 0.0, 0.1, ("A", "B", "C")),
                   Characteristic("5", "size", "hole", -0.01, 0.01, nominal=8.0))
    res = run(nominal, M, labels, plan)
    pos, size = by_id(res, "4"), by_id(res, "5")
    assert pos.value == pytest.approx(2 * np.linalg.norm(shift), abs=1e-5)
    assert size.value == pytest.approx(8.012, abs=1e-6)
    assert size.verdict == REJECT  # 8.012 > 8.01
    assert pos.verdict == (ACCEPT if 2 * np.linalg.norm(shift) <= 0.1 else REJECT)


def test_rps_places_the_part_on_its_labelled_points(nominal):
    rng = np.random.default_rng(5)
    M, labels, faces, P = measure(rng, COUNTS, planted={"skin": 0.02})
    iA, iB, iC = (np.flatnonzero(faces == f) for f in "ABC")
    rps = tuple(RpsPoint(labels[i], tuple(P[i]), lock) for i, lock in
                [(iA[0], ("z",)), (iA[5], ("z",)), (iA[9], ("z",)), (iB[0], ("x",)),
                 (iB[7], ("x",)), (iC[0], ("y",))])
    plan = plan_of(Characteristic("1", "profile", "skin", -0.05, 0.05, ("A", "B", "C")),
                   alignment=Alignment("rps"), rps=rps)
    res = run(nominal, M, labels, plan)
    assert res.plan.alignment.free == ()
    d = res.deviations.signed
    assert np.allclose(d[faces == "skin"], 0.02, atol=2e-6)
    assert np.allclose(d[faces != "skin"][faces[faces != "skin"] != "hole"], 0.0, atol=2e-6)


def test_missing_datum_points_make_dependent_characteristics_inconclusive(nominal):
    rng = np.random.default_rng(6)
    counts = dict(COUNTS, C=0)
    M, labels, faces, _ = measure(rng, counts)
    plan = plan_of(Characteristic("1", "profile", "skin", -0.05, 0.05, ("A", "B", "C")),
                   Characteristic("2", "profile", "skin", -0.05, 0.05))
    res = run(nominal, M, labels, plan)
    assert by_id(res, "1").verdict == INCONCLUSIVE and "datum C has 0" in by_id(res, "1").reason
    assert by_id(res, "2").verdict == ACCEPT
    assert res.verdict == INCONCLUSIVE


def test_a_region_that_selects_no_nominal_point_names_the_plan(nominal):
    from engine.errors import InputError

    rng = np.random.default_rng(7)
    M, labels, _, _ = measure(rng, COUNTS)
    plan = Plan("plan.toml", "0" * 64, Part(), REGIONS + (Region("void", box=(
        (500, 500, 500), (501, 501, 501))),), DATUMS, Alignment("best-fit"),
        (Characteristic("9", "profile", "void", -0.1, 0.1),))
    with pytest.raises(InputError, match=r"plan.toml: \[\[region\]\] 'void': selects no point"):
        run(nominal, M, labels, plan)


def test_the_zone_given_with_a_plan_is_one_more_characteristic(nominal):
    """--tol with a plan: the whole-part best-fit profile is judged beside the plan's."""
    rng = np.random.default_rng(8)
    M, labels, faces, _ = measure(rng, COUNTS, planted={"skin": 0.012})
    plan = plan_of(Characteristic("2", "profile", "skin", -0.05, 0.05))
    res = run(nominal, M, labels, plan, tol=Tolerance.symmetric(0.001), zone_in_verdict=True)
    assert [r.characteristic.id for r in res.plan.characteristics] == ["tol", "2"]
    assert by_id(res, "tol").verdict == REJECT and res.verdict == REJECT
    res = run(nominal, M, labels, plan, tol=Tolerance.symmetric(0.001), zone_in_verdict=False)
    assert res.verdict == ACCEPT


def test_cli_plan_run_writes_characteristics(tmp_path, nominal):
    """The command line with --plan: exit code, summary lines, JSON characteristics, CSV regions."""
    import json

    from qa_app.cli import main

    rng = np.random.default_rng(9)
    M, labels, faces, _ = measure(rng, COUNTS, planted={"skin": 0.012})
    nom = tmp_path / "nominal.csv"
    np.savetxt(nom, np.column_stack([nominal.points, nominal.normals(np.arange(nominal.n))]),
               delimiter=",", header="x,y,z,i,j,k", comments="", fmt="%.9f")
    meas = tmp_path / "measured.csv"
    with open(meas, "w") as f:
        f.write("id,x,y,z\n")
        for lab, p in zip(labels, M):
            f.write(f"{lab},{p[0]:.9f},{p[1]:.9f},{p[2]:.9f}\n")
    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN_TOML)
    code = main(["inspect", str(nom), str(meas), "--plan", str(plan), "--json",
                 str(tmp_path / "r.json"), "--csv", str(tmp_path / "r.csv")])
    assert code == 1  # REJECT: the skin's profile relative to A|B|C
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["verdict"] == "REJECT" and doc["alignment"]["method"] == "datums"
    assert [c["id"] for c in doc["characteristics"]] == ["1", "2"]
    assert doc["characteristics"][0]["value"] == pytest.approx(0.024, abs=1e-5)
    assert doc["plan"]["sha256"] and doc["settings"]["plan"] == str(plan)
    rows = (tmp_path / "r.csv").read_text().splitlines()
    assert rows[0].endswith(",region")
    skin_rows = [r for r in rows[1:] if r.split(",")[1].startswith("skin")]
    assert skin_rows and all(r.endswith(",skin") for r in skin_rows)


PLAN_TOML = """
[[region]]
name = "A"
box = [[-1, -1, -0.5], [101, 61, 0.5]]
[[region]]
name = "B"
box = [[-0.5, -1, -1], [0.5, 61, 40]]
[[region]]
name = "C"
box = [[-1, -0.5, -1], [101, 0.5, 40]]
[[region]]
name = "skin"
box = [[0.5, 0.5, 19.5], [99.5, 59.5, 31]]
[[datum]]
label = "A"
region = "A"
feature = "plane"
[[datum]]
label = "B"
region = "B"
feature = "plane"
[[datum]]
label = "C"
region = "C"
feature = "plane"
[alignment]
method = "datums"
reference = ["A", "B", "C"]
[[characteristic]]
id = "1"
type = "profile"
region = "skin"
zone = 0.02
datums = ["A", "B", "C"]
[[characteristic]]
id = "2"
type = "profile"
region = "skin"
zone = 0.02
"""


def test_the_seat_bracket_sample_plan(tmp_path):
    """samples/seat_bracket/plan.toml through the command line, against the sample's truth: the
    skin's planted +0.012 mm excess rejected by its profile relative to A|B|C and accepted as
    form; the hole's position and size as made (its truth.json), within the probing noise."""
    import json

    from qa_app.cli import main

    here = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "samples",
                        "seat_bracket")
    with open(os.path.join(here, "truth.json")) as f:
        truth = json.load(f)
    code = main(["inspect", os.path.join(here, "nominal.xyz"),
                 os.path.join(here, "measured.csv"), "--plan", os.path.join(here, "plan.toml"),
                 "--json", str(tmp_path / "r.json")])
    doc = json.loads((tmp_path / "r.json").read_text())
    assert code == 1 and doc["verdict"] == "REJECT"
    c = {x["id"]: x for x in doc["characteristics"]}
    assert (c["1"]["verdict"], c["2"]["verdict"]) == ("REJECT", "ACCEPT")
    # The skin's points: 0.012 + N(0, 0.004) over datums machined true to 1.5 um.
    assert 2 * 0.012 < c["1"]["value"] < 2 * (0.012 + 5 * 0.004)
    assert c["4"]["value"] == pytest.approx(truth["hole"]["position_value_mm"], abs=0.004)
    assert c["5"]["value"] == pytest.approx(truth["hole"]["size_value_mm"], abs=0.002)
    assert c["3"]["value"] < 6 * 0.0015 and c["3"]["verdict"] == "ACCEPT"
    labels = {d: set(truth["datum_faces"][d]["labels"]) for d in "ABC"}
    assert [d["n_points"] for d in doc["alignment"]["datums"]] == [len(labels[d]) for d in "ABC"]
    assert doc["alignment"]["free_dofs"] == [] and c["4"]["n_points"] == 16


def test_plan_on_a_2d_template_holes_relative_to_edge_datums(tmp_path):
    """A 200 x 100 plate drawn in DXF with two holes of radius 10 (at different heights, so that
    no symmetry of the outline maps the drawing onto itself); measured in 2D in a random pose
    with the second hole moved by a known vector v and 0.01 mm larger in radius: datums A
    (bottom edge, a line) and B (left edge) place it; position of hole 2 relative to A|B is
    2|v|, its size 20.02, hole 1's position 0."""
    import ezdxf

    from engine.contour import ContourIndex, deviations_2d, points_on
    from engine.io.templates import read_dxf_template
    from engine.pose import apply_transform, pose_2d
    from qa_app.cli import main

    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    msp.add_lwpolyline([(0, 0), (200, 0), (200, 100), (0, 100)], close=True)
    for c in ((50, 50), (150, 35)):
        msp.add_circle(c, 10)
    doc.saveas(tmp_path / "plate.dxf")
    t = read_dxf_template(str(tmp_path / "plate.dxf")).template
    rng = np.random.default_rng(12)
    q = points_on(t, 600, rng)
    v = np.array([0.021, -0.013])
    hole2 = np.linalg.norm(q - [150, 35], axis=1) < 11
    q[hole2] = [150, 35] + v + (q[hole2] - [150, 35]) * 10.01 / 10
    # Keep the edges' points clear of the corners.
    corner = np.min(np.linalg.norm(q[:, None] - np.array(
        [[0, 0], [200, 0], [200, 100], [0, 100]]), axis=2), axis=1) < 5
    q = q[~corner]
    meas = apply_transform(pose_2d(rng.uniform(0, 2 * np.pi), rng.uniform(-300, 300, 2)), q)
    np.savetxt(tmp_path / "m.csv", meas, delimiter=",", header="x,y", comments="", fmt="%.9f")
    (tmp_path / "plan.toml").write_text("""
[[region]]
name = "bottom"
box = [[5, -1, -1], [195, 1, 1]]
[[region]]
name = "left"
box = [[-1, 5, -1], [1, 95, 1]]
[[region]]
name = "hole1"
box = [[39, 39, -1], [61, 61, 1]]
[[region]]
name = "hole2"
box = [[139, 24, -1], [161, 46, 1]]
[[datum]]
label = "A"
region = "bottom"
feature = "line"
[[datum]]
label = "B"
region = "left"
feature = "line"
[alignment]
method = "datums"
reference = ["A", "B"]
[[characteristic]]
id = "1"
type = "position"
region = "hole2"
zone = 0.1
datums = ["A", "B"]
[[characteristic]]
id = "2"
type = "size"
region = "hole2"
nominal = 20.0
lower = -0.01
upper = 0.01
[[characteristic]]
id = "3"
type = "position"
region = "hole1"
zone = 0.01
datums = ["A", "B"]
""")
    import json

    code = main(["inspect", str(tmp_path / "plate.dxf"), str(tmp_path / "m.csv"), "--plan",
                 str(tmp_path / "plan.toml"), "--json", str(tmp_path / "r.json")])
    doc = json.loads((tmp_path / "r.json").read_text())
    c = {x["id"]: x for x in doc["characteristics"]}
    assert c["1"]["value"] == pytest.approx(2 * np.linalg.norm(v), abs=1e-6)
    assert c["2"]["value"] == pytest.approx(20.02, abs=1e-6) and c["2"]["verdict"] == "REJECT"
    assert c["3"]["value"] == pytest.approx(0.0, abs=1e-6) and c["3"]["verdict"] == "ACCEPT"
    assert code == 1 and doc["alignment"]["free_dofs"] == []
    assert np.asarray(doc["alignment"]["T_nominal_measured"]).shape == (4, 4)


def test_the_fuselage_frame_sample_plan():
    """samples/fuselage_frame/plan.toml: edge datum A (a line) and hole B (a circle) place the
    2D template; both holes are drawn 50 mm and made so (noise 3 um), the other hole sits
    within its zone, the outer arc's +0.03 mm rise lies within its profile zone. That profile
    (0.0565 of 0.1 mm) is decided by where the 23 points of the line datum put the frame:
    within 3 sigma of their scatter it reaches past 0.1 mm, so it is INCONCLUSIVE and says
    so; the other three are ACCEPT."""
    import json

    from qa_app.cli import main

    here = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "samples",
                        "fuselage_frame")
    import io
    from contextlib import redirect_stdout

    out = io.StringIO()
    with redirect_stdout(out):
        code = main(["inspect", os.path.join(here, "template.dxf"),
                     os.path.join(here, "measured.csv"), "--plan",
                     os.path.join(here, "plan.toml"), "--json", "-"])
    doc = json.loads(out.getvalue())
    c = {x["id"]: x for x in doc["characteristics"]}
    assert code == 2 and doc["verdict"] == "INCONCLUSIVE"
    assert [c[k]["verdict"] for k in "1234"] == ["ACCEPT"] * 3 + ["INCONCLUSIVE"]
    lo, hi = c["4"]["frame_scatter_values"]
    assert lo < c["4"]["value"] < 0.1 < hi and "scatter of its datums' points" in \
        c["4"]["reason"]
    assert c["2"]["value"] == pytest.approx(50.0, abs=0.003)
    assert c["3"]["value"] == pytest.approx(50.0, abs=0.003)
    assert c["1"]["value"] < 0.05
    assert 2 * 0.02 < c["4"]["value"] < 0.1


def test_a_hole_below_a_plane_takes_two_translations_not_the_turn_about_its_axis(tmp_path):
    """Seat bracket: datum A the bottom plane, datum H the flange's hole (a cylinder, its axis
    along A's normal). H takes the two translations A leaves; the turn about its own axis it
    cannot sense stays free (best-fitted on the skin). The hole's nominal axis, fitted to
    sampled wall points, is parallel to A's normal only to ~1e-8: taking a direction from that
    once put the part 1e17 mm away."""
    import json

    from qa_app.cli import main

    here = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "samples",
                        "seat_bracket")
    with open(os.path.join(here, "plan.toml")) as f:
        text = f.read()
    head = text[:text.index("[[datum]]")]
    (tmp_path / "plan.toml").write_text(head + """
[[datum]]
label = "A"
region = "A"
feature = "plane"
[[datum]]
label = "H"
region = "hole1"
feature = "cylinder"
[alignment]
method = "datums"
reference = ["A", "H"]
best_fit_regions = ["skin"]
[[characteristic]]
id = "1"
type = "profile"
region = "skin"
zone = 0.1
datums = ["A", "H"]
""")
    code = main(["inspect", os.path.join(here, "nominal.xyz"), os.path.join(here, "measured.csv"),
                 "--plan", str(tmp_path / "plan.toml"), "--json", str(tmp_path / "r.json")])
    doc = json.loads((tmp_path / "r.json").read_text())
    assert [d["constrained_dofs"] for d in doc["alignment"]["datums"]] == [3, 2]
    (free,) = doc["alignment"]["free_dofs"]
    assert free.startswith("rotation about (+0.000, +0.000, ") and "through (64.00, 30.00" in free
    # The skin: 0.012 + N(0, 0.004) proud; located by A, centred by the hole.
    assert 2 * 0.012 < doc["characteristics"][0]["value"] < 0.1 and code == 0
