"""Reading DXF contour templates: every entity type, chaining, units, layers, bad files."""

import math

import ezdxf
import numpy as np
import pytest

from engine.contour import ARC, ContourIndex, deviations_2d, signed_area
from engine.errors import InputError, InputNotFoundError
from engine.io.templates import FLATTEN_MM, read_dxf_template


def new_doc(insunits=4):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = insunits
    return doc, doc.modelspace()


def save(doc, tmp_path, name="t.dxf"):
    f = tmp_path / name
    doc.saveas(f)
    return f


def test_unordered_mixed_direction_lines_chain_into_one_closed_contour(tmp_path):
    doc, msp = new_doc()
    # A 30 x 20 rectangle stored out of order, two edges reversed.
    msp.add_line((30, 20), (30, 0))
    msp.add_line((0, 0), (30, 0))
    msp.add_line((0, 20), (0, 0))
    msp.add_line((30, 20), (0, 20))
    t = read_dxf_template(save(doc, tmp_path)).template
    assert t.closed.tolist() == [True] and t.n_primitives == 4
    assert abs(signed_area(t, 0)) == pytest.approx(600.0)
    d = deviations_2d(ContourIndex(t), np.array([[15, -0.1], [15, 0.1]])).signed
    assert np.allclose(d, [0.1, -0.1])


@pytest.mark.parametrize("bulge", [0.4, -0.4, 1.0, -1.7])
def test_lwpolyline_bulges_of_both_signs_are_exact_arcs(tmp_path, bulge):
    doc, msp = new_doc()
    msp.add_lwpolyline([(0, 0, bulge), (10, 0, 0), (10, -20, 0), (0, -20, 0)],
                       format="xyb", close=True)
    t = read_dxf_template(save(doc, tmp_path)).template
    assert t.closed.tolist() == [True] and (t.kind == ARC).sum() == 1
    i = int(np.flatnonzero(t.kind == ARC)[0])
    theta = 4 * math.atan(bulge)
    assert t.sweep[i] == pytest.approx(theta)
    assert t.radius[i] == pytest.approx(10 / (2 * abs(math.sin(theta / 2))))
    # The arc's middle point sits at the bulge's sagitta: a positive bulge turns
    # counter-clockwise, so from (0, 0) to (10, 0) it passes below the chord.
    mid_angle = t.angle0[i] + t.sweep[i] / 2
    mid = t.centre[i] + t.radius[i] * np.array([math.cos(mid_angle), math.sin(mid_angle)])
    assert mid[0] == pytest.approx(5.0) and mid[1] == pytest.approx(-bulge * 5.0)


def test_polyline_2d_with_bulge(tmp_path):
    doc, msp = new_doc()
    pl = msp.add_polyline2d([(0, 0), (10, 0), (10, 10)], close=False)
    pl.vertices[0].dxf.bulge = 0.5
    t = read_dxf_template(save(doc, tmp_path)).template
    assert t.closed.tolist() == [False] and (t.kind == ARC).sum() == 1


def test_arcs_clockwise_by_extrusion_and_circles(tmp_path):
    doc, msp = new_doc()
    # A D-shape: a line and an arc seen from below (extrusion -Z: clockwise in the drawing).
    msp.add_line((0, -10), (0, 10))
    # OCS of (0,0,-1) mirrors x: centre (0, 0) and angles 90..270 give the right half.
    msp.add_arc((0, 0), 10, 90, 270, dxfattribs={"extrusion": (0, 0, -1)})
    msp.add_circle((3, 0), 2)  # a hole
    t = read_dxf_template(save(doc, tmp_path)).template
    assert t.closed.tolist() == [True, True]
    areas = sorted(abs(signed_area(t, c)) for c in range(2))
    assert areas == pytest.approx([math.pi * 4, math.pi * 100 / 2])
    d = deviations_2d(ContourIndex(t), np.array([[10.5, 0], [9.5, 0], [3, 1.5], [3, 2.5]])).signed
    assert np.allclose(d, [0.5, -0.5, 0.5, -0.5])


