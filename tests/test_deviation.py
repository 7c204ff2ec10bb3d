"""Deviation measurement against analytic truth and the naive twin; the sign convention."""

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from engine.deviation import point_to_surface
from engine.nominal import Nominal
from naive import distance_to_mesh
from surfaces import (exact_signed_distance, height_grid, points_off_surface, point_set,
                      sphere_points)


def outward_hull(pts):
    """Convex hull triangles wound counter-clockwise seen from outside (scipy's are unordered)."""
    tris = ConvexHull(pts).simplices.copy()
    v = pts[tris]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    inward = np.einsum("ij,ij->i", n, v.mean(axis=1) - pts.mean(axis=0)) < 0
    tris[inward] = tris[inward][:, ::-1]
    return tris


@pytest.fixture(scope="module")
def curved_case():
    """The 500 x 250 mm doubly curved surface, 60,000-point grid, and 1,500 queries at known
    offsets with their exact distances (Newton on the analytic surface)."""
    pts, nrm, grid = height_grid(300, 200)
    rng = np.random.default_rng(11)
    dev = rng.uniform(-0.4, 0.4, 1500)
    q = points_off_surface(rng, 1500, dev)
    return pts, nrm, grid, q, exact_signed_distance(q)


@pytest.mark.parametrize("kind", ["grid+normals", "grid", "points+normals", "points"])
def test_sub_micrometre_on_doubly_curved_surface(curved_case, kind):
    pts, nrm, grid, q, exact = curved_case
    normals = nrm if "normals" in kind else None
    g = grid if kind.startswith("grid") else None
    nom = Nominal.from_point_set(point_set(pts, normals, g))
    d = point_to_surface(nom, q).signed
    assert np.max(np.abs(d - exact)) < 1e-3  # mm: within 1 um everywhere
    # The paper's flat facets alone are off by micrometres here: the correction is what counts.
    flat = point_to_surface(nom, q, curvature=False).signed
    assert np.max(np.abs(flat - exact)) > 1e-3


def test_sign_positive_outside_sphere_all_nominal_kinds():
    pts, nrm = sphere_points(r=50.0)
    tris = outward_hull(pts)
    rng = np.random.default_rng(5)
    dirs = rng.normal(size=(400, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    dirs = dirs[np.abs(dirs[:, 2]) < 0.9]  # keep away from the open poles
    offs = rng.uniform(-1.0, 1.0, len(dirs))
    q = dirs * (50.0 + offs)[:, None]
    for ps in (point_set(pts, nrm), point_set(pts), point_set(pts, None, None, tris)):
        nom = Nominal.from_point_set(ps)
        d = point_to_surface(nom, q).signed
        assert np.all(np.sign(d) == np.sign(offs)), nom.normals_source
        tol = 0.02 if ps.triangles is not None else 2e-3  # a hull mesh has no normals from file
        assert np.max(np.abs(d - offs)) < tol, nom.normals_source


def test_mesh_winding_inverted_still_signs_outward():
    pts, _ = sphere_points(r=50.0)
    tris = outward_hull(pts)
    q = np.array([[0, 51.0, 0], [0, 0, 0.0], [49.0, 0, 0]])
    for t in (tris, tris[:, ::-1]):
        d = point_to_surface(Nominal.from_point_set(point_set(pts, None, None, t)), q).signed
        assert d[0] > 0 and d[1] < 0 and d[2] < 0


def test_fast_mesh_search_matches_brute_force():
    """Random bumpy mesh with a few huge triangles: the star search finds the true nearest facet."""
    rng = np.random.default_rng(6)
    X, Y = np.meshgrid(np.linspace(0, 40, 21), np.linspace(0, 30, 16))
    Z = 2.0 * np.sin(X / 7.0) * np.cos(Y / 5.0)
    pts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    nom = Nominal.from_point_set(point_set(pts, None, (21, 16)))
    # Append a big flat triangle far away (a coarse CAD facet).
    big = np.array([[60.0, 0, 0], [160.0, 0, 0], [60.0, 100, 0]])
    allp = np.vstack([pts, big])
    tris = np.vstack([nom.triangles, [[len(pts), len(pts) + 1, len(pts) + 2]]])
    mesh = Nominal.from_point_set(point_set(allp, None, None, tris))
    q = np.vstack([np.column_stack([rng.uniform(-3, 43, 300), rng.uniform(-3, 33, 300),
                                    rng.uniform(-4, 4, 300)]),
                   np.column_stack([rng.uniform(62, 100, 60), rng.uniform(2, 40, 60),
                                    rng.uniform(-3, 3, 60)])])
    d = np.abs(point_to_surface(mesh, q, curvature=False).signed)
    ref = np.array([distance_to_mesh(p, allp, tris) for p in q])
    assert np.max(np.abs(d - ref)) < 1e-9


def test_grid_and_mesh_of_same_surface_agree():
    pts, nrm, grid = height_grid(60, 40)
    g = Nominal.from_point_set(point_set(pts, nrm, grid))
    m = Nominal.from_point_set(point_set(pts, nrm, None, g.triangles))
    rng = np.random.default_rng(7)
    q = points_off_surface(rng, 300, rng.uniform(-1, 1, 300))
    assert np.allclose(point_to_surface(g, q).signed, point_to_surface(m, q).signed, atol=1e-12)


def test_plane_offsets_exact():
    X, Y = np.meshgrid(np.linspace(0, 10, 11), np.linspace(0, 10, 11))
    pts = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    q = np.array([[2.3, 4.1, 0.25], [7.7, 1.2, -0.05], [5.0, 5.0, 0.0]])
    for ps in (point_set(pts, np.tile([0, 0, 1.0], (len(pts), 1))), point_set(pts, None, (11, 11))):
        d = point_to_surface(Nominal.from_point_set(ps), q).signed
        assert np.allclose(d, [0.25, -0.05, 0.0], atol=1e-12)
