"""The runout family (engine.gdt.runout) and common datums "A-B" end to end: a stepped shaft
measured in a random pose with planted errors, registered and judged; each value against an
independent computation written here (the analytic value, the spread over the true points
about the true axis, and a scipy least-squares twin of the common datum axis)."""

import numpy as np
import pytest

from engine.gdt.plan import Alignment, Characteristic, Datum, Part, Plan, Region
from engine.nominal import Nominal
from engine.pointset import PointSet
from engine.pose import make_transform, rotation_from_rotvec
from engine.verdict import ACCEPT, INCONCLUSIVE, REJECT
from plan_runs import by_id, run

# A shaft along z: journal A (radius 10, z 0 .. 35), a collar (radius 15, z 35 .. 65) between
# two shoulders (z = 35 facing -z, radii 10 .. 15; z = 65 facing +z, radii 9 .. 15), journal B
# (radius 9, z 65 .. 100); end faces at z = 0 and 100. A key flat on the
# collar (x = 13) keeps the registration from turning freely about the axis.
R_J, R_B, R_C, FLAT = 10.0, 9.0, 15.0, 13.0


def _cylinder(rng, r, z0, z1, k):
    a, z = rng.uniform(0, 2 * np.pi, k), rng.uniform(z0, z1, k)
    u = np.column_stack([np.cos(a), np.sin(a), 0 * a])
    p = np.column_stack([r * u[:, :2], z])
    keep = p[:, 0] <= FLAT if r == R_C else np.ones(k, bool)
    return p[keep], u[keep]


def _disc(rng, r0, r1, z, up, k):
    a, r = rng.uniform(0, 2 * np.pi, k), np.sqrt(rng.uniform(r0 ** 2, r1 ** 2, k))
    p = np.column_stack([r * np.cos(a), r * np.sin(a), np.full(k, z)])
    keep = p[:, 0] <= FLAT
    return p[keep], np.tile([0, 0, 1.0 if up else -1.0], (int(keep.sum()), 1))


@pytest.fixture(scope="module")
def nominal():
    rng = np.random.default_rng(25)
    parts = [_cylinder(rng, R_J, 0, 35, 8000), _cylinder(rng, R_C, 35, 65, 12000),
             _cylinder(rng, R_B, 65, 100, 8000), _disc(rng, R_J, R_C, 35, False, 3000),
             _disc(rng, R_B, R_C, 65, True, 3000), _disc(rng, 0, R_J, 0, False, 3000),
             _disc(rng, 0, R_B, 100, True, 3000)]
    h = np.sqrt(R_C ** 2 - FLAT ** 2)
    y, z = rng.uniform(-h, h, 3000), rng.uniform(35, 65, 3000)
    parts.append((np.column_stack([np.full(3000, FLAT), y, z]), np.tile([1.0, 0, 0], (3000, 1))))
    return Nominal.from_point_set(PointSet(np.vstack([p for p, _ in parts]),
                                           np.vstack([n for _, n in parts])))


RINGS, PER_RING = 6, 48


def _rings(r, z, centre=(0.0, 0.0), tilt=0.0):
    """Rings of radius r at heights z, PER_RING evenly spaced angles from 0 (each ring holds
    the angles 0, 90, 180 and 270 degrees), about ``centre``; the collar's ring points beyond
    the flat left out. ``tilt``: the ring's plane turned about x (z grows by y tan(tilt))."""
    a = np.tile(np.arange(PER_RING) * 2 * np.pi / PER_RING, len(z))
    zz = np.repeat(z, PER_RING)
    p = np.column_stack([centre[0] + r * np.cos(a), centre[1] + r * np.sin(a), zz])
    p[:, 2] += p[:, 1] * np.tan(tilt)
    return p[p[:, 0] <= FLAT - 0.5] if r > R_J + 0.5 else p


