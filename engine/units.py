"""Units a file gets wrong: a nominal and measured points whose sizes differ by the factor
between two length units.

A DXF drawing whose header says metres over numbers in millimetres is read 1000 x too large; a
scan exported in metres, or a drawing in inches read as millimetres, is 1000 or 25.4 x too
small. No rigid pose fits one onto the other: the registration fails ("did not converge", an
rms of centimetres), or, worse, a part shrunk 1000 x fits somewhere on a large nominal and gets
a confident verdict. The sizes tell the mistake: :func:`principal_sizes` of each (independent
of pose), compared by :func:`unit_factor`, and :func:`unit_mismatch` says it in words, with the
option or line that fixes it.
"""

from __future__ import annotations

import numpy as np

UNIT_FACTORS = {10.0: 0.05, 25.4: 0.15, 304.8: 0.15, 1000.0: 0.15}
"""Size ratios between two length units a file may be in (mm against cm, inches, feet and
metres; and their inverses), each with how near the sizes must come to it: the (3,) principal
sizes as vectors, ``|nominal - f * measured| <= tolerance * |nominal|``. The same part sampled
evenly all over agrees to about 1%, one side of it scanned to about 8%; a patch of the part a
tenth of its size is a common measurement, and one that has the part's proportions in its
plane has not its depth (16% off), so a tenth must match to 5%; a patch 25 or 1000 x smaller
than the part with all of its proportions is no measurement anyone makes, so those match to
15%. The windows of the factors do not overlap."""
UNIT_NAMES = {0.001: ("um", "micrometres"), 1.0: ("mm", "millimetres"),
              10.0: ("cm", "centimetres"), 25.4: ("in", "inches"), 304.8: ("ft", "feet"),
              1000.0: ("m", "metres")}
"""mm per unit -> (its symbol, its name)."""
DXF_UNITS = ("mm", "cm", "m", "in")
"""The units ``--units`` reads a DXF drawing in (engine.io.templates)."""
POINT_FILE_UNITS = ("um", "mm", "cm", "m", "in")
"""The units a text point file may state in a ``# units:`` line (engine.io.points)."""


SIZE_POINTS = 200_000
"""Points at most that a size is taken over (every k-th beyond): a scan of millions gives the
same second moments to far better than the tolerances, without copies of it all."""


def principal_sizes(points: np.ndarray) -> np.ndarray:
    """The RMS extents of ``points`` (n, 2) or (n, 3), mm, about their centroid along their
    principal axes, largest first, as (3,) (a planar set's third is ~0): the same for any pose
    of the same points, and for any even sampling of the same shape.

    >>> np.round(principal_sizes(np.array([[-1., 0], [1, 0], [0, -2], [0, 2]])), 6)
    array([1.414214, 0.707107, 0.      ])
    """
    P = np.asarray(points, dtype=np.float64)
    out = np.zeros(3)
    if len(P) == 0:
        return out
    P = P[::len(P) // SIZE_POINTS + 1]
    Q = P - P.mean(axis=0)
    ev = np.sort(np.clip(np.linalg.eigvalsh(Q.T @ Q / len(Q)), 0.0, None))[::-1]
    out[:ev.size] = np.sqrt(ev)
    return out


def unit_factor(nominal: np.ndarray, measured: np.ndarray) -> float | None:
    """The factor f (one of ``UNIT_FACTORS`` or its inverse) by which the nominal's
    :func:`principal_sizes` are the measured points', within that factor's tolerance; None
    when they are at none (at 1, the same units: no mistake found)."""
    nominal, measured = np.asarray(nominal, float), np.asarray(measured, float)
    scale = float(np.linalg.norm(nominal))
    if not scale > 0 or not np.linalg.norm(measured) > 0:
        return None
    for factor, tolerance in UNIT_FACTORS.items():
        for f in (factor, 1.0 / factor):
            if np.linalg.norm(nominal - f * measured) <= tolerance * scale:
                return f
    return None


def _unit(mm: float) -> tuple[str, str] | None:
    """(symbol, name) of the unit of ``mm`` millimetres (within 1%), or None."""
    for size, names in UNIT_NAMES.items():
        if abs(mm / size - 1.0) <= 0.01:
            return names
    return None


def unit_mismatch(nominal: np.ndarray, measured: np.ndarray, nominal_kind: str = "points",
                  nominal_mm_per_unit: float = 1.0) -> str | None:
    """A sentence saying the nominal and the measured points are in different units, and how
    to read either in the other's, or None when their sizes (:func:`principal_sizes`, mm, as
    read) are at no :func:`unit_factor`.

    nominal_kind : how the nominal's numbers became millimetres: "dxf" (a drawing's units,
        ``--units``), "airfoil" (ordinates in chords, ``--scale``), "step" (the file's own
        unit) or "points" (a point or mesh file's, ``# units:``); nominal_mm_per_unit : the mm
        one of its numbers was read as (the drawing's unit; the chord).
    """
    f = unit_factor(nominal, measured)
    if f is None:
        return None
    big, small = ("nominal", "measured points") if f > 1 else ("measured points", "nominal")
    rn, rm = float(np.linalg.norm(nominal)), float(np.linalg.norm(measured))
    said = (f"the {big} {'is' if f > 1 else 'are'} {max(f, 1 / f):g} x the size of the "
            f"{small} (RMS radius about the centre {_mm(rn)} mm against {_mm(rm)} mm): one of "
            "the files is not in the units it is read in, and no pose fits one to the other")
    fixes = [fix for fix in (_nominal_fix(nominal_kind, nominal_mm_per_unit / f),
                             _measured_fix(f)) if fix]
    return said + ("; " + "; or ".join(fixes) if fixes else "")


def _mm(v: float) -> str:
    return f"{v:,.0f}" if v >= 1000 else f"{v:.4g}"


def _nominal_fix(kind: str, mm: float) -> str | None:
    """How to read the nominal with ``mm`` millimetres to its number (None: no way)."""
    if kind == "airfoil":
        return f"if the chord is {mm:.6g} mm, give --scale {mm:.6g} (the chord in mm)"
    unit = _unit(mm)
    if unit is None:
        return None
    if kind == "dxf" and unit[0] in DXF_UNITS:
        return (f"if the drawing's numbers are {unit[1]}, read it with --units {unit[0]} (the "
                "desktop app's DXF units)")
    if kind == "points" and unit[0] in POINT_FILE_UNITS:
        return (f"if the nominal's numbers are {unit[1]}, say so in its file (a line "
                f"'# units: {unit[0]}' before the data of a text point file), or convert it to "
                "mm")
    return None


def _measured_fix(f: float) -> str | None:
    """How to read the measured points if their numbers are in units of ``f`` mm."""
    unit = _unit(f)
    if unit is None:
        return None
    how = (f"say so in their file (a line '# units: {unit[0]}' before the data of a text "
           "point file), or " if unit[0] in POINT_FILE_UNITS else "")
    return f"if the measured points are in {unit[1]}, {how}convert them to mm"
