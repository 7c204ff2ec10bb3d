"""The compiled ICP of the global search (engine.icp_kernels.icp_poses) and its constant-time pairing
(engine.neighbours.SampleLookup), each against an independent twin: scipy's kd-tree, LAPACK's
eigh, and the numpy ICP of engine.registration run with the same pairing."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from engine import icp_kernels, kernels
from engine.pose import apply_transform, make_transform
from engine.nominal import Nominal
from engine.pose import min_norm_solve
from engine.neighbours import spread_subset
from engine.registration import _hypotheses, _icp_batch, _icp_poses
from engine.registration_types import RegistrationSettings
from naive import LookupAsTree, cell_owners, icp_batch, nearest_sample
from surfaces import height, height_grid, point_set, random_rotation


@pytest.fixture(scope="module")
def level():
    pts, nrm, grid = height_grid(300, 200)
    nominal = Nominal.from_point_set(point_set(pts, nrm, grid))
    p, nrm, tree = nominal.level(1000)
    return nominal, p, nrm, nominal.level_shape(1000), \
        nominal.level_spacing(1000), tree, nominal.level_lookup(1000)


def _surface_points(rng, n, noise):
    x, y = rng.uniform(-250, 250, n), rng.uniform(-125, 125, n)
    return np.column_stack([x, y, height(x, y)]) + rng.normal(0.0, noise, (n, 3))


def _pair(lookup, pts, X):
    out = [icp_kernels.nearest_sample(x[0], x[1], x[2], lookup.lo, lookup.cell, lookup.owner,
                                  lookup.graph, pts) for x in X]
    return np.array([o[0] for o in out]), np.array([o[1] for o in out])


def test_the_lookup_pairs_with_the_nearest_sample_or_one_within_its_bound(level):
    """Near the surface almost every point gets its nearest sample (scipy's kd-tree); every point
    in the grid gets one at most 2 sqrt(3) cells farther than the nearest (the cell's owner lies
    within a cell of the sample nearest the cell's centre; the walk only comes nearer), and no graph
    neighbour of the sample found is nearer; outside the grid, the walk still ends at a sample
    no graph neighbour beats. The compiled pairing is its slow twin's."""
    _, pts, _, _, h, tree, lookup = level
    rng = np.random.default_rng(4)
    near = _surface_points(rng, 4000, 0.5 * h)
    box_lo, box_hi = lookup.lo, lookup.lo + lookup.cell * np.array(lookup.owner.shape)
    inside = rng.uniform(box_lo, box_hi, (4000, 3))
    outside = rng.uniform(box_lo - 2000, box_hi + 2000, (2000, 3))
    for X, exact_share in ((near, 0.95), (inside, 0.8), (outside, None)):
        j, d2 = _pair(lookup, pts, X)
        d_true, j_true = tree.query(X)
        assert np.allclose(d2, np.sum((X - pts[j]) ** 2, axis=1), rtol=1e-12, atol=0)
        graph_d2 = np.sum((X[:, None, :] - pts[lookup.graph[j]]) ** 2, axis=2)
        assert np.all(graph_d2 >= d2[:, None])
        twin = [nearest_sample(x, lookup, pts) for x in X[:300]]
        assert np.array_equal(j[:300], [t[0] for t in twin])
        if exact_share is not None:
            assert np.mean(j == j_true) >= exact_share
            assert np.all(np.sqrt(d2) <= d_true + 2 * np.sqrt(3) * lookup.cell + 1e-9)


def test_each_cell_owner_lies_within_a_cell_of_the_nearest_sample(level):
    """The lookup's cell owners (engine.icp_kernels.cell_owners, a distance transform by two
    raster sweeps) against the nearest sample to each cell's centre found by scipy's kd-tree:
    never more than one cell farther, and on most cells the same sample."""
    _, pts, _, _, _, _, lookup = level
    exact, centres = cell_owners(pts, lookup.lo, lookup.cell, lookup.owner.shape)
    d_owner = np.linalg.norm(pts[lookup.owner] - centres, axis=-1)
    d_exact = np.linalg.norm(pts[exact] - centres, axis=-1)
    assert np.all(d_owner <= d_exact + lookup.cell)
    assert np.mean(lookup.owner == exact) >= 0.3


def test_symmetric_eigen_and_the_min_norm_step_match_lapack():
    """Jacobi eigen-decomposition of 6 x 6 pose systems against numpy's eigh (LAPACK), including
    rank-deficient ones (a plane's slides), and the minimum-norm step built on it (or on
    Cholesky, where the condition number provably keeps every direction) against
    engine.pose.min_norm_solve."""
    rng = np.random.default_rng(11)
    w, V, As, out = np.empty(6), np.empty((6, 6)), np.empty((6, 6)), np.empty(6)
    for k in range(300):
        scales = rng.choice([1e-9, 1e-3, 1.0, 1e3], 6)
        B = rng.normal(size=(6, 4 + k % 3)) * scales[:, None]
        A = B @ B.T
        ref = np.linalg.eigh(A)[0]
        work = A.copy()
        icp_kernels.symmetric_eigen(work, w, V)
        assert np.allclose(np.sort(w), ref, rtol=0, atol=1e-13 * ref[-1])
        assert np.allclose(A @ V, V * w, rtol=0, atol=1e-12 * ref[-1])
        assert np.allclose(V.T @ V, np.eye(6), atol=1e-13)
    # Rank-deficient and ill-conditioned steps. The scaled system's eigenvalues are kept at least
    # 100 times from the 1e-6 x largest below which a direction is left alone: at the threshold
    # itself, LAPACK's last digits (which change with the CPU's code path) decide either way.
    for k in range(300):
        Q, _ = np.linalg.qr(rng.normal(size=(6, 6)))
        top, kept = 10.0 ** rng.uniform(-3, 6), 1 + k % 6
        ev = top * np.r_[1.0, 10.0 ** rng.uniform(-4, 0, kept - 1),
                         10.0 ** rng.uniform(-16, -8, 6 - kept) * (k % 2)]
        length = 10.0 ** rng.uniform(-1, 3)
        s = np.r_[np.full(3, 1.0 / length), np.ones(3)]
        A = (Q * ev) @ Q.T / np.outer(s, s)
        A = 0.5 * (A + A.T)
        b = rng.normal(size=6) * np.abs(A).max()
        icp_kernels._min_norm_step(A, b, length, As, w, V, out)
        expect = min_norm_solve(A, b, 3, length)
        assert np.allclose(-out, expect, rtol=0, atol=1e-9 * np.max(np.abs(expect)))
    # Well-conditioned systems take the Cholesky path (checked to be taken), same answer.
    taken = 0
    for k in range(300):
        B = rng.normal(size=(6, 6))
        A = B @ B.T + 10.0 ** rng.uniform(-3, 1) * np.eye(6)
        b, length = rng.normal(size=6), 10.0 ** rng.uniform(-1, 1)
        s = np.r_[np.full(3, 1.0 / length), np.ones(3)]
        taken += icp_kernels._well_conditioned_solve(A * s[:, None] * s[None, :], b, 1.0 / length,
                                                 V, out)
        icp_kernels._min_norm_step(A, b, length, As, w, V, out)
        expect = min_norm_solve(A, b, 3, length)
        assert np.allclose(-out, expect, rtol=1e-9, atol=1e-12 * np.max(np.abs(expect)))
    assert taken > 200


@pytest.mark.parametrize("shape, reach, lam2, m", [(True, np.inf, 0.01, 16),
                                                   (False, np.inf, 0.01, 17),
                                                   (True, 60.0, 0.0, 17)])
def test_compiled_icp_is_the_numpy_icp_with_the_same_pairing(level, shape, reach, lam2, m):
    """Poses from the global search's starts, three ICP iterations: the compiled kernel (split
    over threads) and the numpy ICP twin paired by the same lookup end at the same poses and
    scores, with the curvature term or without, with a reach or without, over an even and an
    odd number of points."""
    nominal, pts, nrm, S, h, _, lookup = level
    rng = np.random.default_rng(7)
    q = _surface_points(rng, 600, 0.004)
    measured = apply_transform(make_transform(random_rotation(rng), rng.uniform(-900, 900, 3)), q)
    T = _hypotheses(nominal, measured, pts, nrm, RegistrationSettings())[::9]
    src = measured[spread_subset(measured, m)]  # an even and an odd count: the median
    S = S if shape else None
    T_fast, s_fast = _icp_poses(T, src, lookup, pts, nrm, S, h, iterations=3, lam2=lam2,
                                reach=reach)
    T_slow, s_slow, done = icp_batch(T, src, LookupAsTree(lookup, pts), pts, nrm, h,
                                     iterations=3, lam2=lam2, reach=reach, shape=S)
    assert done == 3
    def apart(A, B):  # (H,) how far two sets of poses put the points apart, at most, mm
        return np.linalg.norm(np.einsum("hij,mj->hmi", A[:, :3, :3] - B[:, :3, :3], src)
                              + (A[:, None, :3, 3] - B[:, None, :3, 3]), axis=2).max(axis=1)

    # Agreement to rounding: 1e-6 mm, or 1e-9 of how far a pose travelled (some starts are
    # flung metres away, where the last digits of metres are micrometres).
    assert np.all(apart(T_fast, T_slow) <= 1e-6 + 1e-9 * apart(T_fast, T))
    assert np.allclose(s_fast, s_slow, rtol=1e-9, atol=1e-12)
    # The split over threads does not change the answer.
    one = np.empty_like(T_fast), np.empty(len(T))
    icp_kernels.icp_poses(T, src, lookup.lo, lookup.cell, lookup.owner, lookup.graph, pts, nrm,
                      np.zeros((0, 3, 3)) if S is None else S, h, 3, lam2, reach, 0, len(T), *one)
    assert np.array_equal(one[0], T_fast) and np.array_equal(one[1], s_fast)


def test_farthest_points_and_distinct_poses_match_their_twins():
    """The global search's spread subset and its pick of distinct poses, compiled, against
    slow obvious twins, on points with ties (a grid) and without, and on poses with
    near-duplicates."""
    from naive import distinct_first, farthest_points
    rng = np.random.default_rng(5)
    grid = np.stack(np.meshgrid(np.arange(6.0), np.arange(5.0), [0.0, 1.0]), -1).reshape(-1, 3)
    for P in (rng.normal(size=(300, 3)), grid):
        for m in (1, 4, 16, 40):
            assert list(icp_kernels.farthest_points(P, P.mean(0), m)) == \
                farthest_points(P, P.mean(0), m)
    base = rng.normal(size=(40, 4, 3)) * 10
    feat = np.concatenate([base, base + rng.normal(size=base.shape) * 0.05])[rng.permutation(80)]
    for tol, keep in ((0.01, 100), (0.2, 100), (0.2, 7), (50.0, 100)):
        assert list(icp_kernels.distinct_first(feat, tol, keep)) == distinct_first(feat, tol, keep)


def test_shape_operators_match_their_twin_and_a_sphere():
    """Nominal.shape_operators (compiled per point, Cramer's rule) against the numpy twin (LAPACK's
    solve) on the fairing, a sphere and a cube's edges; on a sphere of radius R with outward
    normals S = -(I - n n^T) / R; across the cube's edges S is zero (the tangent plane)."""
    from naive import shape_operators
    from surfaces import sphere_points
    rng = np.random.default_rng(3)
    pts, nrm, grid = height_grid(120, 80)
    fairing = Nominal.from_point_set(point_set(pts, nrm, grid))
    sp, sn = sphere_points(r=50.0)
    sphere = Nominal.from_point_set(point_set(sp, sn))
    c = rng.uniform(0, 20, (3000, 3))
    axis = rng.integers(0, 3, 3000)
    side = rng.integers(0, 2, 3000)
    c[np.arange(3000), axis] = 20.0 * side
    cn = np.zeros((3000, 3))
    cn[np.arange(3000), axis] = 2.0 * side - 1
    cube = Nominal.from_point_set(point_set(c, cn))
    for nominal in (fairing, sphere, cube):
        idx = rng.choice(nominal.n, 500, replace=False)
        S = nominal.shape_operators(idx)
        _, nb = nominal.tree.query(nominal.points[idx], k=9)
        n = nominal.normals(idx)
        twin = shape_operators(n, nominal.points[nb] - nominal.points[idx][:, None],
                               nominal.normals(nb) - n[:, None])
        assert np.allclose(S, twin, rtol=1e-9, atol=1e-12)
        if nominal is sphere:
            expect = -(np.eye(3) - np.einsum("mi,mj->mij", n, n)) / 50.0
            assert np.allclose(S, expect, atol=2e-3 / 50.0)
        if nominal is cube:
            edge = np.min(np.minimum(c[idx], 20.0 - c[idx]) + 20.0 * (
                np.arange(3)[None] == axis[idx][:, None]), axis=1) < 0.5
            assert edge.sum() > 5 and np.all(S[edge] == 0.0)


@pytest.mark.parametrize("level_size, stop_rad", [(4000, 0.0), (None, 1e-6)])
def test_coarse_to_fine_icp_is_its_numpy_twin(level, level_size, stop_rad):
    """The coarse-to-fine levels' ICP (engine.registration._icp_batch: scipy's kd-tree pairs,
    compiled arithmetic) against the numpy twin with the same kd-tree: a quadric level of 4,000
    samples, and the whole nominal (plane, normals looked up as needed, early stop), from poses
    a few millimetres and degrees off."""
    nominal = level[0]
    rng = np.random.default_rng(9)
    q = _surface_points(rng, 500, 0.004)
    T0 = make_transform(random_rotation(rng), rng.uniform(-900, 900, 3))
    measured = apply_transform(T0, q)
    inv = np.linalg.inv(T0)
    from engine.pose import rotation_from_rotvec
    T = np.stack([make_transform(rotation_from_rotvec(rng.normal(0, 0.03, 3)), rng.normal(0, 3, 3))
                  @ inv for _ in range(6)])
    if level_size is None:
        tree, pts, nrm, S = nominal.tree, nominal.points, nominal.normals, None
    else:
        pts, nrm, tree = nominal.level(level_size)
        S = nominal.level_shape(level_size)
    h = nominal.level_spacing(nominal.n if level_size is None else level_size)
    fast = _icp_batch(T, measured, tree, pts, nrm, h, iterations=8, stop_rad=stop_rad,
                      reach=10 * h, shape=S)
    slow = icp_batch(T, measured, tree, pts, nrm, h, iterations=8, stop_rad=stop_rad,
                     reach=10 * h, shape=S)
    assert fast[2] == slow[2] and (stop_rad == 0.0 or fast[2] < 8), fast[2]
    moved = np.linalg.norm(np.einsum("hij,mj->hmi", fast[0][:, :3, :3] - slow[0][:, :3, :3],
                                     measured) + (fast[0][:, None, :3, 3] - slow[0][:, None, :3, 3]),
                           axis=2)
    assert np.max(moved) < 1e-7
    assert np.allclose(fast[1], slow[1], rtol=1e-9, atol=1e-15)
    # and they land where the points belong
    assert np.max(np.linalg.norm(apply_transform(fast[0][0], measured) - q, axis=1)) < 0.05


def test_grid_triangles_and_longest_edges_match_their_twins():
    """The nominal's grid split (shorter diagonal; zero-area triangles at a pole left out), a
    mesh's zero-area test and the triangles' longest edges, compiled, against the numpy twins,
    exactly."""
    from engine.nominal import _grid_triangles
    from naive import grid_triangles
    rng = np.random.default_rng(2)
    for nu, nv in ((7, 5), (40, 31), (300, 200)):
        u, v = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv))
        pts = np.column_stack([u.ravel(), v.ravel(), np.zeros(u.size)]) \
            + rng.normal(0, 0.2 / nu, (u.size, 3))
        assert np.array_equal(_grid_triangles(pts, nu, nv), grid_triangles(pts, nu, nv))
    # A cone: the first row all at the apex, its cells' triangles there have zero area.
    a, h = np.meshgrid(np.linspace(0, 2 * np.pi, 24), np.linspace(0, 10, 9))
    cone = np.column_stack([(h * np.cos(a)).ravel(), (h * np.sin(a)).ravel(), h.ravel()])
    tris = _grid_triangles(cone, 24, 9)
    assert np.array_equal(tris, grid_triangles(cone, 24, 9)) and len(tris) < 2 * 23 * 8
    P = rng.normal(size=(500, 3))
    T = rng.integers(0, 500, (2000, 3))
    e = np.stack([np.sum((P[T[:, k]] - P[T[:, (k + 1) % 3]]) ** 2, axis=1) for k in range(3)])
    assert np.allclose(kernels.longest_edges(P, T), np.sqrt(e.max(axis=0)), rtol=1e-15, atol=0)
    # A mesh's zero-area triangles (a repeated corner, three collinear corners) by the same
    # rule as the grid's.
    from naive import nonzero_area_xyz
    P[:50] = P[50:100] * 0.0 + np.linspace(0, 1, 50)[:, None] * [1.0, 2.0, 3.0]  # a line
    T[:300, 1] = T[:300, 0]
    T[300:600] = rng.integers(0, 50, (300, 3))
    keep = kernels.nonzero_areas(P, T)
    assert np.array_equal(keep, nonzero_area_xyz(P[T[:, 0]].T, P[T[:, 1]].T, P[T[:, 2]].T))
    assert not keep[:600].any() and keep[600:].mean() > 0.99


