"""Datum reference frames (engine.gdt.datums) against analytic geometry: a block with plane faces and
a hole, measured exactly, misplaced by a known rigid motion."""

import numpy as np
import pytest

from engine.gdt.datums import align, align_rps, invariant_motions
from engine.pose import make_transform, rotation_from_rotvec
from engine.gdt.plan import Datum

# A block [0, 100] x [0, 60] x [0, 20] with a vertical hole of radius 4 at (64, 30).
# Outward normals: bottom -z, back -x, side -y, top +z; the hole's wall points at its axis.
PLANES = {"A": ((0.0, 0.0, -1.0), 0.0), "B": ((-1.0, 0.0, 0.0), 0.0),
          "C": ((0.0, -1.0, 0.0), 0.0), "top": ((0.0, 0.0, 1.0), 20.0)}
HOLE_XY, HOLE_R = np.array([64.0, 30.0]), 4.0


def face_points(face, k, rng):
    u, v = rng.uniform(0, 1, k), rng.uniform(0, 1, k)
    if face == "A":
        return np.column_stack([5 + 90 * u, 5 + 50 * v, np.zeros(k)])
    if face == "B":
        return np.column_stack([np.zeros(k), 5 + 50 * u, 2 + 16 * v])
    if face == "C":
        return np.column_stack([5 + 90 * u, np.zeros(k), 2 + 16 * v])
    if face == "top":
        return np.column_stack([5 + 40 * u, 5 + 50 * v, np.full(k, 20.0)])
    a = 2 * np.pi * u
    return np.column_stack([HOLE_XY[0] + HOLE_R * np.cos(a), HOLE_XY[1] + HOLE_R * np.sin(a),
                            2 + 16 * v])


class Block:
    """Measured points with a known face each; ``evaluate`` is the exact signed distance to
    that face's nominal surface (+ outward: excess material)."""

    def __init__(self, counts, rng, misplace, excess=None, hole_shift=(0.0, 0.0), hole_dr=0.0):
        self.face = np.concatenate([[f] * k for f, k in counts.items()])
        P = np.vstack([face_points(f, k, rng) for f, k in counts.items()])
        for f, (n, _) in PLANES.items():
            if excess and f in excess:
                P[self.face == f] += np.outer(excess[f], n) if np.ndim(excess[f]) else \
                    excess[f] * np.asarray(n)
        hole = self.face == "hole"
        # The actual hole: radius HOLE_R + hole_dr about HOLE_XY + hole_shift.
        rel = P[hole, :2] - HOLE_XY
        P[hole, :2] = HOLE_XY + np.asarray(hole_shift) + rel / HOLE_R * (HOLE_R + hole_dr)
        self.true_points = P
        self.misplace = misplace
        self.M = P @ misplace[:3, :3].T + misplace[:3, 3]

    def evaluate(self, T, idx):
        X = self.M[idx] @ T[:3, :3].T + T[:3, 3]
        d = np.empty(len(idx))
        n = np.empty((len(idx), 3))
        for k, f in enumerate(self.face[idx]):
            if f == "hole":
                r = X[k, :2] - HOLE_XY
                rho = np.linalg.norm(r)
                n[k] = [-r[0] / rho, -r[1] / rho, 0.0]
                d[k] = HOLE_R - rho
            else:
                nn, off = PLANES[f]
                n[k] = nn
                d[k] = X[k] @ np.asarray(nn) - (off if f == "top" else 0.0)
        return X, d, n

    def members(self, *faces):
        return [np.flatnonzero(self.face == f) for f in faces]

    def invariants(self, *faces):
        """The motions leaving each face's ideal nominal feature in place (engine.gdt.datums)."""
        c, length = self.frame()
        out = []
        for f in faces:
            if f == "hole":
                out.append(invariant_motions("cylinder", {"point": np.array([*HOLE_XY, 0.0]),
                                                          "direction": np.array([0, 0, 1.0])},
                                             c, length))
            else:
                n, off = PLANES[f]
                out.append(invariant_motions("plane", {"point": off * np.abs(n),
                                                       "normal": np.array(n)}, c, length))
        return out

    def frame(self):
        c = self.M.mean(axis=0)
        return c, float(np.sqrt(np.mean(np.sum((self.M - c) ** 2, axis=1))))


