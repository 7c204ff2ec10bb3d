"""Dimensions of a plan (engine.gdt.dimensions): a radius, the angle between two features and
the distance between two features, on a synthetic part measured in a random pose with planted
errors and noise; each value against the construction's own number (analytic geometry
written here), and bad plans refused naming the plan, the table and the key."""

import numpy as np
import pytest

from engine.gdt.characteristics import inspect_plan
from engine.gdt.plan import Alignment, Characteristic, Part, Plan, Region
from engine.inspection import Tolerance, inspect
from engine.nominal import Nominal
from engine.pointset import PointSet
from engine.pose import rotation_from_rotvec
from engine.verdict import ACCEPT, REJECT
from plan_runs import by_id

# Faces of a part (not closed: each a patch of its surface), mm:
# base z = 0 (x 0 .. 100, y 0 .. 60, normal -z); top z = 20 (x 0 .. 60); a ramp down from the
# top's edge x = 60 at RAMP degrees below it (normal (sin, 0, cos)); side x = 0 (normal -x); a
# hole of radius 5 along z at (20, 30); a pin of radius 4 along z at (45, 15), z 20 .. 35; a
# ball of radius 4 centred (30, 50, 26) (its upper half); a fillet: a quarter cylinder of
# radius 3 along y about (90, y, 10), its outward normals from +x to +z.
RAMP, TOP, HOLE, PIN, BALL, FILLET = 30.0, 20.0, (20.0, 30.0), (45.0, 15.0), (30, 50, 26), 3.0


def _faces(rng, n, turn=0.0, lift=0.0, fillet=0.0, noise=0.0, gap=0.0):
    """{face: (points, outward normals)}: ``n`` points a face, the ramp turned by ``turn``
    degrees more about the top's edge, the top lifted by ``lift``, the fillet's radius grown
    by ``fillet``; each point twice, ``noise`` mm out and in along its normal (a noise whose
    least-squares features are the construction's); with a ``gap`` (the measured part) the
    base and top that far off the hole's and the pin's feet and every face's points off its
    edges (a probe keeps off them), else (the nominal) over whole faces."""
    u, v = rng.uniform(0.05, 0.95, (2, n)) if gap else rng.uniform(0, 1, (2, n))
    out = {"base": (np.column_stack([100 * u, 60 * v, 0 * u]), [0, 0, -1.0]),
           "top": (np.column_stack([60 * u, 60 * v, TOP + lift + 0 * u]), [0, 0, 1.0]),
           "side": (np.column_stack([0 * u, 60 * v, 20 * u]), [-1.0, 0, 0])}
    a = np.radians(RAMP + turn)
    s = 15 * u  # along the ramp, down from the top's edge
    out["ramp"] = (np.column_stack([60 + s * np.cos(a), 60 * v, TOP - s * np.sin(a)]),
                   [np.sin(a), 0, np.cos(a)])
    for k, holes in (("base", (HOLE,)), ("top", (HOLE, PIN))):  # the hole goes through
        p, m = out[k]
        keep = np.all([np.hypot(p[:, 0] - c[0], p[:, 1] - c[1]) > 5 + gap for c in holes], axis=0)
        out[k] = (p[keep], m)
    out = {k: (p, np.broadcast_to(np.asarray(m), p.shape)) for k, (p, m) in out.items()}
    t = 2 * np.pi * u
    e = np.column_stack([np.cos(t), np.sin(t), 0 * t])
    out["hole"] = (np.column_stack([HOLE[0] + 5 * e[:, 0], HOLE[1] + 5 * e[:, 1], 20 * v]), -e)
    out["pin"] = (np.column_stack([PIN[0] + 4 * e[:, 0], PIN[1] + 4 * e[:, 1],
                                   20 + 15 * v]), e)
    lat = np.arcsin(v * 0.98)
    g = np.column_stack([np.cos(lat) * np.cos(t), np.cos(lat) * np.sin(t), np.sin(lat)])
    out["ball"] = (np.asarray(BALL) + 4 * g, g)
    q = 0.5 * np.pi * u
    f = np.column_stack([np.cos(q), 0 * q, np.sin(q)])
    out["fillet"] = (np.array([90.0, 0, 10]) + (FILLET + fillet) * f + np.outer(60 * v,
                                                                                 [0, 1, 0]), f)
    if noise:
        out = {k: (np.vstack([p + noise * m, p - noise * m]), np.vstack([m, m]))
               for k, (p, m) in out.items()}
    return out


