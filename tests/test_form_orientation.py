"""The form and orientation families of a plan (engine.gdt.form, engine.gdt.orientation) end to
end: a block with a datum base, a top face, a face at 30 degrees, a through hole and a pin,
measured in a random pose with planted errors, registered and judged; each value against an
independent computation written here (analytic, linear programs, or a brute-force search with a
scipy twin)."""

import json

import numpy as np
import pytest

from engine.gdt.plan import Alignment, Characteristic, Datum, Part, Plan, Region
from engine.nominal import Nominal
from engine.pointset import PointSet
from engine.pose import make_transform, rotation_from_rotvec
from engine.verdict import ACCEPT, INCONCLUSIVE, REJECT
from naive import radial_extremes
from plan_runs import by_id, run

# A block [0, 100] x [0, 60] x [0, 20]: base A (z = 0), sides B (x = 0) and C (y = 0), a top
# face z = 20 for x <= 70, a face at 30 degrees to A ("slope") from x = 70 down to x = 100, a
# vertical through hole of radius 5 at (30, 30) and a pin of radius 4 at (50, 15), z 20 .. 50.
SLOPE_DEG, HOLE, HOLE_R, PIN, PIN_R, PIN_Z = 30.0, np.array([30.0, 30.0]), 5.0, \
    np.array([50.0, 15.0]), 4.0, (20.0, 50.0)
TAN = np.tan(np.radians(SLOPE_DEG))


def slope_z(x):
    return 20.0 - (x - 70.0) * TAN


def _plane(u, v, face):
    """Points and outward normals of a plane face at parameters u, v in [0, 1]."""
    if face == "A":
        return np.column_stack([100 * u, 60 * v, 0 * u]), [0, 0, -1.0]
    if face == "B":
        return np.column_stack([0 * u, 60 * v, 20 * u]), [-1.0, 0, 0]
    if face == "C":
        return np.column_stack([100 * u, 0 * u, 20 * v]), [0, -1.0, 0]
    if face == "top":
        return np.column_stack([70 * u, 60 * v, 20 + 0 * u]), [0, 0, 1.0]
    x = 70 + 30 * u  # slope
    return np.column_stack([x, 60 * v, slope_z(x)]), [np.sin(np.radians(SLOPE_DEG)), 0,
                                                      np.cos(np.radians(SLOPE_DEG))]


def _clear(p):
    """Keep points of a plane off the hole and the pin's foot."""
    return (np.linalg.norm(p[:, :2] - HOLE, axis=1) > HOLE_R + 1) & \
        (np.linalg.norm(p[:, :2] - PIN, axis=1) > PIN_R + 1)


def _round(face, a, t):
    """Points and outward normals on the hole's wall (normals into the hole) or the pin."""
    r = np.column_stack([np.cos(a), np.sin(a), 0 * a])
    if face == "hole":
        return np.column_stack([HOLE + HOLE_R * r[:, :2], 20 * t]), -r
    return np.column_stack([PIN + PIN_R * r[:, :2], PIN_Z[0] + (PIN_Z[1] - PIN_Z[0]) * t]), r


@pytest.fixture(scope="module")
def nominal():
    rng = np.random.default_rng(24)
    P, N = [], []
    for face, k in {"A": 5000, "B": 1500, "C": 2000, "top": 4000, "slope": 2500}.items():
        u, v = rng.uniform(0, 1, (2, 3 * k))
        p, n = _plane(u, v, face)
        keep = _clear(p)[:k] if face in ("A", "top") else slice(0, k)
        p = p[:k][keep] if face in ("A", "top") else p[:k]
        P.append(p)
        N.append(np.broadcast_to(np.asarray(n, float), p.shape))
    for face, k in {"hole": 2500, "pin": 3000}.items():
        p, n = _round(face, rng.uniform(0, 2 * np.pi, k), rng.uniform(0, 1, k))
        P.append(p)
        N.append(n)
    return Nominal.from_point_set(PointSet(np.vstack(P), np.vstack(N)))


RINGS = 8


