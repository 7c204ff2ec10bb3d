"""The inspection engine: read → register → measure deviations → judge. numpy/scipy only.

Importing the package costs nothing (its modules load when first used); :func:`warm_up` loads
them ahead of time.
"""


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