def measured(rng, offset=0.0, tilt=0.0, b_shift=0.0):
    """True points (collar offset by ``offset`` along y; the shoulder z = 65 tilted by
    ``tilt`` about x; journal B shifted by ``b_shift`` along y) in a random pose. Returns
    (measured, labels, faces, true points)."""
    P, faces = [], []
    for face, p in {"A": _rings(R_J, np.linspace(3, 27, RINGS)),
                    "B": _rings(R_B, np.linspace(73, 97, RINGS), (0.0, b_shift)),
                    "collar": _rings(R_C, np.linspace(38, 62, RINGS), (0.0, offset)),
                    "shoulder": np.vstack([_rings(r, np.array([65.0]), tilt=tilt)
                                           for r in (11.0, 12.0, 13.0, 14.0)]),
                    "end": _rings(5.0, np.array([0.0])),
                    "flat": np.column_stack([np.full(40, FLAT), rng.uniform(-5, 5, 40),
                                             rng.uniform(40, 60, 40)])}.items():
        P.append(p)
        faces += [face] * len(p)
    P = np.vstack(P)
    T = make_transform(rotation_from_rotvec(rng.uniform(-np.pi, np.pi, (1, 3)))[0],
                       rng.uniform(-300, 300, 3))
    M = P @ T[:3, :3].T + T[:3, 3]
    return M, np.array([f"{f}{i}" for i, f in enumerate(faces)]), np.array(faces), P


REGIONS = (Region("A", box=((-11, -11, 1), (11, 11, 29))),
           Region("B", box=((-11, -11, 71), (11, 11, 99))),
           Region("collar", box=((-16, -16, 36), (12, 16, 64))),  # clear of the flat
           Region("shoulder", box=((-16, -16, 64.5), (16, 16, 65.5))),
           Region("end", box=((-9, -9, -0.5), (9, 9, 0.5))))


def plan_of(*characteristics, fit="tangent"):
    return Plan("plan.toml", "0" * 64, Part(), REGIONS,
                (Datum("A", "A", "cylinder", fit), Datum("B", "B", "cylinder", fit)),
                Alignment("best-fit"), tuple(characteristics))


def C(ident, kind, region, zone, datums=("A",), **kw):
    return Characteristic(ident, kind, region, 0.0, zone, tuple(datums), **kw)


def _spread_about(X, point, direction, axial):
    w = X - point
    along = w @ direction
    return float(np.ptp(along if axial else
                        np.linalg.norm(w - np.outer(along, direction), axis=1)))


@pytest.mark.parametrize("seed, fit", [(1, "tangent"), (2, "lsq")])
def test_a_collar_offset_by_e_has_circular_and_total_runout_2e(nominal, seed, fit):
    """The collar's axis offset by e (along y, clear of the flat) from journal A's: circular runout (each ring: 2e) and
    total runout 2e about A, from a random pose, within 1e-6 mm."""
    rng = np.random.default_rng(seed)
    e = 0.004
    M, labels, faces, P = measured(rng, offset=e)
    res = run(nominal, M, labels, plan_of(C("1", "circular_runout", "collar", 0.01),
                                          C("2", "total_runout", "collar", 0.01),
                                          C("3", "circular_runout", "collar", 0.0079), fit=fit))
    rings = [_spread_about(P[faces == "collar"][k::RINGS], np.zeros(3), [0, 0, 1.0], False)
             for k in range(RINGS)]
    assert max(rings) == pytest.approx(2 * e, abs=1e-9)  # the true points, about the true axis
    for i in "12":
        r = by_id(res, i)
        assert r.value == pytest.approx(2 * e, abs=1e-6), r.reason
        assert r.facts["reading"] == "radial" and r.verdict == ACCEPT
    assert by_id(res, "1").facts["sections_judged"] == RINGS
    assert by_id(res, "3").verdict == REJECT and res.verdict == REJECT


@pytest.mark.parametrize("seed", [3, 4])
def test_a_tilted_shoulder_has_total_axial_runout_2_r_tan_theta(nominal, seed):
    """The shoulder z = 65 tilted by theta about x, probed on rings of radius 11 .. 14: total
    axial runout about A = 2 r tan(theta) for its largest ring r = 14, circular axial runout
    (one annulus per ring) the same, each ring's own 2 r tan(theta) in its section."""
    rng = np.random.default_rng(seed)
    theta = np.radians(0.01)
    M, labels, faces, P = measured(rng, tilt=theta)
    res = run(nominal, M, labels, plan_of(C("1", "total_runout", "shoulder", 0.01),
                                          C("2", "circular_runout", "shoulder", 0.01,
                                            sections=4)))
    truth = _spread_about(P[faces == "shoulder"], np.zeros(3), np.array([0, 0, 1.0]), True)
    assert truth == pytest.approx(2 * 14.0 * np.tan(theta), abs=1e-12)
    for i in "12":
        r = by_id(res, i)
        assert r.value == pytest.approx(truth, abs=1e-6) and r.facts["reading"] == "axial"
    per_ring = by_id(res, "2").facts["section_values"]
    assert per_ring == pytest.approx([2 * r * np.tan(theta) for r in (11, 12, 13, 14)],
                                     abs=1e-6)


