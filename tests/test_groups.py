"""Named groups of a nominal (OBJ g/o, a PLY face or vertex property, DXF layers) read by
engine.io and selected by an inspection plan's ``group = "NAME"`` (engine.gdt.regions), against
truth known from how each file was written."""

import json
import struct

import ezdxf
import numpy as np
import pytest

from engine.errors import InputError
from engine.io import load_point_set
from engine.io.templates import read_airfoil_template, read_dxf_template
from engine.gdt.plan import Part, Plan, Region
from engine.gdt.regions import nominal_members

# ------------------------------------------------------------------------- a stepped block
# x in [0, 100], y in [0, 60]; 20 high over x <= 60 (the face "top"), 10 high beyond (no
# rigid motion maps it onto itself, so its registration is unique). Each rectangle is
# origin + s u + t v (s, t in [0, 1]) with u x v outward, meshed in 5 mm quads whose
# vertices are shared along the edges.
STEP = 5.0
RECTS = {
    "top": ((0, 0, 20), (60, 0, 0), (0, 60, 0)),
    "step": ((60, 0, 10), (40, 0, 0), (0, 60, 0)),
    "riser": ((60, 0, 10), (0, 60, 0), (0, 0, 10)),
    "bottom": ((0, 0, 0), (0, 60, 0), (100, 0, 0)),
    "left": ((0, 0, 0), (0, 0, 20), (0, 60, 0)),
    "right": ((100, 0, 0), (0, 60, 0), (0, 0, 10)),
    "front_high": ((0, 0, 0), (60, 0, 0), (0, 0, 20)),
    "front_low": ((60, 0, 0), (40, 0, 0), (0, 0, 10)),
    "back_high": ((0, 60, 0), (0, 0, 20), (60, 0, 0)),
    "back_low": ((60, 60, 0), (0, 0, 10), (40, 0, 0)),
}


def block_mesh():
    """(vertices (n, 3), quads (m, 4) 0-based, outward; each quad's rectangle name)."""
    index: dict = {}
    quads, names = [], []

    def vertex(p):
        return index.setdefault(tuple(np.round(p, 9)), len(index))

    for name, (o, u, v) in RECTS.items():
        o, u, v = (np.asarray(a, float) for a in (o, u, v))
        nu, nv = (int(round(np.linalg.norm(a) / STEP)) for a in (u, v))
        ids = [[vertex(o + i / nu * u + j / nv * v) for j in range(nv + 1)]
               for i in range(nu + 1)]
        for i in range(nu):
            for j in range(nv):
                quads.append([ids[i][j], ids[i + 1][j], ids[i + 1][j + 1], ids[i][j + 1]])
                names.append(name)
    return np.array(list(index)), np.array(quads), np.array(names)


def top_vertices(V):
    """Truth: the vertices of the top face, by their coordinates."""
    return (V[:, 2] == 20.0) & (V[:, 0] <= 60.0)


def write_block_obj(path):
    V, Q, names = block_mesh()
    with open(path, "w") as f:
        f.write("# a stepped block\n")
        f.writelines(f"v {x:g} {y:g} {z:g}\n" for x, y, z in V)
        for group in ("body", "top"):
            f.write(f"g {group}\n")
            sel = (names == "top") == (group == "top")
            f.writelines("f " + " ".join(str(i + 1) for i in q) + "\n" for q in Q[sel])
    return V


FACE_ID = {name: 11 + i for i, name in enumerate(RECTS)}
"""The PLY block's face property: each rectangle's number (the top is 11)."""


def write_block_ply(path):
    V, Q, names = block_mesh()
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(V)}\n"
            "property double x\nproperty double y\nproperty double z\n"
            f"element face {len(Q)}\nproperty list uchar int vertex_indices\n"
            "property int face_id\nend_header\n")
    faces = np.zeros(len(Q), dtype=[("n", "u1"), ("v", "<i4", (4,)), ("g", "<i4")])
    faces["n"], faces["v"] = 4, Q
    faces["g"] = [FACE_ID[n] for n in names]
    with open(path, "wb") as f:
        f.write(head.encode())
        f.write(V.astype("<f8").tobytes())
        f.write(faces.tobytes())
    return V


DOME = 0.03
"""The top's measured points rise DOME mm in its middle: z = 20 + DOME (1 - a^2)(1 - b^2)."""


