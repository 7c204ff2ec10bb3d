"""Generate the bundled samples and their ground truth (deterministic: fixed seeds).

    python samples/generate.py   # rewrites the three samples below (PYTHONHASHSEED=0: the
                                 # DXF's CLASSES section also comes out byte for byte)

belly_fairing/  a 500 x 250 mm doubly curved form tool like the paper's section 5.2:
    nominal.csv   60,000-point u-v grid (300 x 200, u fastest) with I J K normals
    measured.csv  1,100 CMM points (label, x, y, z) in an arbitrary pose on the machine bed, with
                  probing noise and a local dent
    truth.json    the pose, the planted deviation of every point, the expected verdict
seat_bracket/   an L-shaped seat bracket with two freeform faces (A: flange top, B: web face),
                plane bottom (z = 0), back (x = 0) and ends (y = 0, 60), and a vertical through
                hole of diameter 8 in the flange at (x, y) = (64, 30):
    nominal.xyz   200,000 points over the whole part, hole wall included, with outward I J K
                  normals (on the hole's wall: towards its axis)
    measured.csv  176 points in an arbitrary pose: faces A (P001-P050) and B (P051-P100) with a
                  uniform +0.012 mm excess, the end face y = 60 (P101-P120) likewise, the
                  bottom (P121-P136, datum A), the back (P137-P148, datum B) and the end face
                  y = 0 (P165-P176, datum C) machined true, the hole at z = 2.5 and 6
                  (P149-P164), its axis 0.025 mm off and its diameter 8.010
    truth.json    as above, and the datum faces' labels and the hole as made (position 0.05,
                  size 8.010)
    plan.toml     (written by hand) the drawing's inspection plan: datums A|B|C, the skin's profile relative to
                  them (REJECT: the +0.012 mm excess in a 0.02 zone) and as form only (ACCEPT),
                  the flatness of A, the hole's position and size
fuselage_frame/ a fuselage frame contour template like the paper's section 5.1:
    template.dxf  a 30-degree frame segment between radii 1000 and 1100 mm: bulged polyline arcs,
                  straight ends, a spline joggle at one end, two lightening holes (circles)
    measured.csv  500 CMM points (label, x, y, z) along the contours, the template lying tilted
                  on the bed (a planar template measured in 3D), noise and a local rise
    truth.json    the pose, the planted deviation of every point, the expected verdict
    plan.toml     (written by hand, not generated) datums A (the straight end) and B (one hole),
                  the other hole's position, both holes' size, the outer arc's profile
"""

from __future__ import annotations

import json
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


# ----------------------------------------------------------------------------- geometry helpers
def rotation(axis, deg) -> np.ndarray:
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    t = np.radians(deg)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K


def pose(R, t) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


# ----------------------------------------------------------------------------- belly fairing
def fairing_height(x, y):
    """z (mm) of the fairing's moulding surface over x in [-250, 250], y in [-125, 125]."""
    return 60.0 - x**2 / 800.0 - y**2 / 300.0 + 1e-6 * x**3 + 4e-4 * x * y


