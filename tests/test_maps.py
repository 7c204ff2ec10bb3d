"""The deviation maps' colour scale, views, callouts and display mesh (reports.figures,
reports.mapviews, reports.callouts): what an inspector reads off a certificate's map."""

import math
import os

import numpy as np
import pytest

from engine.tolerance import Tolerance
from reports import figures

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ZONES = [Tolerance(-0.25, 0.25), Tolerance(-0.1, 0.3), Tolerance(-0.015, 0.015),
         Tolerance(0.1, 0.3), Tolerance(-0.3, 0.02)]


@pytest.mark.parametrize("tol", ZONES, ids=str)
def test_the_zone_is_split_into_fine_steps_with_green_at_the_nominal(tol):
    table = figures.bands(tol)
    inside = [b for b in table if b.in_tolerance]
    assert 12 <= len(inside) <= 16
    # The in-zone bands tile the zone from limit to limit, in order.
    assert inside[0].lower == tol.lower and inside[-1].upper == tol.upper
    assert all(a.upper == b.lower for a, b in zip(inside, inside[1:]))
    # Two distinct colours beyond each limit, none like any colour inside the zone.
    assert [b.in_tolerance for b in table[:2] + table[-2:]] == [False] * 4
    rgb_in = np.array([b.rgb for b in inside])
    for b in table[:2] + table[-2:]:
        assert np.min(np.linalg.norm(rgb_in - b.rgb, axis=1)) > 0.2, figures.band_label(b)
    # Green where the part is as designed: the nominal (or the zone's middle when the zone
    # leaves out 0) is inside a band whose green channel leads, and every band is its own colour.
    centre = 0.0 if tol.lower <= 0 <= tol.upper else 0.5 * (tol.lower + tol.upper)
    k = int(figures.band_index(np.array([centre]), tol)[0])
    r, g, b = table[k].rgb
    assert g > r + 0.2 and g > b + 0.2
    assert len({b.rgb for b in table}) == len(table)
    # Blue at the lower limit, red at the upper, where the zone reaches a few steps past green.
    k -= 2  # the first two bands lie below the zone
    assert k < 3 or rgb_in[0, 2] > rgb_in[0, 0] + 0.4
    assert len(inside) - k < 4 or rgb_in[-1, 0] > rgb_in[-1, 2] + 0.4


def _naive_band(d, tol, table):
    """Which band a deviation belongs to, read off the band list one band at a time."""
    for k, b in enumerate(table):
        if b.in_tolerance and (b.lower <= d < b.upper or d == b.upper == tol.upper):
            return k
        if not b.in_tolerance and b.upper <= tol.lower and b.lower <= d < b.upper:
            return k
        if not b.in_tolerance and b.lower >= tol.upper and b.lower < d <= b.upper:
            return k
    raise AssertionError(d)


@pytest.mark.parametrize("tol", ZONES, ids=str)
def test_band_index_agrees_with_the_band_list(tol):
    table = figures.bands(tol)
    rng = np.random.default_rng(15)
    width = tol.upper - tol.lower
    d = np.concatenate([rng.uniform(tol.lower - width, tol.upper + width, 2000),
                        [b.lower for b in table[1:]], [b.upper for b in table[:-1]]])
    got = figures.band_index(d, tol)
    assert list(got) == [_naive_band(v, tol, table) for v in d]


@pytest.fixture(scope="module")
def fairing_run():
    from engine.pipeline import inspection_settings, run_files

    folder = os.path.join(ROOT, "samples", "belly_fairing")
    return run_files(os.path.join(folder, "nominal.csv"), os.path.join(folder, "measured.csv"),
                     inspection_settings(Tolerance.symmetric(0.25)))


def test_the_belly_fairings_dent_stands_out_at_a_quarter_millimetre(fairing_run):
    """The sample's planted -0.15 mm dent (sigma 18 mm at x = 120, y = -40 on the nominal,
    samples/generate.py) is read off the map at +-0.25 mm: the points near its bottom are at
    least three colour steps from the points around it."""
    res = fairing_run.result
    r = np.hypot(res.deviations.foot[:, 0] - 120.0, res.deviations.foot[:, 1] + 40.0)
    band = figures.band_index(res.deviations.signed, res.tolerance)
    dent, around = band[r < 12.0], band[(r > 45.0) & (r < 90.0)]
    assert dent.size >= 3 and around.size >= 30
    assert np.all(np.median(around) - dent >= 3), (dent, np.median(around))


