"""The tolerance-banded colour scale of the deviation maps, and the colours of a plan's regions.
No Qt: the desktop app reuses it.

Colour scale: a diverging scale across the tolerance zone [lower, upper] in 12-16 equal-looking
steps: blue at the lower limit, through cyan to green at the nominal (deviation 0, the middle
of a green band) and through yellow to red at the upper limit, interpolated in CIELAB so that
neighbouring steps differ by about the same perceived amount on each side. Beyond the zone,
two darker colours on each side, a quarter zone wide and farther: navy then violet below
the lower limit (material missing), maroon then magenta above the upper limit (excess
material). A deviation exactly on a limit is in tolerance.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # the render process should not pay for importing the engine
    from engine.inspection import Tolerance


ZONE_STEPS = 15
"""Steps of the scale inside the zone (odd: the nominal sits in the middle of a green one);
an asymmetric zone gets 14-16, as its sides divide."""
RAMP = ((0.16, 0.27, 0.80), (0.08, 0.62, 0.86), (0.22, 0.68, 0.24), (0.96, 0.84, 0.16),
        (0.84, 0.13, 0.11))
"""sRGB anchors of the in-zone ramp at the lower limit, half way down, the nominal, half way up
and the upper limit: blue, cyan, green, yellow, red."""
BELOW = ((0.35, 0.06, 0.45), (0.04, 0.09, 0.42))
"""Beyond the lower limit, farthest first: violet (more than a quarter zone), navy."""
ABOVE = ((0.50, 0.0, 0.06), (0.86, 0.0, 0.62))
"""Beyond the upper limit, nearest first: maroon, magenta (more than a quarter zone)."""


@dataclass(frozen=True)
class Band:
    """One colour band of deviations (mm): [lower, upper) below and inside the zone, (lower,
    upper] above it; the zone's bands include both limits."""

    lower: float
    upper: float
    rgb: tuple[float, float, float]
    in_tolerance: bool
    digits: int = 3
    """Decimals the labels print (finer for a narrow zone)."""


@dataclass(frozen=True)
class Zone:
    """Tolerance limits, mm (what the colour scale needs of an engine Tolerance)."""

    lower: float
    upper: float


def _zone_edges(lo: float, hi: float) -> np.ndarray:
    """Edges of the in-zone bands, lo to hi: a green band 1/ZONE_STEPS of the zone wide
    centred on the nominal (on the zone's middle when 0 lies outside), each side divided into
    steps of that width, rounded to whole steps."""
    w = (hi - lo) / ZONE_STEPS
    m = min(max(0.0, lo + w / 2), hi - w / 2) if lo <= 0.0 <= hi else 0.5 * (lo + hi)
    k_lo = int(round((m - w / 2 - lo) / w))
    k_hi = int(round((hi - m - w / 2) / w))
    lower = np.linspace(lo, m - w / 2, k_lo + 1) if k_lo else np.array([lo])
    upper = np.linspace(m + w / 2, hi, k_hi + 1) if k_hi else np.array([hi])
    return np.concatenate([lower, upper])


def _srgb_to_lab(rgb: np.ndarray) -> np.ndarray:
    """CIELAB (D65) of sRGB colours in 0..1, (n, 3)."""
    c = np.asarray(rgb, dtype=float)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    xyz = lin @ np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                          [0.0193, 0.1192, 0.9505]]).T / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.column_stack([116 * f[:, 1] - 16, 500 * (f[:, 0] - f[:, 1]),
                            200 * (f[:, 1] - f[:, 2])])


def _lab_to_srgb(lab: np.ndarray) -> np.ndarray:
    fy = (lab[:, 0] + 16) / 116
    f = np.column_stack([fy + lab[:, 1] / 500, fy, fy - lab[:, 2] / 200])
    xyz = np.where(f > 6 / 29, f**3, 3 * (6 / 29) ** 2 * (f - 4 / 29))
    xyz = xyz * np.array([0.95047, 1.0, 1.08883])
    lin = xyz @ np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415],
                          [0.0557, -0.2040, 1.0570]]).T
    lin = np.clip(lin, 0.0, 1.0)
    return np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)