def measure_block(rng):
    """Measured points: a symmetric 9 x 9 grid on the top, domed (its points include the
    middle, height DOME, and the corners, height 0; the grid is symmetric about the middle, so
    the minimum zone is level and its width is DOME exactly), and exact points on the other
    faces, 3 mm clear of their edges; in a random pose. Returns (points, how many on top)."""
    a, b = np.meshgrid(np.linspace(-1, 1, 9), np.linspace(-1, 1, 9))
    a, b = a.ravel(), b.ravel()
    top = np.column_stack([30 + 25 * a, 30 + 25 * b, 20 + DOME * (1 - a * a) * (1 - b * b)])
    rest = []
    for name, (o, u, v) in RECTS.items():
        if name == "top":
            continue
        o, u, v = (np.asarray(x, float) for x in (o, u, v))
        m = 3.0 / np.array([np.linalg.norm(u), np.linalg.norm(v)])
        s, t = rng.uniform(m[0], 1 - m[0], 30), rng.uniform(m[1], 1 - m[1], 30)
        rest.append(o + s[:, None] * u + t[:, None] * v)
    P = np.vstack([top, *rest])
    from engine.pose import apply_transform, make_transform, rotation_from_rotvec

    T = make_transform(rotation_from_rotvec(rng.normal(size=3) * 0.6), rng.uniform(-80, 80, 3))
    return apply_transform(T, P), top.shape[0]


def flatness_plan(group):
    return f"""
[[region]]
name = "top"
group = "{group}"
[[characteristic]]
id = "1"
type = "flatness"
region = "top"
zone = 0.02
[[characteristic]]
id = "2"
type = "flatness"
region = "top"
zone = 0.05
"""


def run_cli(tmp_path, nominal, measured, plan_text):
    from qa_app.cli import main

    plan = tmp_path / "plan.toml"
    plan.write_text(plan_text)
    out = tmp_path / "r.json"
    code = main(["inspect", str(nominal), str(measured), "--plan", str(plan), "--json",
                 str(out)])
    return code, json.loads(out.read_text())


def plan_of(*regions):
    return Plan("plan.toml", "0" * 64, Part(), tuple(regions), (), None, (), ())


@pytest.mark.parametrize("kind", ["obj", "ply"])
def test_a_group_selects_exactly_its_faces_vertices_and_its_flatness_is_judged(tmp_path, kind):
    """The block's top named as a group (OBJ ``g top``; PLY face_id 11): the region selects
    exactly the top's vertices, and the flatness of the top's measured points is DOME."""
    nominal = tmp_path / f"block.{kind}"
    V = write_block_obj(nominal) if kind == "obj" else write_block_ply(nominal)
    group = "top" if kind == "obj" else str(FACE_ID["top"])
    ps = load_point_set(nominal)
    assert np.array_equal(ps.points, V)
    mask = nominal_members(plan_of(Region("top", group=group)), ps.points, None,
                           ps.groups)["top"]
    assert np.array_equal(mask, top_vertices(V))
    rng = np.random.default_rng(31)
    M, n_top = measure_block(rng)
    np.savetxt(tmp_path / "m.csv", M, delimiter=",", header="x,y,z", comments="", fmt="%.9f")
    code, doc = run_cli(tmp_path, nominal, tmp_path / "m.csv", flatness_plan(group))
    c = {x["id"]: x for x in doc["characteristics"]}
    assert c["1"]["n_points"] == c["2"]["n_points"] == n_top
    assert c["1"]["value"] == pytest.approx(DOME, abs=1e-6)
    assert (c["1"]["verdict"], c["2"]["verdict"], code) == ("REJECT", "ACCEPT", 1)


def test_a_vertex_between_two_groups_is_in_both(tmp_path):
    V = write_block_obj(tmp_path / "block.obj")
    g = load_point_set(tmp_path / "block.obj").groups
    assert list(g) == ["body", "top"]
    body = np.zeros(len(V), bool)
    body[g["body"]] = True
    # The body is every face but the top: every vertex off the top's interior.
    interior = top_vertices(V) & (V[:, 0] > 0) & (V[:, 0] < 60) & (V[:, 1] > 0) & (V[:, 1] < 60)
    assert np.array_equal(body, ~interior)


# ------------------------------------------------------------------------------ OBJ reader

OBJ = """\
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
f 1 2 3
g empty
g a b a  # a comment
f 2 3 4
f 1 2 4 3
o the thing
f 5 6 7
g c
f -3 -2 -1
g
f 5/1/1 6/2/2 8/3/3
"""