def fairing_normal(x, y):
    hx = -x / 400.0 + 3e-6 * x**2 + 4e-4 * y
    hy = -y / 150.0 + 4e-4 * x
    n = np.stack([-hx, -hy, np.ones_like(x)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def fairing_defect(x, y):
    """Planted form error (mm, along the outward normal): a dent and a shallow rise."""
    dent = -0.15 * np.exp(-((x - 120.0) ** 2 + (y + 40.0) ** 2) / (2 * 18.0**2))
    rise = 0.06 * np.exp(-((x + 150.0) ** 2 + (y - 60.0) ** 2) / (2 * 40.0**2))
    return dent + rise


def make_fairing(out: str) -> dict:
    rng = np.random.default_rng(2024)
    nu, nv = 300, 200
    u = np.linspace(-250.0, 250.0, nu)
    v = np.linspace(-125.0, 125.0, nv)
    X, Y = np.meshgrid(u, v)  # rows follow v, so u runs fastest
    x, y = X.ravel(), Y.ravel()
    nominal = np.column_stack([x, y, fairing_height(x, y), fairing_normal(x, y)])
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "nominal.csv"), "w") as f:
        f.write("# belly-fairing form tool, nominal CAD sample (mm)\n")
        f.write(f"# grid: {nu} x {nv}\n")
        f.write("x,y,z,i,j,k\n")
        np.savetxt(f, nominal, fmt="%.6f", delimiter=",")

    # 1,100 CMM points on a jittered 44 x 25 pattern, 5 mm inside the edges.
    gx, gy = np.meshgrid(np.linspace(-245, 245, 44), np.linspace(-120, 120, 25))
    mx = np.clip(gx.ravel() + rng.uniform(-4, 4, gx.size), -245, 245)
    my = np.clip(gy.ravel() + rng.uniform(-4, 4, gy.size), -120, 120)
    planted = fairing_defect(mx, my) + rng.normal(0.0, 0.004, mx.size)
    on = np.column_stack([mx, my, fairing_height(mx, my)])
    pts_nominal_frame = on + planted[:, None] * fairing_normal(mx, my)
    # The part lies upside down and turned on the CMM bed.
    R = rotation([0.3, 1.0, 0.2], 151.0)
    t = np.array([812.4, -233.1, 95.7])
    measured = pts_nominal_frame @ R.T + t
    T_measured_nominal = pose(R, t)
    labels = [f"P{i + 1:04d}" for i in range(mx.size)]
    _write_cmm(os.path.join(out, "measured.csv"), "CMM points, machine coordinates (mm)", labels,
               measured)
    truth = {
        "description": "belly-fairing form tool: 60,000-point grid, 1,100 CMM points",
        "T_nominal_measured": np.linalg.inv(T_measured_nominal).tolist(),
        "planted_deviation_mm": [round(float(d), 6) for d in planted],
        "defect": "dent -0.15 mm (sigma 18 mm) at (120, -40); rise +0.06 mm (sigma 40 mm) at "
                  "(-150, 60); probing noise sigma 0.004 mm; coordinates rounded to 0.0001 mm",
        "tolerance_mm": 0.25,
        "expected_verdict": "ACCEPT",
    }
    _write_json(os.path.join(out, "truth.json"), truth)
    _write_session(out, "nominal.csv", "measured.csv", 0.25)
    return truth


# ----------------------------------------------------------------------------- seat bracket
W = 60.0  # width along y
HOLE_CENTRE = (64.0, 30.0)  # (x, y) mm of the flange's vertical through hole (axis along z)
HOLE_D = 8.0  # its nominal diameter, mm
# The hole as made: axis displaced by this (x, y) vector (mm) from nominal, and its diameter.
HOLE_OFFSET = (0.020, -0.015)
HOLE_D_ACTUAL = 8.010


def face_a_height(x, y):
    """Face A, the flange top: z over x in [8, 120], y in [0, 60]."""
    return 8.0 + 3.0 * np.sin(np.pi * (x - 8.0) / 112.0) * (1.0 - 0.3 * np.cos(np.pi * y / W))


