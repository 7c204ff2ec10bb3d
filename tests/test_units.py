"""Units a file gets wrong (engine.units): a nominal and measured points whose sizes differ by
the factor between two length units are never a verdict; the reason says so and names what
reads the file right (issue 22, item 11).

The truths: a rectangle outline's RMS extents in closed form; the real gear drawing
tests/data/dxf/gear_z20.dxf, whose header says metres over numbers in millimetres (tip
diameter 56 mm: SOURCE.txt); a doubly curved 500 x 250 mm surface measured in metres.
"""

import os

import numpy as np
import pytest

from engine.contour import points_on
from engine.pose import apply_transform, make_transform, pose_2d
from engine.io.templates import read_dxf_template
from engine.units import UNIT_FACTORS, principal_sizes, unit_factor, unit_mismatch
from qa_app.cli import main
from surfaces import height, height_normal, random_rotation, write_grid_nominal

GEAR = os.path.join(os.path.dirname(__file__), "data", "dxf", "gear_z20.dxf")


def run(*args):
    return main([str(a) for a in args])


# ---------------------------------------------------------------------------- the sizes
def rectangle_outline(a, b, n):
    """n points evenly along the outline of an a x b rectangle centred at 0 (z = 0)."""
    s = (np.arange(n) + 0.5) / n * 2 * (a + b)
    corners = np.array([[-a / 2, -b / 2], [a / 2, -b / 2], [a / 2, b / 2], [-a / 2, b / 2]])
    lengths = np.array([a, b, a, b])
    side = np.minimum(np.searchsorted(np.cumsum(lengths), s, side="right"), 3)
    u = (s - np.r_[0, np.cumsum(lengths)][side]) / lengths[side]
    p = corners[side] + u[:, None] * (corners[(side + 1) % 4] - corners[side])
    return np.column_stack([p, np.zeros(n)])


def test_principal_sizes_of_a_rectangle_outline_in_any_pose():
    # By length, x is uniform on the two sides of length a and +-a/2 on the two of length b:
    # E[x^2] = a^2 (a + 3b) / (12 (a + b)); likewise y.
    a, b = 40.0, 10.0
    want = [np.sqrt(a * a * (a + 3 * b) / (12 * (a + b))),
            np.sqrt(b * b * (b + 3 * a) / (12 * (a + b))), 0.0]
    rng = np.random.default_rng(5)
    P = rectangle_outline(a, b, 20000)
    for _ in range(3):
        T = make_transform(random_rotation(rng), rng.uniform(-1e4, 1e4, 3))
        assert np.allclose(principal_sizes(apply_transform(T, P)), want, rtol=1e-3, atol=1e-6)
    assert np.allclose(principal_sizes(P[:, :2]), want, rtol=1e-3, atol=1e-6)  # (n, 2) alike
    # Beyond SIZE_POINTS, every k-th point: as right.
    assert np.allclose(principal_sizes(rectangle_outline(a, b, 450_001)), want, rtol=1e-3)


def test_sizes_match_at_a_units_factor_only():
    s = np.array([14.0, 4.6, 0.3])
    for f in UNIT_FACTORS:
        assert unit_factor(f * s, s) == f and unit_factor(s, f * s) == 1 / f
    # Within 5% of a tenth, 15% of the other factors, as stated.
    for f, near, far in ((10.0, 1.04, 1.07), (25.4, 1.12, 1.2), (304.8, 0.88, 0.8),
                         (1000.0, 1.12, 1.2)):
        assert unit_factor(near * f * s, s) == f and unit_factor(far * f * s, s) is None
    for other in (1.0, 2.0, 50.0, 2000.0):
        assert unit_factor(other * s, s) is None
    # A part measured in part: a tenth of its length, but not of its other proportions.
    assert unit_factor(s, np.array([1.4, 1.2, 0.03])) is None
    assert unit_factor(s, np.zeros(3)) is None and unit_factor(np.zeros(3), s) is None


@pytest.mark.parametrize("kind, mm_per_unit, f, words", [
    ("dxf", 1000.0, 1000.0, "read it with --units mm"),  # header metres, numbers mm
    ("dxf", 25.4, 25.4, "read it with --units mm"),  # header inches, numbers mm
    ("dxf", 1.0, 1 / 25.4, "read it with --units in"),  # unitless (mm), numbers inches
    ("dxf", 304.8, 304.8, "read it with --units mm"),  # header feet, numbers mm
    ("airfoil", 0.3, 1 / 1000, "give --scale 300 (the chord in mm)"),  # the chord in metres
    ("points", 1.0, 1 / 1000, "if the nominal's numbers are metres"),
    ("points", 1.0, 1000.0, "if the measured points are in metres, say so in their file "
                            "(a line '# units: m'"),
    ("step", 1.0, 25.4, "if the measured points are in inches"),
])
def test_the_message_names_what_reads_the_file_right(kind, mm_per_unit, f, words):
    measured = np.array([20.0, 18.0, 0.0])
    said = unit_mismatch(f * measured, measured, kind, mm_per_unit)
    big = max(f, 1 / f)
    assert said.startswith(f"the {'nominal is' if f > 1 else 'measured points are'} {big:g} x "
                           "the size of the"), said
    assert words in said, said
    assert unit_mismatch(measured, measured, kind, mm_per_unit) is None


