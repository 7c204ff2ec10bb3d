"""Analytic test geometry with exact answers (independent of the engine)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from engine.pointset import PointSet


def height(x, y):
    """A doubly curved, asymmetric 500 x 250 mm surface (principal radii ~150-400 mm)."""
    return -x**2 / 800.0 - y**2 / 300.0 + 1e-6 * x**3 + 4e-4 * x * y


def height_normal(x, y):
    hx = -x / 400.0 + 3e-6 * x**2 + 4e-4 * y
    hy = -y / 150.0 + 4e-4 * x
    n = np.stack([-hx, -hy, np.ones_like(np.asarray(x, float))], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def height_grid(nu=300, nv=200):
    """(points (nu*nv, 3), normals, (nu, nv)), u fastest, over [-250, 250] x [-125, 125]."""
    X, Y = np.meshgrid(np.linspace(-250, 250, nu), np.linspace(-125, 125, nv))
    x, y = X.ravel(), Y.ravel()
    return np.column_stack([x, y, height(x, y)]), height_normal(x, y), (nu, nv)


def write_grid_nominal(path, nu=150, nv=100):
    """Write :func:`height_grid` as a nominal file: '# grid:' header, x y z i j k columns."""
    pts, nrm, _ = height_grid(nu, nv)
    with open(path, "w") as f:
        f.write(f"# grid: {nu} x {nv}\nx,y,z,i,j,k\n")
        np.savetxt(f, np.hstack([pts, nrm]), fmt="%.9f", delimiter=",")


def write_labelled_points(path, points):
    """Write (n, 3) points as a CMM file: 'id,x,y,z' with labels P000, P001, ..."""
    with open(path, "w") as f:
        f.write("id,x,y,z\n")
        for i, p in enumerate(points):
            f.write(f"P{i:03d},{p[0]:.6f},{p[1]:.6f},{p[2]:.6f}\n")


def exact_signed_distance(q):
    """Signed distance (positive along +z-ish normal) from q to the height surface (Newton)."""
    out = np.empty(len(q))
    for i, p in enumerate(q):
        r = least_squares(lambda z: p - np.array([z[0], z[1], height(z[0], z[1])]), p[:2],
                          xtol=1e-15, ftol=1e-15, gtol=1e-15)
        s = np.array([r.x[0], r.x[1], height(*r.x)])
        n = height_normal(r.x[0], r.x[1])
        out[i] = np.sign((p - s) @ n) * np.linalg.norm(p - s)
    return out


def points_off_surface(rng, m, dev, xr=(-240, 240), yr=(-115, 115)):
    """m points at signed offsets ``dev`` along the normal of the height surface."""
    x = rng.uniform(*xr, m)
    y = rng.uniform(*yr, m)
    base = np.column_stack([x, y, height(x, y)])
    return base + np.asarray(dev)[:, None] * height_normal(x, y)


def sphere_points(n_theta=60, n_phi=120, r=50.0):
    """A sphere of radius r sampled on a latitude-longitude pattern, with outward normals."""
    th = np.linspace(0.05, np.pi - 0.05, n_theta)
    ph = np.linspace(0, 2 * np.pi, n_phi, endpoint=False)
    T, P = np.meshgrid(th, ph)
    n = np.column_stack([np.sin(T.ravel()) * np.cos(P.ravel()), np.sin(T.ravel()) * np.sin(P.ravel()),
                         np.cos(T.ravel())])
    return r * n, n


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def point_set(points, normals=None, grid=None, triangles=None):
    return PointSet(np.asarray(points, float), normals, None, grid, triangles, 3, "<test>")


def half_turn_symmetric_part(bump: float, dent: float = 0.0, seed: int = 0):
    """A surface symmetric under a half turn about z, with an optional small bump on one side
    only (an asymmetric feature a half-turned part would miss); the measured part (1,500
    points, seeded pose) has an optional ``dent`` (mm deep) of its own. Returns (Nominal,
    measured (1500, 3))."""
    from engine.pose import apply_transform, make_transform
    from engine.nominal import Nominal

    def h(x, y):
        return -x ** 2 / 800.0 - y ** 2 / 300.0 + bump * np.exp(
            -((x - 150) ** 2 + (y - 40) ** 2) / (2 * 15.0 ** 2))

    def n(x, y, e=1e-4):
        hx = (h(x + e, y) - h(x - e, y)) / (2 * e)
        hy = (h(x, y + e) - h(x, y - e)) / (2 * e)
        v = np.stack([-hx, -hy, np.ones_like(x)], axis=-1)
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    X, Y = np.meshgrid(np.linspace(-250, 250, 400), np.linspace(-125, 125, 200))
    x, y = X.ravel(), Y.ravel()
    nominal = Nominal.from_point_set(point_set(np.column_stack([x, y, h(x, y)]), n(x, y),
                                               (400, 200)))
    rng = np.random.default_rng(21)
    mx, my = rng.uniform(-245, 245, 1500), rng.uniform(-120, 120, 1500)
    d = rng.normal(0, 0.005, 1500) - dent * np.exp(-((mx + 60) ** 2 + (my + 50) ** 2)
                                                   / (2 * 20.0 ** 2))
    q = np.column_stack([mx, my, h(mx, my)]) + d[:, None] * n(mx, my)
    T = make_transform(random_rotation(rng), [300.0, 100.0, -50.0])
    if seed:
        prng = np.random.default_rng(1000 + seed)
        T = make_transform(random_rotation(prng), prng.uniform(-1000, 1000, 3))
    return nominal, apply_transform(T, q)


def bracket_two_faces(rng, n_nominal: int):
    """The seat bracket of samples.generate as a point-set nominal of ``n_nominal`` points, and
    100 points on its two curved faces drawn from ``rng`` after it (50 on A, the flange top, x in
    [25, 105], y in [8, 52]; 50 on B, the web face, y in [8, 52], z in [25, 80]): (Nominal,
    points (100, 3), their outward normals (100, 3))."""
    import samples.generate as gen
    from engine.nominal import Nominal

    nominal = gen.bracket_points(n_nominal, rng)
    nom = Nominal.from_point_set(point_set(nominal[:, :3], nominal[:, 3:]))
    xa, ya = rng.uniform(25, 105, 50), rng.uniform(8, 52, 50)
    yb, zb = rng.uniform(8, 52, 50), rng.uniform(25, 80, 50)
    q = np.vstack([np.column_stack([xa, ya, gen.face_a_height(xa, ya)]),
                   np.column_stack([gen.face_b_offset(yb, zb), yb, zb])])
    return nom, q, np.vstack([gen.face_a_normal(xa, ya), gen.face_b_normal(yb, zb)])


CUBE_BOSS = np.array([15.0, 30.0, 50.0])
"""The centre of the hemispherical boss on the top of the 50 mm cube of :func:`cube_face` (a
corner at the origin)."""


def upper_hemisphere(rng, k):
    """k random unit vectors with z > 0."""
    v = rng.normal(size=(4 * k, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    return v[v[:, 2] > 0][:k]


def cube_face(rng, axis, side, k, lo, hi, clear):
    """k points uniform over [lo, hi]^2 on the 50 mm cube's face x[axis] = 50 x side (on the top,
    farther than ``clear`` from the boss's axis), and its outward normals."""
    p = np.insert(rng.uniform(lo, hi, (k, 2)), axis, 50.0 * side, axis=1)
    if axis == 2 and side:
        p = p[np.hypot(p[:, 0] - CUBE_BOSS[0], p[:, 1] - CUBE_BOSS[1]) > clear]
    return p, np.tile(np.insert([0.0, 0.0], axis, 2 * side - 1), (len(p), 1))


