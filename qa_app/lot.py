"""A lot as ``qa-inspect batch`` takes it: the parts its patterns match (every match, an
unreadable one as an ERROR row), the run's settings and outputs (:class:`Batch`), and the exit
code of its verdicts."""

from __future__ import annotations

import glob
import os
from dataclasses import dataclass

from engine.choices import Verdict
from engine.errors import SettingsError


ERROR = "ERROR"
VERDICTS = (*Verdict, ERROR)
EX_DATAERR = 65


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


def exit_code(verdicts: list[str]) -> int:
    """0 when every part is ACCEPT; else 1 if any is REJECT, else 2 if any is INCONCLUSIVE,
    else 65 (only ERRORs besides ACCEPTs)."""
    found = set(verdicts)
    if found and found <= {Verdict.ACCEPT}:
        return 0
    for verdict, code in ((Verdict.REJECT, 1), (Verdict.INCONCLUSIVE, 2)):
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