def misplacement(rng, angle=0.02, shift=0.5):
    R = rotation_from_rotvec(rng.uniform(-angle, angle, (1, 3)))[0]
    return make_transform(R, rng.uniform(-shift, shift, 3))


def planes(fit="tangent"):
    return [Datum(x, x, "plane", fit) for x in "ABC"]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_three_planes_fix_every_degree_of_freedom(seed):
    rng = np.random.default_rng(seed)
    b = Block({"A": 40, "B": 30, "C": 20, "top": 30}, rng, misplacement(rng),
              excess={"top": 0.05})
    c, length = b.frame()
    al = align(b.evaluate, np.eye(4), planes(), b.members("A", "B", "C"), c, length,
               invariants=b.invariants("A", "B", "C"))
    assert [d.constrained for d in al.datums] == [3, 2, 1]
    assert al.free == () and al.complete
    # The misplacement undone exactly; the top face's planted excess measured exactly.
    assert np.max(np.abs(al.T_nominal_measured @ b.misplace - np.eye(4))) < 1e-9
    d = b.evaluate(al.T_nominal_measured, np.arange(len(b.face)))[1]
    assert np.max(np.abs(d[b.face == "top"] - 0.05)) < 1e-9


def _plane_fits(x, y, z):
    """Independent truth for a bottom face (material above it): the plane z = a x + b y + c by
    least squares, and the tangent one (below every point, the largest gap the smallest, then
    the smallest sum of gaps) as linear programs in the plane's own parameters."""
    from scipy.optimize import linprog

    G = np.column_stack([x, y, np.ones_like(x)])
    lsq = np.linalg.lstsq(G, z, rcond=None)[0]
    # Variables (a, b, c, g): G p <= z; z - G p <= g.
    A_ub = np.block([[G, np.zeros((x.size, 1))], [-G, -np.ones((x.size, 1))]])
    b_ub = np.concatenate([z, -z])
    free = [(None, None)] * 3 + [(0, None)]
    g = linprog([0, 0, 0, 1], A_ub=A_ub, b_ub=b_ub, bounds=free, method="highs")
    tangent = linprog(np.append(-G.sum(axis=0), 0.0), A_ub=np.vstack([A_ub, [0, 0, 0, 1]]),
                      b_ub=np.append(b_ub, g.fun + 1e-12), bounds=free, method="highs").x[:3]
    return lsq, tangent, g.fun


def _above(plane, P):
    """Distance of points P above the plane z = a x + b y + c, along its unit normal."""
    a, b, c = plane
    return (P[:, 2] - a * P[:, 0] - b * P[:, 1] - c) / np.sqrt(1 + a * a + b * b)