# ---------------------------------------------------------------------------- callouts
def _two_dents():
    """A 200 x 100 mm plate probed every 5 mm with two dents, the deeper at (40, 30) (2.5 x 2.5
    mm pattern there, so it holds many out-of-tolerance points), the other at (150, 70)."""
    x, y = np.meshgrid(np.arange(0.0, 200.0, 5.0), np.arange(0.0, 100.0, 5.0))
    fine = np.meshgrid(np.arange(25.0, 55.0, 2.5), np.arange(15.0, 45.0, 2.5))
    xy = np.unique(np.vstack([np.column_stack([x.ravel(), y.ravel()]),
                              np.column_stack([fine[0].ravel(), fine[1].ravel()])]), axis=0)
    d = -0.4 * np.exp(-((xy[:, 0] - 40) ** 2 + (xy[:, 1] - 30) ** 2) / (2 * 6.0**2)) \
        - 0.3 * np.exp(-((xy[:, 0] - 150) ** 2 + (xy[:, 1] - 70) ** 2) / (2 * 5.0**2))
    d += np.random.default_rng(3).normal(0.0, 0.003, len(d))
    return np.column_stack([xy, np.zeros(len(xy))]), d


def test_each_dent_gets_one_callout_on_its_worst_point():
    from reports.callouts import callout_points

    feet, d = _two_dents()
    out = d < -0.1
    first = out & (np.hypot(feet[:, 0] - 40, feet[:, 1] - 30) < 30)
    second = out & (np.hypot(feet[:, 0] - 150, feet[:, 1] - 70) < 30)
    assert first.sum() >= 6 and second.sum() >= 2 and (first | second).sum() == out.sum()
    flagged = callout_points(feet, d, -0.1, 0.1)
    worst_first = int(np.flatnonzero(first)[np.argmin(d[first])])
    worst_second = int(np.flatnonzero(second)[np.argmin(d[second])])
    assert flagged == [worst_first, worst_second]
    # Every point in tolerance: the largest departures, one flag per region again.
    flagged = callout_points(feet, d, -1.0, 1.0)
    assert flagged[:2] == [worst_first, worst_second]


def _crossing(p1, p2, q1, q2) -> bool:
    """Whether two segments meet: solve p1 + s (p2 - p1) = q1 + t (q2 - q1), 0 <= s, t <= 1."""
    a = np.array([[p2[0] - p1[0], q1[0] - q2[0]], [p2[1] - p1[1], q1[1] - q2[1]]])
    if abs(np.linalg.det(a)) < 1e-12:
        return False  # parallel leaders: never produced by the placement below
    s, t = np.linalg.solve(a, np.array([q1[0] - p1[0], q1[1] - p1[1]]))
    return 0 <= s <= 1 and 0 <= t <= 1


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_callout_labels_never_overlap(seed):
    from reports.callouts import leader_end, place_labels

    rng = np.random.default_rng(seed)
    width, height = 240.0, 180.0
    # Eight flagged points, five of them crowded into one corner of the picture.
    anchors = np.vstack([rng.uniform(40, 70, (5, 2)), rng.uniform(20, 220, (3, 2)) *
                         [1, 0.75]])
    sizes = rng.uniform([26, 10], [40, 20], (8, 2))
    blocked = ((0, 160, 60, 180),)
    at = place_labels(anchors, sizes, width, height, blocked=blocked)
    placed = [k for k, a in enumerate(at) if a is not None]
    assert len(placed) == 8
    boxes = [(at[k][0], at[k][1], at[k][0] + sizes[k][0], at[k][1] + sizes[k][1])
             for k in placed]
    for k, b in enumerate(boxes):
        assert 0 <= b[0] and b[2] <= width and 0 <= b[1] and b[3] <= height
        for other in boxes[k + 1:] + list(blocked):
            assert b[2] <= other[0] or other[2] <= b[0] or b[3] <= other[1] or other[3] <= b[1]
        inside = ((anchors[:, 0] >= b[0]) & (anchors[:, 0] <= b[2]) &
                  (anchors[:, 1] >= b[1]) & (anchors[:, 1] <= b[3]))
        assert not inside.any()
    leaders = [(anchors[k], np.array(leader_end(anchors[k], b))) for k, b in zip(placed, boxes)]
    for k, (p, q) in enumerate(leaders):
        for r, s in leaders[k + 1:]:
            assert not _crossing(p, q, r, s)