@pytest.fixture(scope="module")
def nominal():
    f = _faces(np.random.default_rng(7), 4000)
    names = list(f)
    P = np.vstack([p for p, _ in f.values()])
    groups, at = {}, 0
    for name in names:
        groups[name] = np.arange(at, at + len(f[name][0]))
        at += len(f[name][0])
    return Nominal.from_point_set(PointSet(P, np.vstack([m for _, m in f.values()]))), groups


def _run(nominal, plan, seed, rule=None, **planted):
    rng = np.random.default_rng(seed)
    f = _faces(rng, 300, noise=0.002, gap=2.0, **planted)
    P = np.vstack([p for p, _ in f.values()])
    R = rotation_from_rotvec(rng.uniform(-np.pi, np.pi, (1, 3)))[0]
    M = P @ R.T + rng.uniform(-300, 300, 3)
    nom, groups = nominal
    res = inspect(nom, M, Tolerance.symmetric(0.5), **(rule or {}))
    return inspect_plan(res, plan, nom, None, M, None, False, nominal_groups=groups)


def _plan(*characteristics):
    regions = tuple(Region(k, group=k) for k in ("base", "top", "side", "ramp", "hole", "pin",
                                                 "ball", "fillet"))
    return Plan("plan.toml", "0" * 64, Part(), regions, (), Alignment("best-fit"),
                tuple(characteristics))


def D(ident, kind, regions, nominal, lower, upper, features=("plane", "plane")):
    return Characteristic(ident, kind, regions[0], lower, upper, nominal=nominal,
                          regions=tuple(regions), features=tuple(features))


PLAN = _plan(
    D("a", "angle", ("top", "ramp"), 30.0, -0.5, 0.5),
    D("a150", "angle", ("ramp", "top"), 150.0, -0.5, 0.5),
    D("a90", "angle", ("base", "side"), 90.0, -0.5, 0.5),
    D("ax", "angle", ("ramp", "hole"), 60.0, -0.5, 0.5, ("plane", "cylinder")),
    D("d", "distance", ("base", "top"), 20.0, -0.1, 0.1),
    D("dh", "distance", ("side", "hole"), 20.0, -0.1, 0.1, ("plane", "cylinder")),
    D("dhp", "distance", ("hole", "pin"), float(np.hypot(25, 15)), -0.1, 0.1,
      ("cylinder", "cylinder")),
    D("db", "distance", ("ball", "hole"), float(np.hypot(10, 20)), -0.1, 0.1,
      ("sphere", "cylinder")),
    D("dbt", "distance", ("top", "ball"), 6.0, -0.1, 0.1, ("plane", "sphere")),
    Characteristic("r", "radius", "fillet", -0.1, 0.1, nominal=FILLET),
    Characteristic("rb", "radius", "ball", -0.1, 0.1, nominal=4.0, kind="sphere"),
    Characteristic("rh", "radius", "hole", -0.1, 0.1, nominal=5.0))


@pytest.mark.parametrize("seed", [1, 2])
def test_each_dimension_equals_the_construction(nominal, seed):
    res = _run(nominal, PLAN, seed)
    expected = {"a": 30.0, "a150": 150.0, "a90": 90.0, "ax": 60.0, "d": 20.0, "dh": 20.0,
                "dhp": np.hypot(25, 15), "db": np.hypot(10, 20), "dbt": 6.0, "r": FILLET,
                "rb": 4.0, "rh": 5.0}
    for ident, value in expected.items():
        r = by_id(res, ident)
        tol = 1e-5 if r.characteristic.type == "angle" else 1e-6
        assert r.value == pytest.approx(value, abs=tol), (ident, r.reason)
        assert r.verdict == ACCEPT, (ident, r.reason)
    assert res.plan.verdict == ACCEPT
    angle = by_id(res, "a")
    assert angle.characteristic.unit == "degree" and by_id(res, "d").characteristic.unit == "mm"
    assert "°" in angle.reason and " mm" not in angle.reason
    assert angle.facts["model_value"] == pytest.approx(30.0, abs=1e-9)