@pytest.mark.parametrize("flags", [True, False])
def test_obj_g_and_o_name_the_groups_of_the_faces_that_follow(tmp_path, monkeypatch, flags):
    """``g`` names (several: several groups), ``o`` an object (the whole rest of the line;
    it leaves the g groups behind), ``g`` alone and faces before any group: 'default'; a
    name no face follows names no group. (flags: the vertices found with a flag per (group,
    vertex), else by sorting, as for many groups over many vertices.)"""
    from engine.io import mesh_data

    if not flags:
        monkeypatch.setattr(mesh_data, "GROUP_FLAGS_MAX", 0)
    f = tmp_path / "g.obj"
    f.write_text(OBJ)
    g = load_point_set(f).groups
    # Faces (0-based vertices): default {0,1,2} and {4,5,7}; a, b {1,2,3} {0,1,3,2};
    # 'the thing' {4,5,6} {5,6,7} {4,5,7}; c {5,6,7}.
    assert list(g) == ["default", "a", "b", "the thing", "c"]
    want = {"default": [0, 1, 2, 4, 5, 7], "a": [0, 1, 2, 3], "b": [0, 1, 2, 3],
            "the thing": [4, 5, 6, 7], "c": [5, 6, 7]}
    assert {k: v.tolist() for k, v in g.items()} == want


def test_obj_without_g_or_o_or_without_faces_has_no_groups(tmp_path):
    f = tmp_path / "plain.obj"
    f.write_text("".join(line + "\n" for line in OBJ.splitlines()
                         if line[0] not in "go"))
    assert load_point_set(f).groups is None
    f.write_text("g pts\n" + "".join(line + "\n" for line in OBJ.splitlines()
                                     if line.startswith("v ")))
    ps = load_point_set(f)
    assert ps.triangles is None and ps.groups is None


# ------------------------------------------------------------------------------ PLY reader

PLY_VERTS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                      [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)


def write_ply(path, fmt, faces, region, group):
    """A PLY whose faces carry a ``region`` and a ``group`` property (the group wins)."""
    head = (f"ply\nformat {fmt} 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {len(faces)}\n"
            "property list uchar int vertex_indices\nproperty int region\n"
            "property short group\nend_header\n").encode()
    if fmt == "ascii":
        body = "".join(" ".join(f"{v:g}" for v in p) + "\n" for p in PLY_VERTS)
        body += "".join(f"{len(q)} {' '.join(map(str, q))} {r} {g}\n"
                        for q, r, g in zip(faces, region, group))
        path.write_bytes(head + body.encode())
        return
    o = "<" if fmt == "binary_little_endian" else ">"
    body = PLY_VERTS.astype(o + "f4").tobytes()
    for q, r, g in zip(faces, region, group):
        body += struct.pack(f"{o}B{len(q)}iih", len(q), *q, r, g)
    path.write_bytes(head + body)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
@pytest.mark.parametrize("mixed", [False, True])
def test_ply_face_property_numbers_the_groups(tmp_path, fmt, mixed):
    faces = [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7], [0, 1, 5]]
    if mixed:  # a quad among the triangles: rows of different lengths
        faces[:2] = [[0, 1, 2, 3]]
    group = [7, -1, 7, 3, 7][:len(faces)] if not mixed else [-1, 7, 3, 7]
    f = tmp_path / "g.ply"
    write_ply(f, fmt, faces, [1] * len(faces), group)
    g = load_point_set(f).groups
    truth = {}
    for q, k in zip(faces, group):
        truth.setdefault(str(k), set()).update(q)
    assert list(g) == sorted(truth, key=int)
    assert {k: v.tolist() for k, v in g.items()} == {k: sorted(v) for k, v in truth.items()}


def test_ply_vertex_property_groups_a_point_cloud(tmp_path):
    labels = [2.0, 2.0, 5.0, 2.0, 5.0, 9.0, 9.0, 2.0]
    f = tmp_path / "v.ply"
    f.write_text("ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
                 "property float z\nproperty float label\nend_header\n"
                 + "".join(f"{x:g} {y:g} {z:g} {k:g}\n" for (x, y, z), k in
                           zip(PLY_VERTS, labels)))
    g = load_point_set(f).groups
    assert {k: v.tolist() for k, v in g.items()} == {"2": [0, 1, 3, 7], "5": [2, 4],
                                                     "9": [5, 6]}


