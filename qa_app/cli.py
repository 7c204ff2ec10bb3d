"""``qa-inspect``: the command line over the engine's pipeline and the reports.

Exit codes (a contract): 0 ACCEPT, 1 REJECT, 2 INCONCLUSIVE, 64 usage error, 65 bad input data,
66 input file not found, 69 the Dask scheduler cannot be reached or has no worker (``batch``), 73
an output could not be written, 70 internal error, 130 interrupted. ``batch`` exits 0 when every
part is ACCEPT, else 1 if any is REJECT, else 2 if any is INCONCLUSIVE, else 65 (ERROR parts).

Usage errors (64) include an empty file name, an output that is one of the run's inputs (NOMINAL,
MEASURED, the --sign identity) or another output, an output onto a folder, a socket, a block
device or a key or certificate file (reports.outputs), ``--report -``, ``--csv -`` with
``--json -``, an --inspector who is not the signer, and a signed ACCEPTED certificate without
--part-number and --serial (found after the run; nothing is written). A signing identity that
cannot sign certificates (wrong passphrase, not valid now, key usage without digitalSignature and
nonRepudiation) is bad input (65), found before any work; ``verify`` fails (1) a certificate
signed with one. The output files of one run are written all together or not at all (73 leaves
every target as it was); a character device or pipe (/dev/null, /dev/stdout) is written through,
after the files.
"""

from __future__ import annotations

import argparse
import math
import os
import sys

from engine.errors import QAError

EXIT = {"ACCEPT": 0, "REJECT": 1, "INCONCLUSIVE": 2}
EX_USAGE, EX_DATAERR, EX_NOINPUT, EX_UNAVAILABLE, EX_SOFTWARE, EX_CANTCREAT = 64, 65, 66, 69, 70, 73


class UsageError(QAError, ValueError):
    """The command line was used wrongly (exit code 64, EX_USAGE): a missing or contradictory
    option, not a problem in the files it names. ``command``: the subcommand whose usage is
    shown with the message (None: the one parsed, else all of them)."""

    def __init__(self, message: str, command: str | None = None):
        super().__init__(message)
        self.command = command


class _Parser(argparse.ArgumentParser):
    """argparse exits with 2 on a usage error; 2 means INCONCLUSIVE here, so raise instead."""

    def error(self, message):
        # A subcommand's parser is named "qa-inspect batch": its usage goes with the message.
        raise UsageError(f"{self.prog}: {message}", self.prog.partition(" ")[2] or None)


def _finite_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"'{text}' is not a finite number")
    return v


EXAMPLES = """examples:
  qa-inspect inspect nominal.csv measured.csv --tol 0.25 --json r.json --csv r.csv
  qa-inspect inspect nominal.xyz measured.csv --plan plan.toml --report cert.pdf \\
      --sign inspector.p12 --part-number SB-1020 --serial S-17
  qa-inspect inspect part.stp scan.ply --tol 0.1 --uncertainty 0.012
  qa-inspect inspect frame.dxf points.csv --tol-lower -0.1 --tol-upper 0.3
  qa-inspect batch nominal.csv 'lot-0412/*.csv' --tol 0.15 --out results/lot-0412
  qa-inspect keygen --name "Ann Inspector" --out identity/
  qa-inspect verify cert.pdf --trust ca.pem --nominal nominal.csv --measured measured.csv"""
EXIT_CODES = """exit codes:
  0   ACCEPT: every point inside the tolerance zone (verify: the certificate is valid)
  1   REJECT: a point outside it (verify: the certificate is not valid)
  2   INCONCLUSIVE: the pose cannot be trusted, or the verdict differs at a pose the
      measurement allows, or (guarded rule) a point lies within its uncertainty of a limit,
      or the nominal and the measured points are a units' factor (10, 25.4, 304.8, 1000)
      apart in size (the message says what reads either file right, e.g. --units mm)
  64  usage error: missing or contradictory options, an output that is an input
  65  bad input data (the message names the file, the line and the problem)
  66  an input file does not exist
  70  internal error (no result is written)
  73  an output could not be written (none is)
  69  batch: the Dask scheduler cannot be reached, or has no worker
  130 interrupted
  batch: 0 every part ACCEPT, else 1 any REJECT, else 2 any INCONCLUSIVE, else 65 (ERRORs)"""


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="qa-inspect", description="Dimensional inspection of measured points "
                "against a nominal, from any pose (soft registration).",
                epilog=EXAMPLES + "\n\n" + EXIT_CODES,
                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="store_true", help="print the version and exit")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    _add_inspect(sub)
    _add_batch(sub)
    _add_keygen(sub)
    _add_verify(sub)
    return p


