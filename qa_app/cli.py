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
import os
import sys

from engine.choices import Verdict
from qa_app.arguments import add_commands
from qa_app.summary import summary_text
from qa_app.usage import EXAMPLES, EXIT_CODES, UsageError, usage

EXIT = {Verdict.ACCEPT: 0, Verdict.REJECT: 1, Verdict.INCONCLUSIVE: 2}
EX_USAGE, EX_DATAERR, EX_NOINPUT, EX_UNAVAILABLE, EX_SOFTWARE, EX_CANTCREAT = 64, 65, 66, 69, 70, 73


class _Parser(argparse.ArgumentParser):
    """argparse exits with 2 on a usage error; 2 means INCONCLUSIVE here, so raise instead."""

    def error(self, message):
        # A subcommand's parser is named "qa-inspect batch": its usage goes with the message.
        raise UsageError(f"{self.prog}: {message}", self.prog.partition(" ")[2] or None)


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="qa-inspect", description="Dimensional inspection of measured points "
                "against a nominal, from any pose (soft registration).",
                epilog=EXAMPLES + "\n\n" + EXIT_CODES,
                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="store_true", help="print the version and exit")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    add_commands(sub)
    return p


def _template_options(args) -> dict:
    """The template options as InspectionSettings fields (checked against the nominal by
    engine.pipeline.check_settings when it is read)."""
    return {"layers": None if args.layer is None else tuple(args.layer), "units": args.units,
            "scale": args.scale}


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
                   "verify": _cmd_verify, "faces": _cmd_faces, "plan": _cmd_plan}
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


def _checked(check, command: str = "inspect"):
    """check()'s value; its SettingsError a usage error of ``command``."""
    from engine.errors import SettingsError

    try:
        return check()
    except SettingsError as e:
        raise UsageError(f"qa-inspect {command}: {e}") from e