def measured(rng, tilt=0.0, top_slope=0.0, slope_extra=0.0, lobes=0.0, bow=0.0, wave=0.0):
    """True points per face with the planted errors (the hole tilted by ``tilt`` rad about y
    through its middle; the top face tilted by ``top_slope`` (dz/dx) about x = 35; the slope
    face turned by ``slope_extra`` rad more about its middle line; the pin with a 3-lobe form
    of amplitude ``lobes`` or its axis bowed by ``bow`` at the middle; the top face waved by
    ``wave`` along x), in rings and lines as a CMM probes them; then the part in a random
    pose. Returns (measured points, labels, faces, true points)."""
    P, faces = [], []
    for face, k in {"A": 60, "B": 30, "C": 30}.items():
        u, v = rng.uniform(0.05, 0.95, (2, 4 * k))
        p = _plane(u, v, face)[0]
        p = p[_clear(p)][:k] if face == "A" else p[:k]
        P.append(p)
        faces += [face] * len(p)
    # The top face probed along RINGS lines y = const (its line elements along x).
    y = np.repeat(np.linspace(5.0, 55.0, RINGS), 25)
    x = rng.uniform(3.0, 67.0, y.size)
    p = np.column_stack([x, y, 20 + top_slope * (x - 35) + wave * np.sin(2 * np.pi * x / 16)])
    keep = _clear(p)
    P.append(p[keep])
    faces += ["top"] * int(keep.sum())
    u, v = rng.uniform(0.05, 0.95, (2, 80))
    p = _plane(u, v, "slope")[0]
    mid = np.array([85.0, 0.0, slope_z(85.0)])
    P.append(mid + (p - mid) @ rotation_from_rotvec(np.array([[0, slope_extra, 0]]))[0].T)
    faces += ["slope"] * 80
    # The hole: rings at heights z on the cylinder tilted by ``tilt`` (ellipses in z planes).
    z = np.repeat(np.linspace(2.0, 18.0, RINGS), 30)
    a = rng.uniform(0, 2 * np.pi, z.size)
    P.append(np.column_stack([HOLE[0] + (z - 10) * np.tan(tilt)
                              + HOLE_R * np.cos(a) / np.cos(tilt),
                              HOLE[1] + HOLE_R * np.sin(a), z]))
    faces += ["hole"] * z.size
    # The pin: rings, evenly spaced angles with a random phase.
    z = np.repeat(np.linspace(23.0, 47.0, RINGS), 36)
    a = (np.tile(np.arange(36) * 2 * np.pi / 36, RINGS)
         + np.repeat(rng.uniform(0, 2 * np.pi, RINGS), 36))
    r = PIN_R + lobes * np.cos(3 * a)
    s = (z - PIN_Z[0]) / (PIN_Z[1] - PIN_Z[0])
    P.append(np.column_stack([PIN[0] + r * np.cos(a) + 4 * bow * s * (1 - s),
                              PIN[1] + r * np.sin(a), z]))
    faces += ["pin"] * z.size
    P = np.vstack(P)
    R = rotation_from_rotvec(rng.uniform(-np.pi, np.pi, (1, 3)))[0]
    T = make_transform(R, rng.uniform(-300, 300, 3))
    M = P @ T[:3, :3].T + T[:3, 3]
    return M, np.array([f"{f}{i}" for i, f in enumerate(faces)]), np.array(faces), P


REGIONS = (Region("A", box=((-1, -1, -0.5), (101, 61, 0.5))),
           Region("B", box=((-0.5, -1, -1), (0.5, 61, 21))),
           Region("C", box=((-1, -0.5, -1), (101, 0.5, 21))),
           Region("top", box=((1, 1, 19.5), (69, 59, 20.5))),
           Region("slope", box=((71, 1, 2), (99, 59, 19.5))),
           Region("hole", box=((24, 24, 0.5), (36, 36, 19.5))),
           Region("pin", box=((45, 10, 21), (55, 20, 49))))
DATUMS = (Datum("A", "A", "plane"), Datum("B", "B", "plane"), Datum("C", "C", "plane"))


def plan_of(*characteristics):
    return Plan("plan.toml", "0" * 64, Part(), REGIONS, DATUMS, Alignment("best-fit"),
                tuple(characteristics))


def C(ident, kind, region, zone, datums=(), **kw):
    return Characteristic(ident, kind, region, 0.0, zone, tuple(datums), **kw)


