"""The inspection engine: read → register → measure deviations → judge. numpy/scipy only.

One inspection in one call (:func:`inspect_files`), its settings (:class:`InspectionSettings`,
:class:`Tolerance`), what it returns (:class:`Run`, whose ``result`` is an
:class:`InspectionResult`) and the errors it raises (:class:`QAError` and its children) are the
public API, listed in ``__all__``. The modules below are the engine's rooms; a name with a
leading underscore is its module's own.

Importing the package costs nothing (its modules load when first used); :func:`warm_up` loads
them ahead of time.
"""

from __future__ import annotations

import importlib
import os

__all__ = ["inspect_files", "Tolerance", "InspectionSettings", "Run", "InspectionResult",
           "QAError", "InputError", "InputNotFoundError", "SettingsError", "warm_up"]

_HOMES = {"Tolerance": "tolerance", "InspectionSettings": "settings", "Run": "pipeline",
          "InspectionResult": "inspection", "QAError": "errors", "InputError": "errors",
          "InputNotFoundError": "errors", "SettingsError": "errors"}


def __getattr__(name: str):
    # The public classes load with their module on first use (PEP 562): ``import engine``
    # stays free for a front end that only warms up.
    if name in _HOMES:
        return getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)
    raise AttributeError(f"module 'engine' has no attribute '{name}'")


def inspect_files(nominal: str | os.PathLike, measured: str | os.PathLike, tolerance=None, *,
                  plan: str | os.PathLike | None = None, progress=None, **options):
    """Inspect one part: read the nominal and the measured points, register them from any pose,
    measure every point's signed deviation (mm, positive along the nominal's outward normal)
    and judge it, as ``qa-inspect inspect`` does.

    nominal, measured : file paths (the formats of ``qa-inspect inspect --help``).
    tolerance : the zone, mm: a :class:`Tolerance` (``Tolerance(-0.1, 0.3)``) or a number t for
        ±t; None with a ``plan``, whose characteristics are then the requirement.
    plan : an inspection plan (TOML), or None.
    progress : called as progress(stage, fraction); it may raise ``engine.errors.Cancelled``.
    options : the other :class:`InspectionSettings` fields, by name (``fit="minimax"``,
        ``decision_rule="guarded"``, ``crop=(x0, y0, z0, x1, y1, z1)``, ``remove_plane=True``,
        ``units="mm"``, ``layers=("CUT",)``, ``scale=...``, ``instrument=...``).

    Returns a :class:`Run`: ``run.result.verdict`` ("ACCEPT", "REJECT" or "INCONCLUSIVE"),
    ``run.result.reasons``, ``run.result.deviations.signed`` (n,), the pose
    ``run.result.registration.T_nominal_measured`` (4, 4) and the rest; ``reports`` turns it
    into JSON, CSV, QIF and a certificate. Raises :class:`InputError` (a file that cannot be
    read, naming it) or :class:`SettingsError` (options that do not fit the files); a verdict
    that cannot be reached is INCONCLUSIVE with its reasons, not an exception.
    """
    from .pipeline import inspection_settings, run_files
    from .tolerance import Tolerance

    if tolerance is not None and not isinstance(tolerance, Tolerance):
        tolerance = Tolerance.symmetric(float(tolerance))
    settings = inspection_settings(tolerance, None if plan is None else os.fspath(plan),
                                   **options)
    return run_files(os.fspath(nominal), os.fspath(measured), settings, progress)


def warm_up() -> None:
    """Import the engine and load its compiled kernels, so that the first inspection does not
    wait for them (0.7-0.9 s measured with numba's cache on disk; 30-60 s on a first run, which
    compiles the kernels).

    A front end calls this in a background thread while the user picks files: it inspects a
    small curved grid (48 x 48 points, more than the global search's coarse level, so that the
    coarse-to-fine ICP runs too) against part of itself shifted by 0.01 mm, which imports the
    pipeline and takes the 3D path through registration, the deviation kernels and the verdict
    (the 2D contour path is not warmed).
    """
    import numpy as np

    from . import pipeline  # noqa: F401  (run_files: the readers and the whole flow)
    from .inspection import inspect
    from .pointset import PointSet
    from .nominal import Nominal
    from .tolerance import Tolerance

    u, v = np.meshgrid(np.linspace(0.0, 40.0, 48), np.linspace(0.0, 40.0, 48), indexing="ij")
    z = 0.01 * (u - 20.0) ** 2 + 0.005 * (v - 20.0) ** 2
    grid = PointSet(np.column_stack([u.ravel(), v.ravel(), z.ravel()]), grid_shape=(48, 48))
    nominal = Nominal.from_point_set(grid)
    inspect(nominal, nominal.points[::7] + [0, 0, 0.01], Tolerance.symmetric(1.0))