# ---------------------------------------------------------------------------- views
@pytest.fixture(scope="module")
def bracket_run():
    from engine.pipeline import inspection_settings, run_files

    folder = os.path.join(ROOT, "samples", "seat_bracket")
    return run_files(os.path.join(folder, "nominal.xyz"), os.path.join(folder, "measured.csv"),
                     inspection_settings(None, os.path.join(folder, "plan.toml")))


def test_every_measured_point_faces_some_view(bracket_run):
    """The seat bracket's end face (20 points) and every other face are seen within 60
    degrees of face-on in at least one view, and the views are named by the nominal's axes."""
    from reports.mapviews import choose_views

    normals = bracket_run.result.deviations.normal
    views = choose_views(normals)
    assert 2 <= len(views) <= 4
    cos = normals @ np.array([v.direction for v in views]).T
    assert np.all(cos.max(axis=1) >= math.cos(math.radians(60)) - 1e-9)
    end = np.abs(normals[:, 1]) > 0.99  # the end faces y = 0 and y = 60
    assert end.sum() >= 20
    for v in views:
        assert v.name.split(" (")[0] in {"Top", "Bottom", "Front", "Back", "Left", "Right", "Iso"}
        letters = v.name.split("(")[1].rstrip(")").split()
        axis = {a[1]: (1 if a[0] == "+" else -1) for a in letters}
        assert np.allclose(v.direction, np.array([axis.get(c, 0) for c in "XYZ"]) /
                           math.sqrt(len(axis)))


@pytest.fixture(scope="module")
def bracket_views(bracket_run):
    from reports.certificate import worst_labels

    run, res = bracket_run, bracket_run.result
    nom = run.nominal
    return figures.render_3d(nom.points, nom.triangles, res.deviations.foot,
                             res.deviations.normal, res.deviations.signed, res.tolerance,
                             worst_labels(run), size=(320, 240),
                             nominal_normals=nom.normals(np.arange(nom.n)))


def test_the_whole_part_is_framed_in_every_view(bracket_views):
    """Nothing of the part touches the picture's border (the white background all round), and
    the part fills a good share of it."""
    from PIL import Image
    import io

    for v in bracket_views:
        img = np.asarray(Image.open(io.BytesIO(v.png)).convert("RGB")).astype(int)
        part = np.any(img < 245, axis=2)
        assert not (part[0].any() or part[-1].any() or part[:, 0].any() or part[:, -1].any()), \
            v.name
        rows, cols = np.flatnonzero(part.any(axis=1)), np.flatnonzero(part.any(axis=0))
        assert max(np.ptp(rows) / 240, np.ptp(cols) / 320) > 0.6, v.name


def test_the_point_nominal_is_drawn_as_a_surface_and_flags_land_on_their_points(bracket_run,
                                                                                bracket_views):
    """The bracket's nominal (bare points) shows as a shaded surface: most of the part's
    silhouette is grey surface, not white gaps between dots; each flag's anchor lies on a
    coloured point; every flagged point shows in some view."""
    from PIL import Image
    import io

    flagged = {i for v in bracket_views for i, _, _ in v.anchors}
    from reports.certificate import worst_labels
    assert flagged == {i for i, _ in worst_labels(bracket_run)}
    for v in bracket_views:
        img = np.asarray(Image.open(io.BytesIO(v.png)).convert("RGB")).astype(int)
        part = np.any(img < 245, axis=2)
        filled = np.zeros_like(part)
        for r in range(part.shape[0]):  # the silhouette, row by row
            c = np.flatnonzero(part[r])
            if c.size:
                filled[r, c[0]:c[-1] + 1] = True
        assert part[filled].mean() > 0.9, v.name
        for _, x, y in v.anchors:
            r, g, b = img[int(y), int(x)]
            assert max(r, g, b) - min(r, g, b) > 30, (v.name, (r, g, b))  # not the grey surface