@pytest.mark.parametrize("seed", [1, 2])
def test_perpendicularity_of_a_tilted_hole_is_its_depth_times_tan_theta(nominal, seed):
    """A hole tilted by theta over its probed depth L (rings at z = 2 .. 18): perpendicularity to
    datum A (diametral) = L tan(theta), exactly, from a random pose; and with datums A|B the
    same (B fixes the turn about A's normal, which does not move a zone along it)."""
    rng = np.random.default_rng(seed)
    theta = np.radians(0.05)
    M, labels, faces, P = measured(rng, tilt=theta)
    plan = plan_of(C("1", "perpendicularity", "hole", 0.02, ["A"], diametral=True),
                   C("2", "perpendicularity", "hole", 0.02, ["A", "B"], diametral=True))
    res = run(nominal, M, labels, plan)
    expected = 16.0 * np.tan(theta)
    for i in ("1", "2"):
        r = by_id(res, i)
        assert r.value == pytest.approx(expected, abs=1e-6), (i, r.reason)
        assert r.verdict == ACCEPT and r.characteristic.feature == "cylinder"


@pytest.mark.parametrize("zone, verdict", [(0.0141, ACCEPT), (0.0139, REJECT)])
def test_a_planted_tilt_just_inside_or_just_outside_the_zone_flips_the_verdict(
        nominal, zone, verdict):
    """L tan(theta) = 0.0140 mm against a zone of 0.0141 (ACCEPT) and of 0.0139 (REJECT)."""
    rng = np.random.default_rng(3)
    theta = np.arctan(0.014 / 16.0)
    M, labels, _, _ = measured(rng, tilt=theta)
    res = run(nominal, M, labels,
              plan_of(C("1", "perpendicularity", "hole", zone, ["A"], diametral=True)))
    assert by_id(res, "1").value == pytest.approx(0.014, abs=1e-6)
    assert by_id(res, "1").verdict == verdict and res.verdict == verdict


def test_parallelism_of_a_tilted_top_is_its_height_change_over_its_extent(nominal):
    rng = np.random.default_rng(4)
    slope = 2e-4
    M, labels, faces, P = measured(rng, top_slope=slope)
    res = run(nominal, M, labels, plan_of(C("1", "parallelism", "top", 0.05, ["A"]),
                                          C("2", "flatness", "top", 0.05)))
    x = P[faces == "top", 0]
    assert by_id(res, "1").value == pytest.approx(slope * np.ptp(x), abs=1e-6)
    assert by_id(res, "2").value == pytest.approx(0.0, abs=1e-6)  # a tilted plane is flat
    assert by_id(res, "1").characteristic.feature == "plane"


def _brute_min(f, lo, hi, n=81):
    """min of f over [lo, hi]: an exhaustive grid, then scipy's bounded Brent about its best."""
    from scipy.optimize import minimize_scalar

    grid = np.linspace(lo, hi, n)
    k = int(np.argmin([f(g) for g in grid]))
    step = grid[1] - grid[0]
    twin = minimize_scalar(f, bounds=(grid[k] - step, grid[k] + step), method="bounded",
                           options={"xatol": 1e-13})
    return min(f(grid[k]), float(twin.fun))


@pytest.mark.parametrize("extra_deg", [0.0, 0.02])
def test_angularity_at_30_degrees_of_a_face_turned_a_little_more(nominal, extra_deg):
    """The slope face (basic 30 degrees to A) turned by a planted extra angle: angularity to A
    equals the narrowest zone of two planes at 30 degrees to A holding its true points (their
    turn about A's normal free), searched here exhaustively."""
    rng = np.random.default_rng(5)
    M, labels, faces, P = measured(rng, slope_extra=np.radians(extra_deg))
    res = run(nominal, M, labels,
              plan_of(C("1", "angularity", "slope", 0.02, ["A"], angle=30.0),
                      C("2", "angularity", "slope", 0.02, ["A"], angle=150.0)))
    X = P[faces == "slope"]
    s30, c30 = np.sin(np.radians(30)), np.cos(np.radians(30))

    def width(phi):
        return float(np.ptp(X @ np.array([s30 * np.cos(phi), s30 * np.sin(phi), c30])))

    truth = _brute_min(width, -0.05, 0.05)
    if extra_deg == 0.0:
        assert truth < 1e-9
    else:  # about the face's extent along its slope times the extra turn
        assert truth == pytest.approx(np.ptp(X[:, 0]) / c30 * np.radians(extra_deg), rel=0.05)
    for i in ("1", "2"):
        assert by_id(res, i).value == pytest.approx(truth, abs=1e-6)
        assert by_id(res, i).verdict == (ACCEPT if truth < 0.02 else REJECT)


