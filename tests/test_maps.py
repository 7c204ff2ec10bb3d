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