def face_a_normal(x, y):
    s = 1.0 - 0.3 * np.cos(np.pi * y / W)
    zx = 3.0 * np.pi / 112.0 * np.cos(np.pi * (x - 8.0) / 112.0) * s
    zy = 3.0 * np.sin(np.pi * (x - 8.0) / 112.0) * 0.3 * np.pi / W * np.sin(np.pi * y / W)
    n = np.stack([-zx, -zy, np.ones_like(x)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def face_b_offset(y, z):
    """Face B, the web's inner face: x over y in [0, 60], z in [8, 90]."""
    return 8.0 + 2.0 * np.sin(np.pi * (z - 8.0) / 82.0) * (1.0 + 0.2 * y / W)


def face_b_normal(y, z):
    xy = 2.0 * np.sin(np.pi * (z - 8.0) / 82.0) * 0.2 / W
    xz = 2.0 * np.pi / 82.0 * np.cos(np.pi * (z - 8.0) / 82.0) * (1.0 + 0.2 * y / W)
    n = np.stack([np.ones_like(y), -xy, -xz], axis=-1)  # outward = +x, into the open corner
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def bracket_points(n_total: int, rng) -> np.ndarray:
    """(n_total, 6) points with outward normals spread over the bracket's faces by area, the
    flange's through hole included (its wall's normals point to the hole's axis: the material is
    outside).

    The faces of the bracket without its hole are drawn from ``rng`` as they were before the hole
    was added (same counts, same calls), so that what a caller draws from ``rng`` afterwards stays
    the same. The hole's wall, at the same density, and the uniform thinning back to ``n_total``
    (which also takes out the points the hole removed from the bottom and the flange top) come
    from a stream jumped off ``rng``'s state; ``rng`` itself is not advanced by them.
    """
    faces = []

    def add(area, sampler):
        faces.append((area, sampler))

    add(112 * W * 1.02, lambda k: _face_a(rng, k))
    add(82 * W * 1.01, lambda k: _face_b(rng, k))
    add(120 * W, lambda k: _plane(rng, k, lambda a, b: (a * 120, b * W, 0 * a), (0, 0, -1)))
    add(90 * W, lambda k: _plane(rng, k, lambda a, b: (0 * a, b * W, a * 90), (-1, 0, 0)))
    add(8 * W, lambda k: _plane(rng, k, lambda a, b: (120 + 0 * a, b * W, a * 8), (1, 0, 0)))
    add(8 * W, lambda k: _plane(rng, k, lambda a, b: (a * 8, b * W, 90 + 0 * a), (0, 0, 1)))
    end_area = 120 * 8 + 8 * 82 + 2 * 112 * 3 / np.pi * 0.7 + 2 * 82 * 2 / np.pi * 1.1
    add(end_area, lambda k: _end(rng, k, 0.0, (0, -1, 0)))
    add(end_area, lambda k: _end(rng, k, W, (0, 1, 0)))
    areas = np.array([a for a, _ in faces])
    counts = np.floor(n_total * areas / areas.sum()).astype(int)
    counts[0] += n_total - counts.sum()
    solid = np.vstack([s(k) for (_, s), k in zip(faces, counts)])

    extra = np.random.Generator(rng.bit_generator.jumped())
    wall = _hole_wall(extra, int(round(n_total * _hole_wall_area() / areas.sum())))
    pts = np.vstack([solid[~_in_hole(solid[:, 0], solid[:, 1])], wall])
    assert len(pts) >= n_total  # the wall (~280 mm^2) outweighs the two discs (~100 mm^2)
    drop = extra.choice(len(pts), len(pts) - n_total, replace=False)
    return np.delete(pts, drop, axis=0)


def _face_a(rng, k):
    x = rng.uniform(8.0, 120.0, k)
    y = rng.uniform(0.0, W, k)
    return np.column_stack([x, y, face_a_height(x, y), face_a_normal(x, y)])


def _face_b(rng, k):
    y = rng.uniform(0.0, W, k)
    z = rng.uniform(8.0, 90.0, k)
    return np.column_stack([face_b_offset(y, z), y, z, face_b_normal(y, z)])


def _plane(rng, k, f, normal):
    a, b = rng.uniform(0, 1, k), rng.uniform(0, 1, k)
    x, y, z = f(a, b)
    n = np.broadcast_to(np.asarray(normal, float), (k, 3))
    return np.column_stack([x, y, z, n])


def _end(rng, k, y0, normal):
    """An end face (y = y0): the L-shaped outline with curved inner edges, by rejection."""
    out = []
    while sum(len(o) for o in out) < k:
        x = rng.uniform(0, 120, 4 * k)
        z = rng.uniform(0, 90, 4 * k)
        inside = ((x <= face_b_offset(y0, np.clip(z, 8, 90))) & (z <= 90)) | \
                 ((z <= face_a_height(np.clip(x, 8, 120), y0)) & (x <= 120))
        out.append(np.column_stack([x[inside], z[inside]]))
    xz = np.vstack(out)[:k]
    n = np.broadcast_to(np.asarray(normal, float), (k, 3))
    return np.column_stack([xz[:, 0], np.full(k, y0), xz[:, 1], n])


def _in_hole(x, y):
    """True where (x, y) (mm, nominal frame) lies inside the through hole's circle."""
    return (x - HOLE_CENTRE[0]) ** 2 + (y - HOLE_CENTRE[1]) ** 2 < (HOLE_D / 2) ** 2


def _hole_top(theta):
    """z (mm) where the hole's wall meets the flange top, at angle theta (rad) about the axis."""
    r = HOLE_D / 2
    return face_a_height(HOLE_CENTRE[0] + r * np.cos(theta), HOLE_CENTRE[1] + r * np.sin(theta))


def _hole_wall_area():
    """Area (mm^2) of the hole's wall, z = 0 up to the flange top: r times the integral of the
    wall's height over the angle."""
    theta = np.linspace(0.0, 2 * np.pi, 3600, endpoint=False)
    return HOLE_D / 2 * 2 * np.pi * float(np.mean(_hole_top(theta)))


def _hole_wall(rng, k):
    """(k, 6) points uniform on the hole's wall, by rejection on the unrolled wall; normals point
    to the axis (out of the material)."""
    r = HOLE_D / 2
    top = float(_hole_top(np.linspace(0.0, 2 * np.pi, 3600, endpoint=False)).max()) + 0.01
    out = []
    while sum(len(o) for o in out) < k:
        theta = rng.uniform(0.0, 2 * np.pi, 2 * k)
        z = rng.uniform(0.0, top, 2 * k)
        keep = z <= _hole_top(theta)
        out.append(np.column_stack([theta[keep], z[keep]]))
    theta, z = np.vstack(out)[:k].T
    u = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(k)])
    return np.column_stack([HOLE_CENTRE[0] + r * u[:, 0], HOLE_CENTRE[1] + r * u[:, 1], z, -u])


