"""The controller: turns the inspector's actions into engine runs and exports, and their outcomes
into changes of the :class:`qa_app.desktop.model.Session`. No Qt here.

Work runs in a worker thread (``synchronous=False``); what it produces is handed back through
``post`` (the window passes a function that queues the call into the GUI thread), so the session
and its views only ever change in the GUI thread. Tests run it with ``synchronous=True``.
Failures become one message in the session, worded as the command line words them.
"""

from __future__ import annotations

import datetime as dt
import json
import os
import threading
from collections.abc import Callable
from dataclasses import replace

from engine.errors import Cancelled, InputError, SettingsError
from engine.settings import InspectionSettings

from .model import Session, engine_rule

SESSION_FORMAT = "qa-inspect session"
SESSION_VERSION = 1
SESSION_SUFFIX = ".qasession"
INPUTS = ("nominal", "measured", "plan")
"""The input files of a session, by role (as the run's InputRecords name them)."""
OPTIONS = ("layers", "units", "scale", "fit", "decision_rule", "crop", "remove_plane",
           "plane_distance")
"""The settings besides the zone and the plan, passed on to the run as they are."""


class Controller:
    def __init__(self, session: Session, synchronous: bool = False,
                 post: Callable[[Callable[[], None]], None] | None = None,
                 prepare: Callable | None = None):
        """prepare : called in the worker with each finished run; what it returns is kept
        as ``session.display`` (the views' heavy preparation, kept off the GUI thread)."""
        self.session = session
        self._prepare = prepare
        self.synchronous = synchronous
        self._post = post or (lambda f: f())
        self._cancel = threading.Event()
        self._thread: threading.Thread | None = None
        self.busy = False
        self.signing_identity: str | None = None
        """The PKCS#12 signing identity last used (path): an input no export may replace."""

    def warm_up(self) -> threading.Thread:
        """Import the engine and load its compiled kernels (:func:`engine.warm_up`) in the
        background while the inspector picks files, so the first inspection does not hold the
        GUI thread with imports."""

        def work():
            import engine

            engine.warm_up()
            import reports.results  # noqa: F401  (the run's document, made after each run)

        t = threading.Thread(target=work, name="qa-inspect warm-up", daemon=True)
        t.start()
        return t

    # ------------------------------------------------------------------ inputs
    def _refuse_while_busy(self) -> bool:
        if self.busy:
            self.session.tell("warning", "an inspection or export is running: wait for it or "
                                         "cancel it before opening other files")
        return self.busy

    def open_nominal(self, path: str) -> None:
        from engine.io.formats import NOMINAL_SUFFIXES

        if self._refuse_while_busy() or not self._check_file(path, NOMINAL_SUFFIXES):
            return
        self.session.set_nominal(os.path.abspath(path))
        self.session.tell("info", f"Nominal: {os.path.basename(path)}")

    def open_measured(self, path: str) -> None:
        if self._refuse_while_busy() or not self._check_file(path):
            return
        self.session.set_measured(os.path.abspath(path))
        self.session.tell("info", f"Measured points: {os.path.basename(path)}")

    def open_plan(self, path: str, on_done: Callable[[], None] | None = None) -> None:
        """Open an inspection plan (TOML): read and checked in the worker; once it is, the
        verdict is its characteristics' and the zone its own (statistics only), as on the
        command line without ``--tol``, and ``on_done`` is called. A plan that cannot be read
        is one error and changes nothing."""
        from engine.io.formats import PLAN_SUFFIXES

        if self._refuse_while_busy() or not self._check_file(path, PLAN_SUFFIXES):
            return
        path = os.path.abspath(path)
        s = self.session

        def job():
            from engine.pipeline import inspection_settings

            return inspection_settings(None, path)

        def done(planned):
            s.set_plan(path)
            s.set_settings(tol_lower=planned.tol_lower, tol_upper=planned.tol_upper,
                           zone_in_verdict=False)
            s.tell("info", f"Plan: {os.path.basename(path)}; the verdict is its "
                           f"characteristics' (zone {planned.tol_lower:+.4g} … "
                           f"{planned.tol_upper:+.4g} mm for the statistics only)")
            if on_done:
                on_done()

        self._start(job, done, lambda: None)

    def clear_plan(self) -> None:
        """Inspect without a plan again: the zone over all points is the verdict."""
        if self._refuse_while_busy() or self.session.plan_path is None:
            return
        self.session.set_plan(None)
        self.session.set_settings(zone_in_verdict=True)
        self.session.tell("info", "No plan: the zone over all points is the verdict")

    def open_files(self, paths: list[str]) -> None:
        """Dropped or command-line files: a template or a STEP model (in any position), else the
        first file, is the nominal when none is set yet, the next one the measured points; a
        session file opens the session, a plan (.toml) the plan."""
        from engine.io import is_template
        from engine.io.formats import PLAN_SUFFIXES, STEP_SUFFIXES

        def nominal_only(p: str) -> bool:
            return is_template(p) or os.path.splitext(p)[1].lower() in STEP_SUFFIXES

        # A file that can only be a nominal (a template, a STEP model) goes first, whatever
        # order the files were dropped in.
        for p in sorted(paths, key=lambda p: not nominal_only(p)):
            if p.endswith(SESSION_SUFFIX):
                self.open_session(p)
            elif os.path.splitext(p)[1].lower() in PLAN_SUFFIXES:
                self.open_plan(p)
            elif self.session.nominal_path is None or nominal_only(p):
                self.open_nominal(p)
            else:
                self.open_measured(p)

    def _check_file(self, path: str, suffixes: tuple[str, ...] | None = None) -> bool:
        """suffixes : the file types accepted (default: measured points, and 3D nominals and
        templates, which the measured slot refuses later with a clearer message)."""
        from engine.io.formats import ALL_SUFFIXES, TEMPLATE_SUFFIXES

        suffixes = suffixes or ALL_SUFFIXES + TEMPLATE_SUFFIXES
        if not os.path.isfile(path):
            self.session.tell("error", f"{path}: no such file")
            return False
        suffix = os.path.splitext(path)[1].lower()
        if suffix not in suffixes:
            self.session.tell("error", f"{path}: unsupported file type '{suffix or '(none)'}'; "
                                       f"supported: {' '.join(suffixes)}")
            return False
        return True

    def set_tolerance(self, lower: float, upper: float) -> bool:
        from engine.tolerance import Tolerance

        try:
            Tolerance(lower, upper)
        except SettingsError as e:
            self.session.tell("error", str(e))
            return False
        self.session.set_settings(tol_lower=float(lower), tol_upper=float(upper))
        return True

    # ------------------------------------------------------------------ inspection
    def inspect(self) -> None:
        """Run the inspection of the session's files with its settings (in the worker). With a
        plan, the run's settings are made as the command line makes them
        (engine.pipeline.inspection_settings): the zone joins the verdict when it is the
        user's, and is the plan's (statistics only) when it is left to the plan."""
        s = self.session
        if not s.can_inspect or self.busy:
            return
        st = s.settings
        plans_zone, plan = s.plans_zone, s.plan_path
        nominal, measured = s.nominal_path, s.measured_path
        s.set_run(None)
        s.set_running(True)

        def job():
            # Imported here, in the worker: the engine's first import holds the interpreter.
            from engine.pipeline import inspection_settings, run_files

            options = {k: getattr(st, k) for k in OPTIONS}
            options["decision_rule"] = engine_rule(options["decision_rule"])
            settings = inspection_settings(None if plans_zone else st.tolerance, plan,
                                           **options)
            run = run_files(nominal, measured, settings, progress=self._progress)
            display = None
            if self._prepare is not None:
                self._progress("preparing the views", 1.0)
                display = self._prepare(run)
            return run, display

        def done(ran):
            run, display = ran
            s.set_running(False)
            s.set_run(run, display)
            res = run.result
            # The trust statements are the banner's details, not this one-line note.
            reasons = [r for r in res.reasons if r not in res.trust_statements]
            s.tell("info", f"{res.verdict}: {'; '.join(reasons)} "
                           f"(max |d| {res.statistics.max_abs:.4f} mm)")
            for w in run.warnings:  # after the note: the message bar keeps what needs attention
                s.tell("warning", w[:1].upper() + w[1:])

        self._start(job, done, lambda: s.set_running(False))

    def cancel(self) -> None:
        self._cancel.set()

    def _progress(self, stage: str, fraction: float) -> None:
        if self._cancel.is_set():
            raise Cancelled()
        self._post(lambda: self.session.progress.emit(stage, fraction))

    # ------------------------------------------------------------------ staleness
    def check_inputs(self) -> bool:
        """Compare the files the result was computed from with the files on disk (SHA-256); any
        difference marks the result stale. Returns True when there is a result and it is
        current."""
        from engine.io import sha256_of

        s = self.session
        if s.run is None:
            return False
        changed = []
        for rec in s.run.inputs:
            try:
                same = sha256_of(rec.path) == rec.sha256
            except InputError:
                changed.append(f"the {rec.role} file {rec.path} can no longer be read")
                continue
            if not same:
                changed.append(f"the {rec.role} file {rec.path} changed on disk since this "
                               "inspection")
        s.set_changed_inputs(changed)
        return not s.stale

    def _refuse_stale(self, what: str) -> bool:
        """True (with a message) when there is no current result to export: an export states
        the result on screen, for the files and settings as they are now."""
        s = self.session
        if s.run is None:
            return True
        if self.busy:
            s.tell("warning", f"an inspection or export is running: wait for it before "
                              f"exporting the {what}")
            return True
        if not self.check_inputs():
            s.tell("warning", f"The result is out of date ({'; '.join(s.stale_reasons)}): "
                              f"press Inspect before exporting the {what}.")
            return True
        return False

    # ------------------------------------------------------------------ exports
    def export_certificate(self, path: str, info, p12: str | None, passphrase: bytes | None,
                           on_done: Callable[[str], None] | None = None) -> None:
        """Write the certificate exactly as ``qa-inspect inspect … --report`` does (signed with
        ``p12`` when given). The passphrase is used here and not kept. Refused while the
        result is stale, onto an input, and (before any rendering, in the command line's words)
        when the inspector named is not the signer or a signed ACCEPTED certificate lacks the
        part number or serial number: a signed certificate names its signer as inspector."""
        if p12:
            self.signing_identity = p12
        if self._refuse_stale("certificate") or self._refuse_output("certificate", path, p12):
            return
        run = self.session.run

        def job():
            from reports.certificate import certified_info, make_certificate
            from reports.figures import RenderProcess
            from reports.outputs import Output, write_all
            from reports.signing import load_identity

            identity = load_identity(p12, passphrase) if p12 else None
            certified = certified_info(info, identity, run.result.verdict)
            self._progress("rendering the deviation maps", 0.2)
            renderer = RenderProcess() if run.template is None else None
            try:
                pdf = make_certificate(run, certified, identity, renderer=renderer)
            finally:
                if renderer is not None:
                    renderer.close()
            self._progress("writing the certificate", 0.95)
            write_all([Output(path, pdf)])
            return path, None if identity is None else identity.common_name

        def done(value):
            p, signer = value
            self.session.set_running(False)
            signed = f"signed by {signer}" if signer is not None else "UNSIGNED DRAFT"
            self.session.tell("info", f"Certificate written ({signed}): {p}")
            if on_done:
                on_done(p)

        self.session.set_running(True)
        self._start(job, done, lambda: self.session.set_running(False))

    def export_csv(self, path: str) -> None:
        from reports.results import points_csv

        run = self.session.run
        if not self._refuse_stale("CSV") and not self._refuse_output("CSV", path):
            self._export(path, lambda: points_csv(run.result, run.measured.points,
                                                  run.measured.labels), "CSV")

    def export_qif(self, path: str) -> None:
        from reports.qif import plan_source, qif_results_document
        from reports.results import run_document

        run = self.session.run
        if self._refuse_stale("QIF") or self._refuse_output("QIF", path):
            return
        res = run.result
        self._export(path, lambda: qif_results_document(
            run_document(run), res.registered, res.deviations.signed, res.in_tolerance,
            run.measured.labels, res.outlier, plan_source(run)), "QIF")

    def _refuse_output(self, what: str, path: str, identity: str | None = None) -> bool:
        """True (with the error) when ``path`` is no file name or names one of the inputs: the
        nominal, the measured points, the inspected files of the result, the signing identity
        (``identity``, else the last one used). An output never replaces an input
        (reports.outputs.check_outputs)."""
        from reports.messages import user_message
        from reports.outputs import OutputConflictError, check_outputs

        s = self.session
        inputs = {"nominal": s.nominal_path, "measured": s.measured_path, "plan": s.plan_path,
                  "signing identity": identity or self.signing_identity}
        for rec in (s.run.inputs if s.run is not None else ()):
            inputs.setdefault(f"inspected {rec.role}", rec.path)  # the run's, should they differ
        try:
            check_outputs({what: path}, inputs)
        except OutputConflictError as e:
            s.tell("error", user_message(e))
            return True
        return False

    def _export(self, path: str, make: Callable, what: str) -> None:
        from reports.outputs import Output, write_all

        def job():
            write_all([Output(path, make())])
            return path

        def done(p):
            self.session.set_running(False)
            self.session.tell("info", f"{what} written: {p}")

        self.session.set_running(True)
        self._start(job, done, lambda: self.session.set_running(False))

    # ------------------------------------------------------------------ verification
    def verify_certificate(self, path: str, trust: list[str], nominal: str | None = None,
                           measured: str | None = None, plan: str | None = None,
                           on_done: Callable | None = None) -> None:
        """Verify the certificate ``path`` as ``qa-inspect verify`` does
        (reports.verify.verify_certificate, in the worker): its signatures against the trust
        anchors ``trust`` only and, given the nominal and measured files (and the plan), their
        SHA-256s and a re-run of its inspection. ``on_done`` gets the
        reports.verify.CertificateVerification; files that do not go together, a trust anchor or
        a file that cannot be read is one error, as on the command line. The session's result
        is not touched."""
        if self.busy:
            self.session.tell("warning", "an inspection or export is running: wait for it "
                                         "before verifying a certificate")
            return
        s = self.session

        def job():
            from reports.verify import verify_certificate

            self._progress("verifying the signatures", 0.05)
            return verify_certificate(path, trust, nominal, measured, plan,
                                      progress=self._progress)

        def done(v):
            s.set_running(False)
            s.tell("info" if v.valid else "warning",
                   f"Certificate {'VALID' if v.valid else 'INVALID'}: {path}")
            if on_done:
                on_done(v)

        s.set_running(True)
        self._start(job, done, lambda: s.set_running(False))

    # ------------------------------------------------------------------ sessions
    def save_session(self, path: str) -> None:
        """Inputs by path with SHA-256, the settings, and the results document (none when the
        result is stale: results are saved only with the settings and files they belong to)."""
        from reports.outputs import Output, write_all

        s = self.session
        if self._refuse_output("session", path):
            return
        try:
            s.settings.tolerance  # a zone that is no zone is not saved
        except SettingsError as e:
            s.tell("error", str(e))
            return
        if s.run is not None:
            self.check_inputs()
        try:
            doc = self._session_doc(path)
            write_all([Output(path, json.dumps(doc, indent=1, allow_nan=False) + "\n")])
        except (OSError, InputError, SettingsError) as e:  # SettingsError: the target changed
            from reports.messages import user_message

            s.tell("error", user_message(e))
            return
        s.tell("info", f"Session saved: {path}")

    def _session_doc(self, path: str) -> dict:
        from engine.io import sha256_of
        from reports.results import run_document

        s = self.session
        return {"format": SESSION_FORMAT, "version": SESSION_VERSION,
               "saved": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
               "inputs": [{"role": role, "path": p,
                           "relative_path": _relative(p, path) if p else None,
                           "sha256": sha256_of(p) if p else None}
                          for role, p in zip(INPUTS, (s.nominal_path, s.measured_path,
                                                      s.plan_path))],
               "settings": s.settings.to_json(),
               "results": None if s.run is None or s.stale else run_document(s.run)}

    def open_session(self, path: str) -> None:
        """Reopen a saved session: its inputs and settings; warns about any input changed since
        (by SHA-256), and re-runs the inspection when all are unchanged (the engine is
        deterministic: the same results)."""
        from engine.io import sha256_of

        s = self.session
        if self._refuse_while_busy():
            return
        try:
            if os.path.exists(path) and not os.path.isfile(path):
                # A named pipe would block the window until something writes to it.
                raise InputError("is not a session file: not a regular file (a folder, a "
                                 "named pipe or a device); it was not opened", path)
            with open(path, encoding="utf-8") as f:
                doc = json.load(f)
            if doc.get("format") != SESSION_FORMAT:
                raise InputError("not a qa-inspect session file", path)
            # Every session this app writes states its version; one written by a later app
            # (another layout) is refused, not misread.
            if doc.get("version", SESSION_VERSION) != SESSION_VERSION:
                raise InputError(f"a session of version {doc.get('version')!r}; this qa-app "
                                 f"reads version {SESSION_VERSION}; it was not opened", path)
            inputs = {i["role"]: i for i in doc["inputs"]}
            st = doc["settings"]
            settings = InspectionSettings.from_json(st)
            settings.tolerance  # a zone that is no zone is refused here
        except FileNotFoundError:
            s.tell("error", f"{path}: no such file")
            return
        except SettingsError as e:
            s.tell("error", f"{path}: {e}")
            return
        except RecursionError:
            s.tell("error", f"{path}: not a readable session file (its JSON is nested too "
                   "deeply)")
            return
        except (ValueError, KeyError, TypeError, AttributeError, OSError, InputError) as e:
            s.tell("error", e.__str__() if isinstance(e, InputError) else
                   f"{path}: not a readable session file ({type(e).__name__}: {e})")
            return
        changed = []
        for role in INPUTS:
            rec = inputs.get(role) or {}
            # A session moved together with its files (a sample, a copied job folder) finds
            # them beside it.
            rel = rec.get("relative_path")
            here = os.path.join(os.path.dirname(os.path.abspath(path)), rel) if rel else None
            if here and (not rec.get("path") or not os.path.isfile(rec["path"])) \
                    and os.path.isfile(here):
                rec["path"] = os.path.normpath(here)
            p = rec.get("path")
            if p and not os.path.isfile(p):
                changed.append(f"{role} file {p} no longer exists")
            elif p and sha256_of(p) != rec.get("sha256"):
                changed.append(f"{role} file {p} changed since the session was saved")
        s.set_run(None)  # another session is another job: nothing of the last one stays
        s.settings = replace(settings, plan=None)  # the plan is an input: plan_path
        s.settings_changed.emit()
        s.set_inputs(*(inputs.get(role, {}).get("path") for role in INPUTS))
        if changed:
            s.tell("warning", "Session reopened, but " + "; ".join(changed) +
                   ". Inspect again to get results for the files as they are now.")
            return
        s.tell("info", f"Session reopened: {path}")
        if s.can_inspect:  # the files are as they were: bring the results back
            self.inspect()

    # ------------------------------------------------------------------ worker
    def _start(self, job: Callable, on_done: Callable, on_fail: Callable) -> None:
        from reports.messages import user_message

        self._cancel.clear()
        self.busy = True

        def finish(ok: bool, value) -> None:
            self.busy = False
            if ok:
                on_done(value)
            else:
                on_fail()
                level = "warning" if isinstance(value, Cancelled) else "error"
                self.session.tell(level, user_message(value))

        def work():
            try:
                value = job()
            except Exception as e:  # every failure reaches the user as one message
                self._post(lambda err=e: finish(False, err))
            else:
                self._post(lambda v=value: finish(True, v))

        if self.synchronous:
            work()
            return
        self._thread = threading.Thread(target=work, name="qa-inspect worker", daemon=True)
        self._thread.start()

    def wait(self, timeout: float | None = None) -> None:
        """Block until the worker thread ends (tests, shutdown)."""
        if self._thread is not None:
            self._thread.join(timeout)


def _relative(p: str, session_path: str) -> str | None:
    try:
        return os.path.relpath(p, os.path.dirname(os.path.abspath(session_path)))
    except ValueError:  # another drive
        return None