def test_planted_errors_move_their_dimension_only(nominal):
    """The ramp turned 0.8° more, the top lifted 0.3 mm, the fillet grown 0.25 mm: the angle
    is 30.8° (REJECT against ±0.5°), the distance 20.3 (REJECT), the radius 3.25 (REJECT); the
    distance of the side to the hole stays (ACCEPT)."""
    res = _run(nominal, PLAN, 3, turn=0.8, lift=0.3, fillet=0.25)
    for ident, value in {"a": 30.8, "a150": 149.2, "d": 20.3, "r": 3.25}.items():
        r = by_id(res, ident)
        tol = 1e-5 if r.characteristic.type == "angle" else 1e-6
        assert r.value == pytest.approx(value, abs=tol), (ident, r.reason)
        assert r.verdict == REJECT, (ident, r.reason)
    assert by_id(res, "dh").verdict == ACCEPT and by_id(res, "a90").verdict == ACCEPT
    assert by_id(res, "dbt").value == pytest.approx(6.0 - 0.3, abs=1e-6)
    assert res.plan.verdict == REJECT


def test_the_guarded_rule_guards_an_angle_by_the_tilt_its_uncertainty_allows(nominal):
    """U about 1 µm: a distance is guarded by 2U, a radius by half a diameter's bound, the angle between the top (54
    mm across its narrower way) and the ramp (13.5 mm down its slope) by 2U / 13.5 mm + 2U /
    54 mm in degrees; the ramp turned 0.495° (0.005° inside its limit) is INCONCLUSIVE
    guarded, ACCEPT by the simple rule."""
    from engine.uncertainty import Instrument

    plan = _plan(D("a", "angle", ("top", "ramp"), 30.0, -0.5, 0.5),
                 D("d", "distance", ("base", "top"), 20.0, -0.1, 0.1),
                 Characteristic("r", "radius", "fillet", -0.1, 0.1, nominal=FILLET),
                 Characteristic("s", "size", "fillet", -0.2, 0.2, nominal=2 * FILLET))
    guarded = {"decision_rule": "guarded", "instrument": Instrument(uncertainty_mm=0.001)}
    res = _run(nominal, plan, 5, guarded, turn=0.495)
    a, d = by_id(res, "a"), by_id(res, "d")
    two_u = d.facts["uncertainty_bound"]  # 2U of the planes' points (U: 1 µm stated, expanded)
    assert 0.0015 <= two_u <= 0.0025
    assert a.facts["uncertainty_bound"] == pytest.approx(
        np.degrees(two_u / 13.5 + two_u / 54), rel=0.02), a.facts
    assert a.value == pytest.approx(30.495, abs=1e-5)
    assert a.verdict == "INCONCLUSIVE" and "°" in a.reason and "tilt" in a.reason, a.reason
    r, size = by_id(res, "r"), by_id(res, "s")  # (their sampling margins on the curve too)
    assert r.facts["uncertainty_bound"] == pytest.approx(0.5 * size.facts["uncertainty_bound"])
    assert r.value == pytest.approx(0.5 * size.value, abs=1e-12) and r.verdict == ACCEPT
    assert by_id(_run(nominal, plan, 5, turn=0.495), "a").verdict == ACCEPT