def _datum_and_hole_points(rng):
    """The inspector's points for datums A (the bottom, z = 0) and B (the back, x = 0) and for
    the flange's hole, in the nominal frame: (on (n, 3) on the nominal surface, normals (n, 3)
    outward, planted (n,) mm along them), n = 16 + 12 + 16.

    The datum faces are machined true (1.5 um of noise). The hole as made (HOLE_OFFSET,
    HOLE_D_ACTUAL) is probed at 8 points around at z = 2.5 and 8 at z = 6.0 (the flange top is
    above 10.8 mm all round the hole); each point lies on the nominal wall's normal, where that
    line meets the actual wall, plus 1 um of noise.
    """
    # Datum A: a jittered 4 x 4 pattern, 5 mm or more inside the edges and clear of the hole.
    gx, gy = np.meshgrid(np.linspace(12, 108, 4), np.linspace(10, 50, 4))
    xa = gx.ravel() + rng.uniform(-5, 5, 16)
    ya = gy.ravel() + rng.uniform(-4, 4, 16)
    assert np.min(np.hypot(xa - HOLE_CENTRE[0], ya - HOLE_CENTRE[1])) > HOLE_D / 2 + 3
    # Datum B: 3 across by 4 up the back.
    gy, gz = np.meshgrid(np.linspace(12, 48, 3), np.linspace(12, 78, 4))
    yb = gy.ravel() + rng.uniform(-4, 4, 12)
    zb = gz.ravel() + rng.uniform(-4, 4, 12)
    planted_datums = rng.normal(0.0, 0.0015, 28)
    # The hole: two rings of 8, the upper ring turned half a step.
    k = np.arange(16)
    theta = 2 * np.pi * (k % 8 + 0.5 * (k // 8) + rng.uniform(-0.2, 0.2, 16)) / 8
    u = np.column_stack([np.cos(theta), np.sin(theta)])
    r = HOLE_D / 2
    # Distance rho from the nominal axis, along u, to the actual wall: |e + rho u| = R with e the
    # nominal centre seen from the actual one.
    e = -np.asarray(HOLE_OFFSET)
    ue = u @ e
    rho = -ue + np.sqrt(ue**2 - e @ e + (HOLE_D_ACTUAL / 2) ** 2)
    planted_hole = -(rho - r) + rng.normal(0.0, 0.001, 16)
    on = np.vstack([np.column_stack([xa, ya, np.zeros(16)]),
                    np.column_stack([np.zeros(12), yb, zb]),
                    np.column_stack([HOLE_CENTRE[0] + r * u[:, 0], HOLE_CENTRE[1] + r * u[:, 1],
                                     np.repeat([2.5, 6.0], 8)])])
    nrm = np.vstack([np.tile([0.0, 0.0, -1.0], (16, 1)), np.tile([-1.0, 0.0, 0.0], (12, 1)),
                     np.column_stack([-u, np.zeros(16)])])
    return on, nrm, np.concatenate([planted_datums, planted_hole])


def _bracket_truth(labels, planted, T_measured_nominal) -> dict:
    """truth.json of the bracket: pose, planted deviations, the datum faces' labels, the hole."""
    offset = np.array([*HOLE_OFFSET, 0.0])
    return {
        "description": "seat bracket with a through hole in its flange: 200,000 nominal points, "
                       "176 CMM points on faces A and B, the end faces, the bottom, the back "
                       "and the hole",
        "T_nominal_measured": np.linalg.inv(T_measured_nominal).tolist(),
        "planted_deviation_mm": [round(float(d), 6) for d in planted],
        "defect": "uniform +0.012 mm excess with noise sigma 0.004 mm on faces A, B and the end "
                  "face y = 60; bottom, back and end face y = 0 machined true (noise sigma "
                  "0.0015 mm); the hole's axis "
                  "displaced by (+0.020, -0.015) mm and its diameter 8.010 mm (noise sigma "
                  "0.001 mm)",
        "datum_faces": {
            "A": {"face": "bottom", "plane": "z = 0", "outward_normal": [0.0, 0.0, -1.0],
                  "labels": labels[120:136]},
            "B": {"face": "back", "plane": "x = 0", "outward_normal": [-1.0, 0.0, 0.0],
                  "labels": labels[136:148]},
            "C": {"face": "end", "plane": "y = 0", "outward_normal": [0.0, -1.0, 0.0],
                  "labels": labels[164:176]},
        },
        "hole": {
            "labels": labels[148:164],
            "nominal_centre_mm": [*HOLE_CENTRE, 0.0],
            "axis": [0.0, 0.0, 1.0],
            "depth": "through the flange: z = 0 up to face A (10.8 to 11.2 mm around the hole)",
            "nominal_diameter_mm": HOLE_D,
            "actual_centre_offset_mm": offset.tolist(),
            "actual_diameter_mm": HOLE_D_ACTUAL,
            "position_value_mm": round(2 * float(np.linalg.norm(offset)), 6),
            "size_value_mm": HOLE_D_ACTUAL,
        },
        "tolerance_mm": 0.05,
        "expected_verdict": "ACCEPT",
    }


def make_bracket(out: str) -> dict:
    rng = np.random.default_rng(77)
    nominal = bracket_points(200_000, rng)
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "nominal.xyz"), "w") as f:
        f.write("# seat bracket, nominal CAD sample over every face (mm), outward normals\n")
        f.write("x y z i j k\n")
        np.savetxt(f, nominal, fmt="%.6f", delimiter=" ")
    # 50 points on face A and 50 on face B, away from the edges.
    xa, ya = rng.uniform(25, 105, 50), rng.uniform(8, 52, 50)
    yb, zb = rng.uniform(8, 52, 50), rng.uniform(25, 80, 50)
    on = np.vstack([np.column_stack([xa, ya, face_a_height(xa, ya)]),
                    np.column_stack([face_b_offset(yb, zb), yb, zb])])
    nrm = np.vstack([face_a_normal(xa, ya), face_b_normal(yb, zb)])
    # Machined: a small uniform offset of 15 um plus noise, like the paper's 0.0004-0.023 mm.
    planted = 0.012 + rng.normal(0.0, 0.004, 100)
    # Two faces at right angles leave the pose free along their common edge direction (y): an
    # inspector also probes the end face y = W, 10 points on each leg of its L, away from edges.
    xe = np.concatenate([rng.uniform(25, 105, 10), rng.uniform(2.5, 6.0, 10)])
    ze = np.concatenate([rng.uniform(2.5, 6.0, 10), rng.uniform(25, 80, 10)])
    on = np.vstack([on, np.column_stack([xe, np.full(20, W), ze])])
    nrm = np.vstack([nrm, np.tile([0.0, 1.0, 0.0], (20, 1))])
    planted = np.concatenate([planted, 0.012 + rng.normal(0.0, 0.004, 20)])
    # Drawn after the points above, so that those stay as they were before the datums and the
    # hole were added.
    on_dh, nrm_dh, planted_dh = _datum_and_hole_points(rng)
    on, nrm = np.vstack([on, on_dh]), np.vstack([nrm, nrm_dh])
    planted = np.concatenate([planted, planted_dh])
    # Datum C: the other end face, y = 0, machined true: 6 points on the flange's leg of its L
    # and 6 on the web's, away from the edges (drawn last, so all the above stay as they were).
    xc = np.concatenate([rng.uniform(25, 105, 6), rng.uniform(2.5, 6.0, 6)])
    zc = np.concatenate([rng.uniform(2.5, 6.0, 6), rng.uniform(25, 80, 6)])
    on = np.vstack([on, np.column_stack([xc, np.zeros(12), zc])])
    nrm = np.vstack([nrm, np.tile([0.0, -1.0, 0.0], (12, 1))])
    planted = np.concatenate([planted, rng.normal(0.0, 0.0015, 12)])
    pts = on + planted[:, None] * nrm
    R = rotation([-0.5, 0.2, 1.0], 73.0)
    t = np.array([402.0, 618.5, -55.25])
    measured = pts @ R.T + t
    labels = [f"P{i + 1:03d}" for i in range(len(measured))]
    _write_cmm(os.path.join(out, "measured.csv"),
               "CMM points on faces A (P001-P050), B (P051-P100), the end face y = 60 "
               "(P101-P120), the bottom (P121-P136, datum A), the back (P137-P148, datum B), the "
               "hole (P149-P156 at z 2.5, P157-P164 at z 6) and the end face y = 0 (P165-P176, "
               "datum C), machine coordinates",
               labels, measured)
    truth = _bracket_truth(labels, planted, pose(R, t))
    _write_json(os.path.join(out, "truth.json"), truth)
    _write_session(out, "nominal.xyz", "measured.csv", 0.05)
    return truth