def _flat_error(t, pts):
    return np.max(np.abs(deviations_2d(ContourIndex(t), pts).signed))


def test_weighted_spline_and_fit_point_spline_flattened_within_0_1_um(tmp_path):
    doc, msp = new_doc()
    cps = [(0, 0), (10, 20), (30, -10), (50, 15), (60, 0)]
    sp = msp.add_rational_spline(cps, weights=[1, 3, 0.5, 2, 1], degree=3)
    msp.add_spline(fit_points=[(0, 40), (20, 55), (40, 45), (60, 60)])
    f = save(doc, tmp_path)
    d = read_dxf_template(f)
    assert d.flattened == 2
    for e in ezdxf.readfile(f).modelspace().query("SPLINE"):
        pts = np.array([(p.x, p.y) for p in e.construction_tool().points(np.linspace(0, 1, 400)
                        * e.construction_tool().max_t)])
        assert _flat_error(d.template, pts) <= FLATTEN_MM * 1.0001
    assert sp.dxf.flags is not None


def test_partial_ellipse(tmp_path):
    doc, msp = new_doc()
    msp.add_ellipse((5, 5), major_axis=(20, 10), ratio=0.4, start_param=0.3, end_param=4.0)
    d = read_dxf_template(save(doc, tmp_path))
    t = d.template
    assert d.flattened == 1 and t.closed.tolist() == [False]
    a, b = math.hypot(20, 10), 0.4 * math.hypot(20, 10)
    u = np.array([20, 10]) / math.hypot(20, 10)
    v = np.array([-u[1], u[0]])
    s = np.linspace(0.3, 4.0, 500)
    pts = 5 + np.outer(a * np.cos(s), u) + np.outer(b * np.sin(s), v)
    assert _flat_error(t, pts) <= FLATTEN_MM * 1.0001


def test_inserted_blocks_are_expanded_and_annotation_ignored(tmp_path):
    doc, msp = new_doc()
    blk = doc.blocks.new("HOLE")
    blk.add_circle((0, 0), 1.0)
    msp.add_blockref("HOLE", (10, 10), dxfattribs={"xscale": 2.0, "yscale": 2.0})
    msp.add_text("PART 42")
    msp.add_point((1, 1))
    d = read_dxf_template(save(doc, tmp_path))
    t = d.template
    assert t.n_primitives == 1 and t.radius[0] == pytest.approx(2.0)
    assert np.allclose(t.centre[0], [10, 10])
    assert d.ignored == {"TEXT": 1, "POINT": 1}


@pytest.mark.parametrize("code, factor, unitless", [(1, 25.4, False), (6, 1000.0, False),
                                                    (5, 10.0, False), (0, 1.0, True)])
def test_units_to_millimetres(tmp_path, code, factor, unitless):
    doc, msp = new_doc(code)
    msp.add_line((0, 0), (1, 0))
    d = read_dxf_template(save(doc, tmp_path))
    assert d.unitless == unitless
    assert np.allclose(d.template.end[0], [factor, 0])
    assert np.allclose(read_dxf_template(save(doc, tmp_path), units="mm").template.end[0], [1, 0])


def test_layers(tmp_path):
    doc, msp = new_doc()
    doc.layers.add("PROFILE")
    doc.layers.add("CONSTRUCTION")
    msp.add_circle((0, 0), 5, dxfattribs={"layer": "PROFILE"})
    msp.add_line((-9, 0), (9, 0), dxfattribs={"layer": "CONSTRUCTION"})
    f = save(doc, tmp_path)
    assert read_dxf_template(f).template.n_primitives == 2
    assert read_dxf_template(f, layers=["profile"]).template.n_primitives == 1
    with pytest.raises(InputError, match="no layer named nope"):
        read_dxf_template(f, layers=["nope"])