@pytest.mark.parametrize("row, message", [
    ("3 0 1 2 1 1.5", r"g.ply:21: face 1: its group property 'group' is 1.5; group numbers "
                      "are whole numbers"),
    ("3 0 1 2 1", r"g.ply:21: face row 1: its 'group' is missing"),
    ("3 0 1 2 1 x", r"g.ply:21: face row 1: its 'group' 'x' is not a number"),
])
def test_ply_group_values_that_are_no_whole_numbers_are_refused(tmp_path, row, message):
    f = tmp_path / "g.ply"
    write_ply(f, "ascii", [[0, 1, 2], [0, 2, 3]], [1, 1], [4, 4])
    lines = f.read_text().splitlines()
    lines[20] = row  # face row 1
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=message):
        load_point_set(f)


# ------------------------------------------------------------------------------ DXF layers

def test_dxf_primitives_keep_their_layers_as_the_layer_table_spells_them(tmp_path):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    doc.layers.add("OUTER")
    doc.layers.add("Holes")
    msp = doc.modelspace()
    msp.add_lwpolyline([(0, 0), (200, 0), (200, 100), (0, 100)], close=True,
                       dxfattribs={"layer": "OUTER"})
    msp.add_circle((50, 50), 10, dxfattribs={"layer": "HOLES"})  # the table says 'Holes'
    block = doc.blocks.new("PIN")
    block.add_circle((0, 0), 5)  # on layer 0, inside a block inserted on OUTER
    msp.add_blockref("PIN", (150, 40), dxfattribs={"layer": "OUTER"})
    doc.saveas(tmp_path / "t.dxf")
    t = read_dxf_template(tmp_path / "t.dxf").template
    on = dict(zip(np.round(t.radius, 6), (t.layers[i] for i in t.layer)))
    assert t.layers == ("0", "Holes", "OUTER")
    assert on[10.0] == "Holes" and on[5.0] == "0"
    assert [t.layers[i] for i in t.layer[t.radius == 0]] == ["OUTER"] * 4
    only = read_dxf_template(tmp_path / "t.dxf", layers=["holes"]).template
    assert only.layers == ("Holes",) and only.layer.tolist() == [0]


def test_an_airfoil_template_has_no_layers(tmp_path):
    f = tmp_path / "a.dat"
    f.write_text("foil\n1 0\n0.5 0.1\n0 0\n0.5 -0.1\n1 0\n")
    t = read_airfoil_template(f, 100.0).template
    assert t.layer is None and t.layers == ()


# -------------------------------------------------------------------------- a 2D plan

def test_dxf_layers_are_regions_of_a_2d_plan(tmp_path):
    """A 200 x 100 plate on layer OUTER, a hole of diameter 20 on layer HOLES and one of
    diameter 10 on layer PILOT; made with the first hole 20.02 across. Size on
    ``group = "HOLES"`` measures that hole (REJECT against 20 +-0.01), on ``group = "pilot"``
    (the name compared without case, as DXF does) the other; a profile on OUTER holds only the
    outline's points."""
    from engine.contour import points_on
    from engine.pose import apply_transform, pose_2d

    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    for name in ("OUTER", "HOLES", "PILOT"):
        doc.layers.add(name)
    msp = doc.modelspace()
    msp.add_lwpolyline([(0, 0), (200, 0), (200, 100), (0, 100)], close=True,
                       dxfattribs={"layer": "OUTER"})
    msp.add_circle((50, 50), 10, dxfattribs={"layer": "HOLES"})
    msp.add_circle((150, 35), 5, dxfattribs={"layer": "PILOT"})
    doc.saveas(tmp_path / "plate.dxf")
    t = read_dxf_template(tmp_path / "plate.dxf").template
    rng = np.random.default_rng(5)
    q = points_on(t, 600, rng)
    hole = np.linalg.norm(q - [50, 50], axis=1) < 11
    pilot = np.linalg.norm(q - [150, 35], axis=1) < 6
    q[hole] = [50, 50] + (q[hole] - [50, 50]) * 10.01 / 10
    meas = apply_transform(pose_2d(rng.uniform(0, 2 * np.pi), rng.uniform(-300, 300, 2)), q)
    np.savetxt(tmp_path / "m.csv", meas, delimiter=",", header="x,y", comments="", fmt="%.9f")
    code, doc = run_cli(tmp_path, tmp_path / "plate.dxf", tmp_path / "m.csv", """
[[region]]
name = "outline"
group = "OUTER"
[[region]]
name = "big"
group = "HOLES"
[[region]]
name = "small"
group = "pilot"
[[characteristic]]
id = "1"
type = "size"
region = "big"
nominal = 20.0
lower = -0.01
upper = 0.01
[[characteristic]]
id = "2"
type = "size"
region = "small"
nominal = 10.0
lower = -0.01
upper = 0.01
[[characteristic]]
id = "3"
type = "profile"
region = "outline"
zone = 0.1
""")
    c = {x["id"]: x for x in doc["characteristics"]}
    assert c["1"]["value"] == pytest.approx(20.02, abs=1e-6) and c["1"]["verdict"] == "REJECT"
    assert c["2"]["value"] == pytest.approx(10.0, abs=1e-6) and c["2"]["verdict"] == "ACCEPT"
    assert (c["1"]["n_points"], c["2"]["n_points"]) == (hole.sum(), pilot.sum())
    assert c["3"]["n_points"] == (~hole & ~pilot).sum() and c["3"]["verdict"] == "ACCEPT"
    assert code == 1