def _round_zone_brute(q):
    """The minimum-zone radial separation of 2D points q: a grid of centres about their mean,
    then Nelder-Mead about the best (a twin of the linear programs)."""
    from scipy.optimize import minimize

    def width(c):
        return float(np.ptp(np.linalg.norm(q - c, axis=1)))

    g = q.mean(axis=0)
    offsets = np.linspace(-0.01, 0.01, 21)
    best = min(((width(g + [u, v]), g + [u, v]) for u in offsets for v in offsets),
               key=lambda t: t[0])
    twin = minimize(width, best[1], method="Nelder-Mead",
                    options={"xatol": 1e-12, "fatol": 1e-15, "maxiter": 20000})
    return min(best[0], float(twin.fun))


def _axis_starts(X):
    """Starting axes for naive.radial_extremes: parallel to z through a 3 x 3 grid of points
    within 5 µm of the points' mean."""
    g = X[:, :2].mean(axis=0)
    return [[g[0] + u, g[1] + v, 0.0, 0.0] for u in (-0.005, 0.0, 0.005)
            for v in (-0.005, 0.0, 0.005)]


def test_cylindricity_and_circularity_of_a_three_lobed_pin(nominal):
    """A pin with a 3-lobe form of amplitude a (rings of 36 points, evenly spaced at a random
    phase each): cylindricity and circularity equal the minimum zones searched here by brute
    force by an independent optimiser (naive.radial_extremes: SLSQP on the exact distances;
    2a up to the sampling), within 1e-6 mm."""
    rng = np.random.default_rng(6)
    a = 0.004
    M, labels, faces, P = measured(rng, lobes=a)
    res = run(nominal, M, labels, plan_of(C("1", "cylindricity", "pin", 0.01),
                                          C("2", "circularity", "pin", 0.01),
                                          C("3", "circularity", "pin", 0.007)))
    X = P[faces == "pin"]
    rings = [X[k * 36:(k + 1) * 36, :2] for k in range(RINGS)]
    circ = max(radial_extremes(q, "zone", [s[:2] for s in _axis_starts(q)]) for q in rings)
    cyl = radial_extremes(X, "zone", _axis_starts(X))
    assert circ == pytest.approx(2 * a, abs=2e-5) and cyl == pytest.approx(2 * a, abs=2e-5)
    assert by_id(res, "1").value == pytest.approx(cyl, abs=1e-6)
    assert by_id(res, "2").value == pytest.approx(circ, abs=1e-6)
    assert by_id(res, "2").facts["sections_judged"] == RINGS
    assert [by_id(res, i).verdict for i in "123"] == [ACCEPT, ACCEPT, REJECT]


def _line_zone_lp(u, w):
    """The minimum-zone width of 2D points (u, w) between two parallel lines: a linear program
    in the line's slope and offset (w - (s u + c) within +-h, minimise h), as a width."""
    from scipy.optimize import linprog

    G = np.column_stack([u, np.ones_like(u), -np.ones_like(u)])
    lp = linprog([0, 0, 1], A_ub=np.vstack([G * [-1, -1, 1], G * [1, 1, 1]]),
                 b_ub=np.concatenate([-w, w]), bounds=[(None, None)] * 2 + [(0, None)],
                 method="highs")
    return 2 * lp.x[2] / np.sqrt(1 + lp.x[0] ** 2)