@pytest.mark.parametrize("seed", [4, 5])
def test_tangent_and_least_squares_datum_on_a_face_with_a_bump(seed):
    """Datum A carries a bump of h = 0.03 mm excess near one end on 4 of its 60 points: the
    part rests on it as on a surface plate (tangent) or on the mean plane (least squares); the
    top face (20 mm above A, no excess) then reads its distance from that plane minus 20,
    checked against the planes fitted independently in their own parameters."""
    rng = np.random.default_rng(seed)
    h = 0.03
    b = Block({"A": 60, "B": 30, "C": 20, "top": 30}, rng, misplacement(rng))
    A = b.face == "A"
    near = np.argsort(b.true_points[A, 0])[:4]  # the four points nearest x = 0
    bump = np.zeros(60)
    bump[near] = h
    b = Block({"A": 60, "B": 30, "C": 20, "top": 30}, np.random.default_rng(seed),
              b.misplace, excess={"A": bump})
    P = b.true_points
    lsq, tangent, gap = _plane_fits(P[A, 0], P[A, 1], P[A, 2])
    assert gap == pytest.approx(h, rel=1e-6)  # the bump is the largest gap either way
    c, length = b.frame()
    top = b.face == "top"
    for fit, plane in (("tangent", tangent), ("lsq", lsq)):
        al = align(b.evaluate, np.eye(4), planes(fit), b.members("A", "B", "C"), c, length,
                   invariants=b.invariants("A", "B", "C"))
        d = b.evaluate(al.T_nominal_measured, np.arange(len(b.face)))[1]
        assert np.max(np.abs(d[top] - (_above(plane, P[top]) - 20.0))) < 1e-8, fit
    al = align(b.evaluate, np.eye(4), planes(), b.members("A", "B", "C"), c, length,
               invariants=b.invariants("A", "B", "C"))
    dA = b.evaluate(al.T_nominal_measured, np.flatnonzero(A))[1]
    assert dA.max() == pytest.approx(0.0, abs=1e-9) and al.datums[0].gap == pytest.approx(h)


def test_a_tilted_tangent_plane_minimises_the_largest_gap():
    """Datum A's points lie on a plane tilted by a slope s along x: the tangent simulator takes
    the tilt (the gap becomes zero), where a fixed-orientation plane would leave 90 s."""
    rng = np.random.default_rng(5)
    b = Block({"A": 50, "B": 20, "C": 20}, rng, np.eye(4))
    slope = 2e-4
    A = b.face == "A"
    b.M[A, 2] -= slope * (b.M[A, 0] - 50.0)
    c, length = b.frame()
    al = align(b.evaluate, np.eye(4), planes()[:1], b.members("A"), c, length,
               invariants=b.invariants("A"))
    assert al.datums[0].gap < 1e-9
    R = al.T_nominal_measured[:3, :3]
    assert np.degrees(np.arccos(min(1.0, R[2, 2]))) == pytest.approx(np.degrees(slope),
                                                                      rel=1e-6)


def test_hole_as_datum_centres_the_largest_inscribed_cylinder():
    """A hole 0.02 mm larger in radius, its axis 0.03 mm off, is the primary datum after A:
    the inscribed cylinder's axis lands on the nominal's, its offset is -0.02 mm (the
    simulator is larger than the nominal by the radius difference)."""
    rng = np.random.default_rng(6)
    b = Block({"A": 40, "hole": 40, "C": 20}, rng, misplacement(rng, 0.01, 0.2),
              hole_shift=(0.03, -0.01), hole_dr=0.02)
    c, length = b.frame()
    ds = [Datum("A", "A", "plane"), Datum("H", "hole", "cylinder")]
    for fit in ("tangent", "lsq"):
        ds = [Datum("A", "A", "plane", fit), Datum("H", "hole", "cylinder", fit)]
        al = align(b.evaluate, np.eye(4), ds, b.members("A", "hole"), c, length,
                   invariants=b.invariants("A", "hole"))
        assert [d.constrained for d in al.datums] == [3, 2]
        assert al.datums[1].offset == pytest.approx(-0.02, abs=1e-9), fit
        # The actual hole's axis maps onto the nominal axis.
        X = b.evaluate(al.T_nominal_measured, b.members("hole")[0])[0]
        rho = np.linalg.norm(X[:, :2] - HOLE_XY, axis=1)
        assert np.max(np.abs(rho - (HOLE_R + 0.02))) < 1e-9, fit
        # Left free: the rotation about the hole's axis.
        assert len(al.free) == 1 and al.free[0].type == "rotation"
        assert np.allclose(np.abs(al.free[0].along), [0, 0, 1], atol=1e-9)
        assert np.allclose(al.free[0].through[:2], HOLE_XY, atol=1e-6)  # now on the nominal axis