def _common_axis_twin(parts):
    """The least-squares axis of coaxial cylinders with a radius each (scipy's
    least_squares over the axis' point at z = 50, its tilts and the radii)."""
    from scipy.optimize import least_squares

    def res(p):
        d = np.array([p[2], p[3], 1.0]) / np.linalg.norm([p[2], p[3], 1.0])
        out = []
        for k, X in enumerate(parts):
            w = X - np.array([p[0], p[1], 50.0])
            out.append(np.linalg.norm(w - np.outer(w @ d, d), axis=1) - p[4 + k])
        return np.concatenate(out)

    p = least_squares(res, [0, 0, 0, 0, R_J, R_B], xtol=1e-15, ftol=1e-15, gtol=1e-15).x
    return np.array([p[0], p[1], 50.0]), np.array([p[2], p[3], 1.0]) / np.linalg.norm(
        [p[2], p[3], 1.0])


def test_runout_about_a_common_datum_axis_a_b(nominal):
    """Journal B shifted by 0.01 mm: the common datum axis A-B (least squares of both
    journals, each its own radius) tilts; the collar's runout about it equals the spread of
    its true points about the twin's axis, and differs from the runout about A alone."""
    rng = np.random.default_rng(5)
    M, labels, faces, P = measured(rng, offset=0.002, b_shift=0.01)
    res = run(nominal, M, labels, plan_of(C("1", "total_runout", "collar", 0.05, ["A-B"]),
                                          C("2", "circular_runout", "collar", 0.05, ["A-B"]),
                                          C("3", "total_runout", "collar", 0.05, ["A"])))
    point, direction = _common_axis_twin([P[faces == "A"], P[faces == "B"]])
    X = P[faces == "collar"]
    truth = _spread_about(X, point, direction, False)
    rings = max(_spread_about(X[k::RINGS], point, direction, False) for k in range(RINGS))
    assert by_id(res, "1").value == pytest.approx(truth, abs=1e-6)
    assert by_id(res, "2").value == pytest.approx(rings, abs=1e-6)
    assert by_id(res, "3").value == pytest.approx(0.004, abs=1e-6)
    assert abs(truth - 0.004) > 1e-4  # the common axis is not A's
    assert "coaxial features together" in by_id(res, "1").facts["datum_axis_fit"]


def test_guarded_rule_guards_runout_with_its_uncertainty(nominal):
    from engine.uncertainty import Instrument

    rng = np.random.default_rng(6)
    M, labels, _, _ = measured(rng, offset=0.004)
    res = run(nominal, M, labels, plan_of(C("1", "total_runout", "collar", 0.0085),
                                          C("2", "total_runout", "collar", 0.5)),
              decision_rule="guarded", instrument=Instrument(uncertainty_mm=0.001))
    assert by_id(res, "1").facts["uncertainty_bound"] >= 0.002
    assert by_id(res, "1").verdict == INCONCLUSIVE and by_id(res, "2").verdict == ACCEPT


def test_a_runout_of_a_face_neither_round_about_nor_normal_to_the_axis_is_refused(nominal):
    """The key flat (x = 13) is parallel to the axis, not round about it: refused, naming the
    characteristic."""
    from engine.errors import InputError

    rng = np.random.default_rng(7)
    M, labels, _, _ = measured(rng)
    regions = REGIONS + (Region("flat", box=((12.5, -5, 40), (13.5, 5, 60))),)
    plan = Plan("plan.toml", "0" * 64, Part(), regions, (Datum("A", "A", "cylinder"),),
                Alignment("best-fit"), (C("1", "total_runout", "flat", 0.01),))
    with pytest.raises(InputError, match="'1': region 'flat' is neither a surface of "
                       "revolution about the axis of datum A nor a face normal to it"):
        run(nominal, M, labels, plan)


