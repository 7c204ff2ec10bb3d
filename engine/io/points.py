"""Point files as CMMs and CAD exports write them: ``.csv .txt .xyz .asc`` text and ``.npy``.

Text layout accepted (detected from the file, no options needed):

* delimiter: comma, semicolon, tab or runs of spaces; a semicolon file may use decimal commas;
* ``#`` comment lines anywhere; ``# units: inch`` (mm, cm, m, in/inch) converts to millimetres;
  ``# grid: NU x NV`` declares a u-v grid, points ordered with u fastest (index = j*NU + i). Both
  count wherever they stand before the first data row (before or after a header row); after it
  they would apply to some points only, so the file is refused;
* text encoding: UTF-8 (with or without BOM), UTF-16 (with a BOM, or recognised by its zero
  bytes), else Windows cp1252 (whose byte 0x85 is an ellipsis, not a line break);
* an optional header row naming the columns (``x y z``, ``i j k`` or ``nx ny nz``, a label column
  such as ``id``/``name``/``label``/``point``);
* without a header, columns by count: ``x y`` (2D), ``x y z``, ``x y z i j k``, or those preceded
  by a label column (``P0001, x, y, z``; a leading all-integer column counts as a label too).

Every problem raises :class:`~engine.errors.InputError` naming the file and 1-based line. A
coordinate beyond ``COORD_LIMIT_MM`` (1e9 mm, 1000 km) is refused: no part is that large, and
squaring such numbers overflows. ``.npy`` files must hold real numbers (float or integer) in an
(n, 2), (n, 3) or (n, 6) array whose declared size matches the file's length.
Meshes are read by ``engine.io.meshes`` (numpy: ``ply``, ``obj``, ``stl``) and ``engine.io.vtk``
(VTK), which build the same :class:`PointSet`.
"""

from __future__ import annotations

import codecs
import math
import os
import re
import warnings
from dataclasses import dataclass

import numpy as np

from engine.errors import InputError, InputNotFoundError
from engine.pointset import PointSet

from . import formats
from .formats import TEXT_SUFFIXES

COORD_LIMIT_MM = 1e9
"""Largest |coordinate| accepted (mm): 1000 km; beyond it a number is an export error, and its
square (used by every fit) approaches float64's range."""
UNIT_SCALE_TO_MM = {"mm": 1.0, "millimetre": 1.0, "millimeter": 1.0, "cm": 10.0, "m": 1000.0,
                    "metre": 1000.0, "meter": 1000.0, "in": 25.4, "inch": 25.4, "inches": 25.4,
                    "um": 1e-3, "µm": 1e-3, "micron": 1e-3}

_GRID_RE = re.compile(r"^#\s*grid\s*[:=]?\s*(\d+)\s*(?:x|×|,|\s)\s*(\d+)\s*$", re.IGNORECASE)
_UNITS_RE = re.compile(r"^#\s*units?\s*[:=]?\s*([a-zµ]+)\s*$", re.IGNORECASE)
_LABEL_NAMES = {"id", "name", "label", "point", "pt", "no", "nr", "number", "pid", "index"}
_AXIS_NAMES = {
    "x": 0, "y": 1, "z": 2,
    "i": 3, "j": 4, "k": 5, "nx": 3, "ny": 4, "nz": 5, "u": 3, "v": 4, "w": 5,
}


def read_points(path: str | os.PathLike) -> PointSet:
    """Read a text or ``.npy`` point file (see the module docstring for the layouts)."""
    path = os.fspath(path)
    suffix = os.path.splitext(path)[1].lower()
    formats.check_file(path)
    if formats.KIND.get(suffix) == formats.NPY:
        return _read_npy(path)
    if suffix in TEXT_SUFFIXES:
        return _read_text(path)
    raise InputError(f"unsupported point file type '{suffix}' (expected one of "
                     f"{', '.join(formats.suffixes(formats.POINT_TEXT, formats.NPY))})", path)