def test_straightness_of_a_bowed_pins_median_line(nominal):
    """The pin's axis bowed by b at its middle: the straightness of its derived median line
    (diametral, 8 sections) is the smallest cylinder about the ring centres, which lie in one
    plane: the minimum zone of two lines about them (a linear program)."""
    rng = np.random.default_rng(7)
    bow = 0.01
    M, labels, faces, P = measured(rng, bow=bow)
    res = run(nominal, M, labels, plan_of(C("1", "straightness", "pin", 0.02, diametral=True),
                                          C("2", "cylindricity", "pin", 0.02)))
    z = np.linspace(23.0, 47.0, RINGS)
    s = (z - PIN_Z[0]) / (PIN_Z[1] - PIN_Z[0])
    truth = _line_zone_lp(z, 4 * bow * s * (1 - s))
    assert by_id(res, "1").value == pytest.approx(truth, abs=1e-6)
    assert by_id(res, "1").verdict == ACCEPT
    # Round sections about a bowed axis: the radial zone about the best axis is about the bow.
    assert by_id(res, "2").value == pytest.approx(truth, rel=0.01)


def test_straightness_of_a_waved_faces_line_elements(nominal):
    """The top face waved along x (amplitude w, period 16 mm), probed along 8 lines: the
    straightness along [1, 0, 0] is the largest minimum zone of the lines (linear programs on
    the true points)."""
    rng = np.random.default_rng(8)
    wave = 0.003
    M, labels, faces, P = measured(rng, wave=wave)
    res = run(nominal, M, labels, plan_of(
        C("1", "straightness", "top", 0.01, direction=(1.0, 0.0, 0.0)),
        C("2", "straightness", "top", 0.01, direction=(1.0, 0.0, 0.0), sections=4)))
    X = P[faces == "top"]
    lines = [X[X[:, 1] == y] for y in np.unique(X[:, 1])]
    truth = max(_line_zone_lp(q[:, 0], q[:, 2]) for q in lines)
    assert truth == pytest.approx(2 * wave, abs=2e-4)
    r = by_id(res, "1")
    assert r.value == pytest.approx(truth, abs=1e-6) and r.facts["sections_judged"] == RINGS
    assert by_id(res, "2").value >= truth - 1e-6  # two lines a section: no narrower


def test_guarded_rule_guards_each_new_value_with_its_uncertainty(nominal):
    """Under the guarded rule every new value carries its uncertainty bound (twice the largest
    U of its points) and is INCONCLUSIVE within it of its limit."""
    from engine.uncertainty import Instrument

    rng = np.random.default_rng(9)
    theta = np.arctan(0.014 / 16.0)
    M, labels, _, _ = measured(rng, tilt=theta, lobes=0.002)
    plan = plan_of(C("1", "perpendicularity", "hole", 0.0141, ["A"], diametral=True),
                   C("2", "perpendicularity", "hole", 0.5, ["A"], diametral=True),
                   C("3", "cylindricity", "pin", 0.0041), C("4", "circularity", "pin", 0.5),
                   C("5", "parallelism", "top", 0.5, ["A"]))
    res = run(nominal, M, labels, plan, decision_rule="guarded",
              instrument=Instrument(uncertainty_mm=0.001))
    for i in "12345":
        assert by_id(res, i).facts["uncertainty_bound"] >= 0.002
    assert by_id(res, "1").verdict == INCONCLUSIVE and by_id(res, "3").verdict == INCONCLUSIVE
    assert [by_id(res, i).verdict for i in "245"] == [ACCEPT] * 3


ROOT = __file__.rsplit("/tests/", 1)[0]
SEAT = (f"{ROOT}/samples/seat_bracket/nominal.xyz", f"{ROOT}/samples/seat_bracket/measured.csv")
NEW = """
[[characteristic]]
id = "6"
type = "perpendicularity"
region = "hole1"
zone = 0.05
datums = ["A"]
diametral = true

[[characteristic]]
id = "7"
type = "cylindricity"
region = "hole1"
zone = 0.05

[[characteristic]]
id = "8"
type = "circularity"
region = "hole1"
zone = 0.05
sections = 2

[[characteristic]]
id = "9"
type = "straightness"
region = "A"
zone = 0.05
direction = [1, 0, 0]
sections = 3

[[characteristic]]
id = "10"
type = "perpendicularity"
region = "C"
zone = 0.05
datums = ["A", "B"]

[[characteristic]]
id = "11"
type = "angularity"
region = "B"
zone = 0.05
datums = ["A"]
angle = 90

[[characteristic]]
id = "12"
type = "straightness"
region = "hole1"
zone = 0.05
sections = 3
"""


