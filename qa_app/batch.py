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
import json
import os
import sys
import time
from dataclasses import asdict, dataclass, replace

from engine.errors import InputError
from engine.io import sha256_of
from engine.pipeline import LoadedNominal, inspect_measured, load_nominal
from engine.settings import InspectionSettings

from .lot import VERDICTS, Batch, Part
from .lot_summary import summary_row, tracked_characteristics

RETRIES = 2
"""Re-runs of a part whose task failed (a part is re-run anyway when its worker dies)."""


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