# ----------------------------------------------------------------------------- fuselage frame
FRAME_R_IN, FRAME_R_OUT = 1000.0, 1100.0
FRAME_A0, FRAME_A1 = np.radians(75.0), np.radians(105.0)
HOLES = [(np.radians(85.0), 25.0), (np.radians(95.0), 25.0)]


def _frame_joggle():
    """Fit points of the spline closing the frame at 75 degrees: an S-shaped joggle."""
    a = FRAME_A0
    radial = np.array([np.cos(a), np.sin(a)])
    tangent = np.array([-np.sin(a), np.cos(a)])
    r = np.linspace(FRAME_R_IN, FRAME_R_OUT, 5)
    off = np.array([0.0, 4.0, 0.0, -4.0, 0.0])
    return [tuple(ri * radial + oi * tangent) for ri, oi in zip(r, off)]


def _write_frame_dxf(ezdxf, path: str) -> None:
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4  # millimetres
    doc.layers.add("PROFILE")
    doc.layers.add("NOTES")
    msp = doc.modelspace()
    p_out0 = FRAME_R_OUT * np.array([np.cos(FRAME_A0), np.sin(FRAME_A0)])
    p_out1 = FRAME_R_OUT * np.array([np.cos(FRAME_A1), np.sin(FRAME_A1)])
    p_in1 = FRAME_R_IN * np.array([np.cos(FRAME_A1), np.sin(FRAME_A1)])
    p_in0 = FRAME_R_IN * np.array([np.cos(FRAME_A0), np.sin(FRAME_A0)])
    b = np.tan((FRAME_A1 - FRAME_A0) / 4.0)
    # Outer arc counter-clockwise, straight end, inner arc clockwise: one open polyline whose
    # ends the spline joggle joins.
    msp.add_lwpolyline([(*p_out0, b), (*p_out1, 0.0), (*p_in1, -b), (*p_in0, 0.0)],
                       format="xyb", close=False, dxfattribs={"layer": "PROFILE"})
    fit = _frame_joggle()
    msp.add_spline(fit_points=fit[::-1], dxfattribs={"layer": "PROFILE"})  # inner end -> outer
    for ang, r in HOLES:
        c = 1050.0 * np.array([np.cos(ang), np.sin(ang)])
        msp.add_circle(tuple(c), r, dxfattribs={"layer": "PROFILE"})
    msp.add_text("FRAME 12 TEMPLATE, TOL +/-0.05", dxfattribs={"layer": "NOTES"})
    doc.saveas(path)


