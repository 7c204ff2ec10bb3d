"""``qa-inspect batch``: many measured parts against one nominal, on a Dask cluster.

The client (this process) reads the nominal (and the plan) once with
:func:`engine.pipeline.load_nominal`, hands it to every worker once (scattered to all of them;
a STEP model, whose OpenCascade objects cannot be pickled, is read once per worker instead,
checked by its SHA-256) and submits one independent task per part (:func:`inspect_part`). A
worker returns texts and bytes (the part's JSON document, its CSV, its certificate laid out but
not signed); the client signs (the key never leaves it), writes each part's files atomically as
its result arrives, and writes ``summary.csv`` and ``summary.json`` at the end.

Outputs in DIR: ``parts/<serial>.json`` (the document of ``inspect --json``), ``.csv`` (of
``inspect --csv``), ``.pdf`` (with ``--report``), and ``parts/.<serial>.key.json``, what the
part's result was made from (its inputs' SHA-256, the settings, the certificate's fields and
signer): a part whose key matches and whose files all exist is not inspected again (resume).

Parts are in measurement order: the MEASURED arguments in the order given, each glob's matches
sorted by name. A part's serial is its file's stem (the point formats carry no serial).
"""

from __future__ import annotations

import contextlib
import glob
import json
import logging
import os
import sys
import time
from dataclasses import asdict, dataclass, replace

import numpy as np

from engine.errors import InputError, SettingsError
from engine.io import sha256_of
from engine.pipeline import LoadedNominal, inspect_measured, load_nominal
from engine.settings import InspectionSettings
from engine.spc import Kind, mean_deviation_kind

ERROR = "ERROR"
VERDICTS = ("ACCEPT", "REJECT", "INCONCLUSIVE", ERROR)
EX_DATAERR = 65
RETRIES = 2
"""Re-runs of a part whose task failed (a part is re-run anyway when its worker dies)."""


class BatchUsageError(SettingsError):
    """The parts named cannot make a batch (a pattern matching nothing, two parts with one
    serial, an output onto an input): a usage error, found before any work."""


# ---------------------------------------------------------------------------- the parts
@dataclass(frozen=True)
class Part:
    """One measured file: its serial (the file's stem) and its path as given; ``problem``
    says why a glob's match cannot be read at all (a dangling symbolic link, a named pipe, a
    folder …; :func:`unreadable`): the part is then an ERROR row, and the file is never
    opened."""

    serial: str
    path: str
    problem: str | None = None