def test_the_new_types_through_the_command_line_json_qif_and_certificate(tmp_path):
    """The seat bracket sample's plan with one characteristic of each new type: each in the
    JSON with its type, symbol and keys, in the QIF as its own QIF 3.0 characteristic type
    (valid against the XSD), and on the certificate."""
    from lxml import etree

    from qa_app.cli import main
    from reports.qif import qif_results_document

    plan = tmp_path / "plan.toml"
    with open(f"{ROOT}/samples/seat_bracket/plan.toml") as f:
        plan.write_text(f.read() + NEW)
    code = main(["inspect", *SEAT, "--plan", str(plan), "--json", str(tmp_path / "r.json"),
                 "--csv", str(tmp_path / "r.csv"), "--report", str(tmp_path / "r.pdf")])
    assert code == 1  # the sample's skin profile to A|B|C rejects, as it always has
    doc = json.loads((tmp_path / "r.json").read_text())
    chars = {c["id"]: c for c in doc["characteristics"]}
    assert [chars[i]["type"] for i in ("6", "7", "8", "9", "10", "11", "12")] == [
        "perpendicularity", "cylindricity", "circularity", "straightness", "perpendicularity",
        "angularity", "straightness"]
    assert [chars[i]["symbol"] for i in ("6", "7", "8", "9", "11")] == ["⟂", "⌭", "○", "⏤", "∠"]
    assert chars["6"]["diametral"] and not chars["10"]["diametral"] and chars["12"]["diametral"]
    assert chars["9"]["direction"] == [1.0, 0.0, 0.0] and chars["8"]["sections"] == 2
    assert chars["11"]["angle"] == 90.0
    for i in ("6", "7", "9", "10", "11"):  # the sample is made to its nominal, within noise
        assert chars[i]["verdict"] == "ACCEPT" and chars[i]["value"] < 0.05, chars[i]
    assert (tmp_path / "r.pdf").stat().st_size > 0
    import csv

    with open(tmp_path / "r.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    data = qif_results_document(
        doc, np.array([[float(r[k]) for k in ("x_reg", "y_reg", "z_reg")] for r in rows]),
        np.array([float(r["deviation"]) for r in rows]),
        np.array([r["in_tolerance"] == "true" for r in rows]), np.array([r["label"] for r in rows]))
    schema = etree.XMLSchema(etree.parse(f"{ROOT}/tests/data/qif-3.0-xsd/QIFDocument.xsd"))
    tree = etree.ElementTree(etree.fromstring(data))
    assert schema.validate(tree), "\n".join(str(e) for e in schema.error_log)
    tags = {etree.QName(e).localname for e in tree.iter()}
    for kind in ("Perpendicularity", "Cylindricity", "Circularity", "Straightness",
                 "Angularity"):
        assert f"{kind}CharacteristicDefinition" in tags
        assert f"{kind}CharacteristicMeasurement" in tags


REGION_TOP = '[[region]]\nname = "A"\nbox = [[-1, -1, -0.5], [121, 61, 0.5]]\n' \
    '[[region]]\nname = "hole"\nbox = [[59.5, 25.5, 0.5], [68.5, 34.5, 7.5]]\n' \
    '[[datum]]\nlabel = "A"\nregion = "A"\nfeature = "plane"\n'


def _char(body):
    return REGION_TOP + '[[characteristic]]\nid = "7"\n' + body


