"""The one table of input file types: a file's suffix decides what it is and which reader reads it.

Every reader, the check of the options against the nominal, the pipeline and both front ends ask
this table. A new file format is a row here and its reader in ``engine.io`` (dispatched in
:func:`engine.io.load_point_set`, or in :func:`engine.io.templates.read_template` for a 2D
template, or :func:`engine.io.plan.read_plan` for an inspection plan: TOML, or QIF through
:mod:`engine.io.qif_plan`), plus one test.
"""

from __future__ import annotations

import os
import stat

from engine.errors import InputError, InputNotFoundError

POINT_TEXT = "point text"
"""Delimited text point files (``engine.io.points``)."""
NPY = "npy"
"""numpy ``.npy`` arrays of points (``engine.io.points``)."""
MESH = "mesh"
"""PLY, OBJ and STL meshes, read and checked with numpy (``engine.io.meshes``: ``ply``, ``obj``,
``stl``)."""
VTK = "VTK"
"""VTK's own mesh formats, read by VTK in a child process (``engine.io.vtk``)."""
GRID = "structured grid"
"""VTK XML structured grids: u-v grids whose cells are the facets (``engine.io.vtk``)."""
DXF = "DXF template"
"""2D contour templates drawn in DXF (``engine.io.templates``)."""
AIRFOIL = "airfoil template"
"""2D airfoil ordinate templates, Selig order (``engine.io.templates``)."""
PLAN = "inspection plan"
"""Inspection plans in TOML: regions, datums, alignment, characteristics (``engine.io.plan``)."""
QIF = "QIF"
"""QIF 3.0 documents (``.qif``/``.QIF``): a model-based definition's inspection plan, its
features matched to a STEP nominal's faces (``engine.io.qif_plan``)."""
E57 = "E57"
"""ASTM E2807 scanner files, every scan in the file's frame, read with pye57 in a child process
(``engine.io.e57``)."""
STEP = "STEP"
"""STEP CAD models (ISO 10303-21; AP203/AP214/AP242), read with OpenCascade (``engine.io.step``)."""

KIND = {
    ".csv": POINT_TEXT, ".txt": POINT_TEXT, ".xyz": POINT_TEXT, ".asc": POINT_TEXT,
    ".npy": NPY,
    ".ply": MESH, ".stl": MESH, ".obj": MESH,
    ".vtk": VTK, ".vtp": VTK,
    ".vts": GRID,
    ".e57": E57,
    ".dxf": DXF,
    ".dat": AIRFOIL,
    ".toml": PLAN,
    ".qif": QIF,
    ".stp": STEP, ".step": STEP,
}
"""Suffix (lower case, with its dot) -> kind of file."""

POINT_SET_KINDS = (POINT_TEXT, NPY, MESH, VTK, GRID, E57)
"""Files read into a :class:`engine.io.points.PointSet` (a 3D nominal or measured points)."""
TEMPLATE_KINDS = (DXF, AIRFOIL)
"""Files read into a 2D contour template (a nominal only)."""


def suffixes(*kinds: str) -> tuple[str, ...]:
    """The suffixes of the given kinds, in the table's order."""
    return tuple(s for s, k in KIND.items() if k in kinds)


TEXT_SUFFIXES = suffixes(POINT_TEXT)
MESH_SUFFIXES = suffixes(MESH, VTK, GRID)
ALL_SUFFIXES = suffixes(*POINT_SET_KINDS)
TEMPLATE_SUFFIXES = suffixes(*TEMPLATE_KINDS)
PLAN_SUFFIXES = suffixes(PLAN, QIF)
"""What ``--plan`` reads: a TOML plan, or a QIF MBD whose features name a STEP nominal's faces."""
STEP_SUFFIXES = suffixes(STEP)
NOMINAL_SUFFIXES = ALL_SUFFIXES + STEP_SUFFIXES + TEMPLATE_SUFFIXES
"""Every file a nominal may be: a point set, a STEP model or a 2D template."""
MEASURED_SUFFIXES = suffixes(POINT_TEXT, NPY, E57) + (".ply",)
"""What CMMs and scanners write: the desktop app's filter for measured files (any point set is
accepted)."""


def suffix_of(path: str | os.PathLike) -> str:
    """The file's suffix, lower case, with its dot ('' when it has none)."""
    return os.path.splitext(os.fspath(path))[1].lower()


def kind_of(path: str | os.PathLike) -> str | None:
    """The kind of file ``path`` is by its suffix (one of this module's kinds), or None."""
    return KIND.get(suffix_of(path))


def is_template(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a 2D contour template (DXF drawing or airfoil ordinates)."""
    return kind_of(path) in TEMPLATE_KINDS


def check_file(path: str) -> None:
    """Before any reader opens ``path``: InputNotFoundError naming it when it does not exist, is
    a folder, or is not a regular file (a named pipe, socket or device: opening or reading one
    can wait for ever); InputError when it cannot be examined."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise InputNotFoundError("no such file", path) from None
    except OSError as e:
        raise InputError(f"cannot be read ({e.strerror})", path) from e
    if stat.S_ISDIR(mode):
        raise InputNotFoundError("is a folder, not a file", path)
    if not stat.S_ISREG(mode):
        raise InputNotFoundError("is not a file (a named pipe, socket or device)", path)