def _flat_points(rng, wave, twist):
    """The key flat x = 13 probed on lines z = 40, 45, .., 60 (30 points each, y in -5 .. 5:
    sections as a CMM scans them; points off the plane would carry the registration's tilt
    across it, which no refit within the plane removes): x waved by ``wave`` along y and twisted (each line tilted by ``twist`` x its
    height above z = 50, per mm)."""
    z = np.repeat(np.arange(40.0, 61.0, 5.0), 30)
    y = rng.uniform(-5, 5, 150)
    x = FLAT + wave * np.sin(2 * np.pi * y / 7 + z) + twist * (z - 50) * y
    return np.column_stack([x, y, z])


def _line_zone(u, w, minimax):
    """A section's profile value, its line refitted alone: least squares (polyfit) or the
    minimum zone of |w - (a + b u)| (a linear program), as twice the largest |residual|."""
    from scipy.optimize import linprog

    if not minimax:
        return 2 * float(np.max(np.abs(w - np.polyval(np.polyfit(u, w, 1), u))))
    one = np.ones_like(u)
    # a + b u - h <= w and -(a + b u) - h <= -w: |w - (a + b u)| <= h, h the smallest.
    lp = linprog([0, 0, 1], A_ub=np.vstack([np.column_stack([one, u, -one]),
                                            np.column_stack([-one, -u, -one])]),
                 b_ub=np.concatenate([w, -w]), bounds=[(None, None)] * 2 + [(0, None)],
                 method="highs")
    return 2 * float(lp.x[2])


@pytest.mark.parametrize("fit", ["lsq", "minimax"])
def test_line_profile_of_a_twisted_waved_flat_refits_each_section(nominal, fit):
    """The flat, waved and twisted, probed on 5 lines: a form-only line profile normal to z
    every 5 mm refits each line in its plane: each section's value is its line's own refit
    (polyfit / a linear program on the true points), the largest reported; the twist, which
    no refit of the whole face removes, leaves the surface profile wider."""
    rng = np.random.default_rng(8)
    M, labels, faces, P = measured(rng)
    F = _flat_points(rng, 0.002, 4e-5)
    T = make_transform(rotation_from_rotvec(rng.uniform(-np.pi, np.pi, (1, 3)))[0],
                       rng.uniform(-300, 300, 3))
    # The rest of the part (its own flat points replaced) at the same random pose.
    P = np.vstack([P[faces != "flat"], F])
    M = P @ T[:3, :3].T + T[:3, 3]
    labels = np.array([f"p{i}" for i in range(len(P))])
    regions = REGIONS + (Region("flat", box=((12.5, -5.5, 37), (13.5, 5.5, 63))),)
    plan = Plan("plan.toml", "0" * 64, Part(), regions, (Datum("A", "A", "cylinder"),),
                Alignment("best-fit"),
                (Characteristic("1", "line_profile", "flat", -0.01, 0.01, fit=fit,
                                direction=(0.0, 0.0, 1.0), spacing=5.0),
                 Characteristic("2", "profile", "flat", -0.01, 0.01, fit=fit, all_around=True),
                 Characteristic("3", "profile", "flat", -0.01, 0.01, fit=fit)))
    res = run(nominal, M, labels, plan)
    k = np.rint(F[:, 2] / 5.0)
    truth = [_line_zone(F[k == s, 1], F[k == s, 0], fit == "minimax") for s in np.unique(k)]
    r = by_id(res, "1")
    assert r.facts["section_values"] == pytest.approx(truth, abs=1e-6)
    assert r.value == pytest.approx(max(truth), abs=1e-6) and r.verdict == ACCEPT
    assert r.facts["section_points"] == [30] * 5
    assert r.facts["section_positions"] == [40.0, 45.0, 50.0, 55.0, 60.0]
    assert by_id(res, "2").value == by_id(res, "3").value > r.value + 0.002


def _files(tmp_path, nominal, rng, **planted):
    M, _, _, _ = measured(rng, **planted)
    head = "x y z i j k"
    np.savetxt(tmp_path / "n.xyz", np.column_stack([nominal.points,
                                                    nominal.normals(np.arange(nominal.n))]),
               header=head, comments="", fmt="%.9f")
    np.savetxt(tmp_path / "m.csv", M, delimiter=",", header="x,y,z", comments="", fmt="%.9f")
    return str(tmp_path / "n.xyz"), str(tmp_path / "m.csv")