@functools.lru_cache(maxsize=1)
def _ramp_table(samples: int = 401):
    """The ramp sampled densely over t in [-1, 1] (t: -1 lower limit, 0 nominal, +1 upper)
    in CIELAB, and each sample's share of its side's path length (so that equal steps of
    that share are equal perceived steps)."""
    anchors = _srgb_to_lab(np.array(RAMP))
    t = np.linspace(-1.0, 1.0, samples)
    lab = np.column_stack([np.interp(t, np.linspace(-1, 1, len(RAMP)), anchors[:, k])
                           for k in range(3)])
    step = np.r_[0.0, np.linalg.norm(np.diff(lab, axis=0), axis=1)]
    mid = samples // 2
    share = np.empty(samples)
    for side in (slice(0, mid + 1), slice(mid, samples)):
        arc = np.cumsum(step[side]) - step[side][0]
        share[side] = arc / arc[-1]
    share[: mid + 1] -= 1.0  # -1 at the lower limit, 0 at the nominal
    return share, lab


def ramp_rgb(t: np.ndarray) -> np.ndarray:
    """(n, 3) sRGB in 0..1 of the in-zone ramp at ``t`` in [-1, 1] (the share of the way from
    the nominal to a limit, -1 lower, +1 upper), perceptually even on each side."""
    share, lab = _ramp_table()
    t = np.clip(np.asarray(t, dtype=float).reshape(-1), -1.0, 1.0)
    col = np.column_stack([np.interp(t, share, lab[:, k]) for k in range(3)])
    return _lab_to_srgb(col)


@functools.lru_cache(maxsize=64)
def _bands(lo: float, hi: float) -> tuple[Band, ...]:
    edges = _zone_edges(lo, hi)
    centres = 0.5 * (edges[:-1] + edges[1:])
    green = int(np.argmin(np.abs(centres - (0.0 if lo <= 0.0 <= hi else 0.5 * (lo + hi)))))
    m = centres[green]
    t = np.where(centres < m, (centres - m) / (m - lo if m > lo else 1.0),
                 (centres - m) / (hi - m if hi > m else 1.0))
    rgb = [(round(float(r), 4), round(float(g), 4), round(float(b), 4))
           for r, g, b in ramp_rgb(t)]
    digits = max(3, int(math.ceil(-math.log10(float(np.min(np.diff(edges)))))) + 1)
    s = (hi - lo) / 4.0
    out = [Band(-math.inf, lo - s, BELOW[0], False, digits),
           Band(lo - s, lo, BELOW[1], False, digits)]
    out += [Band(float(edges[k]), float(edges[k + 1]), rgb[k], True, digits)
            for k in range(len(centres))]
    out += [Band(hi, hi + s, ABOVE[0], False, digits),
            Band(hi + s, math.inf, ABOVE[1], False, digits)]
    return tuple(out)


def bands(tol: "Tolerance | Zone") -> list[Band]:
    """The bands from the most negative to the most positive deviation: two below the zone,
    12-16 inside it (:data:`ZONE_STEPS`), two above it."""
    return list(_bands(float(tol.lower), float(tol.upper)))


def band_label(b: Band) -> str:
    """The band's range as the legends print it, mm."""
    n = b.digits
    if math.isinf(b.upper):
        return f"> {b.lower:+.{n}f}"
    if math.isinf(b.lower):
        return f"< {b.upper:+.{n}f}"
    return f"{b.lower:+.{n}f} … {b.upper:+.{n}f}"


def band_index(d: np.ndarray, tol: "Tolerance | Zone") -> np.ndarray:
    """Index into :func:`bands` of each deviation (mm): a band holds [lower, upper), the zone
    its limits, the first band beyond a limit the next quarter zone (its far end included)."""
    d = np.asarray(d, dtype=float)
    lo, hi = float(tol.lower), float(tol.upper)
    s = (hi - lo) / 4.0
    edges = _zone_edges(lo, hi)
    inside = 2 + np.clip(np.searchsorted(edges, d, side="right") - 1, 0, len(edges) - 2)
    last = len(edges) + 1  # the first band above the zone
    return np.where(d < lo - s, 0, np.where(d < lo, 1, np.where(
        d > hi + s, last + 1, np.where(d > hi, last, inside))))