def test_display_mesh_lies_on_a_sampled_box():
    """Points with outward normals sampled on a 60 x 40 x 30 mm box: the display mesh lies on
    its faces (within a voxel at the edges, which it rounds), and covers every face."""
    from scipy.spatial import cKDTree

    from reports.mapviews import display_mesh

    rng = np.random.default_rng(7)
    size = np.array([60.0, 40.0, 30.0])
    pts, nrm = [], []
    for axis in range(3):
        for side in (0.0, 1.0):
            p = rng.uniform(0, 1, (4000, 3)) * size
            p[:, axis] = side * size[axis]
            n = np.zeros((4000, 3))
            n[:, axis] = 1.0 if side else -1.0
            pts.append(p)
            nrm.append(n)
    pts, nrm = np.vstack(pts), np.vstack(nrm)
    mesh = display_mesh(pts, nrm, cells=40)
    v = np.asarray(mesh.points)
    h = 60.0 / 40
    # Distance from each vertex to the box's surface.
    inside = np.minimum(v, size - v).min(axis=1)
    outside = np.linalg.norm(np.maximum(np.maximum(-v, v - size), 0), axis=1)
    off = np.where(outside > 0, outside, np.abs(inside))
    assert off.max() < h and np.median(off) < 0.01 * h  # on the faces, rounded at the edges
    assert cKDTree(v).query(pts)[0].max() < 1.5 * h


@pytest.mark.parametrize("seed", range(3))
def test_the_surface_takes_the_colour_of_its_nearest_measured_point_within_reach(seed):
    """reports.figures.surface_field against the naive twin (every vertex against every
    point): the deviation of the nearest point when it lies within reach, NaN beyond; its
    colours the band's, grey where NaN."""
    from reports.figures import surface_field, surface_rgb
    from reports.figures.colours import UNCOVERED_RGB, Zone

    rng = np.random.default_rng(seed)
    feet = rng.uniform(0, 10, (60, 3))
    d = rng.normal(0, 0.1, 60)
    vertices = rng.uniform(-2, 12, (400, 3))
    reach = 1.5
    got = surface_field(vertices, feet, d, reach)
    dist = np.linalg.norm(vertices[:, None] - feet[None], axis=2)
    nearest = dist.argmin(axis=1)
    want = np.where(dist.min(axis=1) < reach, d[nearest], np.nan)
    assert np.array_equal(np.isnan(got), np.isnan(want)) and np.isnan(got).any()
    assert np.array_equal(got[~np.isnan(got)], want[~np.isnan(want)])
    zone = Zone(-0.1, 0.1)
    rgb = surface_rgb(got, zone)
    assert (rgb[np.isnan(got)] == np.round(np.array(UNCOVERED_RGB) * 255)).all()
    covered = ~np.isnan(got)
    assert np.array_equal(rgb[covered], figures.band_rgb(got[covered], zone))


def test_a_coloured_surface_keeps_every_face_whatever_its_budget():
    """reports.figures.coloured_surface cuts a plate's two large triangles to its points'
    reach but never drops area (VTK's subdivision stops at its budget and loses the rest): at
    a small budget the cut is coarser, the area and each cell's face the same; a point's patch
    takes its colour, the plate beyond the points stays grey."""
    import pyvista as pv

    from reports.figures import coloured_surface
    from reports.figures.colours import UNCOVERED_RGB, Zone

    plate = pv.PolyData.from_regular_faces(
        np.array([[0, 0, 0], [100, 0, 0], [100, 50, 0], [0, 50, 0]], float),
        np.array([[0, 1, 2], [0, 2, 3]]))
    g = np.stack(np.meshgrid(np.arange(5, 45, 2.0), np.arange(5, 45, 2.0)), -1).reshape(-1, 2)
    feet = np.column_stack([g, np.zeros(len(g))])  # the left part measured, 2 mm apart
    d = np.where(feet[:, 0] < 20, 0.5, 0.0)  # out of tolerance left of x = 20
    zone = Zone(-0.1, 0.1)
    for budget in (600_000, 2_000):
        surf, faces = coloured_surface(plate, feet, d, zone, 0.1, max_triangles=budget,
                                       cell_faces=np.array([7, 8]))
        assert surf.n_cells > 100 and surf.n_cells <= budget
        assert surf.area == pytest.approx(5000.0, rel=1e-9)
        centres = surf.cell_centers().points
        assert np.array_equal(faces, np.where(centres[:, 1] < centres[:, 0] / 2, 7, 8))
        rgb, P = np.asarray(surf.point_data["rgb"]), np.asarray(surf.points)
        grey = (rgb == np.round(np.array(UNCOVERED_RGB) * 255)).all(axis=1)
        assert grey[P[:, 0] > 60].all() and not grey[(P[:, 0] < 40) & (P[:, 1] < 40)
                                                     & (P[:, 0] > 8) & (P[:, 1] > 8)].any()
        left = (P[:, 0] < 15) & (P[:, 0] > 6) & (P[:, 1] > 6) & (P[:, 1] < 40)
        assert (rgb[left] == figures.band_rgb(np.array([0.5]), zone)[0]).all()