def _cmd_inspect(args) -> int:
    from engine.io import is_template
    from qa_app.sections import check_section_options
    from reports.outputs import OutputConflictError, check_outputs

    _no_empty_paths("inspect", {"NOMINAL": args.nominal, "MEASURED": args.measured,
                                "--report": args.report, "--csv": args.csv, "--json": args.json,
                                "--qif": args.qif, "--sign": args.sign, "--plan": args.plan})
    tol = _tolerance(args)  # usage errors first, before any process is started
    _scene_options(args, "inspect")
    _checked(lambda: check_section_options(args.section, args.section_band, args.nominal))
    if args.sign and not args.report:
        raise UsageError("qa-inspect inspect: --sign needs --report FILE.pdf")
    if args.report == "-":
        raise UsageError("qa-inspect inspect: --report needs a file name (a PDF is not written "
                         "to standard output)")
    streamed = [f"--{k} -" for k in ("csv", "json", "qif") if getattr(args, k) == "-"]
    if len(streamed) > 1:
        raise UsageError(f"qa-inspect inspect: {' and '.join(streamed)} "
                         f"{'both' if len(streamed) == 2 else 'all'} ask for standard output; "
                         "give all but one of them a file name")
    try:
        check_outputs({"--report": args.report, "--csv": None if args.csv == "-" else args.csv,
                       "--json": None if args.json == "-" else args.json,
                       "--qif": None if args.qif == "-" else args.qif},
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
    from qa_app import batch as qb, lot

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
        parts = lot.find_parts(args.measured)
        info, identity = _certificate_identity(args, "batch")
        job = lot.Batch(parts, args.out, info, identity, args.part_number)
        lot.check_batch_outputs(job, [args.nominal, args.plan, args.sign]
                               + [p.path for p in parts])
        # Absolute paths: the workers may run elsewhere (the same files at the same paths).
        settings = inspection_settings(tol, args.plan and os.path.abspath(args.plan),
                                       **_template_options(args),
                                       fit=args.fit, decision_rule=args.decision_rule,
                                       instrument=_instrument(args, "batch"), seed=args.seed,
                                       **_scene_options(args, "batch"))
        loaded = load_nominal(os.path.abspath(args.nominal), settings)  # once, before the cluster
        qb.check_certifiable(job, loaded)
    except SettingsError as e:
        raise UsageError(f"qa-inspect batch: {e}") from e
    return _run_batch(args, job, loaded)


def _run_batch(args, job, loaded) -> int:
    import time

    from qa_app import batch as qb, cluster, lot, lot_summary
    from reports.messages import printable

    bar = None if args.quiet or not sys.stderr.isatty() else qb.ProgressBar(len(job.parts))
    t0 = time.monotonic()
    try:
        # The cluster is started (or reached) only if some part is left to inspect.
        rows = qb.run_batch(job, loaded, on_row=bar and bar.update,
                            connect=lambda: cluster.dask_client(args.scheduler, args.workers))
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
    written = lot_summary.write_summary(job, loaded, rows)
    print(lot_summary.summary_text(rows, time.monotonic() - t0, written))
    return lot.exit_code([r["verdict"] for r in rows])


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


def _cmd_faces(args) -> int:
    """``faces PART.stp``: qa_app.model_commands."""
    from qa_app.model_commands import cmd_faces

    _no_empty_paths("faces", {"PART": args.part, "--csv": args.csv})
    return cmd_faces(args)


def _cmd_plan(args) -> int:
    """``plan SOURCE``: qa_app.model_commands."""
    from qa_app.model_commands import cmd_plan

    _no_empty_paths("plan", {"SOURCE": args.source, "--nominal": args.nominal,
                             "--toml": args.toml})
    return cmd_plan(args)


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
    from qa_app.sections import results_document, run_sections, summary_lines
    from reports.results import points_csv, result_json

    info, identity = _certificate_identity(args, "inspect")
    try:
        # A plan alone (no --tol): its zone for the per-point statistics, outside the verdict.
        settings = inspection_settings(tol, args.plan, **_template_options(args),
                                       fit=args.fit, decision_rule=args.decision_rule,
                                       instrument=_instrument(args, "inspect"), seed=args.seed,
                                       **_scene_options(args, "inspect"))
        run = _with_progress(args, lambda progress: run_files(args.nominal, args.measured,
                                                              settings, progress))
    except SettingsError as e:
        raise UsageError(f"qa-inspect inspect: {e}") from e
    result = run.result
    # Before any output: a section that misses the part writes nothing.
    sections = _checked(lambda: run_sections(run, args.section, args.section_band))
    outputs = []
    if args.report:
        from reports.certificate import (CertificationError, certified_info, make_certificate,
                                         plan_info)

        try:  # the plan's [part] stands where --part-number/--part-name/--revision do not
            info = certified_info(plan_info(info, run), identity, result.verdict)
        except CertificationError as e:
            raise UsageError(f"qa-inspect inspect: {e}") from e
        outputs.append(Output(args.report, make_certificate(run, info, identity,
                                                            renderer=renderer,
                                                            sections=sections)))
    stdout = None  # "-": the one output written to standard output
    if args.csv:
        csv_text = points_csv(result, run.measured.points, run.measured.labels)
        if args.csv == "-":
            stdout = csv_text
        else:
            outputs.append(Output(args.csv, csv_text))
    if args.json:
        if args.json == "-":
            stdout = result_json(results_document(run, sections))
        else:
            outputs.append(Output(args.json, result_json(results_document(run, sections))))
    if args.qif:
        from reports.qif import plan_source, qif_results_document

        qif = qif_results_document(results_document(run, sections), result.registered,
                                   result.deviations.signed, result.in_tolerance,
                                   run.measured.labels, result.outlier, plan_source(run))
        if args.qif == "-":
            stdout = qif.decode("utf-8")
        else:
            outputs.append(Output(args.qif, qif))
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
        print("\n".join([summary_text(result, written, run.selection)]
                        + summary_lines(sections)))
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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