def cube_with_small_boss(rng, radius=2.0, per_face=10_000, on_boss=3000, measured_per_face=300,
                         measured_on_boss=12, noise=0.001):
    """The 50 mm cube with a boss of ``radius`` on its top, sampled at random as bare points
    (``per_face`` a face, ``on_boss`` on the boss): (points, normals), and points measured on
    it in its frame: ``measured_per_face`` on each of the bottom, the sides x = 0 and y = 0 and
    the top (5 mm or more from every edge and 3 mm from the boss), up to ``measured_on_boss``
    on the boss (those more than 0.1 radius above the top), ``noise`` mm along the normals."""
    faces = [cube_face(rng, axis, side, per_face, 0.0, 50.0, radius)
             for axis in range(3) for side in (0.0, 1.0)]
    s = upper_hemisphere(rng, on_boss)
    pts = np.vstack([p for p, _ in faces] + [CUBE_BOSS + radius * s])
    nrm = np.vstack([n for _, n in faces] + [s])
    faces = [cube_face(rng, axis, side, 4 * measured_per_face // 3, 5.0, 45.0, radius + 3)
             for axis, side in ((2, 0.0), (0, 0.0), (1, 0.0), (2, 1.0))]
    s = upper_hemisphere(rng, measured_on_boss)
    s = s[s[:, 2] > 0.1]
    q = np.vstack([p[:measured_per_face] for p, _ in faces] + [CUBE_BOSS + radius * s])
    n = np.vstack([n[:measured_per_face] for _, n in faces] + [s])
    return pts, nrm, q + rng.normal(0.0, noise, len(q))[:, None] * n