def test_a_plan_nominal_the_model_does_not_have_is_refused(nominal):
    """An angle of 45° between faces at 30° (150°), a distance between a plane and a plane at
    30° to it: the plan does not fit its part (InputError naming the characteristic)."""
    from engine.errors import InputError

    with pytest.raises(InputError, match=r"'bad'.*30\.0000° \(or 150\.0000°\) on the nominal, "
                                         r"not the 45° the plan states"):
        _run(nominal, _plan(D("bad", "angle", ("top", "ramp"), 45.0, -0.5, 0.5)), 4)
    with pytest.raises(InputError, match=r"'bad'.*no parallel planes on the nominal"):
        _run(nominal, _plan(D("bad", "distance", ("top", "ramp"), 5.0, -0.5, 0.5)), 4)


# ---------------------------------------------------------------- the TOML contract
TOML_REGIONS = "".join(f'[[region]]\nname = "{k}"\ngroup = "{k}"\n'
                       for k in ("top", "ramp", "hole", "ball", "fillet"))
GOOD = TOML_REGIONS + """
[[characteristic]]
id = "r"
type = "radius"
region = "fillet"
nominal = 3
lower = -0.1
upper = 0.1

[[characteristic]]
id = "rb"
type = "radius"
region = "ball"
nominal = 4.0
lower = -0.1
upper = 0.05
feature = "sphere"

[[characteristic]]
id = "a"
type = "angle"
regions = ["top", "ramp"]
nominal = 150
lower = -0.5
upper = 0.25

[[characteristic]]
id = "d"
type = "distance"
regions = ["ramp", "hole"]
nominal = 40.0
lower = -0.2
upper = 0.1
features = ["plane", "cylinder"]
"""


def _write(tmp_path, text):
    path = tmp_path / "plan.toml"
    path.write_text(text, encoding="utf-8")
    return str(path)


def test_the_toml_plan_reads_each_dimension_into_the_exact_characteristic(tmp_path):
    from engine.io.plan import read_plan

    plan = read_plan(_write(tmp_path, GOOD))
    assert plan.characteristics == (
        Characteristic("r", "radius", "fillet", -0.1, 0.1, nominal=3.0),
        Characteristic("rb", "radius", "ball", -0.1, 0.05, nominal=4.0, kind="sphere"),
        Characteristic("a", "angle", "top", -0.5, 0.25, nominal=150.0, regions=("top", "ramp"),
                       features=("plane", "plane")),
        Characteristic("d", "distance", "ramp", -0.2, 0.1, nominal=40.0,
                       regions=("ramp", "hole"), features=("plane", "cylinder")))
    assert [c.unit for c in plan.characteristics] == ["mm", "mm", "degree", "mm"]


def _char(body):
    return TOML_REGIONS + '[[characteristic]]\nid = "7"\n' + body