TOML_REGIONS = "".join(f'[[region]]\nname = "{r.name}"\nbox = {[list(c) for c in r.box]}\n'
                       for r in REGIONS) + \
    '[[datum]]\nlabel = "A"\nregion = "A"\nfeature = "cylinder"\n' \
    '[[datum]]\nlabel = "B"\nregion = "B"\nfeature = "cylinder"\n' \
    '[[region]]\nname = "shoulders"\nbox = [[-16, -16, 34.5], [16, 16, 35.5]]\n' \
    '[[datum]]\nlabel = "E"\nregion = "end"\nfeature = "plane"\n'


def test_runout_and_line_profile_through_the_command_line_json_and_qif(tmp_path, nominal):
    """A TOML plan with each new type: its JSON type, symbol and keys; the QIF's circular and
    total runout and line profile characteristic types, valid against the QIF 3.0 XSD."""
    import csv
    import json

    from lxml import etree

    from qa_app.cli import main
    from reports.qif import qif_results_document

    nom, meas = _files(tmp_path, nominal, np.random.default_rng(9), offset=0.003)
    plan = tmp_path / "plan.toml"
    plan.write_text(TOML_REGIONS + """
[[characteristic]]
id = "1"
type = "circular_runout"
region = "collar"
zone = 0.02
datums = ["A-B"]
sections = 3
[[characteristic]]
id = "2"
type = "total_runout"
region = "collar"
zone = 0.02
datums = ["A"]
[[characteristic]]
id = "3"
type = "line_profile"
region = "collar"
zone = 0.5
direction = [0, 0, 1]
spacing = 10
all_around = true
fit = "minimax"
""")
    code = main(["inspect", nom, meas, "--plan", str(plan), "--json", str(tmp_path / "r.json"),
                 "--csv", str(tmp_path / "r.csv"), "--report", str(tmp_path / "r.pdf")])
    doc = json.loads((tmp_path / "r.json").read_text())
    chars = {c["id"]: c for c in doc["characteristics"]}
    assert code == 0, [c["reason"] for c in doc["characteristics"]]
    assert [chars[i]["symbol"] for i in "123"] == ["↗", "⌰", "⌒"]
    assert chars["1"]["sections"] == 3 and chars["1"]["datums"] == ["A-B"]
    assert chars["2"]["value"] == pytest.approx(0.006, abs=1e-6)
    assert chars["3"]["spacing"] == 10.0 and chars["3"]["all_around"] is True
    assert chars["3"]["section_points"] and chars["3"]["direction"] == [0.0, 0.0, 1.0]
    with open(tmp_path / "r.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    data = qif_results_document(
        doc, np.array([[float(r[k]) for k in ("x_reg", "y_reg", "z_reg")] for r in rows]),
        np.array([float(r["deviation"]) for r in rows]),
        np.array([r["in_tolerance"] == "true" for r in rows]))
    root = __file__.rsplit("/tests/", 1)[0]
    schema = etree.XMLSchema(etree.parse(f"{root}/tests/data/qif-3.0-xsd/QIFDocument.xsd"))
    tree = etree.ElementTree(etree.fromstring(data))
    assert schema.validate(tree), "\n".join(str(e) for e in schema.error_log)
    tags = {etree.QName(e).localname for e in tree.iter()}
    for kind in ("CircularRunout", "TotalRunout", "LineProfile"):
        assert f"{kind}CharacteristicDefinition" in tags
        assert f"{kind}CharacteristicMeasurement" in tags