def band_rgb(d: np.ndarray, tol: "Tolerance | Zone") -> np.ndarray:
    """(n, 3) uint8 colours of deviations ``d``."""
    table = (np.array([b.rgb for b in bands(tol)]) * 255).round().astype(np.uint8)
    return table[band_index(d, tol)]


UNCOVERED_RGB = (0.80, 0.81, 0.83)
"""The nominal surface where no measured point lies (the grey the surface is drawn in)."""
COVERAGE_SPACINGS = 2.0
"""A surface point takes the colour of its nearest measured point when that lies within this
many typical spacings of the measured points (their coverage); farther, it stays grey."""


def surface_field(vertices: np.ndarray, feet: np.ndarray, d: np.ndarray,
                  reach: float) -> np.ndarray:
    """(m,) the deviation shown at each surface point ``vertices`` (m, 3): that of its nearest
    measured point (``feet`` (n, 3), their foot points on the nominal, deviations ``d`` (n,)),
    NaN where none lies within ``reach`` mm. The nearest point's own value, never a mean: a
    point out of tolerance among good ones keeps its colour on the patch around it."""
    from scipy.spatial import cKDTree

    out = np.full(vertices.shape[0], np.nan)
    if not len(feet) or not vertices.shape[0]:
        return out
    dist, idx = cKDTree(feet).query(vertices, distance_upper_bound=reach)
    near = np.isfinite(dist)
    out[near] = d[idx[near]]
    return out


def surface_rgb(values: np.ndarray, tol: "Tolerance | Zone") -> np.ndarray:
    """(m, 3) uint8 colours of :func:`surface_field`'s values: the band of each, grey where
    NaN (not covered)."""
    rgb = np.empty((values.size, 3), np.uint8)
    covered = np.isfinite(values)
    rgb[covered] = band_rgb(values[covered], tol)
    rgb[~covered] = (np.array(UNCOVERED_RGB) * 255).round().astype(np.uint8)
    return rgb


REGION_RGB = ((0.90, 0.62, 0.0), (0.34, 0.71, 0.91), (0.0, 0.62, 0.45), (0.80, 0.47, 0.65),
              (0.0, 0.45, 0.70), (0.84, 0.37, 0.0), (0.94, 0.89, 0.26), (0.35, 0.35, 0.40))
"""The regions' colours (Okabe and Ito's palette, told apart with colour-blindness), in the
order of the regions' names; repeated beyond eight regions."""
NO_REGION_RGB = (0.80, 0.80, 0.82)
"""Points in no region."""


def region_colours(regions: np.ndarray) -> tuple[list[tuple[str, tuple, int]], np.ndarray]:
    """The colours of the points' plan regions.

    regions : (n,) str, each point's regions ('a+b' for a point in two, '' for none:
    engine.gdt.characteristics.PlanResult.regions). Returns the legend, [(name, rgb in 0..1,
    number of points)] with the named regions in sorted order and "(no region)" last, and the
    (n, 3) uint8 colour of each point.
    """
    regions = np.asarray(regions, dtype=str)
    names, inverse, counts = np.unique(regions, return_inverse=True, return_counts=True)
    colour = {n: REGION_RGB[k % len(REGION_RGB)] for k, n in enumerate(n for n in names if n)}
    colour[""] = NO_REGION_RGB
    rgb = [colour[n] for n in names]
    table = (np.array(rgb, dtype=float).reshape(-1, 3) * 255).round().astype(np.uint8)
    legend = [(str(n) or "(no region)", c, int(k)) for n, c, k in zip(names, rgb, counts)]
    if names.size and names[0] == "":  # '' sorts first; listed last
        legend = legend[1:] + legend[:1]
    return legend, table[inverse.reshape(-1)]