def make_frame(out: str) -> dict:
    import ezdxf

    from engine.contour import SEGMENT, ContourIndex, deviations_2d, points_on
    from engine.io.templates import read_dxf_template

    os.makedirs(out, exist_ok=True)
    # Fixed dates, GUIDs and writer stamps, so that the file is reproducible byte for byte.
    fixed = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = True
    try:
        _write_frame_dxf(ezdxf, os.path.join(out, "template.dxf"))
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = fixed
    t = read_dxf_template(os.path.join(out, "template.dxf")).template
    rng = np.random.default_rng(512)
    # 500 points: 400 along the outer profile, 50 in each hole, spread by length.
    length = [np.sum(np.where(t.kind == SEGMENT, np.linalg.norm(t.end - t.start, axis=1),
                              np.abs(t.sweep) * t.radius)[t.contour == c])
              for c in range(t.closed.size)]
    outer = int(np.argmax(length))
    q = np.vstack([points_on(t, n, rng, (t.contour == c).astype(float))
                   for c, n in [(outer, 400)] + [(c, 50) for c in range(t.closed.size)
                                                 if c != outer]])
    # Planted deviation along the positive normal: a rise of +0.03 mm on the outer arc near
    # 100 degrees, probing noise 3 um.
    ang = np.arctan2(q[:, 1], q[:, 0])
    rad = np.hypot(q[:, 0], q[:, 1])
    rise = 0.03 * np.exp(-((ang - np.radians(100.0)) / np.radians(2.0)) ** 2) * (rad > 1090)
    planted = rise + rng.normal(0.0, 0.003, q.shape[0])
    nrm = deviations_2d(ContourIndex(t), q).normal
    q2 = q + planted[:, None] * nrm
    # The template lies on the CMM bed tilted by 2 degrees, turned and shifted; the probe also
    # sees 2 um of flatness noise.
    z = rng.normal(0.0, 0.002, q.shape[0])
    P3 = np.column_stack([q2, z])
    R = rotation([0.2, -0.1, 1.0], 63.0) @ rotation([1.0, 0.0, 0.0], 2.0)
    tr = np.array([-310.0, -1180.0, 42.0])
    measured = P3 @ R.T + tr
    _write_cmm(os.path.join(out, "measured.csv"),
               "CMM points along the frame template, machine coordinates (mm)",
               [f"F{i + 1:03d}" for i in range(len(measured))], measured)
    truth = {
        "description": "fuselage frame contour template (DXF) and 500 CMM points, tilted 2 deg",
        "T_nominal_measured": np.linalg.inv(pose(R, tr)).tolist(),
        "planted_deviation_mm": [round(float(d), 6) for d in planted],
        "defect": "rise +0.03 mm (sigma 2 deg) on the outer arc at 100 deg; noise sigma 0.003 "
                  "mm in plane and 0.002 mm out of plane",
        "tolerance_mm": 0.05,
        "expected_verdict": "ACCEPT",
    }
    _write_json(os.path.join(out, "truth.json"), truth)
    _write_session(out, "template.dxf", "measured.csv", 0.05)
    return truth