ANGLE = 'type = "angle"\nregions = ["top", "ramp"]\n'
BAD = [
    ("an angle with one region", _char('type = "angle"\nregion = "top"\nnominal = 30\n'
                                       'lower = -1\nupper = 1\n'), "region",
     "is not how an angle names its features: give regions = [\"a\", \"b\"]"),
    ("an angle of three", _char('type = "angle"\nregions = ["top", "ramp", "hole"]\n'
                                'nominal = 30\nlower = -1\nupper = 1\n'), "regions",
     "names 3 regions; an angle is between two features"),
    ("an unknown region", _char('type = "angle"\nregions = ["top", "nope"]\nnominal = 30\n'
                                'lower = -1\nupper = 1\n'), "regions",
     'names "nope", which is not the name of any [[region]]'),
    ("an angle of 200°", _char(ANGLE + "nominal = 200\nlower = -1\nupper = 1\n"), "nominal",
     "must be an angle between 0 and 180 degrees"),
    ("an angle past 180°", _char(ANGLE + "nominal = 179.5\nlower = -1\nupper = 1\n"), "upper",
     "takes the angle beyond 0 .. 180 degrees"),
    ("an angle as a zone", _char(ANGLE + "nominal = 30\nzone = 1\n"), "zone",
     "does not apply to angle: give 'nominal' and 'lower' and 'upper' (offsets about it, "
     "degrees)"),
    ("an angle without limits", _char(ANGLE + "nominal = 30\nlower = -1\n"), "upper",
     "is missing: an angle has 'lower' and 'upper' limits about its nominal (degrees)"),
    ("an angle with datums", _char(ANGLE + 'nominal = 30\nlower = -1\nupper = 1\n'
                                   'datums = ["A"]\n'), "datums",
     "must not be given: an angle is a dimension, relative to no datum"),
    ("an angle to a sphere", _char(ANGLE + 'nominal = 30\nlower = -1\nupper = 1\n'
                                   'features = ["plane", "sphere"]\n'), "features",
     "must be two of plane, cylinder (one per region"),
    ("a distance without nominal", _char('type = "distance"\nregions = ["top", "ramp"]\n'
                                         'lower = -1\nupper = 1\n'), "nominal",
     "is missing (the nominal distance, mm)"),
    ("a distance's limits upside down", _char('type = "distance"\nregions = ["top", "hole"]\n'
                                              'nominal = 5\nlower = 1\nupper = -1\n'), "upper",
     "must be above 'lower'"),
    ("a radius of a width", _char('type = "radius"\nregion = "hole"\nnominal = 5\nlower = -1\n'
                                  'upper = 1\nfeature = "width"\n'), "feature",
     "must be one of cylinder, sphere"),
    ("a radius of two", _char('type = "radius"\nregions = ["hole", "ball"]\nnominal = 5\n'
                              'lower = -1\nupper = 1\n'), "regions",
     "is not how a radius names its feature: give 'region'"),
    ("a radius leaving none", _char('type = "radius"\nregion = "hole"\nnominal = 5\n'
                                    'lower = -5\nupper = 1\n'), "lower",
     "leaves no radius: nominal 5 + lower -5 must be > 0"),
    ("a radius with a method", _char('type = "radius"\nregion = "hole"\nnominal = 5\n'
                                     'lower = -1\nupper = 1\nmethod = "two-point"\n'), "method",
     "does not apply to radius (its keys are id, type, region, nominal, lower, upper, feature, name, designator, source)"),
    ("features on a profile", _char('type = "profile"\nregion = "top"\nzone = 0.1\n'
                                    'features = ["plane", "plane"]\n'), "features",
     "applies to angle and distance only, not profile"),
    ("a region two features at once", _char('type = "radius"\nregion = "hole"\nnominal = 5\n'
                                            'lower = -1\nupper = 1\n') +
     '[[characteristic]]\nid = "8"\ntype = "distance"\nregions = ["top", "hole"]\n'
     'nominal = 5\nlower = -1\nupper = 1\n', "type",
     '"distance" is judged on a plane and region "hole" is no plane: characteristic "7" '
     "(radius) takes it for a cylinder"),
]


@pytest.mark.parametrize("text, key, words", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_dimensions_are_refused_naming_file_table_and_key(tmp_path, text, key, words):
    from engine.errors import InputError
    from engine.io.plan import read_plan

    path = _write(tmp_path, text)
    with pytest.raises(InputError) as e:
        read_plan(path)
    message = str(e.value)
    number = "#2 (id \"8\")" if "id = \"8\"" in text else "#1 (id \"7\")"
    assert message.startswith(f"{path}: [[characteristic]] {number}: '{key}' "), message
    assert words in message, message


def test_a_bad_dimension_exits_65_on_the_command_line(tmp_path, capsys):
    from qa_app.cli import main

    plan = _write(tmp_path, _char(ANGLE + "nominal = 200\nlower = -1\nupper = 1\n"))
    np.savetxt(tmp_path / "m.csv", np.eye(3) * 10, delimiter=",")
    np.savetxt(tmp_path / "n.csv", np.eye(3) * 10, delimiter=",")
    code = main(["inspect", str(tmp_path / "n.csv"), str(tmp_path / "m.csv"), "--plan", plan])
    assert code == 65
    assert f"{plan}: [[characteristic]] #1 (id \"7\"): 'nominal' must be an angle" in \
        capsys.readouterr().err