def unreadable(path: str) -> str | None:
    """Why ``path`` is no file a part can be read from, in words, found without opening it (a
    named pipe would block the reader until something writes to it); None for a regular file
    (or a link to one)."""
    import stat

    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        if os.path.islink(path):
            return f"a symbolic link to {os.readlink(path)}, which does not exist"
        return "no such file (it went away after the pattern was matched)"
    except OSError as e:
        return f"cannot be examined ({e.strerror})"
    if stat.S_ISREG(mode):
        return None
    for test, what in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a named pipe (FIFO)"),
                       (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device")):
        if test(mode):
            return f"{what}, not a file of measured points (it is not opened)"
    return "not a regular file (it is not opened)"


def find_parts(patterns: list[str]) -> list[Part]:
    """The parts named by MEASURED ``patterns`` (files or globs), in measurement order: the
    patterns in the order given, a glob's matches sorted by name, a file named twice once.
    Every match of a glob is a part: one that is no regular file (a dangling symbolic link, a
    named pipe, a folder) has its ``problem`` and becomes an ERROR row, never silently left
    out of the lot.

    Raises BatchUsageError for a pattern that names no file (a missing file, a glob matching
    nothing: a lot with a part silently missing would be summarised as complete), for a file
    named directly that is no regular file, and for two files with one serial (their results
    would overwrite each other).
    """
    paths: list[str] = []
    for pattern in patterns:
        if glob.has_magic(pattern):
            found = sorted(glob.glob(pattern))
            if not found:
                raise BatchUsageError(f"MEASURED pattern '{pattern}' matches no file")
        elif os.path.isfile(pattern):
            found = [pattern]
        elif os.path.lexists(pattern) and not os.path.isdir(pattern):
            raise BatchUsageError(f"MEASURED file {pattern} is {unreadable(pattern)}")
        else:
            raise BatchUsageError(f"MEASURED file {pattern} does not exist"
                                  + (" (it is a folder: give a glob such as "
                                     f"'{os.path.join(pattern, '*.csv')}')"
                                     if os.path.isdir(pattern) else ""))
        paths += found
    seen: dict[str, str] = {}
    parts = []
    for path in paths:
        real = os.path.realpath(path)
        if real in seen.values():
            continue
        serial = os.path.splitext(os.path.basename(os.path.normpath(path)))[0]
        if serial in seen:
            raise BatchUsageError(f"two parts have the serial '{serial}': {seen[serial]} and "
                                  f"{path} (a part's serial is its file's stem); rename one")
        seen[serial] = real
        parts.append(Part(serial, path, unreadable(path)))
    return parts


# ---------------------------------------------------------------------------- on the workers
@dataclass(frozen=True)
class NominalRef:
    """A nominal each worker reads itself, once (a STEP model cannot be pickled), with the
    SHA-256 of the nominal and of the plan (None without one) the client read: a worker that
    served an earlier batch reads them again when either file changed since."""

    path: str
    sha256: str
    settings: InspectionSettings
    plan_sha256: str | None = None


@dataclass(frozen=True)
class CertificateRequest:
    """What a worker needs to lay out a part's certificate: the fields the inspector gave (the
    serial is the part's) and the signer's public identity (None: an unsigned draft)."""

    info: object  # reports.certificate.CertificateInfo
    identity: object | None  # reports.signing.Identity.public()


@dataclass(frozen=True)
class PartResult:
    """What a worker returns for one part: the texts and bytes of its files, or an error."""

    json: str | None = None
    csv: str | None = None
    draft: object | None = None  # reports.certificate.CertificateDraft
    error: str | None = None
    seconds: float = 0.0


_LOADED: dict[tuple, LoadedNominal] = {}


def _resolve(nominal) -> LoadedNominal:
    """The loaded nominal: as scattered, or (NominalRef) read once by this worker process."""
    if isinstance(nominal, LoadedNominal):
        return nominal
    key = (nominal.path, nominal.sha256, nominal.plan_sha256,
           json.dumps(nominal.settings.to_json(), sort_keys=True))
    if key not in _LOADED:
        loaded = load_nominal(nominal.path, nominal.settings)
        plan_sha = None if loaded.plan is None else loaded.plan.sha256
        for what, path, got, want in (("nominal", nominal.path, loaded.source.record.sha256,
                                       nominal.sha256),
                                      ("plan", nominal.settings.plan, plan_sha,
                                       nominal.plan_sha256)):
            if got != want:
                raise InputError(f"the {what} this worker reads is not the client's (SHA-256 "
                                 f"{str(got)[:16]}… ≠ {str(want)[:16]}…): the workers must "
                                 "see the same files at the same paths", path)
        _LOADED.clear()  # one nominal at a time: a worker may serve many batches
        _LOADED[key] = loaded
    return _LOADED[key]


def inspect_part(nominal, measured_path: str, serial: str,
                 certificate: CertificateRequest | None) -> PartResult:
    """Inspect one part (on a worker): its JSON document and CSV, and its certificate laid out
    with ``certificate``. A part that cannot be read or inspected is a result with ``error``
    (the user's message), not an exception: the batch goes on.

    nominal : the LoadedNominal (scattered) or a NominalRef.
    """
    from reports.messages import user_message
    from reports.results import points_csv, result_json, run_document

    t0 = time.perf_counter()
    try:
        run = inspect_measured(_resolve(nominal), measured_path)
        draft = None
        if certificate is not None:
            from reports.certificate import draft_certificate

            draft = draft_certificate(run, replace(certificate.info, serial=serial),
                                      certificate.identity)
        return PartResult(result_json(run_document(run)),
                          points_csv(run.result, run.measured.points, run.measured.labels),
                          draft, None, time.perf_counter() - t0)
    except Exception as e:  # noqa: BLE001 - any failure of one part is that part's ERROR row
        return PartResult(error=user_message(e), seconds=time.perf_counter() - t0)


# ---------------------------------------------------------------------------- what is tracked
@dataclass(frozen=True)
class Tracked:
    """A characteristic tracked over the parts of a batch (for SPC): its value's limits.

    lower, upper : the limits the value must respect (None: no limit on that side), in
        ``unit``; definition : what the value is, in words; kind : what SPC may judge of it
        (engine.spc.Kind: a value, a value >= 0 with an upper limit, a count, or information
        only when the fit forces it to ~0).
    """

    id: str
    name: str
    unit: str
    lower: float | None
    upper: float | None
    definition: str
    kind: Kind = Kind.MEASURED


def tracked_characteristics(loaded: LoadedNominal) -> list[Tracked]:
    """The characteristics whose values a batch summarises: the plan's (with ``tol``, the
    profile over all points, first when the zone is part of the verdict), or without a plan
    max |d|, mean d (information only after a least-squares fit, which sets it to ~0) and the
    count of points out of tolerance."""
    settings = loaded.settings
    lo, hi = settings.tol_lower, settings.tol_upper
    if loaded.plan is None:
        mean = mean_deviation_kind(settings.fit)
        judged = mean is not Kind.FORCED
        return [Tracked("max_abs", "max |d|", "mm", None, max(abs(lo), abs(hi)),
                        "largest |signed deviation| over the part's points; upper: the "
                        "largest |limit| of the zone (beyond it a point is outside)",
                        Kind.BOUNDED),
                Tracked("mean", "mean d", "mm", lo if judged else None, hi if judged else None,
                        "mean signed deviation over the part's points; " + (
                            "limits: the zone's" if judged else "no limits: the least-squares "
                            "fit sets it to ~0 (information only)"), mean),
                Tracked("n_out", "points out of tolerance", "points", None, 0.0,
                        "points outside the zone (the part document's deviations.n_out); "
                        "upper: 0", Kind.COUNT)]
    from engine.gdt.plan import RESERVED_ID, Characteristic

    chars = list(loaded.plan.characteristics)
    if settings.zone_in_verdict:
        chars.insert(0, Characteristic(RESERVED_ID, "profile", "(all points)", lo, hi))
    out = []
    for c in chars:
        name = f"{c.type} {c.region}" + (f" |{'|'.join(c.datums)}" if c.datums else "")
        if c.type == "size":
            out.append(Tracked(c.id, name, "mm", c.nominal + c.lower, c.nominal + c.upper,
                               "least-squares diameter; limits: nominal + the zone's"))
        else:  # a width or a diameter about the true position: >= 0, an upper limit only
            out.append(Tracked(c.id, name, "mm", None, c.width,
                               f"{c.type} value (the width of the smallest zone holding the "
                               "region, see the part's characteristic_value_definition); "
                               "upper: the zone", Kind.BOUNDED))
    return out


def _values(doc: dict, tracked: list[Tracked]) -> dict[str, float | None]:
    """Each tracked characteristic's value in a part's JSON document (None where it has none)."""
    dev = doc["deviations"]
    by_id = {c["id"]: c.get("value") for c in doc.get("characteristics", [])}
    plain = {"max_abs": dev["max_abs"], "mean": dev["mean"], "n_out": dev["n_out"]}
    return {t.id: (by_id.get(t.id) if "characteristics" in doc else plain.get(t.id))
            for t in tracked}


def summary_row(part: Part, sha256: str | None, doc: dict | None, tracked: list[Tracked],
                error: str | None = None, seconds: float = 0.0, skipped: bool = False) -> dict:
    """One part's row of the summary, from its JSON document (or its error message)."""
    if doc is None:
        return {"serial": part.serial, "file": part.path, "sha256": sha256, "verdict": ERROR,
                "max_abs": None, "n_out": None, "values": {t.id: None for t in tracked},
                "time_s": round(seconds, 6), "skipped": False, "message": error}
    return {"serial": part.serial, "file": part.path, "sha256": sha256,
            "verdict": doc["verdict"], "max_abs": doc["deviations"]["max_abs"],
            "n_out": doc["deviations"]["n_out"], "values": _values(doc, tracked),
            "time_s": doc["timings_s"]["total"], "skipped": skipped,
            "message": (doc["reasons"] or [""])[0]}


def exit_code(verdicts: list[str]) -> int:
    """0 when every part is ACCEPT; else 1 if any is REJECT, else 2 if any is INCONCLUSIVE,
    else 65 (only ERRORs besides ACCEPTs)."""
    found = set(verdicts)
    if found and found <= {"ACCEPT"}:
        return 0
    for verdict, code in (("REJECT", 1), ("INCONCLUSIVE", 2)):
        if verdict in found:
            return code
    return EX_DATAERR


# ---------------------------------------------------------------------------- the client
@dataclass(frozen=True)
class Batch:
    """One batch: its parts, where its outputs go and what they hold.

    out : the output folder DIR; info : the certificate fields (reports.certificate.
    CertificateInfo) with --report, else None; identity : the signing identity (key
    included: it stays in this process) with --sign, else None; part_number : the part number
    given (--part-number, with or without --report), which the lot's SPC names.
    """

    parts: list[Part]
    out: str
    info: object | None = None
    identity: object | None = None
    part_number: str | None = None

    def files(self, serial: str) -> dict[str, str]:
        """The output files of part ``serial``: json, csv, pdf (with --report) and key."""
        stem = os.path.join(self.out, "parts", serial)
        files = {"json": stem + ".json", "csv": stem + ".csv"}
        if self.info is not None:
            files["pdf"] = stem + ".pdf"
        files["key"] = os.path.join(self.out, "parts", f".{serial}.key.json")
        return files

    def summary_files(self) -> dict[str, str]:
        return {"csv": os.path.join(self.out, "summary.csv"),
                "json": os.path.join(self.out, "summary.json"),
                "spc": os.path.join(self.out, "spc.pdf")}


def check_batch_outputs(batch: Batch, inputs: list[str]) -> None:
    """Raise BatchUsageError when an output of the batch would replace one of its inputs
    (NOMINAL, a MEASURED file, the plan, the signing identity) or is a folder."""
    from reports.outputs import OutputConflictError, output_kind

    real = {os.path.realpath(p): p for p in inputs if p}
    targets = list(batch.summary_files().values())
    targets += [f for part in batch.parts for f in batch.files(part.serial).values()]
    for target in targets:
        if os.path.realpath(target) in real:
            raise BatchUsageError(f"the output {target} is the input "
                                  f"{real[os.path.realpath(target)]}: an output never replaces "
                                  "an input; choose another --out folder")
        if os.path.lexists(target):
            try:
                output_kind(target)
            except OutputConflictError as e:
                raise BatchUsageError(str(e)) from e


def part_key(batch: Batch, loaded: LoadedNominal, measured_sha256: str) -> dict:
    """What a part's result is made from (its inputs' SHA-256, the settings, the software,
    the certificate's fields and signer), as JSON types: equal keys, equal results."""
    from reports.results import software_version

    cert = None
    if batch.info is not None:
        ident = batch.identity
        cert = dict(asdict(batch.info), signer=None if ident is None else ident.common_name,
                    ca=None if ident is None else ident.ca_fingerprint)
    return json.loads(json.dumps({
        "measured_sha256": measured_sha256, "nominal_sha256": loaded.source.record.sha256,
        "plan_sha256": None if loaded.plan is None else loaded.plan.sha256,
        "settings": loaded.settings.to_json(), "software": software_version(),
        "certificate": cert}))


def _sha_or_none(path: str) -> str | None:
    try:
        return sha256_of(path)
    except InputError:
        return None


def _finished(batch: Batch, loaded: LoadedNominal, part: Part) -> tuple[str, dict] | None:
    """(SHA-256, JSON document) of the part's result of an earlier run when it is complete
    and was made from the same inputs and settings (resume), else None."""
    files = batch.files(part.serial)
    if not all(os.path.isfile(f) for f in files.values()):
        return None
    sha = _sha_or_none(part.path)
    try:
        with open(files["key"], encoding="utf-8") as f:
            key = json.load(f)
        with open(files["json"], encoding="utf-8") as f:
            doc = json.load(f)
    except (OSError, ValueError):
        return None
    if sha is None or key != part_key(batch, loaded, sha):
        return None
    return sha, doc


def _write_part(batch: Batch, loaded: LoadedNominal, part: Part,
                res: PartResult) -> tuple[str, dict]:
    """Write one part's files, all or none (signing its certificate here); (its SHA-256, its
    JSON document)."""
    from reports.outputs import Output, write_all

    doc = json.loads(res.json)
    sha = next(r["sha256"] for r in doc["inputs"] if r["role"] == "measured")
    files = batch.files(part.serial)
    outputs = [Output(files["json"], res.json), Output(files["csv"], res.csv)]
    if "pdf" in files:
        from reports.certificate import finish_certificate

        outputs.append(Output(files["pdf"], finish_certificate(res.draft, batch.identity)))
    key = json.dumps(part_key(batch, loaded, sha), indent=1) + "\n"
    write_all(outputs + [Output(files["key"], key)])
    return sha, doc


def _remove_part(batch: Batch, part: Part) -> None:
    """Remove the files an earlier run wrote for a part that is now an ERROR (its key first:
    a resume never trusts what is left), so that no result or certificate contradicts the
    summary."""
    files = batch.files(part.serial)
    for name in ["key"] + [k for k in files if k != "key"]:
        with contextlib.suppress(FileNotFoundError):
            os.remove(files[name])


def run_batch(batch: Batch, loaded: LoadedNominal, client=None, on_row=None,
              connect=None) -> list[dict]:
    """Inspect every part of ``batch`` against ``loaded`` on the Dask ``client``'s cluster;
    return the summary rows in measurement order (:func:`summary_row`), each part once.

    connect : instead of ``client``, a function returning a context manager that yields one
    (e.g. ``lambda: dask_client(None, 2)``), entered only when some part is left to inspect: the
    resume of a finished lot starts no cluster.

    A part with a complete result of an earlier run for the same inputs and settings is not
    inspected again (its row says ``skipped``). Each part's files are written as its result
    arrives. on_row : called with each row as it is known (a progress bar). A KeyboardInterrupt
    (or any exception) cancels the parts not finished and propagates: the files written are
    each part's complete result, nothing else.
    """
    tracked = tracked_characteristics(loaded)
    rows: list[dict | None] = [None] * len(batch.parts)
    todo = []
    for i, part in enumerate(batch.parts):
        if part.problem is not None:  # no file to read: its ERROR row, and never opened
            _remove_part(batch, part)
            rows[i] = summary_row(part, None, None, tracked, f"{part.path}: {part.problem}")
        else:
            done = _finished(batch, loaded, part)
            if done is None:
                todo.append(i)
                continue
            rows[i] = summary_row(part, done[0], done[1], tracked, skipped=True)
        if on_row is not None:
            on_row(rows[i])
    with contextlib.ExitStack() as stack:
        if todo and connect is not None:
            client = stack.enter_context(connect())
        results = stack.enter_context(contextlib.closing(_compute(batch, loaded, client, todo)))
        for i, res in results:
            part = batch.parts[i]
            if res.error is None:
                rows[i] = summary_row(part, *_write_part(batch, loaded, part, res), tracked)
            else:
                _remove_part(batch, part)
                rows[i] = summary_row(part, _sha_or_none(part.path), None, tracked, res.error,
                                      res.seconds)
            if on_row is not None:
                on_row(rows[i])
    return rows


def _compute(batch: Batch, loaded: LoadedNominal, client, todo: list[int]):
    """Submit the parts ``todo`` (indices) as independent tasks; yield (index, PartResult) as
    each finishes. A task that failed even after its retries (its workers died) is an error."""
    from distributed import as_completed

    if not todo:
        return
    request = None
    if batch.info is not None:
        request = CertificateRequest(batch.info, None if batch.identity is None
                                     else batch.identity.public())
    if loaded.picklable:  # the nominal goes to every worker once, not with every part
        nominal = client.scatter(loaded, broadcast=True, hash=False)
    else:
        nominal = NominalRef(loaded.path, loaded.source.record.sha256, loaded.settings,
                             None if loaded.plan is None else loaded.plan.sha256)
    futures = {client.submit(inspect_part, nominal, os.path.abspath(batch.parts[i].path),
                             batch.parts[i].serial, request, pure=False, retries=RETRIES,
                             key=f"qa-part-{batch.parts[i].serial}-{os.urandom(4).hex()}"): i
               for i in todo}
    try:
        for future in as_completed(list(futures)):
            i = futures.pop(future)
            try:
                res = future.result()
            except Exception as e:  # noqa: BLE001 - e.g. KilledWorker: this part's ERROR
                res = PartResult(error=f"the inspection did not finish on the cluster "
                                       f"({type(e).__name__}: {e})")
            yield i, res
    finally:
        if futures:  # interrupted (or failed): the parts not finished are cancelled
            client.cancel(list(futures))


CONNECT_S = 5.0
"""Seconds a Dask scheduler named by ``--scheduler`` has to accept the connection, and as many
to answer Dask's handshake (one on the same network answers in milliseconds): a closed port, or
a port where another service listens (an HTTP server, the dashboard's port), is said within
seconds, not after Dask's own 30 s of retries, or never (Dask waits for the handshake's answer
without end)."""


def probe_scheduler(address: str, seconds: float = CONNECT_S) -> None:
    """Connect to the Dask scheduler at ``address`` (``tcp://HOST:PORT``; ``tls://`` and
    Dask's other schemes too), shake hands with it, and hang up: first a plain connection
    (within ``seconds``; a refusal is final), then Dask's handshake (within ``seconds``).

    Raises ConnectionError naming the address and the reason: the address is none, nothing
    listens there, nothing answers, or what accepted the connection did not answer as a Dask
    scheduler does (another service on that port)."""
    import asyncio
    import socket

    from distributed.comm import connect, parse_address, parse_host_port

    def refused(reason: str) -> ConnectionError:
        return ConnectionError(f"cannot reach the Dask scheduler {address}: {reason}")

    other = "another service on that port? a scheduler listens on 8786 by default, its " \
            "dashboard on 8787"

    try:
        scheme, location = parse_address(address)
        if scheme in ("tcp", "tls"):
            with socket.create_connection(parse_host_port(location), timeout=seconds):
                pass
    except ConnectionRefusedError as e:
        raise refused("the connection was refused (nothing listens on that port)") from e
    except (socket.timeout, TimeoutError) as e:
        raise refused(f"no answer within {seconds:.0f} s") from e
    except (OSError, ValueError, TypeError) as e:
        raise refused(f"{e.strerror or e}" if isinstance(e, OSError) else f"{e}") from e

    async def shake_hands():
        comm = await connect(address, timeout=seconds)
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(shake_hands(), seconds))
    except (asyncio.TimeoutError, TimeoutError) as e:
        raise refused(f"something accepted the connection but did not answer as a Dask "
                      f"scheduler within {seconds:.0f} s ({other})") from e
    except Exception as e:  # noqa: BLE001 - whatever the answer was, it was not a scheduler's
        raise refused(f"what answered is not a Dask scheduler (its answer could not be read: "
                      f"{type(e).__name__}; {other})") from e


