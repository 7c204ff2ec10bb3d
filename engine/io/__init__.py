"""Files -> engine objects: the only part of the engine that opens input files.

``formats`` is the one table of file types; ``points`` reads text and ``.npy`` point files (and
defines :class:`~engine.io.points.PointSet`); ``meshes`` reads PLY/OBJ/STL with numpy (``ply``,
``obj``, ``stl``, one module per format, sharing ``mesh_data``) and ``vtk`` VTK's formats through
VTK; ``templates`` reads 2D contour templates (DXF drawings with ezdxf, airfoil
ordinates); ``plan`` reads inspection plans (TOML) into :class:`engine.gdt.plan.Plan`. Only this
package may import pyvista/VTK or ezdxf (an import-linter contract checks it), and only lazily,
inside the readers that need them.

* ``.ply`` (ASCII or binary; scanner PLYs with extra elements such as ``range_grid`` are fine),
  ``.stl``, ``.obj``: points, and triangles when the file has faces (polygons are triangulated);
  PLY ``nx ny nz`` normals when present; the named groups of the faces (OBJ ``g``/``o``, a PLY
  face property such as ``group``), as the vertices of each (``PointSet.groups``), which an
  inspection plan's regions select. Declared counts, face indices and file length are
  checked first: a damaged file is refused ("truncated: the header declares …"), never read in
  part and never handed to native code that could crash the process on it;
* ``.vtk``, ``.vtp``: the same without groups, read by VTK; any error or warning VTK reports
  while reading means a damaged or truncated file, an ASCII legacy file's section lengths are
  checked first (VTK reads one cut short without complaint), and cell indices before any VTK
  filter runs;
* ``.vts`` (structured grid): a u-v grid (x fastest), its cells are the facets;
* ``.e57`` (ASTM E2807 scanner files, ``e57``): the points of every scan moved by its pose into
  the file's frame, metres made mm, with intensity and normals where every scan has them; read
  by pye57 in a child process once the header is checked.
"""

from __future__ import annotations

import hashlib
import os

from engine.errors import InputError, InputNotFoundError
from engine.pointset import PointSet

from . import formats
from .formats import ALL_SUFFIXES, is_template  # noqa: F401  (the package's front door)


def load_point_set(path: str | os.PathLike) -> PointSet:
    """Read a point, mesh or grid file (units: millimetres unless the file says otherwise)."""
    path = os.fspath(path)
    formats.check_file(path)
    suffix, kind = formats.suffix_of(path), formats.kind_of(path)
    if kind == formats.MESH:
        from .meshes import read_mesh
        return read_mesh(path, suffix)
    if kind in (formats.VTK, formats.GRID):
        from .vtk import read_vtk
        return read_vtk(path, suffix)
    if kind == formats.E57:
        from .e57 import read_e57
        return read_e57(path)
    if kind in (formats.POINT_TEXT, formats.NPY):
        from .points import read_points
        return read_points(path)
    raise InputError(f"unsupported file type '{suffix or '(none)'}'; supported: "
                     f"{' '.join(ALL_SUFFIXES)}", path)


def sha256_of(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes, hex. InputError (naming the file) when it cannot be read."""
    formats.check_file(os.fspath(path))
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
    except FileNotFoundError:
        raise InputNotFoundError("no such file", os.fspath(path)) from None
    except OSError as e:
        raise InputError(f"cannot be read ({e.strerror})", os.fspath(path)) from e
    return h.hexdigest()