# ---------------------------------------------------------------------- missing groups

def _inspect(tmp_path, nominal, plan_text, measured=None):
    from engine.pipeline import inspection_settings, run_files

    plan = tmp_path / "plan.toml"
    plan.write_text(plan_text)
    if measured is None:
        M, _ = measure_block(np.random.default_rng(2))
        measured = tmp_path / "m.csv"
        np.savetxt(measured, M, delimiter=",", header="x,y,z", comments="", fmt="%.9f")
    return run_files(str(nominal), str(measured), inspection_settings(None, str(plan)))


def test_a_group_the_nominal_does_not_have_names_the_plan_region_and_groups(tmp_path, capsys):
    """Exit 65 (a bad plan), naming the plan, its region and the groups the nominal has (an
    OBJ's group names compare with their case)."""
    from qa_app.cli import main

    write_block_obj(tmp_path / "block.obj")
    M, _ = measure_block(np.random.default_rng(2))
    np.savetxt(tmp_path / "m.csv", M, delimiter=",", header="x,y,z", comments="", fmt="%.9f")
    (tmp_path / "plan.toml").write_text(flatness_plan("Top"))
    code = main(["inspect", str(tmp_path / "block.obj"), str(tmp_path / "m.csv"), "--plan",
                 str(tmp_path / "plan.toml")])
    assert code == 65
    assert (f"{tmp_path / 'plan.toml'}: [[region]] 'top': the nominal has no group 'Top' (its "
            "groups: 'body', 'top')") in capsys.readouterr().err


def test_a_layer_the_template_does_not_have_lists_its_layers(tmp_path):
    doc = ezdxf.new("R2010")
    doc.layers.add("OUTER")
    doc.modelspace().add_lwpolyline([(0, 0), (200, 0), (200, 100), (0, 100)], close=True,
                                    dxfattribs={"layer": "OUTER"})
    doc.modelspace().add_circle((50, 50), 10)
    doc.saveas(tmp_path / "plate.dxf")
    pts = np.array([[0, 10], [10, 0], [200, 50], [100, 100], [40, 50]], float)
    np.savetxt(tmp_path / "m.csv", pts, delimiter=",", header="x,y", comments="")
    with pytest.raises(InputError, match=r"plan.toml: \[\[region\]\] 'top': the nominal has "
                                         r"no group 'HOLES' \(its groups: '0', 'OUTER'\)"):
        _inspect(tmp_path, tmp_path / "plate.dxf", flatness_plan("HOLES"), tmp_path / "m.csv")


@pytest.mark.parametrize("suffix", [".xyz", ".vtp"])
def test_a_nominal_without_groups_says_so(tmp_path, suffix):
    """A point file has no groups, nor (here) a mesh VTK reads."""
    import pyvista as pv

    V, Q, _ = block_mesh()
    f = tmp_path / f"block{suffix}"
    if suffix == ".xyz":
        np.savetxt(f, V)
    else:
        pv.PolyData(V, np.column_stack([np.full(len(Q), 4), Q]).ravel()).save(f)
    with pytest.raises(InputError, match=r"plan.toml: \[\[region\]\] 'top': 'group' selects "
                                         r"a named group .* this nominal has no groups"):
        _inspect(tmp_path, f, flatness_plan("top"))


def test_a_message_about_a_missing_group_lists_a_dozen_of_many():
    points = np.zeros((30, 3))
    groups = {f"face{i}": np.array([2 * i, 2 * i + 1]) for i in range(15)}
    with pytest.raises(InputError, match=r"no group 'face15' \(its groups: 'face0', 'face1', "
                                         r".*'face11', … \(15 in all\)\)"):
        nominal_members(plan_of(Region("r", group="face15")), points, None, groups)
    got = nominal_members(plan_of(Region("r", group="face14")), points, None, groups)["r"]
    assert np.flatnonzero(got).tolist() == [28, 29]