@contextlib.contextmanager
def dask_client(scheduler: str | None, workers: int | None, wait_s: float = 60.0):
    """A Dask client: of the existing cluster at ``scheduler`` (tcp://HOST:PORT), or of a local
    cluster of ``workers`` single-threaded worker processes (default: the cores) started here
    and closed at the end. Distributed's log messages below ERROR are silenced.

    Raises ConnectionError when the scheduler cannot be reached or does not answer as one
    (:func:`probe_scheduler`, within seconds), or has no worker within ``wait_s`` seconds.
    """
    from distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.ERROR)
    with contextlib.ExitStack() as stack:
        if scheduler is None:
            with _sigint_ignored():  # inherited by the worker processes: see _sigint_ignored
                cluster = stack.enter_context(LocalCluster(
                    n_workers=workers or _cores(), threads_per_worker=1, processes=True,
                    # Any free port for its web server (None is Dask's fixed 8787): two
                    # batches, or a batch beside another Dask user, run side by side.
                    dashboard_address=":0", silence_logs=logging.ERROR))
            client = stack.enter_context(Client(cluster))
        else:
            probe_scheduler(scheduler)
            try:
                client = stack.enter_context(Client(scheduler, timeout=CONNECT_S))
            except (OSError, TimeoutError, ValueError) as e:
                raise ConnectionError(f"cannot reach the Dask scheduler {scheduler}: {e}") from e
            try:
                client.wait_for_workers(1, timeout=wait_s)
            except TimeoutError as e:
                raise ConnectionError(f"the Dask scheduler {scheduler} has no worker (none "
                                      f"joined within {wait_s:.0f} s)") from e
        yield client