@pytest.mark.parametrize("body, key, words", [
    ('type = "perpendicularity"\nregion = "hole"\nzone = 0.05\ndiametral = true\n',
     "datums", "a perpendicularity is oriented relative to at least one datum"),
    ('type = "parallelism"\nregion = "hole"\nzone = 0.05\ndatums = []\n',
     "datums", "is missing or empty"),
    ('type = "angularity"\nregion = "hole"\nzone = 0.05\ndatums = ["A"]\n',
     "angle", "is missing"),
    ('type = "angularity"\nregion = "hole"\nzone = 0.05\ndatums = ["A"]\nangle = 190\n',
     "angle", "between 0 and 180"),
    ('type = "circularity"\nregion = "A"\nzone = 0.05\n', "type",
     'region "A" is no cylinder: datum "A" is a plane'),
    ('type = "cylindricity"\nregion = "A"\nzone = 0.05\n', "type", "is no cylinder"),
    ('type = "circularity"\nregion = "hole"\nzone = 0.05\nsections = 0\n', "sections",
     "whole number from 1"),
    ('type = "straightness"\nregion = "hole"\nzone = 0.05\nsections = 2\n', "sections",
     "whole number from 3"),
    ('type = "circularity"\nregion = "hole"\nzone = 0.05\ndirection = [0, 0, 1]\n',
     "direction", "applies to straightness and line_profile only"),
    ('type = "straightness"\nregion = "A"\nzone = 0.05\ndirection = [0, 0, 0]\n',
     "direction", "non-zero"),
    ('type = "straightness"\nregion = "A"\nzone = 0.05\ndirection = [1, 0, 0]\n'
     'diametral = true\n', "diametral", "median line"),
    ('type = "cylindricity"\nregion = "hole"\nzone = 0.05\ndatums = ["A"]\n', "datums",
     "cylindricity is form only"),
    ('type = "perpendicularity"\nregion = "hole"\nzone = 0.05\ndatums = ["A"]\n'
     'diametral = "yes"\n', "diametral", "true or false"),
    ('type = "parallelism"\nregion = "hole"\nzone = 0.05\ndatums = ["A"]\nangle = 10\n'
     'diametral = true\n', "angle", "applies to angularity only"),
])
def test_bad_plans_are_refused_with_65_naming_plan_table_and_key(tmp_path, capsys, body, key,
                                                                  words):
    from qa_app.cli import main

    plan = tmp_path / "plan.toml"
    plan.write_text(_char(body))
    assert main(["inspect", *SEAT, "--plan", str(plan)]) == 65
    err = capsys.readouterr().err
    assert f"{plan}: [[characteristic]] #1 (id \"7\"): '{key}' " in err, err
    assert words in err, err


@pytest.mark.parametrize("body, words", [
    ('type = "cylindricity"\nregion = "top"\nzone = 0.05\n',
     "region 'top' is no cylinder: the normals of its nominal points all face one way"),
    ('type = "parallelism"\nregion = "top"\nzone = 0.05\ndatums = ["B"]\n',
     "stands 90.00° from the 0° its parallelism asks to datum B"),
    ('type = "straightness"\nregion = "top"\nzone = 0.05\ndirection = [0, 0, 1]\n',
     "lies along the normal of region 'top'"),
])
def test_plans_the_nominal_shows_wrong_are_refused_with_65(tmp_path, capsys, body, words):
    """What only the nominal shows (a cylindricity of a flat region, a parallelism of a face
    at right angles to its datum, line elements along the normal) is refused too, naming the
    plan and the characteristic."""
    from qa_app.cli import main

    plan = tmp_path / "plan.toml"
    plan.write_text('[[region]]\nname = "top"\nbox = [[-1, -1, -0.5], [121, 61, 0.5]]\n'
                    '[[region]]\nname = "B"\nbox = [[-0.5, -1, -1], [0.5, 61, 91]]\n'
                    '[[datum]]\nlabel = "B"\nregion = "B"\nfeature = "plane"\n'
                    '[[characteristic]]\nid = "7"\n' + body)
    assert main(["inspect", *SEAT, "--plan", str(plan)]) == 65
    err = capsys.readouterr().err
    assert f"{plan}: [[characteristic]] '7': " in err and words in err, err


@pytest.mark.parametrize("seed, n", [(10, 40), (11, 200), (12, 2000)])
def test_the_minimum_zone_circle_equals_its_brute_force_twin_on_random_rounds(seed, n):
    """engine.gdt.form.round_zone (linear programs, the rows near the zone's edges only above
    300 points) against the grid + Nelder-Mead twin, on noisy lobed circles off the origin."""
    from engine.gdt.form import round_zone

    rng = np.random.default_rng(seed)
    a = rng.uniform(0, 2 * np.pi, n)
    r = 7.0 + 0.003 * np.cos(rng.integers(2, 6) * a + 1.0) + rng.normal(0, 5e-4, n)
    q = np.column_stack([r * np.cos(a), r * np.sin(a)]) + rng.uniform(-50, 50, 2)
    width, centre = round_zone(q)
    assert width == pytest.approx(_round_zone_brute(q), abs=1e-7)
    assert np.ptp(np.linalg.norm(q - centre, axis=1)) == pytest.approx(width, abs=1e-12)
