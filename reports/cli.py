"""``qa-inspect``: the command line over the engine.

Exit codes (a contract): 0 ACCEPT, 1 REJECT, 2 INCONCLUSIVE, 64 usage error, 65 bad input data,
66 input file not found, 73 an output could not be written, 70 internal error, 130 interrupted.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

EXIT = {"ACCEPT": 0, "REJECT": 1, "INCONCLUSIVE": 2}
EX_USAGE, EX_DATAERR, EX_NOINPUT, EX_SOFTWARE, EX_CANTCREAT = 64, 65, 66, 70, 73


class UsageError(Exception):
    pass


class _Parser(argparse.ArgumentParser):
    """argparse exits with 2 on a usage error; 2 means INCONCLUSIVE here, so raise instead."""

    def error(self, message):
        raise UsageError(f"{self.prog}: {message}")


def _finite_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"'{text}' is not a finite number")
    return v


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="qa-inspect", description="Dimensional inspection of measured points "
                "against a nominal, from any pose (soft registration).")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    i = sub.add_parser("inspect", help="register measured points to a nominal and judge them",
                       description="Register MEASURED to NOMINAL from any pose, measure every "
                       "point's signed deviation (positive = excess material, mm) and judge it "
                       "against the tolerance zone. Exit code 0 ACCEPT, 1 REJECT, 2 INCONCLUSIVE.")
    i.add_argument("nominal", metavar="NOMINAL",
                   help="nominal: points (.csv .txt .xyz .asc .npy, optional I J K normals, "
                        "'# grid: NU x NV' header for a u-v grid), mesh (.stl .ply .obj .vtk "
                        ".vtp), structured grid (.vts), or a 2D contour template: a DXF "
                        "drawing (.dxf) or airfoil ordinates (.dat, with --scale)")
    i.add_argument("measured", metavar="MEASURED", help="measured points (same formats)")
    i.add_argument("--tol", type=_finite_float, metavar="T",
                   help="symmetric tolerance: deviations within ±T mm are in tolerance")
    i.add_argument("--tol-lower", type=_finite_float, metavar="L",
                   help="lower limit of an asymmetric zone, mm (e.g. -0.1)")
    i.add_argument("--tol-upper", type=_finite_float, metavar="U",
                   help="upper limit of an asymmetric zone, mm (e.g. 0.3)")
    i.add_argument("--layer", action="append", metavar="NAME",
                   help="DXF template: take this layer (repeatable; default: every layer)")
    i.add_argument("--units", metavar="U", choices=["mm", "cm", "m", "in"],
                   help="DXF template: its units, overriding the file's $INSUNITS")
    i.add_argument("--scale", type=_finite_float, metavar="CHORD",
                   help="airfoil ordinate template (.dat): chord length in mm")
    i.add_argument("--json", metavar="FILE|-", help="write the JSON results (- for stdout)")
    i.add_argument("--csv", metavar="FILE", help="write one CSV row per measured point")
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.command is None:
            raise UsageError("qa-inspect: a command is required (try 'qa-inspect inspect --help')")
        if args.command == "inspect":
            return _cmd_inspect(args)
        raise UsageError(f"qa-inspect: unknown command {args.command}")
    except UsageError as e:
        print(str(e), file=sys.stderr)
        print("usage: qa-inspect inspect NOMINAL MEASURED --tol T "
              "[--tol-lower L --tol-upper U] [--json FILE|-] [--csv FILE] "
              "[--layer NAME] [--units U] [--scale CHORD]", file=sys.stderr)
        return EX_USAGE
    except KeyboardInterrupt:
        print("qa-inspect: interrupted; no result was written", file=sys.stderr)
        return 130


def _tolerance(args):
    from engine.errors import SettingsError
    from engine.inspection import Tolerance

    asym = args.tol_lower is not None or args.tol_upper is not None
    try:
        if args.tol is not None and asym:
            raise UsageError("qa-inspect inspect: give either --tol or --tol-lower/--tol-upper, "
                             "not both")
        if args.tol is not None:
            return Tolerance.symmetric(args.tol)
        if asym:
            if args.tol_lower is None or args.tol_upper is None:
                raise UsageError("qa-inspect inspect: an asymmetric zone needs both --tol-lower "
                                 "and --tol-upper")
            return Tolerance(args.tol_lower, args.tol_upper)
    except SettingsError as e:
        raise UsageError(f"qa-inspect inspect: {e}") from e
    raise UsageError("qa-inspect inspect: a tolerance is required (--tol T, or --tol-lower L "
                     "--tol-upper U)")


def _cmd_inspect(args) -> int:
    from engine.errors import InputError, InputNotFoundError

    tol = _tolerance(args)
    try:
        return _run_inspect(args, tol)
    except UsageError:
        raise
    except InputNotFoundError as e:
        print(f"qa-inspect: error: {e}", file=sys.stderr)
        return EX_NOINPUT
    except InputError as e:
        print(f"qa-inspect: error: {e}", file=sys.stderr)
        return EX_DATAERR
    except OSError as e:
        print(f"qa-inspect: error: cannot write {e.filename or 'output'}: {e.strerror}",
              file=sys.stderr)
        return EX_CANTCREAT
    except Exception as e:  # a bug: say so, give no result that could be taken for one
        print(f"qa-inspect: internal error ({type(e).__name__}: {e}); no result was written. "
              "Please report this with the input files.", file=sys.stderr)
        if os.environ.get("QA_DEBUG"):
            raise
        return EX_SOFTWARE


def _run_inspect(args, tol) -> int:
    from engine.errors import InputError
    from engine.inspection import inspect, inspect_2d
    from engine.nominal import Nominal

    from .loading import load_point_set, sha256_of
    from .results import (InputRecord, points_csv, result_document, result_json,
                          write_atomic)

    t0 = time.perf_counter()
    is_template = os.path.splitext(args.nominal)[1].lower() in (".dxf", ".dat")
    if is_template:
        from .template2d import read_airfoil_template, read_dxf_template

        if args.nominal.lower().endswith(".dxf"):
            if args.scale is not None:
                raise UsageError("qa-inspect inspect: --scale applies to airfoil ordinate "
                                 "templates (.dat) only")
            tpl = read_dxf_template(args.nominal, layers=args.layer, units=args.units)
        else:
            if args.scale is None:
                raise UsageError("qa-inspect inspect: an airfoil ordinate template needs "
                                 "--scale CHORD (the chord length in mm)")
            if args.layer or args.units:
                raise UsageError("qa-inspect inspect: --layer and --units apply to DXF "
                                 "templates only")
            tpl = read_airfoil_template(args.nominal, args.scale)
        nominal_record = InputRecord("nominal", args.nominal, sha256_of(args.nominal), None,
                                     tpl.template.n_primitives)
    else:
        if args.layer or args.units or args.scale is not None:
            raise UsageError("qa-inspect inspect: --layer, --units and --scale apply to 2D "
                             "templates (.dxf, .dat) only")
        nominal_ps = load_point_set(args.nominal)
        nominal_record = InputRecord("nominal", args.nominal, sha256_of(args.nominal),
                                     nominal_ps.n)
    measured_ps = load_point_set(args.measured)
    if not is_template:
        if measured_ps.dim != 3:
            raise InputError("measured points have 2 columns (x y) but the nominal is a 3D "
                             "surface", measured_ps.path)
        nominal = Nominal.from_point_set(nominal_ps)
    inputs = [nominal_record,
              InputRecord("measured", args.measured, sha256_of(args.measured), measured_ps.n)]
    t1 = time.perf_counter()
    if is_template:
        result = inspect_2d(tpl.template, measured_ps.points, measured_ps.dim, tol)
        result.extra["template"].update(units=tpl.units, unitless=tpl.unitless,
                                        flattened_curves=tpl.flattened,
                                        ignored_entities=tpl.ignored)
    else:
        result = inspect(nominal, measured_ps.points, tol)
    t2 = time.perf_counter()
    timings = {"load": t1 - t0, "register": result.timings_s["register"],
               "deviation": result.timings_s["deviation"], "total": t2 - t0}
    doc = result_document(result, inputs, timings)
    written = []
    if args.csv:
        write_atomic(args.csv, points_csv(result, measured_ps.points, measured_ps.labels))
        written.append(args.csv)
    if args.json and args.json != "-":
        write_atomic(args.json, result_json(doc))
        written.append(args.json)
    if args.json == "-":
        sys.stdout.write(result_json(doc))
    else:
        print(_summary(result, written))
    return EXIT[result.verdict]


def _summary(result, written) -> str:
    st = result.statistics
    reg = result.registration
    tol = result.tolerance
    lines = [
        f"{result.verdict}: {'; '.join(result.reasons)}",
        f"  deviations {st.min:+.4f} … {st.max:+.4f} mm, max |d| {st.max_abs:.4f} mm, "
        f"rms {st.rms:.4f} mm; zone {tol.lower:+.4f} … {tol.upper:+.4f} mm; "
        f"{st.n_out} of {st.count} out of tolerance",
        f"  registration: {'converged' if reg.converged else 'NOT converged'} after "
        f"{reg.iterations} iterations, rms {reg.rms:.4f} mm over {reg.n_inliers} inlier points, "
        f"{reg.hypotheses} pose hypotheses",
    ]
    if result.normals_source == "estimated":
        lines.append("  note: the nominal has no normals; the deviation sign comes from normals "
                     "estimated from its points")
    tpl = result.extra.get("template")
    if tpl:
        lines.append(f"  template: {tpl['contours']} contour(s), {tpl['closed']} closed, "
                     f"{tpl['primitives']} primitives, units {tpl['units']}"
                     + ("; symmetric: equivalent poses give the same deviations"
                        if tpl["symmetric"] else ""))
    flat = result.extra.get("flatness")
    if flat:
        lines.append(f"  measured plane: flatness {flat['peak_to_valley']:.4f} mm peak to "
                     f"valley, {flat['rms']:.4f} mm rms")
    if written:
        lines.append("results: " + ", ".join(os.path.abspath(w) for w in written))
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
