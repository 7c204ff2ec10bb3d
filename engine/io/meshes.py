"""PLY, OBJ and STL meshes read with numpy and checked before any native code sees them.

VTK's readers trust a file's declared counts and indices: a face pointing at a missing vertex, or a
PLY header declaring fewer vertices than the file holds, crashes the process in the filters that
follow, and a truncated file is read as a shorter mesh. Here every declared count is checked
against the rows or bytes present, every face index against the vertex count, and any mismatch
raises :class:`~engine.errors.InputError` naming the file, line where known, and the problem
("truncated: the header declares 90000 vertices, the file holds 60000").

One module per format, as trimesh's ``exchange``: ``engine.io.ply``, ``engine.io.obj`` and
``engine.io.stl`` read a file into a :class:`~engine.io.mesh_data.MeshData` (``mesh_data`` holds
what they share), :func:`read_mesh` here makes it a :class:`~engine.pointset.PointSet`, and
``engine.io.vtk`` reads VTK's own formats.

A group's points are the vertices of its faces: a vertex on the edge between faces of two groups
is in both (:class:`engine.pointset.PointSet` ``groups``). STL solids and VTK's formats carry no
groups here.

Coordinates stay in the file's units (meshes carry none; millimetres by convention).

VTK's own formats (``.vtk``, ``.vtp``, ``.vts``) are read by VTK's readers in a child process
(:func:`engine.io.vtk.read_vtk`; ``python -m engine.io.vtk`` is that child), and the faces of
every mesh are triangulated by VTK's filters once checked (:func:`engine.io.vtk.surface`). VTK's
own messages never reach the terminal: they are routed into a string (see
``engine.io.vtk.vtk_log``).

Why a reader of our own rather than a library's (tried 2026-12-01): trimesh (MIT) reads the bad
files these checks exist for without a word — an ASCII PLY declaring 25 vertices of 40 as 25
vertices and no faces, one declaring 60 of 40 with face rows read as points; OBJ negative indices
against the whole file instead of the vertices above the line; ``f 0 1 2`` as ``[0, 0, 1]``; an
ASCII STL cut before ``endsolid`` or a binary one cut mid-triangle as an empty scene. plyfile
reads PLY well but is GPL-3.0-or-later (this project is MIT) and parses ASCII PLY 5-15 times
slower. The checks these formats need parse every row anyway, so a library would add a second
parse and no safety.
"""

from __future__ import annotations

import os

from engine.errors import InputError
from engine.pointset import PointSet

from .mesh_data import check_vertices, unit_normals_or_none
from .obj import read_obj
from .ply import read_ply
from .points import finish_point_set
from .stl import read_stl
from .vtk import surface, vtk_log


def read_mesh(path: str, suffix: str) -> PointSet:
    """A PLY, OBJ or STL file (``suffix``) read with numpy; its faces triangulated by VTK."""
    if os.path.getsize(path) == 0:
        raise InputError("the file is empty", path)
    mesh = {".ply": read_ply, ".obj": read_obj, ".stl": read_stl}[suffix](path)
    pts = mesh.points
    check_vertices(pts, path)
    normals = unit_normals_or_none(mesh.normals, pts)
    if mesh.polygons is None:
        return finish_point_set(PointSet(pts, normals, None, None, None, 3, path, mesh.groups))
    import pyvista as pv

    vtk_log()
    return surface(pv.PolyData(pts, mesh.polygons), normals, path, mesh.groups)