@contextlib.contextmanager
def _sigint_ignored():
    """Ignore SIGINT while the local cluster's processes start, which keep it ignored: Ctrl-C
    in a terminal reaches every process of its group, and a worker interrupted by it prints
    tracebacks; this process alone takes it, cancels the parts and closes the cluster."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


# ---------------------------------------------------------------------------- the summary
def verdict_counts(rows: list[dict]) -> dict[str, int]:
    """How many rows have each verdict, in VERDICTS order (ERROR included)."""
    return {v: sum(r["verdict"] == v for r in rows) for v in VERDICTS}


def summary_document(batch: Batch, loaded: LoadedNominal, rows: list[dict],
                     tracked: list[Tracked], analyses: list) -> dict:
    """summary.json: the inputs and settings, the tracked characteristics with their limits,
    one row per part in measurement order, the counts per verdict, the exit code and the SPC
    ``analyses`` (engine.spc.Analysis, one per tracked characteristic)."""
    from engine.spc import to_json
    from reports.results import SOFTWARE_NAME, software_version

    return {
        "nominal": {"path": loaded.path, "sha256": loaded.source.record.sha256},
        "plan": None if loaded.plan is None else {"path": loaded.plan.path,
                                                 "sha256": loaded.plan.sha256},
        "settings": loaded.settings.to_json(),
        "characteristics": [asdict(t) for t in tracked],
        "order": "measurement order: the MEASURED arguments as given, each glob's matches "
                 "sorted by name",
        "parts": rows,
        "counts": verdict_counts(rows),
        "skipped": sum(r["skipped"] for r in rows),
        "exit_code": exit_code([r["verdict"] for r in rows]),
        "row_definition": "max_abs: largest |deviation| (mm); n_out: points outside the zone; "
                          "values: each characteristic's value by id (null: none, or ERROR); "
                          "time_s: the inspection's time (the part document's timings_s.total, "
                          "or until the error); skipped: the result of an earlier run for the "
                          "same inputs and settings; message: the first reason, or the error",
        "spc": [{"id": t.id, **to_json(a)} for t, a in zip(tracked, analyses)],
        "software": {"name": SOFTWARE_NAME, "version": software_version()},
    }


def lot_series(tracked: list[Tracked], rows: list[dict]) -> list:
    """Each tracked characteristic over the lot (engine.spc.Series): its values in measurement
    order (NaN for a part without one: an ERROR), the parts' serials, its limits and kind."""
    from engine.spc import Series

    serials = [r["serial"] for r in rows]
    out = []
    for t in tracked:
        values = [np.nan if r["values"].get(t.id) is None else r["values"][t.id] for r in rows]
        out.append(Series(t.name, t.unit, np.array(values, float), serials, t.lower, t.upper,
                          t.kind))
    return out


