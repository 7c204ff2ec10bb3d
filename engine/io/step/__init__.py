"""STEP nominals: the CAD model itself (ISO 10303-21; AP203, AP214, AP242), read with OpenCascade.

:func:`read_step` returns a :class:`StepNominal`: every face of every solid, shell and placed
assembly instance with an id (1..F, in the file's reading order) and, where the file gives them,
its name and its part's name; a tessellation for registration (a :class:`~engine.pointset.PointSet`
of points, outward unit normals and triangles, with the face id of every point); and
:meth:`StepNominal.deviations`, the exact signed distance from points to the B-rep.

This package is the only code of the product that imports OpenCascade (``OCP``, the
``cadquery-ocp-novtk`` wheel: OpenCascade without a VTK of its own, so pyvista's stays intact),
and only inside functions: a run without a STEP file never loads it (about half a second).

It is read in three modules, in the order a model is read:

* ``reader``: the file's checks, its entities' references, OpenCascade's reading and
  translation, the assembly's placed faces, its units (:func:`read_step`);
* ``brep``: the placed faces together: the tessellation and the exact distance to the B-rep
  (:class:`StepNominal`);
* ``faces``: one face: its record (:class:`StepFace`), the nearest points on its surface (closed
  forms of the elementary surfaces, OpenCascade's extrema on the others) and its trim.
"""

from .brep import StepNominal, deflection_for
from .faces import StepFace
from .reader import check_step_file, read_step

__all__ = ["StepFace", "StepNominal", "check_step_file", "deflection_for", "read_step"]