def _read_npy(path: str) -> PointSet:
    # The header is checked against the file's length before numpy allocates anything: a
    # damaged header may claim 10^11 rows.
    try:
        with open(path, "rb") as f:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
            elif version == (2, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
            else:
                raise ValueError(f".npy format version {version[0]}.{version[1]} is not supported")
            data_start = f.tell()
    except (ValueError, OSError, SyntaxError) as e:
        raise InputError(f"not a readable .npy array ({e})", path) from e
    if dtype.fields is not None or dtype.subdtype is not None or dtype.kind not in "fiu":
        raise InputError(f"array of dtype {dtype}; expected real numbers (float or integer)", path)
    if len(shape) != 2 or shape[1] not in (2, 3, 6):
        raise InputError(f"array of shape {shape}; expected (n, 2), (n, 3) or (n, 6)", path)
    row_bytes = shape[1] * dtype.itemsize
    held = (os.path.getsize(path) - data_start) // row_bytes
    if held != shape[0]:
        raise InputError(f"{'truncated' if held < shape[0] else 'inconsistent'}: the header "
                         f"declares {shape[0]} rows, the file holds {held}", path)
    try:
        arr = np.load(path, allow_pickle=False)
    except (ValueError, OSError) as e:
        raise InputError(f"not a readable .npy array ({e})", path) from e
    arr = arr.astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
    if bad.size:
        raise InputError(f"row {bad[0]} holds NaN or infinity", path)
    check_coordinate_range(arr[:, :3], path)
    dim = 2 if arr.shape[1] == 2 else 3
    pts = np.zeros((arr.shape[0], 3))
    pts[:, :dim] = arr[:, :dim]
    normals = _unit_normals(arr[:, 3:6], path, None) if arr.shape[1] == 6 else None
    return finish_point_set(PointSet(pts, normals, dim=dim, path=path))


def check_coordinate_range(coords: np.ndarray, path: str, line_no=None,
                           scale: float = 1.0) -> None:
    """Refuse finite coordinates beyond ``COORD_LIMIT_MM`` (after multiplying by ``scale``, the
    file's unit in mm). coords : (n, k) finite floats; line_no : (n,) 1-based lines or None."""
    big = np.abs(coords) > COORD_LIMIT_MM / scale
    if big.any():
        row, col = (int(v[0]) for v in np.nonzero(big))
        where = f"point {row}: " if line_no is None else ""
        raise InputError(f"{where}coordinate {coords[row, col]:g}"
                         f"{'' if scale == 1.0 else f' (x {scale:g} mm)'} lies beyond "
                         "±1e9 mm (1000 km); it is not a part's coordinate",
                         path, None if line_no is None else int(line_no[row]))


@dataclass
class _Layout:
    delimiter: str | None  # None = whitespace
    decimal_comma: bool
    label_col: int | None
    coord_cols: list[int]  # x, y[, z]
    normal_cols: list[int] | None
    n_cols: int
    header_line: int | None  # 0-based line index of the header row
    grid_shape: tuple[int, int] | None
    unit_scale: float


def _split(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return line.split()
    return [t.strip() for t in line.split(delimiter)]


def _is_number(tok: str, decimal_comma: bool) -> bool:
    try:
        float(tok.replace(",", ".") if decimal_comma else tok)
        return True
    except ValueError:
        return False


def _directive(s: str, path: str, idx: int, found: dict) -> None:
    """Apply a ``# grid:`` or ``# units:`` comment (s stripped, idx its 0-based line) to found."""
    m = _GRID_RE.match(s)
    if m:
        grid_shape = (int(m.group(1)), int(m.group(2)))
        if min(grid_shape) < 2:
            raise InputError(f"grid {grid_shape[0]} x {grid_shape[1]} needs at least 2 x 2 "
                             "points", path, idx + 1)
        if found.get("grid", grid_shape) != grid_shape:
            raise InputError("a second '# grid:' comment contradicts the first", path, idx + 1)
        found["grid"] = grid_shape
    m = _UNITS_RE.match(s)
    if m:
        unit = m.group(1).lower()
        if unit not in UNIT_SCALE_TO_MM:
            raise InputError(f"unknown unit '{m.group(1)}' (expected one of mm, cm, m, in)",
                             path, idx + 1)
        if found.get("units", UNIT_SCALE_TO_MM[unit]) != UNIT_SCALE_TO_MM[unit]:
            raise InputError("a second '# units:' comment contradicts the first", path, idx + 1)
        found["units"] = UNIT_SCALE_TO_MM[unit]


def _detect_layout(path: str, lines: list[str]) -> _Layout:
    """The layout of a text point file (``lines`` without their line ends): delimiter, decimal
    comma, the label, x y [z] and i j k columns (0-based), the header row, and the grid and
    units declared by ``#`` comments before the first data row."""
    found: dict = {}
    first = _directives_up_to_row(path, lines, 0, found)
    if first is None:
        raise InputError("the file holds no points", path)
    s = lines[first].strip()
    if ";" in s:
        delimiter: str | None = ";"
    elif "\t" in s:
        delimiter = "\t"
    elif "," in s:
        delimiter = ","
    else:
        delimiter = None
    tokens = _split(s, delimiter)
    decimal_comma = delimiter in (";", "\t", None) and any(
        re.fullmatch(r"[-+]?\d+,\d+(?:[eE][-+]?\d+)?", t) for t in tokens)

    header_line = None
    n_cols = len(tokens)
    numeric = [_is_number(t, decimal_comma) for t in tokens]
    # A header row has no number in it except possibly none at all: names only.
    if not any(numeric[1:]) and len(tokens) >= 2:
        header_line = first
        label_col, coord_cols, normal_cols = _named_columns(path, tokens, first)
    else:
        label_col = None
        if not numeric[0]:
            label_col = 0
        elif n_cols in (4, 7) and _looks_like_integer_labels(lines, first, delimiter, decimal_comma):
            label_col = 0
        coord_cols, normal_cols = _counted_columns(path, n_cols, label_col, first)
    if header_line is not None:
        # Comments between the header row and the first data row still describe the whole file.
        _directives_up_to_row(path, lines, header_line + 1, found)
    return _Layout(delimiter, decimal_comma, label_col, coord_cols, normal_cols, n_cols,
                   header_line, found.get("grid"), found.get("units", 1.0))


def _directives_up_to_row(path: str, lines: list[str], start: int, found: dict) -> int | None:
    """Apply the ``# grid:`` / ``# units:`` comments from line ``start`` (0-based) on to
    ``found``, up to the first row that is neither blank nor a comment: its 0-based index, or
    None when there is none."""
    for idx in range(start, len(lines)):
        s = lines[idx].strip()
        if not s:
            continue
        if not s.startswith("#"):
            return idx
        _directive(s, path, idx, found)
    return None


def _named_columns(path: str, tokens: list[str],
                   line: int) -> tuple[int | None, list[int], list[int] | None]:
    """(label column or None, x y [z] columns, i j k columns or None), all 0-based, as named by
    the header row ``tokens`` (0-based ``line``); a header naming no x and y column is refused.
    Without a label name, a first column that is no axis is taken as the label."""
    label_col = None
    normal_cols = None
    names = [t.strip().strip('"').strip("'").lower() for t in tokens]
    slots: dict[int, int] = {}
    for col, name in enumerate(names):
        key = name.split("[")[0].split("(")[0].strip()
        if key in _AXIS_NAMES and _AXIS_NAMES[key] not in slots:
            slots[_AXIS_NAMES[key]] = col
        elif key in _LABEL_NAMES and label_col is None:
            label_col = col
    if 0 not in slots or 1 not in slots:
        raise InputError(f"header row {tokens!r} names no x and y columns", path, line + 1)
    coord_cols = [slots[0], slots[1]] + ([slots[2]] if 2 in slots else [])
    if all(a in slots for a in (3, 4, 5)):
        normal_cols = [slots[3], slots[4], slots[5]]
    if label_col is None and 0 not in slots.values() and len(names) > 0:
        label_col = 0 if names[0] not in _AXIS_NAMES else None
    return label_col, coord_cols, normal_cols


def _counted_columns(path: str, n_cols: int, label_col: int | None,
                     line: int) -> tuple[list[int], list[int] | None]:
    """(x y [z] columns, i j k columns or None), all 0-based, of a file without a header row,
    told by its ``n_cols`` columns after the label column (if any): 2 or 3 coordinates, or 3
    and a normal. Any other count is refused at the first data row (0-based ``line``)."""
    normal_cols = None
    data_count = n_cols - (1 if label_col is not None else 0)
    off = 1 if label_col is not None else 0
    if data_count == 2:
        coord_cols = [off, off + 1]
    elif data_count == 3:
        coord_cols = [off, off + 1, off + 2]
    elif data_count == 6:
        coord_cols = [off, off + 1, off + 2]
        normal_cols = [off + 3, off + 4, off + 5]
    else:
        raise InputError(
            f"{n_cols} columns without a header row: expected x y, x y z or x y z i j k, "
            "optionally after a label column (add a header such as 'id,x,y,z' to say which "
            "column is which)", path, line + 1)
    return coord_cols, normal_cols


def _refuse_late_directives(path: str, lines: list[str], start: int) -> None:
    """A ``# units:`` or ``# grid:`` comment after the first data row would apply to some points
    only (or silently to none): refuse it rather than guess."""
    data = None
    for idx in range(start, len(lines)):
        ln = lines[idx]
        if "#" not in ln:
            if data is None and ln.strip():
                data = idx
            continue
        s = ln.strip()
        if not s.startswith("#"):
            if data is None:
                data = idx
            continue
        if data is not None and (_GRID_RE.match(s) or _UNITS_RE.match(s)):
            raise InputError(f"'{s}' stands after the first data row (line {data + 1}); declare "
                             "units and grid before the data", path, idx + 1)


def _looks_like_integer_labels(lines, first, delimiter, decimal_comma) -> bool:
    """A leading column of integers on the first rows is a point number, not a coordinate."""
    seen = 0
    for raw in lines[first:first + 50]:
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        tok = _split(s, delimiter)[0]
        if not re.fullmatch(r"[-+]?\d+", tok):
            return False
        seen += 1
    return seen > 0


_ODD_BREAKS = ("\x0b", "\x0c", "\x1c", "\x1d", "\x1e", "\x85", "\u2028", "\u2029")


def split_lines(text: str) -> list[str]:
    """Lines split at ``\\n``, ``\\r\\n`` or ``\\r`` only: ``str.splitlines`` also splits at form
    feeds, ``\\x85``, U+2028 and others, which may stand inside a comment or a label."""
    if any(c in text for c in _ODD_BREAKS):
        lines = re.split(r"\r\n|\r|\n", text)
        if lines and lines[-1] == "":
            lines.pop()
        return lines
    return text.splitlines()


def _lines(raw: bytes, encoding: str, block: int = 1 << 22) -> list[str]:
    """The text's lines, decoded a few megabytes at a time (cut at line ends) so that other
    threads get the interpreter in between."""
    lines: list[str] = []
    start = 0
    errors = "replace" if encoding == "cp1252" else "strict"  # cp1252 leaves 5 bytes undefined
    while start < len(raw):
        end = raw.find(b"\n", min(start + block, len(raw)))
        end = len(raw) if end < 0 else end + 1
        lines.extend(split_lines(raw[start:end].decode(encoding if start == 0 else
                                                       encoding.replace("-sig", ""), errors)))
        start = end
    return lines


def read_bytes(path: str) -> bytes:
    """A file's bytes; InputNotFoundError / InputError naming the file (never a bare OSError)
    when it cannot be read. Every reader of the product reads its input through this."""
    formats.check_file(path)
    try:
        with open(path, "rb") as f:
            return f.read()
    except FileNotFoundError:
        raise InputNotFoundError("no such file", path) from None
    except IsADirectoryError:
        raise InputError("is a folder, not a file", path) from None
    except OSError as e:
        raise InputError(f"cannot be read ({e.strerror})", path) from e


def text_lines(raw: bytes, path: str, what: str = "text point file") -> list[str]:
    """The lines of a text file's bytes: UTF-8 (BOM or not); UTF-16 with a BOM, or without one
    when every other byte is zero; else cp1252 (Windows exports; latin-1 would read byte 0x85 as
    a line break). A file with other zero bytes is binary: InputError."""
    head = raw[:4096]
    utf16 = None
    if raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        utf16 = "utf-16"
    elif b"\x00" in head:
        even, odd = head[0::2], head[1::2]
        if len(head) >= 2 and odd.count(0) == len(odd) and 0 not in even:
            utf16 = "utf-16-le"
        elif len(head) >= 2 and even.count(0) == len(even) and 0 not in odd:
            utf16 = "utf-16-be"
        else:
            raise InputError(f"is a binary file, not a {what}", path)
    if utf16 is not None:
        try:
            return split_lines(raw.decode(utf16))
        except UnicodeDecodeError as e:
            raise InputError(f"damaged UTF-16 text (byte {e.start} cannot be decoded)",
                             path) from None
    try:
        return _lines(raw, "utf-8-sig")
    except UnicodeDecodeError:
        return _lines(raw, "cp1252")


def _read_text(path: str) -> PointSet:
    lines = text_lines(read_bytes(path), path)
    layout = _detect_layout(path, lines)
    start = (layout.header_line + 1) if layout.header_line is not None else 0
    _refuse_late_directives(path, lines, start)
    if not any(ln.strip() and not ln.lstrip().startswith("#") for ln in lines[start:]):
        raise InputError("the file holds a header but no points", path)
    data = _parse_fast(lines, start, layout)
    if data is None:
        data = _parse_slow(path, lines, start, layout)
    coords, normals, labels, line_no = data
    if coords.shape[0] == 0:
        raise InputError("the file holds a header but no points", path)
    bad = np.flatnonzero(~np.isfinite(coords).all(axis=1))
    if normals is not None:
        bad = np.union1d(bad, np.flatnonzero(~np.isfinite(normals).all(axis=1)))
    if bad.size:
        ln = line_no[bad[0]] if line_no is not None else _line_of_row(lines, start, bad[0])
        raise InputError("NaN or infinity is not a coordinate", path, ln)
    big = np.flatnonzero((np.abs(coords) > COORD_LIMIT_MM / layout.unit_scale).any(axis=1))
    if big.size:
        r = int(big[0])
        ln = line_no[r] if line_no is not None else _line_of_row(lines, start, r)
        check_coordinate_range(coords[r:r + 1], path, [ln], layout.unit_scale)
    dim = coords.shape[1]
    pts = np.zeros((coords.shape[0], 3))
    pts[:, :dim] = coords * layout.unit_scale
    if normals is not None:
        normals = _unit_normals(normals, path, line_no, lines, start)
    ps = PointSet(pts, normals, labels, layout.grid_shape, None, dim, path)
    return finish_point_set(ps)


def _line_of_row(lines: list[str], start: int, row: int) -> int:
    count = -1
    for idx in range(start, len(lines)):
        s = lines[idx].strip()
        if s and not s.startswith("#"):
            count += 1
            if count == row:
                return idx + 1
    return len(lines)


def _parse_fast(lines, start, layout: _Layout):
    """np.loadtxt over the data lines; None when anything is off (the slow path then explains)."""
    if layout.decimal_comma:
        return None
    cols = layout.coord_cols + (layout.normal_cols or [])
    try:
        with warnings.catch_warnings():
            # numpy notes blank and comment lines inside the data; they are allowed here.
            warnings.simplefilter("ignore", UserWarning)
            return _loadtxt(lines, start, layout, cols)
    except (ValueError, IndexError):
        return None


CHUNK_LINES = 32_768
"""Lines parsed per np.loadtxt call: between calls other threads get the interpreter, so a
desktop app reading a million-line file in its worker stays responsive (a chunk takes ~40 ms)."""


def _chunked_loadtxt(lines, ndmin, **kw):
    parts = []
    for k in range(0, len(lines), CHUNK_LINES):
        a = np.loadtxt(lines[k:k + CHUNK_LINES], comments="#", ndmin=ndmin, **kw)
        if a.shape[0]:
            parts.append(a)
    if not parts:
        raise ValueError("no data")
    if len({p.shape[1:] for p in parts}) != 1:
        raise ValueError("rows differ in their number of columns")
    return np.concatenate(parts)


def _loadtxt(lines, start, layout: _Layout, cols):
    labels = None
    data = lines[start:]
    if layout.label_col is None:
        # Without usecols loadtxt itself refuses rows whose column count differs.
        arr = _chunked_loadtxt(data, 2, delimiter=layout.delimiter, dtype=np.float64)
        if arr.shape[1] != layout.n_cols:
            return None
        arr = arr[:, cols]
    else:
        if not _column_counts_ok(lines, start, layout):
            return None
        arr = _chunked_loadtxt(data, 2, delimiter=layout.delimiter, usecols=cols,
                               dtype=np.float64)
        labels = _chunked_loadtxt(data, 1, delimiter=layout.delimiter,
                                  usecols=[layout.label_col], dtype=str)
        labels = np.char.strip(np.char.strip(labels), '"')
    nc = len(layout.coord_cols)
    coords = arr[:, :nc]
    normals = arr[:, nc:nc + 3] if layout.normal_cols else None
    return coords, normals, labels, None


def _column_counts_ok(lines, start, layout: _Layout) -> bool:
    n = layout.n_cols
    d = layout.delimiter
    for raw in lines[start:]:
        s = raw.strip()
        if not s or s[0] == "#":
            continue
        if (len(s.split()) if d is None else s.count(d) + 1) != n:
            return False
    return True


def _parse_slow(path, lines, start, layout: _Layout):
    coords, normals, labels, line_no = [], [], [], []
    nc = len(layout.coord_cols)
    for idx in range(start, len(lines)):
        s = lines[idx].strip()
        if not s or s.startswith("#"):
            continue
        toks = _split(s, layout.delimiter)
        if len(toks) != layout.n_cols:
            raise InputError(f"{len(toks)} columns where the file has {layout.n_cols}", path, idx + 1)
        vals = []
        for col in layout.coord_cols + (layout.normal_cols or []):
            tok = toks[col]
            try:
                vals.append(float(tok.replace(",", ".") if layout.decimal_comma else tok))
            except ValueError:
                raise InputError(f"'{tok}' is not a number", path, idx + 1) from None
        for v in vals:
            if not math.isfinite(v):
                raise InputError("NaN or infinity is not a coordinate", path, idx + 1)
        coords.append(vals[:nc])
        if layout.normal_cols:
            normals.append(vals[nc:])
        if layout.label_col is not None:
            labels.append(toks[layout.label_col].strip('"'))
        line_no.append(idx + 1)
    return (np.asarray(coords, dtype=np.float64).reshape(-1, nc),
            np.asarray(normals, dtype=np.float64).reshape(-1, 3) if layout.normal_cols else None,
            np.asarray(labels, dtype=str) if layout.label_col is not None else None,
            np.asarray(line_no))


def _unit_normals(normals, path, line_no=None, lines=None, start=0) -> np.ndarray:
    # Scaled by the largest component first, so that huge finite components do not overflow.
    big = np.abs(normals).max(axis=1)
    ok = np.isfinite(big) & (big > 0)
    normals = normals / np.where(ok, big, 1.0)[:, None]
    norm = np.where(ok, np.linalg.norm(normals, axis=1), 0.0)
    bad = np.flatnonzero(~(norm > 1e-12) | ~np.isfinite(norm))
    if bad.size:
        if line_no is not None:
            raise InputError("normal (I J K) has zero length", path, int(line_no[bad[0]]))
        if lines is not None:
            raise InputError("normal (I J K) has zero length", path, _line_of_row(lines, start, bad[0]))
        raise InputError(f"row {bad[0]}: normal (I J K) has zero length", path)
    return normals / norm[:, None]


def finish_point_set(ps: PointSet) -> PointSet:
    """Check what every reader must check: enough points, finite, not degenerate, grid size."""
    pts = ps.points
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points of shape {pts.shape}; expected (n, 3)", ps.path)
    if pts.shape[0] == 0:
        raise InputError("the file holds no points", ps.path)
    if pts.shape[0] < 3:
        raise InputError(f"only {pts.shape[0]} point(s); at least 3 are needed", ps.path)
    if not np.isfinite(pts).all():
        row = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise InputError(f"point {row} holds NaN or infinity", ps.path)
    check_coordinate_range(pts, ps.path)
    check_not_degenerate(pts, ps.path, ps.dim)
    if ps.grid_shape is not None:
        nu, nv = ps.grid_shape
        if nu * nv != pts.shape[0]:
            raise InputError(f"header declares a {nu} x {nv} grid ({nu * nv} points) but the file "
                             f"holds {pts.shape[0]} points", ps.path)
    return ps


def check_not_degenerate(pts: np.ndarray, path: str, dim: int = 3) -> None:
    """Raise when all points coincide or lie on one line (no rigid pose can be found from them).
    pts : (n, 3) float; dim : the coordinates the file gave (2: x y, shown without the z)."""
    # Equal coordinates, not a zero spread about the mean: the mean of 1,000 copies of 1.1 is
    # not 1.1 to the last bit, and the rounding left looked like a line.
    if not np.ptp(pts, axis=0).any():
        raise InputError(f"all {pts.shape[0]:,} points are the same point "
                         f"({', '.join(f'{v:g}' for v in pts[0, :dim])}): one distinct point", path)
    centred = pts - pts.mean(axis=0)
    scale = float(np.abs(centred).max())
    sv = np.linalg.svd(centred / scale, compute_uv=False)
    if sv[1] <= 1e-9 * sv[0]:
        raise InputError(f"all {pts.shape[0]} points lie on one straight line", path)
