"""Typed errors of the inspection engine.

"Invalid input" raises one of these; "could not compute" (ICP did not converge, an ambiguous pose) is
a value in the result instead, and the verdict says INCONCLUSIVE.
"""

from __future__ import annotations


class QAError(Exception):
    """Base of every error this product raises on purpose."""


class InputError(QAError, ValueError):
    """An input file or array is unusable.

    ``path`` and ``line`` (1-based) locate the problem when known; ``str(error)`` reads
    ``measured.csv:17: 'x1.2' is not a number``.
    """

    def __init__(self, message: str, path: str | None = None, line: int | None = None):
        self.message = message
        self.path = path
        self.line = line
        where = ""
        if path is not None:
            where = f"{path}:{line}: " if line is not None else f"{path}: "
        super().__init__(where + message)


class InputNotFoundError(InputError, FileNotFoundError):
    """An input file does not exist or cannot be opened."""


class SettingsError(QAError, ValueError):
    """Inconsistent settings (e.g. a tolerance zone whose lower limit exceeds the upper)."""


class NoDistanceError(QAError, ArithmeticError):
    """No distance could be computed from some points to a nominal's surface (OpenCascade found
    none to any face of a STEP model): a "could not compute", which the pipeline turns into an
    INCONCLUSIVE verdict naming the points, never an internal error.

    ``points`` : (k,) int indices of those points in the array asked about;
    ``coordinates`` : (k, 3) float, the points themselves (mm, the nominal's frame).
    """

    def __init__(self, points, coordinates, why: str):
        self.points = points
        self.coordinates = coordinates
        self.why = why
        super().__init__(f"{why} from {len(points)} point(s), the first at "
                         f"{tuple(round(float(c), 6) for c in coordinates[0])} mm")


class Cancelled(QAError):
    """The user stopped the computation (raised from a progress callback)."""