def test_degenerate_samples_take_the_tangent_plane_and_the_lookup_still_builds():
    """Neighbours all at one place (a grid's pole row, points stored twice) or no normal: the
    shape operator is zero (the tangent plane; the numpy twin's answer for coincident
    neighbours), where the compiled Cramer's rule divided by zero. Samples in one plane with no
    spacing between copies: the lookup's grid stays within its cell budget, where its cell count
    overflowed. Both ended a registration with an exception; found by review."""
    from naive import shape_operators
    from engine.neighbours import LOOKUP_CELLS, SampleLookup
    rng = np.random.default_rng(8)
    n = rng.normal(size=(6, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n[5] = 0.0
    dx = np.zeros((6, 9, 3))
    dx[3:5] = rng.normal(size=(2, 9, 3)) * 1e-90
    dn = np.zeros((6, 9, 3))
    S = np.full((6, 3, 3), np.nan)
    icp_kernels.shape_fit(n, dx, dn, S)
    assert np.array_equal(S, np.zeros((6, 3, 3)))
    assert np.array_equal(shape_operators(n[:3], dx[:3], dn[:3]), np.zeros((3, 3, 3)))
    x, y = np.meshgrid(np.linspace(0, 100, 30), np.linspace(0, 60, 20))
    plate = np.repeat(np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)]), 2, axis=0)
    lookup = SampleLookup.build(plate, cKDTree(plate), 0.0)
    assert lookup.owner.size <= LOOKUP_CELLS
    X = plate[::7] + [0.3, -0.2, 1.0]
    j, _ = _pair(lookup, plate, X)
    assert np.allclose(np.linalg.norm(X - plate[j], axis=1), cKDTree(plate).query(X)[0])