@pytest.mark.parametrize("arc", [90, 150, 360])
def test_a_hole_probed_on_less_than_half_its_circumference_does_not_hold_its_datum(arc):
    """The largest cylinder inscribed in points along less than half of a hole's circumference
    can grow without bound (NIST CTC-03's datum B on 5 points). The tangent datum's steps,
    each trust region four times the last, carried the part 1e20 mm away, the alignment said
    "complete", and a 12,000-point plan ran for more than 11 minutes. Such a datum is not
    established, and says why; 8 points around the whole hole hold it."""
    rng = np.random.default_rng(6)
    b = Block({"A": 40, "hole": 200, "C": 20}, rng, misplacement(rng, 0.01, 0.2), hole_dr=0.02)
    c, length = b.frame()
    (hole,) = b.members("hole")
    rel = b.true_points[hole, :2] - HOLE_XY
    on = hole[np.degrees(np.arctan2(rel[:, 1], rel[:, 0])) % 360 < arc][:8]
    ds = [Datum("A", "A", "plane", "tangent"), Datum("H", "hole", "cylinder", "tangent")]
    al = align(b.evaluate, np.eye(4), ds, [b.members("A")[0], on], c, length,
               invariants=b.invariants("A", "hole"))
    assert np.max(np.abs(al.T_nominal_measured[:3, 3])) < 1.0
    if arc < 180:
        assert not al.complete
        assert al.message.startswith("datum H: its 8 points do not hold its tangent cylinder")
    else:
        assert al.complete, al.message
        X = b.evaluate(al.T_nominal_measured, on)[0]
        # The inscribed cylinder is the actual hole: its axis on the nominal's.
        rho = np.linalg.norm(X[:, :2] - HOLE_XY, axis=1)
        assert np.max(np.abs(rho - (HOLE_R + 0.02))) < 1e-6


def test_free_directions_are_named_and_best_fitted_on_request():
    rng = np.random.default_rng(7)
    b = Block({"A": 40, "B": 30, "C": 20}, rng, misplacement(rng))
    c, length = b.frame()
    only_a = align(b.evaluate, np.eye(4), planes()[:1], b.members("A"), c, length,
                   invariants=b.invariants("A"))
    kinds = sorted(f.type for f in only_a.free)
    assert kinds == ["rotation", "translation", "translation"] and not only_a.best_fitted
    for f in only_a.free:
        if f.type == "translation":
            assert abs(f.along[2]) < 1e-9  # in the plane of A
        else:
            assert np.allclose(np.abs(f.along), [0, 0, 1], atol=1e-9)
    # Best-fitting the freedom A leaves on B and C's points finishes the job.
    fitted = align(b.evaluate, np.eye(4), planes()[:1], b.members("A"), c, length,
                   best_fit=np.concatenate(b.members("B", "C")), invariants=b.invariants("A"))
    assert fitted.best_fitted
    assert np.max(np.abs(fitted.T_nominal_measured @ b.misplace - np.eye(4))) < 1e-9


def test_a_datum_without_enough_points_makes_the_alignment_incomplete():
    rng = np.random.default_rng(8)
    b = Block({"A": 40, "B": 2, "C": 20}, rng, misplacement(rng))
    c, length = b.frame()
    al = align(b.evaluate, np.eye(4), planes(), b.members("A", "B", "C"), c, length,
               invariants=b.invariants("A", "B", "C"))
    assert not al.complete and "datum B has 2 measured points" in al.message


def test_rps_locks_six_labelled_points_onto_their_nominal_positions():
    rng = np.random.default_rng(9)
    b = Block({"A": 10, "B": 10, "C": 10}, rng, misplacement(rng))
    c, length = b.frame()
    # 3-2-1: three points of A locked in z, two of B in x, one of C in y.
    idx = np.array([0, 1, 2, 10, 11, 20])
    axes = np.eye(3)[[2, 2, 2, 0, 0, 1]]
    al = align_rps(b.evaluate, np.eye(4), idx, b.true_points[idx], axes, c, length)
    assert al.free == () and al.datums[0].constrained == 6
    assert np.max(np.abs(al.T_nominal_measured @ b.misplace - np.eye(4))) < 1e-9