def summary_csv(tracked: list[Tracked], rows: list[dict]) -> str:
    """summary.csv: one row per part; a ``value_<id>`` column per tracked characteristic."""
    import csv
    import io

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["serial", "file", "sha256", "verdict", "max_abs_mm", "n_out"]
               + [f"value_{t.id}" for t in tracked] + ["time_s", "skipped", "message"])
    for r in rows:
        w.writerow([r["serial"], r["file"], r["sha256"] or "", r["verdict"],
                    _cell(r["max_abs"]), "" if r["n_out"] is None else r["n_out"]]
                   + [_cell(r["values"][t.id]) for t in tracked]
                   + [f"{r['time_s']:.3f}", "true" if r["skipped"] else "false",
                      r["message"] or ""])
    return buf.getvalue()


def _cell(v) -> str:
    return "" if v is None else repr(float(v))


def write_summary(batch: Batch, loaded: LoadedNominal, rows: list[dict]) -> list[str]:
    """Write summary.csv, summary.json and spc.pdf (the lot's SPC: reports.spc), all or none;
    return their paths."""
    from engine.spc import analyse
    from reports.outputs import Output, write_all
    from reports.results import result_json
    from reports.spc import spc_pdf

    files = batch.summary_files()
    tracked = tracked_characteristics(loaded)
    analyses = [analyse(series) for series in lot_series(tracked, rows)]  # once, for both
    counts = verdict_counts(rows)
    number = part_number(batch, loaded)
    title = (f"{number or os.path.splitext(os.path.basename(loaded.path))[0]}: {len(rows)} parts"
             + (f", plan {os.path.basename(loaded.plan.path)}" if loaded.plan else ""))
    facts = {"part number": number or "none given (--part-number, or the plan's [part]): the "
                                      "title names the nominal's file",
             "parts": len(rows), **counts, "nominal": loaded.path}
    doc = summary_document(batch, loaded, rows, tracked, analyses)
    write_all([Output(files["csv"], summary_csv(tracked, rows)),
               Output(files["json"], result_json(doc)),
               Output(files["spc"], spc_pdf(analyses, title, facts))])
    return [files["csv"], files["json"], files["spc"]]