@pytest.mark.parametrize("body, key, words", [
    ('type = "total_runout"\nregion = "collar"\nzone = 0.05\ndatums = ["E"]\n', "datums",
     'names datum "E", a plane: a total_runout is about a datum axis'),
    ('type = "circular_runout"\nregion = "collar"\nzone = 0.05\n', "datums",
     "must name one datum axis"),
    ('type = "total_runout"\nregion = "collar"\nzone = 0.05\ndatums = ["A", "B"]\n', "datums",
     "must name one datum axis"),
    ('type = "total_runout"\nregion = "collar"\nzone = 0.05\ndatums = ["A-E"]\n', "datums",
     "a common datum joins two datums of one kind"),
    ('type = "total_runout"\nregion = "collar"\nzone = 0.05\ndatums = ["A-C"]\n', "datums",
     'names "A-C", which is not the label of any [[datum]]'),
    ('type = "total_runout"\nregion = "collar"\nzone = 0.05\ndatums = ["A"]\nsections = 3\n',
     "sections", "applies to straightness and circularity and circular_runout only"),
    ('type = "line_profile"\nregion = "collar"\nzone = 0.05\nspacing = 5\n', "direction",
     "is missing: a line profile needs the normal of its section planes"),
    ('type = "line_profile"\nregion = "collar"\nzone = 0.05\ndirection = [0, 0, 1]\n',
     "spacing", "is missing"),
    ('type = "line_profile"\nregion = "collar"\nzone = 0.05\ndirection = [0, 0, 1]\n'
     'spacing = -1\n', "spacing", "must be > 0"),
    ('type = "profile"\nregion = "collar"\nzone = 0.05\nall_around = 1\n', "all_around",
     "true or false"),
    ('type = "total_runout"\nregion = "collar"\nzone = 0.05\ndatums = ["A"]\nall_around = '
     'true\n', "all_around", "applies to profile and line_profile only"),
])
def test_bad_runout_and_line_profile_plans_are_refused_with_65(tmp_path, capsys, nominal, body,
                                                                key, words):
    from qa_app.cli import main

    nom, meas = _files(tmp_path, nominal, np.random.default_rng(10))
    plan = tmp_path / "plan.toml"
    plan.write_text(TOML_REGIONS + '[[characteristic]]\nid = "7"\n' + body)
    assert main(["inspect", nom, meas, "--plan", str(plan)]) == 65
    err = capsys.readouterr().err
    assert f"{plan}: [[characteristic]] #1 (id \"7\"): '{key}' " in err, err
    assert words in err, err


def test_a_region_of_several_groups_is_their_union(tmp_path):
    """group = ["a", "b"] selects the nominal points of both groups; a missing one is named."""
    from engine.errors import InputError
    from engine.gdt.regions import nominal_members
    from engine.io.plan import read_plan

    path = tmp_path / "plan.toml"
    path.write_text('[[region]]\nname = "R"\ngroup = ["a", "b"]\n[[characteristic]]\nid = "1"'
                    '\ntype = "profile"\nregion = "R"\nzone = 0.1\nall_around = true\n')
    plan = read_plan(path)
    assert plan.regions[0].group == ("a", "b") and plan.characteristics[0].all_around
    groups = {"a": np.array([0, 1]), "b": np.array([3]), "c": np.array([2])}
    mask = nominal_members(plan, np.zeros((5, 3)), None, groups)["R"]
    assert mask.tolist() == [True, True, False, True, False]
    with pytest.raises(InputError, match="the nominal has no group 'b'"):
        nominal_members(plan, np.zeros((5, 3)), None, {"a": np.array([0])})
    path.write_text('[[region]]\nname = "R"\ngroup = []\n')
    with pytest.raises(InputError, match="'group' is empty"):
        read_plan(path)


@pytest.mark.parametrize("seed", [1, 3])
def test_a_least_squares_refit_of_a_cylinder_does_not_slide_along_it(nominal, seed):
    """A form-only profile refitted by least squares on the collar (a cylinder: its turn and its
    slide along the axis are free) of a shaft whose collar is 3 µm off: the refit leaves the
    free motions alone, so the profile is the nominal sample's own chordal error, the same from
    any pose, and well inside ±0.025 mm. (It slid the points along the axis off the collar's
    ends: 0.27 mm and REJECT from seed 3's pose, 0.048 from seed 1's.) The minimax refit is
    the independent check: both stay within 0.001 mm."""
    M, labels, _, _ = measured(np.random.default_rng(seed), offset=0.003)
    plan = plan_of(*(Characteristic(i, "profile", "collar", -0.025, 0.025, (), fit=f)
                     for i, f in (("1", "lsq"), ("2", "minimax"))))
    res = run(nominal, M, labels, plan)
    lsq, minimax = by_id(res, "1"), by_id(res, "2")
    assert lsq.verdict == minimax.verdict == "ACCEPT"
    assert lsq.value < 0.001 and minimax.value < 0.001