def _write_cmm(path, comment, labels, points):
    """A CMM point file as the machines write them: comment, header, label and x y z (0.1 um)."""
    with open(path, "w") as f:
        f.write(f"# {comment}\n")
        f.write("id,x,y,z\n")
        for lab, p in zip(labels, points):
            f.write(f"{lab},{p[0]:.4f},{p[1]:.4f},{p[2]:.4f}\n")


def _write_session(out, nominal, measured, tol):
    """inspection.qasession: the sample as a desktop-app session (files beside it, the zone),
    so that ``qa-app samples/NAME/inspection.qasession`` opens and inspects it."""
    import hashlib

    def sha(f):
        with open(os.path.join(out, f), "rb") as fh:
            return hashlib.sha256(fh.read()).hexdigest()

    _write_json(os.path.join(out, "inspection.qasession"), {
        "format": "qa-inspect session", "version": 1, "saved": None,
        "inputs": [{"role": role, "path": None, "relative_path": f, "sha256": sha(f)}
                   for role, f in (("nominal", nominal), ("measured", measured))],
        "settings": {"tol_lower": -tol, "tol_upper": tol, "layers": None, "units": None,
                     "scale": None},
        "results": None})


def _write_json(path, obj):
    with open(path, "w") as f:
        json.dump(obj, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    make_fairing(os.path.join(HERE, "belly_fairing"))
    make_bracket(os.path.join(HERE, "seat_bracket"))
    make_frame(os.path.join(HERE, "fuselage_frame"))
    print("samples written under", HERE)