def part_number(batch: Batch, loaded: LoadedNominal) -> str:
    """The lot's part number: --part-number, else the plan's [part] number, else "" (the
    SPC's title then names the nominal's file, without its extension)."""
    given = (batch.part_number or "").strip()
    return given or (loaded.plan.part.number.strip() if loaded.plan is not None else "")


# ---------------------------------------------------------------------------- progress
def progress_line(done: int, total: int, computed: int, elapsed: float,
                  counts: dict[str, int], width: int = 20) -> str:
    """The progress bar's text: parts done of total, parts/s and the time left (from the
    parts inspected in this run: ``computed`` in ``elapsed`` seconds), counts per verdict."""
    filled = width * done // total if total else width
    rate = computed / elapsed if elapsed > 0 else 0.0
    if done >= total:
        eta = "0:00"
    elif rate > 0:
        left = round((total - done) / rate)
        eta = f"{left // 60}:{left % 60:02d}"
    else:
        eta = "?"
    verdicts = " ".join(f"{v} {counts.get(v, 0)}" for v in VERDICTS)
    return (f"[{'#' * filled}{'.' * (width - filled)}] {done}/{total} parts  "
            f"{rate:.2f} parts/s  ETA {eta}  {verdicts}")


class ProgressBar:
    """A one-line progress bar on ``stream`` (a terminal), redrawn at most 10 times a second
    and when the last part is done; :meth:`update` takes each summary row."""

    def __init__(self, total: int, stream=None, clock=time.monotonic):
        self.total, self.stream, self.clock = total, stream or sys.stderr, clock
        self.start = clock()
        self.done = self.computed = 0
        self.counts: dict[str, int] = {}
        self._drawn = -1.0

    def update(self, row: dict) -> None:
        self.done += 1
        self.computed += not row["skipped"]
        self.counts[row["verdict"]] = self.counts.get(row["verdict"], 0) + 1
        now = self.clock()
        if now - self._drawn >= 0.1 or self.done == self.total:
            self._drawn = now
            self.stream.write("\r" + progress_line(self.done, self.total, self.computed,
                                                   now - self.start, self.counts))
            self.stream.flush()

    def close(self) -> None:
        if self._drawn >= 0:
            self.stream.write("\n")
            self.stream.flush()