NOMINAL_HELP = ("nominal: points (.csv .txt .xyz .asc .npy, optional I J K normals, '# grid: NU x "
                "NV' header for a u-v grid), mesh (.stl .ply .obj .vtk .vtp), structured grid "
                "(.vts), an E57 scan (.e57: every scan in the file's frame), a STEP model (.stp "
                ".step: deviations exact to its faces), or a 2D "
                "contour template: a DXF drawing (.dxf) or airfoil ordinates (.dat, with "
                "--scale)")


def _add_inspect(sub: argparse._SubParsersAction) -> None:
    """``qa-inspect inspect NOMINAL MEASURED``: the inputs, the tolerance zone (mm), the
    template options, the fit and decision rule, the JSON and CSV outputs, and the certificate."""
    i = sub.add_parser("inspect", help="register measured points to a nominal and judge them",
                       description="Register MEASURED to NOMINAL from any pose, measure every "
                       "point's signed deviation (positive = excess material, mm) and judge it "
                       "against the tolerance zone. Exit code 0 ACCEPT, 1 REJECT, 2 INCONCLUSIVE.",
                       epilog=EXAMPLES + "\n\n" + EXIT_CODES,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    i.add_argument("nominal", metavar="NOMINAL",
                   help=NOMINAL_HELP)
    i.add_argument("measured", metavar="MEASURED", help="measured points (same formats)")
    _add_zone_options(i)
    _add_template_options(i)
    _add_fit_options(i)
    _add_scene_options(i)
    i.add_argument("--json", metavar="FILE|-", help="write the JSON results (- for stdout)")
    i.add_argument("--csv", metavar="FILE|-",
                   help="write one CSV row per measured point (- for stdout)")
    i.add_argument("--quiet", action="store_true",
                   help="no progress line on the terminal (drawn when a run lasts over 2 s)")
    _add_certificate_options(i)


def _add_zone_options(i: argparse.ArgumentParser) -> None:
    """The tolerance zone (mm) or the inspection plan, of ``inspect`` and ``batch``."""
    i.add_argument("--tol", type=_finite_float, metavar="T",
                   help="symmetric tolerance: deviations within ±T mm are in tolerance")
    i.add_argument("--tol-lower", type=_finite_float, metavar="L",
                   help="lower limit of an asymmetric zone, mm (e.g. -0.1)")
    i.add_argument("--tol-upper", type=_finite_float, metavar="U",
                   help="upper limit of an asymmetric zone, mm (e.g. 0.3)")
    i.add_argument("--plan", metavar="PLAN.toml",
                   help="inspection plan: regions, datums, alignment and characteristics "
                        "(profile, flatness, position, size); with it --tol is optional and "
                        "adds a profile over all points")


def _add_template_options(i: argparse.ArgumentParser) -> None:
    """How a 2D template file is read (engine.io.templates), of ``inspect`` and ``batch``."""
    i.add_argument("--layer", action="append", metavar="NAME",
                   help="DXF template: take this layer (repeatable; default: every layer)")
    i.add_argument("--units", metavar="U", choices=["mm", "cm", "m", "in"],
                   help="DXF template: its units, overriding the file's $INSUNITS")
    i.add_argument("--scale", type=_finite_float, metavar="CHORD",
                   help="airfoil ordinate template (.dat): chord length in mm")


def _template_options(args) -> dict:
    """The template options as InspectionSettings fields (checked against the nominal by
    engine.pipeline.check_settings when it is read)."""
    return {"layers": None if args.layer is None else tuple(args.layer), "units": args.units,
            "scale": args.scale}


def _add_fit_options(i: argparse.ArgumentParser) -> None:
    """The fit and the decision rule, of ``inspect`` and ``batch``."""
    i.add_argument("--fit", choices=["lsq", "minimax"], default="lsq",
                   help="lsq: least-squares best fit (default); minimax: the pose minimising the "
                        "largest excursion from the zone's centre ('can the part be placed "
                        "inside its zone?')")
    i.add_argument("--decision-rule", choices=["simple", "guarded"], default=None,
                   help="simple: every point inside the zone (the default without an "
                        "instrument); guarded (ISO 14253-1, the default with --uncertainty or a "
                        "plan's [measurement] instrument): accept inside the zone shrunk by each "
                        "point's expanded uncertainty U, reject outside the zone grown by it, "
                        "INCONCLUSIVE between")
    i.add_argument("--uncertainty", type=_finite_float, metavar="U",
                   help="the instrument's expanded measurement uncertainty, mm (k = 2); "
                        "combined per point with the registration's pose uncertainty and the "
                        "nominal-sampling margin (replaces a plan's [measurement] instrument)")


def _add_scene_options(i: argparse.ArgumentParser) -> None:
    """The measured scene's crop and plane removal (engine.scene), of ``inspect`` and
    ``batch``."""
    g = i.add_argument_group("measured scene (a scan holding more than the part)")
    g.add_argument("--crop", type=_finite_float, nargs=6,
                   metavar=("XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX"),
                   help="inspect only the measured points inside this box (mm, the measured "
                        "file's coordinates)")
    g.add_argument("--remove-plane", action="store_true",
                   help="remove the dominant plane (the table under the part) from the measured "
                        "points, after the crop (seeded RANSAC; the distance from the data: 3 "
                        "robust standard deviations of the plane's points, at least their "
                        "spacing)")
    g.add_argument("--remove-plane-distance", type=_finite_float, metavar="MM",
                   help="with --remove-plane: remove the points within MM of the plane")


def _scene_options(args, command: str) -> dict:
    """The scene options as InspectionSettings fields, checked (usage errors, before any
    file is read)."""
    from engine.errors import SettingsError
    from engine.scene import check_box, check_plane_distance

    distance = args.remove_plane_distance
    try:
        crop = None if args.crop is None else check_box(args.crop)
        check_plane_distance(distance)
    except SettingsError as e:
        raise UsageError(f"qa-inspect {command}: {_option_words(e)}") from e
    if distance is not None and not args.remove_plane:
        raise UsageError(f"qa-inspect {command}: --remove-plane-distance applies with "
                         "--remove-plane")
    return {"crop": crop, "remove_plane": bool(args.remove_plane), "plane_distance": distance}


def _option_words(e: Exception) -> str:
    """A scene setting's error in the command line's words."""
    return (str(e).replace("the crop box", "--crop")
            .replace("the plane removal distance", "--remove-plane-distance"))


def _add_certificate_options(i: argparse.ArgumentParser) -> None:
    """The ``certificate`` group of ``inspect``: the PDF, its signing identity and the fields
    printed on it."""
    c = i.add_argument_group("certificate")
    c.add_argument("--report", metavar="FILE.pdf",
                   help="write the inspection certificate (PDF; an UNSIGNED DRAFT without "
                        "--sign)")
    c.add_argument("--sign", metavar="IDENTITY.p12",
                   help="sign the certificate with this PKCS#12 identity (PAdES)")
    c.add_argument("--sign-pass-env", metavar="VAR",
                   help="read the PKCS#12 passphrase from environment variable VAR (default: "
                        "ask without echo)")
    _add_part_fields(c, PART_FIELDS)
    _add_traceability_options(c)


PART_FIELDS = (("part-number", "part number"), ("part-name", "part name"),
               ("revision", "drawing/part revision"), ("serial", "serial number"),
               ("order", "order or job number"),
               ("inspector", "inspector's name (signed: the signer's, which is the default)"),
               ("organisation", "inspecting organisation"),
               ("device", "measuring device (CMM, scanner)"),
               ("notes", "free text printed on the certificate"))
"""The certificate's fields the inspector states (``--part-number TEXT``, ...)."""


def _add_part_fields(group, fields) -> None:
    for name, text in fields:
        group.add_argument(f"--{name}", metavar="TEXT", help=text)


def _add_batch(sub: argparse._SubParsersAction) -> None:
    """``qa-inspect batch NOMINAL MEASURED...``: the parts, the zone or plan, the output folder,
    the certificates, and the Dask cluster."""
    b = sub.add_parser("batch", help="inspect many parts against one nominal (on Dask)",
                       description="Inspect every MEASURED part against NOMINAL on a local Dask "
                       "cluster (or an existing one, --scheduler) and write DIR/parts/SERIAL."
                       "json/.csv (and .pdf with --report), DIR/summary.csv and "
                       "DIR/summary.json. A part that fails is an ERROR row. Re-running skips "
                       "the parts already done for the same inputs and settings. Exit code 0 "
                       "all ACCEPT, else 1 any REJECT, else 2 any INCONCLUSIVE, else 65.")
    b.add_argument("nominal", metavar="NOMINAL", help=NOMINAL_HELP)
    b.add_argument("measured", metavar="MEASURED", nargs="+",
                   help="measured files or quoted globs ('lot7/*.csv'), one part each, in "
                        "measurement order (a glob's matches sorted by name); a part's serial "
                        "is its file's stem")
    _add_zone_options(b)
    _add_template_options(b)
    b.add_argument("--out", required=True, metavar="DIR", help="output folder")
    _add_fit_options(b)
    _add_scene_options(b)
    c = b.add_argument_group("certificates")
    c.add_argument("--report", action="store_true",
                   help="write each part's certificate DIR/parts/SERIAL.pdf (an UNSIGNED DRAFT "
                        "without --sign)")
    c.add_argument("--sign", metavar="IDENTITY.p12",
                   help="sign the certificates with this PKCS#12 identity (in this process: the "
                        "key is never sent to the workers)")
    c.add_argument("--sign-pass-env", metavar="VAR",
                   help="read the PKCS#12 passphrase from environment variable VAR (default: "
                        "ask without echo)")
    _add_part_fields(c, [(name, "part number (also the title of the lot's spc.pdf, with or "
                          "without --report)" if name == "part-number" else text)
                         for name, text in PART_FIELDS if name != "serial"])
    _add_traceability_options(c)
    d = b.add_argument_group("cluster")
    d.add_argument("--scheduler", metavar="ADDRESS",
                   help="the Dask scheduler of an existing cluster (tcp://HOST:PORT); its "
                        "workers must read the files at the same paths")
    d.add_argument("--workers", type=int, metavar="N",
                   help="worker processes of the local cluster (default: the cores)")
    d.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_traceability_options(c) -> None:
    """The certificate's traceability fields (also the plan's [measurement] and [part] keys,
    which fill in what is not given here)."""
    for name, text in (("device-serial", "the measuring device's serial number"),
                       ("probe", "probe and stylus (e.g. 'TP20, M2 ruby 2 x 20 mm')"),
                       ("program", "measurement program (name or file)"),
                       ("drawing", "drawing number (its revision: --revision)"),
                       ("cad-revision", "revision of the CAD model (the nominal)")):
        c.add_argument(f"--{name}", metavar="TEXT", help=text)
    c.add_argument("--calibration-date", metavar="YYYY-MM-DD", type=_iso_date,
                   help="the measuring device's last calibration")
    c.add_argument("--temperature", metavar="C", type=_finite_float, dest="temperature_c",
                   help="the part's temperature during the measurement, °C")


def _iso_date(text: str) -> str:
    import datetime as dt

    try:
        return dt.date.fromisoformat(text.strip()).isoformat()
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a date YYYY-MM-DD") from None


def _add_keygen(sub: argparse._SubParsersAction) -> None:
    """``qa-inspect keygen``: a demonstration CA and inspector identity."""
    k = sub.add_parser("keygen", help="make a DEMONSTRATION CA and inspector signing identity",
                       description="Write DIR/ca.pem (the trust anchor to give verifiers) and "
                       "DIR/inspector.p12 (the inspector's key and certificate, passphrase-"
                       "protected). For trials and demonstrations only: real users sign with "
                       "the PKCS#12 identity their organisation issues.")
    k.add_argument("--name", required=True, help="the inspector's name")
    k.add_argument("--organisation", default="", help="the organisation's name")
    k.add_argument("--out", required=True, metavar="DIR", help="folder to write into")
    k.add_argument("--pass-env", metavar="VAR",
                   help="read the passphrase from environment variable VAR (default: ask "
                        "twice without echo)")


def _add_verify(sub: argparse._SubParsersAction) -> None:
    """``qa-inspect verify CERTIFICATE.pdf``: the certificate, the trusted CAs and the files to
    re-run it on."""
    v = sub.add_parser("verify", help="verify a signed certificate",
                       description="Exit 0 only if every signature is intact, the signer "
                       "chains to a trusted CA and nothing was changed after signing (and, "
                       "with --nominal/--measured (and --plan), the files match the "
                       "certificate and the inspection re-run gives the same verdict); 1 "
                       "otherwise.")
    v.add_argument("certificate", metavar="CERTIFICATE.pdf")
    v.add_argument("--trust", required=True, action="append", metavar="CA.pem",
                   help="trusted CA certificate(s), PEM or DER (repeatable); nothing else is "
                        "trusted")
    v.add_argument("--nominal", metavar="FILE", help="the nominal file, to check and re-run")
    v.add_argument("--measured", metavar="FILE", help="the measured file, to check and re-run")
    v.add_argument("--plan", metavar="PLAN.toml",
                   help="the inspection plan, to check and re-run (required with --nominal/"
                        "--measured when the certificate was made with one)")


USAGES = {
    "inspect": """qa-inspect inspect NOMINAL MEASURED --tol T [--tol-lower L --tol-upper U]
                  [--plan PLAN.toml] [--json FILE|-] [--csv FILE|-] [--quiet]
                  [--layer NAME] [--units U] [--scale CHORD]
                  [--crop XMIN YMIN ZMIN XMAX YMAX ZMAX]
                  [--remove-plane [--remove-plane-distance MM]]
                  [--report FILE.pdf [--sign ID.p12 [--sign-pass-env VAR]] [--part-number …]]""",
    "batch": """qa-inspect batch NOMINAL MEASURED... (--tol T | --tol-lower L --tol-upper U |
                  --plan PLAN.toml) --out DIR [--layer NAME] [--units U] [--scale CHORD]
                  [--fit …] [--decision-rule …] [--crop …]
                  [--remove-plane [--remove-plane-distance MM]]
                  [--report [--sign ID.p12 --sign-pass-env VAR] [--part-number …]]
                  [--scheduler ADDRESS] [--workers N] [--quiet]""",
    "keygen": "qa-inspect keygen --name NAME [--organisation ORG] --out DIR [--pass-env VAR]",
    "verify": """qa-inspect verify CERTIFICATE.pdf --trust CA.pem [--nominal FILE --measured FILE
                  [--plan FILE]]""",
}
"""Each subcommand's usage, shown with its usage errors (continuation lines aligned for the
"usage: " before them)."""
USAGE = "usage: " + "\n       ".join([*USAGES.values(), "qa-inspect --version"])
"""Every subcommand's usage: shown when no subcommand was named, or a wrong one."""


def usage(command: str | None) -> str:
    """The usage shown with a usage error of ``command`` (None or unknown: all of them)."""
    return "usage: " + USAGES[command] if command in USAGES else USAGE


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = None
    try:
        args = parser.parse_args(argv)
        if args.version:
            print(f"qa-inspect {_version()}")
            return 0
        if args.command is None:
            raise UsageError("qa-inspect: a command is required (try 'qa-inspect inspect --help')")
        command = {"inspect": _cmd_inspect, "batch": _cmd_batch, "keygen": _cmd_keygen,
                   "verify": _cmd_verify}
        return _guarded(command[args.command], args)
    except UsageError as e:
        from reports.messages import printable

        print(printable(str(e)), file=sys.stderr)  # it may quote a file name or a certificate
        print(usage(e.command or getattr(args, "command", None)), file=sys.stderr)
        return EX_USAGE
    except KeyboardInterrupt:
        print("qa-inspect: interrupted; no result was written", file=sys.stderr)
        return 130


def _version() -> str:
    # Not reports.results.software_version: that imports the engine, a second for --version.
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("qa-inspect")
    except PackageNotFoundError:  # running from a source tree that was not installed
        return "0+unknown"


def _no_empty_paths(command: str, paths: dict[str, str | None]) -> None:
    """An empty file name is a usage error (not 'no such file', nor a file named '')."""
    for name, path in paths.items():
        for p in path if isinstance(path, list) else [path]:
            if p is not None and not p.strip():
                raise UsageError(f"qa-inspect {command}: {name} needs a file name (got an "
                                 "empty one)")


def _tolerance(args, command: str = "inspect"):
    from engine.errors import SettingsError
    from engine.inspection import Tolerance

    asym = args.tol_lower is not None or args.tol_upper is not None
    try:
        if args.tol is not None and asym:
            raise UsageError(f"qa-inspect {command}: give either --tol or --tol-lower/"
                             "--tol-upper, not both")
        if args.tol is not None:
            return Tolerance.symmetric(args.tol)
        if asym:
            if args.tol_lower is None or args.tol_upper is None:
                raise UsageError(f"qa-inspect {command}: an asymmetric zone needs both "
                                 "--tol-lower and --tol-upper")
            return Tolerance(args.tol_lower, args.tol_upper)
    except SettingsError as e:
        raise UsageError(f"qa-inspect {command}: {e}") from e
    if args.plan is not None:
        return None  # the plan's characteristics are the requirement
    raise UsageError(f"qa-inspect {command}: a tolerance is required (--tol T, or --tol-lower "
                     "L --tol-upper U, or an inspection plan --plan PLAN.toml)")


def _instrument(args, command: str):
    """The instrument the command line states (``--uncertainty``), or None."""
    if args.uncertainty is None:
        return None
    from engine.uncertainty import Instrument

    if not args.uncertainty > 0:
        raise UsageError(f"qa-inspect {command}: --uncertainty must be positive (an expanded "
                         f"uncertainty, mm), got {args.uncertainty:g}")
    return Instrument(uncertainty_mm=args.uncertainty)


def _guarded(command, args) -> int:
    """Run a command; user mistakes become one-line messages and exit codes, never tracebacks."""
    from engine.errors import InputError, InputNotFoundError
    from reports.messages import user_message
    from reports.signing import OutputExistsError

    try:
        return command(args)
    except (UsageError, KeyboardInterrupt):
        raise
    except Exception as e:
        print(f"qa-inspect: error: {user_message(e)}", file=sys.stderr)
        if isinstance(e, InputNotFoundError):
            return EX_NOINPUT
        if isinstance(e, InputError):
            return EX_DATAERR
        if isinstance(e, (OutputExistsError, OSError)):
            return EX_CANTCREAT
        if os.environ.get("QA_DEBUG"):  # a bug: say so, give no result that could be taken
            raise
        return EX_SOFTWARE


def _cmd_inspect(args) -> int:
    from engine.io import is_template
    from reports.outputs import OutputConflictError, check_outputs

    _no_empty_paths("inspect", {"NOMINAL": args.nominal, "MEASURED": args.measured,
                                "--report": args.report, "--csv": args.csv, "--json": args.json,
                                "--sign": args.sign, "--plan": args.plan})
    tol = _tolerance(args)  # usage errors first, before any process is started
    _scene_options(args, "inspect")
    if args.sign and not args.report:
        raise UsageError("qa-inspect inspect: --sign needs --report FILE.pdf")
    if args.report == "-":
        raise UsageError("qa-inspect inspect: --report needs a file name (a PDF is not written "
                         "to standard output)")
    if args.csv == "-" and args.json == "-":
        raise UsageError("qa-inspect inspect: --csv - and --json - both ask for standard "
                         "output; give one of them a file name")
    try:
        check_outputs({"--report": args.report, "--csv": None if args.csv == "-" else args.csv,
                       "--json": None if args.json == "-" else args.json},
                      {"NOMINAL": args.nominal, "MEASURED": args.measured,
                       "--sign identity": args.sign, "--plan": args.plan})
    except OutputConflictError as e:
        raise UsageError(f"qa-inspect inspect: {e}") from e
    renderer = None
    if args.report and not is_template(args.nominal):
        from reports.figures import RenderProcess

        renderer = RenderProcess()  # pyvista/OpenGL start-up overlaps all the work below
    try:
        return _run_inspect(args, tol, renderer)
    finally:
        if renderer is not None:
            renderer.close()


def _cmd_batch(args) -> int:
    from engine.errors import SettingsError
    from engine.pipeline import inspection_settings, load_nominal
    from qa_app import batch as qb

    _no_empty_paths("batch", {"NOMINAL": args.nominal, "MEASURED": args.measured,
                              "--out": args.out, "--sign": args.sign, "--plan": args.plan})
    tol = _tolerance(args, "batch")
    _scene_options(args, "batch")
    if args.sign and not args.report:
        raise UsageError("qa-inspect batch: --sign needs --report")
    if args.workers is not None and (args.scheduler or args.workers < 1):
        raise UsageError("qa-inspect batch: --workers N (N >= 1) sets the local cluster's "
                         "workers; an existing cluster (--scheduler) has its own")
    try:
        parts = qb.find_parts(args.measured)
        info, identity = _certificate_identity(args, "batch")
        job = qb.Batch(parts, args.out, info, identity, args.part_number)
        qb.check_batch_outputs(job, [args.nominal, args.plan, args.sign]
                               + [p.path for p in parts])
        # Absolute paths: the workers may run elsewhere (the same files at the same paths).
        settings = inspection_settings(tol, args.plan and os.path.abspath(args.plan),
                                       **_template_options(args),
                                       fit=args.fit, decision_rule=args.decision_rule,
                                       instrument=_instrument(args, "batch"),
                                       **_scene_options(args, "batch"))
        loaded = load_nominal(os.path.abspath(args.nominal), settings)  # once, before the cluster
        qb.check_certifiable(job, loaded)
    except SettingsError as e:
        raise UsageError(f"qa-inspect batch: {e}") from e
    return _run_batch(args, job, loaded)


def _run_batch(args, job, loaded) -> int:
    import time

    from qa_app import batch as qb
    from reports.messages import printable

    bar = None if args.quiet or not sys.stderr.isatty() else qb.ProgressBar(len(job.parts))
    t0 = time.monotonic()
    try:
        # The cluster is started (or reached) only if some part is left to inspect.
        rows = qb.run_batch(job, loaded, on_row=bar and bar.update,
                            connect=lambda: qb.dask_client(args.scheduler, args.workers))
    except KeyboardInterrupt:
        if bar is not None:
            bar.close()
        print(printable(f"qa-inspect batch: interrupted; each part in "
                        f"{os.path.join(job.out, 'parts')} is complete, the others were not "
                        "written; run the same command again to resume"), file=sys.stderr)
        return 130
    except ConnectionError as e:
        print(f"qa-inspect: error: {printable(e)}", file=sys.stderr)
        return EX_UNAVAILABLE
    if bar is not None:
        bar.close()
    written = qb.write_summary(job, loaded, rows)
    print(qb.summary_text(rows, time.monotonic() - t0, written))
    return qb.exit_code([r["verdict"] for r in rows])


def _cmd_keygen(args) -> int:
    from reports.signing import make_demo_identity

    if not args.name.strip():
        raise UsageError("qa-inspect keygen: --name must not be empty")
    _no_empty_paths("keygen", {"--out": args.out})
    passphrase = _passphrase(args.pass_env, "Passphrase for the new inspector.p12: ",
                             confirm=True)
    if not passphrase:
        raise UsageError("qa-inspect keygen: the passphrase must not be empty")
    ca, p12 = make_demo_identity(args.name, args.organisation, args.out, passphrase)
    print(f"DEMONSTRATION identity for {args.name}"
          f"{' (' + args.organisation + ')' if args.organisation else ''}, not for production:"
          f"\n  trust anchor (give to verifiers): {os.path.abspath(ca)}"
          f"\n  signing identity (keep private):  {os.path.abspath(p12)}")
    return 0


def _cmd_verify(args) -> int:
    """``verify``: reports.verify's outcome, printed; exit 0 when the certificate is valid."""
    from reports.messages import printable
    from reports.verify import RerunFilesError, outcome_lines, verify_certificate

    _no_empty_paths("verify", {"CERTIFICATE": args.certificate, "--trust": args.trust,
                               "--nominal": args.nominal, "--measured": args.measured,
                               "--plan": args.plan})
    try:
        v = verify_certificate(args.certificate, args.trust, args.nominal, args.measured,
                               args.plan)
    except RerunFilesError as e:
        raise UsageError(f"qa-inspect verify: {e}") from e
    # The signer's name and the certificate's reasons come from the file being verified.
    print("\n".join(printable(line) for line in outcome_lines(v)))
    return 0 if v.valid else 1


def _certificate_identity(args, command: str):
    """(CertificateInfo or None without --report, the signing Identity or None without
    --sign), the identity loaded and checked against --inspector before any work."""
    import dataclasses

    info = identity = None
    if args.report:
        from reports.certificate import CertificateInfo

        info = CertificateInfo(**{f.name: getattr(args, f.name, None)
                                  for f in dataclasses.fields(CertificateInfo)})
    if args.sign:
        from reports.certificate import CertificationError, check_inspector
        from reports.signing import load_identity

        # The key first: a wrong passphrase or an unsuitable key must not cost an inspection.
        identity = load_identity(args.sign, _passphrase(args.sign_pass_env, "PKCS#12 passphrase "
                                                       f"for {args.sign}: ", confirm=False))
        try:
            check_inspector(info, identity)
        except CertificationError as e:
            raise UsageError(f"qa-inspect {command}: {e}") from e
    elif args.sign_pass_env:
        raise UsageError(f"qa-inspect {command}: --sign-pass-env applies with --sign only")
    return info, identity


def _run_inspect(args, tol, renderer) -> int:
    from engine.errors import SettingsError
    from engine.pipeline import inspection_settings, run_files
    from reports.outputs import Output, OutputConflictError, write_all
    from reports.results import points_csv, result_json, run_document

    info, identity = _certificate_identity(args, "inspect")
    try:
        # A plan alone (no --tol): its zone for the per-point statistics, outside the verdict.
        settings = inspection_settings(tol, args.plan, **_template_options(args),
                                       fit=args.fit, decision_rule=args.decision_rule,
                                       instrument=_instrument(args, "inspect"),
                                       **_scene_options(args, "inspect"))
        run = _with_progress(args, lambda progress: run_files(args.nominal, args.measured,
                                                              settings, progress))
    except SettingsError as e:
        raise UsageError(f"qa-inspect inspect: {e}") from e
    result = run.result
    outputs = []
    if args.report:
        from reports.certificate import (CertificationError, certified_info, make_certificate,
                                         plan_info)

        try:  # the plan's [part] stands where --part-number/--part-name/--revision do not
            info = certified_info(plan_info(info, run), identity, result.verdict)
        except CertificationError as e:
            raise UsageError(f"qa-inspect inspect: {e}") from e
        outputs.append(Output(args.report, make_certificate(run, info, identity,
                                                            renderer=renderer)))
    stdout = None  # "-": the one output written to standard output
    if args.csv:
        csv_text = points_csv(result, run.measured.points, run.measured.labels)
        if args.csv == "-":
            stdout = csv_text
        else:
            outputs.append(Output(args.csv, csv_text))
    if args.json:
        if args.json == "-":
            stdout = result_json(run_document(run))
        else:
            outputs.append(Output(args.json, result_json(run_document(run))))
    try:
        write_all(outputs)  # every file or none; stdout only after they all succeeded
    except OutputConflictError as e:  # the target changed into a folder, key... during the run
        raise UsageError(f"qa-inspect inspect: {e}") from e
    written = [o.path for o in outputs]
    from reports.messages import printable

    for w in run.warnings:  # they quote file names
        print(f"qa-inspect: warning: {printable(w)}", file=sys.stderr)
    if stdout is not None:
        sys.stdout.write(stdout)
    else:
        print(_summary(result, written, run.selection))
    return EXIT[result.verdict]


def _with_progress(args, run):
    """run(progress listener or None), with a progress line on standard error when it is a
    terminal (qa_app.progress; not with --quiet), erased before anything else is printed."""
    if args.quiet or not sys.stderr.isatty():
        return run(None)
    from qa_app.progress import StageLine

    line = StageLine(sys.stderr)
    try:
        return run(line)
    finally:
        line.close()


def _passphrase(env_var: str | None, prompt: str, confirm: bool) -> bytes:
    """The passphrase from the environment variable ``env_var``, else asked without echo."""
    import getpass

    if env_var:
        value = os.environ.get(env_var)
        if value is None:
            raise UsageError(f"qa-inspect: the environment variable {env_var} is not set")
        return value.encode("utf-8")
    if not sys.stdin.isatty():
        raise UsageError("qa-inspect: no terminal to ask for the passphrase; give it in an "
                         "environment variable with --pass-env/--sign-pass-env VAR")
    value = getpass.getpass(prompt)
    if confirm and getpass.getpass("Repeat the passphrase: ") != value:
        raise UsageError("qa-inspect: the two passphrases differ")
    return value.encode("utf-8")


def _plan_summary(plan) -> list[str]:
    """The plan's alignment and one line per characteristic: id, type, region, datums, value
    against its zone, verdict."""
    from reports.messages import alignment_text, limits_text

    lines = []
    if plan.alignment is not None:
        lines.append(f"  alignment: {alignment_text(plan)}")
    for r in plan.characteristics:
        c = r.characteristic
        ref = f" |{'|'.join(c.datums)}" if c.datums else ""
        value = "—" if r.value is None else f"{r.value:.4f} mm"
        lines.append(f"  [{c.id}] {c.type} {c.region}{ref}: {value}, {limits_text(c)}, "
                     f"{r.indices.size} points: {r.verdict}")
    return lines


def _selection_line(sel) -> str:
    """The measured points a crop and plane removal kept, in words."""
    parts = [f"{sel.n_read:,} read"]
    if sel.box is not None:
        parts.append(f"{sel.n_outside_box:,} outside the crop box")
    if sel.plane is not None:
        parts.append(f"{sel.n_on_plane:,} on the dominant plane (within "
                     f"{sel.plane.distance:.3g} mm)")
    return f"  measured points: {', '.join(parts)}; {sel.n_kept:,} inspected"


def _summary(result, written, selection=None) -> str:
    st = result.statistics
    reg = result.registration
    tol = result.tolerance
    lines = [
        f"{result.verdict}: {'; '.join(result.reasons)}",
        f"  deviations {st.min:+.4f} … {st.max:+.4f} mm, max |d| {st.max_abs:.4f} mm, "
        f"rms {st.rms:.4f} mm; zone {tol.lower:+.4f} … {tol.upper:+.4f} mm; "
        f"{st.n_out} of {st.count} out of tolerance"
        + ("" if result.plan is None or result.plan.zone_in_verdict else
           " (the zone of the plan's widest profile, for these statistics only: the verdict "
           "is the characteristics')"),
        f"  registration: {'converged' if reg.converged else 'NOT converged'} after "
        f"{reg.iterations} iterations, rms {reg.rms:.4f} mm over {reg.n_inliers} fitted points, "
        f"{reg.hypotheses} pose hypotheses",
    ]
    if selection is not None:
        lines.append(_selection_line(selection))
    if result.normals_source == "estimated":
        lines.append("  note: the nominal has no normals; the deviation sign comes from normals "
                     "estimated from its points")
    tpl = result.extra.get("template")
    if tpl:
        lines.append(f"  template: {tpl['contours']} contour(s), {tpl['closed']} closed, "
                     f"{tpl['primitives']} primitives, units {tpl['units']}"
                     + ("; symmetric: equivalent poses give the same deviations"
                        if tpl["symmetric"] else ""))
    if result.plan is not None:
        lines += _plan_summary(result.plan)
    flat = result.extra.get("flatness")
    if flat:
        lines.append(f"  measured plane: flatness {flat['peak_to_valley']:.4f} mm peak to "
                     f"valley, {flat['rms']:.4f} mm rms")
    if written:
        lines.append("results: " + ", ".join(os.path.abspath(w) for w in written))
    from reports.messages import printable

    # Each line escaped before they are joined: a reason may quote a file name or a label.
    return "\n".join(printable(line) for line in lines)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