# ---------------------------------------------------------------------------- the inspections
@pytest.fixture(scope="module")
def gear_points(tmp_path_factory):
    """400 points on the gear's contours as drawn (mm), 2 um noise, turned and shifted (x y)."""
    rng = np.random.default_rng(22)
    t = read_dxf_template(GEAR, units="mm").template
    q = apply_transform(pose_2d(0.7, np.array([120.0, -40.0])), points_on(t, 400, rng))
    path = tmp_path_factory.mktemp("gear") / "gear_mm.csv"
    np.savetxt(path, q + rng.normal(0, 0.002, q.shape), delimiter=",", header="x,y",
               comments="")
    return path


def test_a_drawing_whose_header_says_metres_names_the_units_option(gear_points, capsys):
    # The gear: its header says metres, its numbers are millimetres. Read as metres it
    # is 1000 x the measured points: the verdict says so and how to read it, not only that the
    # registration did not converge.
    assert run("inspect", GEAR, gear_points, "--tol", "0.05") == 2
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("INCONCLUSIVE: the nominal is 1000 x the size of the measured "
                            "points"), first
    assert "read it with --units mm" in first
    # The option named reads it right.
    assert run("inspect", GEAR, gear_points, "--tol", "0.05", "--units", "mm") == 0
    assert capsys.readouterr().out.startswith("ACCEPT")


@pytest.fixture(scope="module")
def surface(tmp_path_factory):
    """The 500 x 250 mm surface's nominal, and 2,000 points measured on it in a random pose,
    written in mm and (a scanner's export) in metres, and the three quarters of them of
    y < 60 mm, in metres."""
    d = tmp_path_factory.mktemp("surface")
    write_grid_nominal(d / "nominal.csv", 150, 100)
    rng = np.random.default_rng(3)
    x, y = rng.uniform(-248, 248, 2000), rng.uniform(-123, 123, 2000)
    q = np.column_stack([x, y, height(x, y)]) + rng.normal(0, 0.002, 2000)[:, None] * \
        height_normal(x, y)
    q = apply_transform(make_transform(random_rotation(rng), rng.uniform(-300, 300, 3)), q)
    everything = np.ones(2000, bool)
    for name, factor, keep in (("mm.csv", 1.0, everything), ("metres.csv", 1e-3, everything),
                               ("part_of_it.csv", 1e-3, y < 60)):
        np.savetxt(d / name, q[keep] * factor, delimiter=",", header="x,y,z", comments="")
    return d


def test_a_part_measured_in_metres_is_no_confident_verdict(surface, capsys):
    # In metres the 500 mm part is a 0.5 mm cluster of points, which a loose zone holds
    # anywhere on the surface: the pose converges and the verdict was a confident ACCEPT.
    d = surface
    assert run("inspect", d / "nominal.csv", d / "metres.csv", "--tol", "0.5") == 2
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("INCONCLUSIVE: the nominal is 1000 x the size of the measured "
                            "points"), first
    assert "if the measured points are in metres, say so in their file (a line '# units: m'" \
        in first
    # Said so in the file, the same numbers are the part.
    with open(d / "metres.csv") as f:
        (d / "said.csv").write_text("# units: m\n" + f.read())
    assert run("inspect", d / "nominal.csv", d / "said.csv", "--tol", "0.05") == 0
    assert run("inspect", d / "nominal.csv", d / "mm.csv", "--tol", "0.05") == 0
    assert "units" not in capsys.readouterr().out
    # Three quarters of its width scanned, in metres: still told.
    assert run("inspect", d / "nominal.csv", d / "part_of_it.csv", "--tol", "0.5") == 2
    assert "if the measured points are in metres" in capsys.readouterr().out


def test_a_patch_of_the_part_is_no_units_mistake(surface, capsys):
    # A tenth of the part's length and width, measured in mm: its proportions in the plane are
    # the part's, but its depth is not (a hundredth of the curvature's sag), so it is judged.
    d = surface
    rng = np.random.default_rng(8)
    x, y = rng.uniform(-25, 25, 500), rng.uniform(-12.5, 12.5, 500)
    np.savetxt(d / "patch.csv", np.column_stack([x, y, height(x, y)]), delimiter=",",
               header="x,y,z", comments="")
    run("inspect", d / "nominal.csv", d / "patch.csv", "--tol", "0.05")
    assert "the size of the" not in capsys.readouterr().out
