"""Registration sweep cases on a real STEP part: measurements with realistic defects in random
poses, and the truth they are judged against (for tests/test_sweep.py and
benchmarks/bench_sweep.py).

A measurement is ``n`` points spread area-uniformly over the exact B-rep faces (random points of
the tessellation's triangles, each triangle by its area, carried onto the B-rep: their feet),
moved along the exact outward normal by N(0, ``noise``) mm and by the defect:

* ``none``;
* ``bow0.1`` / ``bow0.3`` / ``bow1.0``: the largest face (by area) bowed outward, a dome of
  that height at the face's centre of mass falling to 0 at its farthest sampled point;
* ``bump0.5``: a Gaussian bump of 0.5 mm (sigma 3% of the part's diagonal) at a random point;
* ``cover30``: only the 30% of the points nearest a random point of the part (a patch);
* ``outliers2``: 2% of the points moved 2-10 mm in random directions (mis-probes).

The truth is computed here, independently of the registration: the least-squares pose started
at the known pose, by Gauss-Newton on OpenCascade's exact distances over every point but the
planted outliers, and the exact deviations of every point there. A pose found is *right* when
every deviation reported is within ``RIGHT_MM`` of those.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

DEFECTS = ("none", "bow0.1", "bow0.3", "bow1.0", "bump0.5", "cover30", "outliers2")
RIGHT_MM = 0.01


def face_areas(part) -> tuple[np.ndarray, np.ndarray]:
    """(triangle areas (m,), triangle face ids (m,)) of the part's tessellation."""
    ps = part.point_set
    P, T = ps.points, ps.triangles
    area = 0.5 * np.linalg.norm(np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]),
                                axis=1)
    return area, np.asarray(part.face_ids)[T[:, 0]]


def on_part(part, rng, n: int):
    """n points spread area-uniformly on the B-rep: (points (n, 3), outward normals, face ids)."""
    ps = part.point_set
    area, _ = face_areas(part)
    tri = ps.triangles[rng.choice(len(area), n, p=area / area.sum())]
    w = rng.dirichlet(np.ones(3), n)
    _, P, N, face = part.deviations(np.einsum("ij,ijk->ik", w, ps.points[tri]))
    return P, N, face


def make_case(part, defect: str, seed: int, n: int = 2000, noise: float = 0.002):
    """One measurement: dict with ``measured`` (m, 3) in a random pose, ``true`` (m, 3) the same
    points in the nominal frame, ``R``, ``t`` (measured = true @ R.T + t), ``outlier`` (m,) the
    planted mis-probes."""
    rng = np.random.default_rng(seed)
    P, N, face = on_part(part, rng, n)
    d = rng.normal(0.0, noise, len(P))
    diag = float(np.linalg.norm(np.ptp(P, axis=0)))
    if defect.startswith("bow"):
        area, tface = face_areas(part)
        largest = np.bincount(tface, weights=area).argmax()
        on = face == largest
        c = P[on].mean(axis=0)
        r = np.linalg.norm(P[on] - c, axis=1)
        d[on] += float(defect[3:]) * (1.0 - (r / r.max()) ** 2)
    elif defect.startswith("bump"):
        c = P[rng.integers(len(P))]
        s = 0.03 * diag
        d += float(defect[4:]) * np.exp(-0.5 * np.sum((P - c) ** 2, axis=1) / (s * s))
    X = P + d[:, None] * N
    outlier = np.zeros(len(X), bool)
    if defect.startswith("cover"):
        c = P[rng.integers(len(P))]
        keep = np.argsort(np.linalg.norm(P - c, axis=1))[: int(len(P) * float(defect[5:]) / 100)]
        X, outlier = X[np.sort(keep)], outlier[np.sort(keep)]
    elif defect.startswith("outliers"):
        k = int(round(len(X) * float(defect[8:]) / 100))
        pick = rng.choice(len(X), k, replace=False)
        v = rng.normal(size=(k, 3))
        X[pick] += v / np.linalg.norm(v, axis=1, keepdims=True) * rng.uniform(2, 10, k)[:, None]
        outlier[pick] = True
    R = Rotation.random(random_state=rng).as_matrix()
    t = rng.uniform(-300, 300, 3)
    return {"measured": X @ R.T + t, "true": X, "R": R, "t": t, "outlier": outlier}


def _rotvec_matrix(w: np.ndarray) -> np.ndarray:
    return Rotation.from_rotvec(w).as_matrix()


def truth(part, case, iterations: int = 30) -> np.ndarray:
    """The exact deviations (m,) of every point at the least-squares pose started at the known
    pose: Gauss-Newton on OpenCascade's exact distances, planted outliers left out of the fit."""
    X = case["true"].copy()
    use = ~case["outlier"]
    for _ in range(iterations):
        signed, _, normal, _ = part.deviations(X)
        c = X[use].mean(axis=0)
        J = np.hstack([np.cross(X[use] - c, normal[use]), normal[use]])
        step = np.linalg.lstsq(J, -signed[use], rcond=None)[0]
        moved = np.linalg.norm(np.cross(step[:3], X - c) + step[3:], axis=1).max()
        X = (X - c) @ _rotvec_matrix(step[:3]).T + c + step[3:]
        if moved < 1e-9:
            break
    return part.deviations(X)[0]


def judge(result, d_true: np.ndarray, tol: float) -> tuple[str, float]:
    """('right' | 'INCONCLUSIVE' | 'wrong', the largest deviation error, mm) of an inspection
    result against the truth: right when the verdict is the truth's (every |d| <= tol: ACCEPT,
    else REJECT) and every deviation is within RIGHT_MM of the truth's."""
    err = float(np.max(np.abs(result.deviations.signed - d_true)))
    if result.verdict == "INCONCLUSIVE":
        return "INCONCLUSIVE", err
    expected = "ACCEPT" if np.all(np.abs(d_true) <= tol) else "REJECT"
    return ("right" if err <= RIGHT_MM and result.verdict == expected else "wrong"), err