def check_certifiable(batch: Batch, loaded: LoadedNominal) -> None:
    """Raise CertificationError when signed certificates could not name their part: a signed
    ACCEPTED certificate needs a part number (--part-number, or the plan's [part]); the
    serial is each file's stem. Found before any work rather than after the first part."""
    from reports.certificate import CertificationError

    if batch.identity is None:
        return
    number = batch.info.part_number or (loaded.plan.part.number if loaded.plan else "")
    if not (number or "").strip():
        raise CertificationError("signed certificates must identify their part: give its part "
                                 "number (--part-number), or a plan whose [part] has one")


def summary_text(rows: list[dict], seconds: float, written: list[str]) -> str:
    """What the command prints at the end: the counts, each ERROR part, the files."""
    from reports.messages import printable

    counts = ", ".join(f"{n} {v}" for v, n in verdict_counts(rows).items())
    skipped = sum(r["skipped"] for r in rows)
    lines = [f"{len(rows)} parts: {counts}"
             + (f"; {skipped} skipped (done by an earlier run)" if skipped else "")
             + f"; {seconds:.1f} s"]
    lines += [f"  ERROR {r['serial']} ({r['file']}): {r['message']}"
              for r in rows if r["verdict"] == ERROR]
    parts = os.path.join(os.path.dirname(os.path.abspath(written[0])), "parts")
    lines.append("results: " + ", ".join(os.path.abspath(w) for w in written) + f", {parts}/")
    # Each line escaped before they are joined: a serial is a file's name, whatever it holds.
    return "\n".join(printable(line) for line in lines)
