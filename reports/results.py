"""Machine-readable results: the JSON document and the per-point CSV, written atomically.

The JSON names and the CSV columns are a contract scripts depend on (see the README).
"""

from __future__ import annotations

import csv
import io
import json
import os
import tempfile
from dataclasses import dataclass

import numpy as np

from engine.inspection import InspectionResult

SOFTWARE_NAME = "qa-inspect"
CSV_COLUMNS = ("index", "label", "x", "y", "z", "x_reg", "y_reg", "z_reg", "deviation",
               "in_tolerance")


def software_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("qa-inspect")
    except PackageNotFoundError:  # running from a source tree that was not installed
        return "0+unknown"


@dataclass(frozen=True)
class InputRecord:
    """One input file as the results cite it."""

    role: str  # "nominal" or "measured"
    path: str
    sha256: str
    n_points: int | None
    """Points in the file (None for a 2D template, which has primitives instead)."""
    n_primitives: int | None = None
    """Line segments and arcs of a 2D template."""


def result_document(result: InspectionResult, inputs: list[InputRecord],
                    timings_s: dict) -> dict:
    """The JSON document of one inspection (plain dict of JSON types)."""
    reg = result.registration
    st = result.statistics
    dev = result.deviations.signed
    return {
        "verdict": result.verdict,
        "reasons": list(result.reasons),
        "transform": [[float(v) for v in row] for row in reg.T_nominal_measured],
        "transform_convention": "T_nominal_measured: row-major 4x4, maps measured coordinates "
                                "(mm) into the nominal frame",
        "registration": {
            "converged": bool(reg.converged),
            "iterations": int(reg.iterations),
            "rms": _num(reg.rms),
            "rms_definition": reg.rms_definition,
            "n_inliers": int(reg.n_inliers),
            "outlier_cut": _num(reg.outlier_cut),
            "score": _num(reg.score),
            "hypotheses": int(reg.hypotheses),
            "runner_up_score": None if reg.runner_up_score is None else _num(reg.runner_up_score),
            "score_definition": "truncated RMS sqrt(mean(min(d^2, cut^2))) in mm over a seeded "
                                "subset of at most 4096 measured points, the same for the "
                                "runner-up pose; lower is better",
            "message": reg.message,
        },
        "deviations": {
            "count": st.count, "min": st.min, "max": st.max, "mean": st.mean, "std": st.std,
            "rms": st.rms, "max_abs": st.max_abs, "n_out": st.n_out,
            "fraction_in": st.fraction_in,
            "worst": [{"index": i, "deviation": float(dev[i])} for i in st.worst],
            "sign": "positive along the nominal's outward normal (excess material)",
            "normals_source": result.normals_source,
            "method": ("exact distance to the template's line segments and circular arcs "
                       "(splines and ellipses flattened within 0.1 um); positive outward for "
                       "closed contours (into holes), to the left of the drawn direction for "
                       "open ones" if result.normals_source == "contour" else
                       "local facets around the nearest nominal points, curvature-corrected "
                       "with the nominal normals"),
            "units": "mm",
        },
        "tolerance": {"lower": result.tolerance.lower, "upper": result.tolerance.upper,
                      "decision_rule": "simple: every point inside the zone"},
        "inputs": [{"role": r.role, "path": r.path, "sha256": r.sha256, "n_points": r.n_points,
                    **({} if r.n_primitives is None else {"n_primitives": r.n_primitives})}
                   for r in inputs],
        "software": {"name": SOFTWARE_NAME, "version": software_version()},
        "timings_s": {k: round(float(v), 6) for k, v in timings_s.items()},
        **_json_safe(result.extra),
    }


def _json_safe(obj):
    """Kind-specific facts (numpy scalars included) as plain JSON types."""
    if isinstance(obj, dict):
        return {str(k): _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        return _num(float(obj))
    return obj


def _num(v: float):
    return float(v) if np.isfinite(v) else None


def result_json(doc: dict) -> str:
    return json.dumps(doc, indent=2, allow_nan=False) + "\n"


def points_csv(result: InspectionResult, measured: np.ndarray,
               labels: np.ndarray | None) -> str:
    """One row per measured point in input order (columns: CSV_COLUMNS)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    reg = result.registered
    d = result.deviations.signed
    inside = result.in_tolerance
    for i in range(measured.shape[0]):
        label = str(labels[i]) if labels is not None else ""
        w.writerow((i, label, *(f"{v:.6f}" for v in measured[i]), *(f"{v:.6f}" for v in reg[i]),
                    f"{d[i]:.6f}", "true" if inside[i] else "false"))
    return buf.getvalue()


def write_atomic(path: str | os.PathLike, data: str | bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder, then rename, so a
    failure never leaves a half-written file under the final name."""
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", dir=folder)
    try:
        os.fchmod(fd, 0o666 & ~_umask())  # as an ordinary new file (mkstemp makes it 0600)
        with os.fdopen(fd, "wb") as f:
            f.write(data.encode("utf-8") if isinstance(data, str) else data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
