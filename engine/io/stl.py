"""STL meshes read with numpy, the declared triangle count checked against the file's length
(see ``engine.io.meshes``).

STL: binary (length exactly 84 + 50 x the declared triangle count) or ASCII (``solid`` …
``facet normal`` … ``outer loop`` three ``vertex`` ``endloop endfacet`` … ``endsolid``, any
number of solids); bit-identical corners are merged into shared vertices, as VTK's reader did.
"""

from __future__ import annotations

import re

import numpy as np

from engine.errors import InputError

from .mesh_data import MeshData, cells
from .points import read_bytes, text_lines


_STL_DTYPE = np.dtype([("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])
_FACET_WORDS = {0: "facet", 1: "normal", 5: "outer", 6: "loop", 7: "vertex", 11: "vertex",
                15: "vertex", 19: "endloop", 20: "endfacet"}


def read_stl(path: str) -> MeshData:
    """An STL file's triangles, bit-identical corners merged into shared vertices."""
    raw = read_bytes(path)
    declared = int.from_bytes(raw[80:84], "little") if len(raw) >= 84 else None
    binary_fits = declared is not None and len(raw) == 84 + 50 * declared
    head = raw[:1024]
    if not binary_fits and raw.lstrip()[:5].lower() == b"solid" and b"\x00" not in head:
        corners = _stl_ascii(raw, path)
    else:
        if declared is None:
            raise InputError(f"truncated: a binary STL needs at least 84 bytes, the file holds "
                             f"{len(raw)}", path)
        if not binary_fits:
            held = (len(raw) - 84) // 50
            word = "truncated" if held < declared else "inconsistent"
            raise InputError(f"{word}: the header declares {declared} triangles "
                             f"({84 + 50 * declared} bytes), the file holds {held} "
                             f"({len(raw)} bytes)", path)
        corners = np.frombuffer(raw, _STL_DTYPE, declared, 84)["v"].reshape(-1, 3)
    if corners.shape[0] == 0:
        raise InputError("the file holds no triangles", path)
    # + 0.0 turns -0.0 into 0.0, so that the two merge like equal coordinates do.
    corners = corners.astype(np.float64) + 0.0
    if not np.isfinite(corners).all():
        row = int(np.flatnonzero(~np.isfinite(corners).all(axis=1))[0])
        raise InputError(f"triangle {row // 3} holds NaN or infinity", path)
    # Group equal corners (a stable lexicographic sort); number the groups in the order the
    # file first uses them.
    n = corners.shape[0]
    order = np.lexsort(corners.T[::-1])
    sc = corners[order]
    new = np.ones(n, dtype=bool)
    new[1:] = np.any(sc[1:] != sc[:-1], axis=1)
    group = np.empty(n, dtype=np.int64)
    group[order] = np.cumsum(new) - 1
    first = order[new]  # the stable sort puts each group's first use first
    by_use = np.argsort(first)
    rank = np.empty_like(by_use)
    rank[by_use] = np.arange(by_use.size)
    tri = rank[group].reshape(-1, 3)
    return MeshData(sc[new][by_use], cells(tri, by_use.size, path,
                                            lambda i: (f"triangle {i}", None)))


def _stl_ascii(raw: bytes, path: str) -> np.ndarray:
    """(3m, 3) corners of an ASCII STL's facets, the structure checked token by token."""
    text = "\n".join(text_lines(raw, path, "text STL file"))
    marks = list(re.finditer(r"(?im)^[ \t]*(end)?solid\b.*$", text))
    out = []
    solids = 0
    pos = 0
    for k in range(0, len(marks), 2):
        head = marks[k]
        if head.group(1) or text[pos:head.start()].strip():
            raise InputError("damaged ASCII STL: text outside 'solid' … 'endsolid'", path,
                             text.count("\n", 0, head.start()) + 1)
        tail = marks[k + 1] if k + 1 < len(marks) else None
        tokens = text[head.end():tail.start() if tail else len(text)].split()
        nfacets = len(tokens) // 21
        if tail is None:
            raise InputError(f"truncated: solid {solids + 1} has no 'endsolid' line (the file "
                             f"ends after {nfacets} complete facets)", path)
        if not tail.group(1):
            raise InputError("damaged ASCII STL: 'solid' inside a solid", path,
                             text.count("\n", 0, tail.start()) + 1)
        if len(tokens) % 21:
            raise InputError(f"damaged ASCII STL: solid {solids + 1} holds {len(tokens)} words, "
                             "not a whole number of 21-word facets (facet normal i j k outer "
                             "loop, 3 vertex x y z, endloop endfacet)", path,
                             text.count("\n", 0, head.start()) + 1)
        for col, word in _FACET_WORDS.items():
            words = tokens[col::21]
            if set(words) != {word} and words and {w.lower() for w in words} != {word}:
                k = next(k for k, w in enumerate(words) if w.lower() != word)
                raise InputError(f"damaged ASCII STL: facet {k} of solid {solids + 1} has "
                                 f"'{words[k]}' where '{word}' belongs", path)
        try:
            xyz = np.column_stack([np.fromiter(map(float, tokens[c::21]), np.float64, nfacets)
                                   for c in (8, 9, 10, 12, 13, 14, 16, 17, 18)])
        except ValueError:
            raise InputError(f"damaged ASCII STL: a vertex of solid {solids + 1} is not three "
                             "numbers", path) from None
        out.append(xyz.reshape(-1, 3))
        solids += 1
        pos = tail.end()
    if text[pos:].strip():
        raise InputError("damaged ASCII STL: text outside 'solid' … 'endsolid'", path)
    if not solids:
        raise InputError("the file holds no triangles", path)
    return np.concatenate(out)