def test_bad_files(tmp_path):
    junk = tmp_path / "junk.dxf"
    junk.write_text("this is not a drawing\n")
    with pytest.raises(InputError, match="junk.dxf"):
        read_dxf_template(junk)
    with pytest.raises(InputNotFoundError):
        read_dxf_template(tmp_path / "missing.dxf")
    doc, msp = new_doc()
    msp.add_text("only text")
    with pytest.raises(InputError, match="holds no contour geometry"):
        read_dxf_template(save(doc, tmp_path, "text.dxf"))
    doc, msp = new_doc()
    msp.add_circle((0, 0), 0.0)
    with pytest.raises(InputError, match="radius 0"):
        read_dxf_template(save(doc, tmp_path, "r0.dxf"))
    doc, msp = new_doc()
    msp.add_arc((0, 0), 5, 0, 90, dxfattribs={"extrusion": (1, 0, 0)})
    with pytest.raises(InputError, match="does not lie in the drawing's XY plane"):
        read_dxf_template(save(doc, tmp_path, "tilted.dxf"))


DATA = __import__("os").path.join(__import__("os").path.dirname(__file__), "data", "dxf")


def test_real_gear_outline_and_centre_hole():
    """An involute gear drawn as LINE chains; its header says metres, its numbers are mm."""
    d = read_dxf_template(f"{DATA}/gear_z20.dxf", units="mm")
    t = d.template
    assert t.closed.tolist() == [True, True]
    r = np.linalg.norm(np.vstack([t.start, t.end]), axis=1)
    assert r.max() == pytest.approx((20 / 2 + 1) * 2.5465, abs=1e-3)  # tip radius
    dev = deviations_2d(ContourIndex(t), np.array([[0, 0.0], [0, 2.0], [0, 28.5]])).signed
    # Into the centre hole is positive (excess material would be there), the web negative.
    assert dev[0] == pytest.approx(1.5 * math.cos(math.pi / 30), abs=1e-6)
    assert dev[1] == pytest.approx(-0.5, abs=1e-6) and dev[2] > 0


def test_real_plate_holes_and_slots():
    d = read_dxf_template(f"{DATA}/plate_HFP1JZ.dxf")
    t = d.template
    assert d.unitless and t.closed.sum() == 10 and d.ignored.get("DIMENSION", 0) >= 0
    holes = [c for c in np.flatnonzero(t.closed) if (t.contour == c).sum() == 1]
    assert len(holes) == 6
    idx = ContourIndex(t)
    for c in holes:
        i = int(np.flatnonzero(t.contour == c)[0])
        # 0.5 mm inside the hole (its centre lies on the drawing's centre lines, also geometry).
        probe = t.centre[i] + (t.radius[i] - 0.5) * np.array([math.sqrt(0.5), math.sqrt(0.5)])
        assert deviations_2d(idx, probe[None]).signed[0] == pytest.approx(0.5)


def test_real_unordered_loop_of_lines_and_arcs():
    t = read_dxf_template(f"{DATA}/closed_loop_with_arcs.dxf").template
    assert t.closed.tolist() == [True] and t.n_primitives == 11 and (t.kind == ARC).sum() == 2
    ends = np.roll(t.end, 1, axis=0)
    assert np.max(np.linalg.norm(t.start - ends, axis=1)) < 1e-6 * np.ptp(t.start)


def test_damaged_file_goes_through_recover_mode(tmp_path):
    doc, msp = new_doc()
    msp.add_line((0, 0), (10, 0))
    msp.add_circle((0, 0), 3)
    f = save(doc, tmp_path)
    text = f.read_text()
    damaged = tmp_path / "damaged.dxf"
    damaged.write_text(text[: text.rfind("OBJECTS")])  # truncated: no OBJECTS, no EOF
    d = read_dxf_template(damaged)
    assert d.recovered and d.template.n_primitives == 2
    hopeless = tmp_path / "hopeless.dxf"
    i = text.find("AcDbLine")
    hopeless.write_text(text[:i] + "AcDbLine\n 10\nnot-a-number\n" + text[i + 9:])
    with pytest.raises(InputError, match="hopeless.dxf: not a readable DXF file"):
        read_dxf_template(hopeless)