@pytest.mark.parametrize("layout", ["pole row", "stored twice"])
def test_degenerate_nominals_register(layout):
    """End to end on the review's cases: a dome's grid whose first row is its pole (72 copies of
    one point) and a plate whose every point is stored twice, in arbitrary poses; the plate comes
    back where it was (the dome is symmetric about its axis: only its fit is checked)."""
    from engine.pointset import PointSet
    from engine.registration import register
    rng = np.random.default_rng(1)
    if layout == "pole row":
        th, ph = np.meshgrid(np.linspace(0, 2 * np.pi, 72), np.linspace(0, np.pi / 2, 40))
        P = 50 * np.column_stack([np.sin(ph.ravel()) * np.cos(th.ravel()),
                                  np.sin(ph.ravel()) * np.sin(th.ravel()), np.cos(ph.ravel())])
        P[:, 2] += 0.0005 * P[:, 0] ** 2
        nominal = Nominal.from_point_set(PointSet(P, grid_shape=(72, 40)))
        q = P[rng.choice(len(P), 600, replace=False)] + rng.normal(0, 0.01, (600, 3))
    else:
        x, y = np.meshgrid(np.linspace(0, 100, 30), np.linspace(0, 60, 20))
        keep = ~((x > 70) & (y > 30))
        P = np.column_stack([x[keep], y[keep], np.zeros(keep.sum())])
        nominal = Nominal.from_point_set(PointSet(np.repeat(P, 2, axis=0)))
        q = P[rng.choice(len(P), 200, replace=False)] + rng.normal(0, 0.01, (200, 3))
    measured = apply_transform(make_transform(random_rotation(rng), rng.uniform(-200, 200, 3)), q)
    res = register(nominal, measured)
    assert res.rms < 0.02
    if layout == "stored twice":
        assert np.max(np.linalg.norm(apply_transform(res.T_nominal_measured, measured) - q,
                                     axis=1)) < 0.01