@pytest.mark.parametrize("feature", ["plane", "cylinder", "sphere", "line", "circle"])
def test_invariant_motions_leave_the_ideal_feature_in_place(feature):
    """Each motion invariant_motions names moves points of the ideal feature along it (zero
    normal velocity), and there are as many as the feature leaves free: the rigid degrees of
    freedom less engine.gdt.plan.CONSTRAINED_DOFS."""
    from engine.pose import pose_jacobian
    from engine.gdt.plan import CONSTRAINED_DOFS

    rng = np.random.default_rng(13)
    dim = 2 if feature in ("line", "circle") else 3
    q = rng.normal(0, 20, dim)
    if feature in ("plane", "line"):
        n = rng.normal(size=dim)
        n /= np.linalg.norm(n)
        along = np.linalg.svd(n[None, :])[2][1:]  # (dim - 1, dim): directions in the plane
        P = q + rng.normal(0, 30, (50, dim - 1)) @ along
        N = np.tile(n, (50, 1))
        nominal = {"point": q, "normal": n}
    elif feature == "cylinder":
        a = rng.normal(size=3)
        a /= np.linalg.norm(a)
        u, v = np.linalg.svd(a[None, :])[2][1:]
        th, h = rng.uniform(0, 2 * np.pi, 50), rng.uniform(-10, 10, 50)
        N = np.outer(np.cos(th), u) + np.outer(np.sin(th), v)
        P = q + 5 * N + np.outer(h, a)
        nominal = {"point": q, "direction": a}
    else:
        N = rng.normal(size=(50, dim))
        N /= np.linalg.norm(N, axis=1)[:, None]
        P = q + 7 * N
        nominal = {"centre": q}
    c, length = rng.normal(0, 10, dim), 37.0
    inv = invariant_motions(feature, nominal, c, length)
    dof = 6 if dim == 3 else 3
    assert inv.shape == (dof, dof - CONSTRAINED_DOFS[feature])
    J = pose_jacobian(P, N, c)
    J[:, :dof // 2 if dim == 3 else 1] /= length
    assert np.max(np.abs(J @ inv)) < 1e-9
    assert np.linalg.matrix_rank(inv) == inv.shape[1]


@pytest.mark.parametrize("kind", ["plane", "slot", "tab", "hole", "pin", "ball", "circle"])
def test_ideal_deviations_against_analytic_offsets(kind):
    """engine.gdt.region_features.ideal_deviations: points planted at known offsets (+ excess
    material) from an ideal feature, beyond the nominal samples' extent, come back with those
    offsets and the outward normals, whichever side they lie on."""
    from engine.gdt.region_features import ideal_deviations

    rng = np.random.default_rng(3)
    off = rng.uniform(-0.5, 0.5, 40)
    if kind == "plane":
        n = np.array([0.0, 0.6, 0.8])
        P = rng.uniform(-10, 10, (30, 3))
        P -= np.outer(P @ n, n)
        X = rng.uniform(-500, 500, (40, 3))
        X += np.outer(off - X @ n, n)  # off along n from the plane through 0
        got = ideal_deviations("plane", {"point": np.zeros(3), "normal": -n}, P,
                               np.tile(n, (30, 1)))
        want_n = np.tile(n, (40, 1))
    elif kind in ("slot", "tab"):
        # Faces x = +-5; a slot's outward normals face x = 0, a tab's face away from it.
        side = rng.choice([-1.0, 1.0], 40)
        face = np.where(np.arange(30) % 2 == 0, -1.0, 1.0)
        P = np.column_stack([5 * face, rng.uniform(-9, 9, (30, 2))])
        N = np.column_stack([(face if kind == "tab" else -face), np.zeros((30, 2))])
        out = side if kind == "tab" else -side
        X = np.column_stack([side * 5 + out * off, rng.uniform(-90, 90, (40, 2))])
        got = ideal_deviations("width", {"point": np.zeros(3), "normal": np.array(
            [1.0, 0, 0]), "width": 10.0}, P, N)
        want_n = np.column_stack([out, np.zeros((40, 2))])
    else:
        dim = 2 if kind == "circle" else 3
        u = rng.normal(size=(40, dim))
        u /= np.linalg.norm(u, axis=1)[:, None]
        if kind in ("hole", "pin"):
            u[:, 2] = 0.0
            u /= np.linalg.norm(u, axis=1)[:, None]
        out = -1.0 if kind == "hole" else 1.0
        o = np.arange(dim) + 1.0
        along = np.zeros((40, dim))
        if kind in ("hole", "pin"):
            along[:, 2] = rng.uniform(-300, 300, 40)  # past the nominal's ends
        X = o + u * (7.0 + out * off)[:, None] + along
        P = o + 7.0 * u[:30]
        nominal = {"centre": o, "diameter": 14.0} if kind != "hole" and kind != "pin" else \
            {"point": o, "direction": np.array([0.0, 0, 1]), "diameter": 14.0}
        got = ideal_deviations("sphere" if kind == "ball" else "circle" if kind == "circle"
                               else "cylinder", nominal, P, out * u[:30])
        want_n = out * u
    d, normals = got(X)
    assert np.allclose(d, off, atol=1e-9) and np.allclose(normals, want_n, atol=1e-9)


def _full_program(A, d, size, radius):
    """The tangent simulator's program over every point at once (its definition, solved
    directly): [eta, s, g] at the optimum, ties by the smallest sum of gaps, or None."""
    from scipy.optimize import linprog

    m, r = A.shape
    ones = np.ones((m, 1))
    A_ub = np.block([[A, -ones, np.zeros((m, 1))], [-A, ones, -ones]])
    b_ub = np.concatenate([-d, d])
    primary = np.zeros(r + 2)
    primary[r if size else r + 1] = 1.0
    bounds = [(-radius, radius)] * r + [(None, None) if size else (0.0, 0.0), (0.0, None)]
    sol = linprog(primary, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs")
    if sol.status != 0:
        return None
    gaps = np.concatenate([-A.sum(axis=0), [m, 0.0]])
    tie = linprog(gaps, A_ub=np.vstack([A_ub, primary]), b_ub=np.append(b_ub, sol.fun + 1e-12),
                  bounds=bounds, method="highs")
    return tie.x if tie.status == 0 else sol.x


@pytest.mark.parametrize("seed", range(4))
def test_the_tangent_program_over_the_binding_points_is_the_full_programs(seed):
    """engine.gdt.tangent_lp solves the simulator's program over the points that bind it
    (constraint generation): its optimum, gap and motion are the program's over every point,
    for planes and size features, noisy and with ties (deviations rounded to 1 µm)."""
    from engine.gdt.tangent_lp import tangent_solve

    rng = np.random.default_rng(seed)
    for trial in range(25):
        m, r, size = int(rng.integers(5, 2500)), int(rng.integers(1, 6)), bool(trial % 2)
        A = rng.normal(size=(m, r)) * rng.uniform(0.1, 2.0, r)
        d = rng.normal(0.0, 0.01, m) + (rng.uniform(-0.05, 0.05, m) if trial % 3 else 0.0)
        if trial % 4 == 0:
            d = np.round(d, 3)
        got, want = tangent_solve(A, d, size, 1.0, 1e-9), _full_program(A, d / 1.0, size, 1.0)
        assert (got is None) == (want is None)
        if want is None:
            continue
        unit = float(np.max(np.abs(d)))
        k = r if size else r + 1
        assert got[k] == pytest.approx(want[k], abs=1e-9 * unit)  # the optimum
        assert np.max(d + A @ got[:r] - got[r]) <= 1e-7 * unit  # no point beyond it
        assert np.abs(got - want).max() <= 1e-6 * unit, (trial, m, r, size)
