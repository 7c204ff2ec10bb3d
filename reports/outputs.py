"""The files one run writes: checked against its inputs and each other before any work, then
written all together or not at all.

* :func:`check_outputs` refuses an output that is empty, that is one of the run's inputs, or that
  names the same file as another output (compared by resolved real path, and by inode where the
  file exists: ``./x`` and ``x``, symbolic and hard links all name one file).
* :func:`write_all` writes every output to a temporary file beside its target, and renames them
  onto their targets only when every one was written. A failure removes every temporary file and
  leaves each target as it was; a rename that fails midway undoes the renames already done (a
  replaced target gets its previous content back from a hard link kept until the end).

What a target may be, decided before any work (:func:`check_outputs`) and again just before
writing (:func:`write_all`), both by :func:`output_kind`:

* A regular file, or no file yet: replaced atomically as above. A symbolic link is followed: the
  file it points to is replaced and the link stays a link (what ``>`` in a shell does; replacing
  the link by a file would silently cut whatever the link was there for).
* A character device or a FIFO (``/dev/null``, ``/dev/stdout`` on a pipe or terminal, a named
  pipe a reader waits on), or a path through ``/dev/stdout``, ``/dev/fd/N``, ``/proc/*/fd/N``:
  written *through*, opened for appending without creating or truncating, as ``cp``, ``tee``
  and the shell's ``>`` do; these are what users name to discard or pipe an output
  (``--json /dev/null``, ``--csv /dev/stdout | ...``). One of this process's own descriptors is
  written through a duplicate, sharing its position with what is printed afterwards
  (``--json /dev/stdout > out.txt`` gives the JSON, then the summary). Renaming a temporary
  file onto such a target would replace the system's ``/dev/null`` (as root), leave a pipe's
  reader waiting for ever and print nothing where the user asked for it. A stream cannot be
  taken back, so "all or none" cannot hold for it: streams are written last, after every
  regular file was renamed, in the order given; a failure then names the files written.
* A folder, a socket, a block device (a disk: never written by an inspection tool) or anything
  else: refused, a usage error (OutputConflictError).
* A regular file that is a signing identity or a certificate of trust (a PKCS#12 file, a PEM or
  DER key or certificate, see :func:`is_key_material`): refused. Losing ``inspector.p12`` or
  ``ca.pem`` to a mistyped ``--csv`` cannot be undone; the earlier outputs of qa-inspect (PDF,
  CSV, JSON, QIF, sessions) start with text or ``%PDF`` and stay replaceable.
"""

from __future__ import annotations

import errno
import os
import re
import stat
import sys
import tempfile
from dataclasses import dataclass

from engine.errors import SettingsError


class OutputConflictError(SettingsError):
    """An output path is empty, is an input, is another output, is no file to write (a folder,
    socket, block device) or is a key or certificate (a usage error)."""


#: Paths that are one of this process's open files: written through, never renamed onto.
_FD_PATH = re.compile(r"^/(?:dev/(?:std(?:in|out|err)|fd/\d+)|proc/[^/]+/fd/\d+)$")
#: PEM armour of keys and certificates at the start of a line ("-----BEGIN CERTIFICATE-----",
#: "-----BEGIN ENCRYPTED PRIVATE KEY-----", "-----BEGIN PKCS7-----", ...). JSON escapes its
#: line breaks and a PDF compresses its text, so no output of this product matches.
_PEM = re.compile(rb"(?:^|\n)-----BEGIN [A-Z0-9 ]*(?:CERTIFICATE|PRIVATE KEY|PKCS7|PKCS12|"
                  rb"X509 CRL|PUBLIC KEY)[A-Z0-9 ]*-----\r?\n")
_SNIFF = 1 << 16  # bytes read to look for PEM armour (text before it, e.g. openssl -text)


def is_key_material(head: bytes, size: int) -> bool:
    """True when a file of ``size`` bytes starting with ``head`` is a key, a certificate or a
    PKCS#12 identity: PEM armour at a line start, or one DER SEQUENCE spanning exactly the
    whole file (PKCS#12, X.509, PKCS#8, PKCS#7 in DER; tag 0x30 and a definite length whose
    value ends at the last byte: a text, PDF or random binary file does not satisfy that)."""
    if _PEM.search(head):
        return True
    if len(head) < 2 or head[0] != 0x30:
        return False
    n = head[1]
    if n < 0x80:
        return 2 + n == size
    k = n & 0x7F
    if not 1 <= k <= 4 or len(head) < 2 + k:
        return False
    length = int.from_bytes(head[2:2 + k], "big")
    return length >= 0x80 and 2 + k + length == size


def _fd_path(path: str) -> str | None:
    """The first of ``path`` and the symbolic links it leads through that names an open file
    descriptor (/dev/stdout, /dev/fd/N, /proc/PID/fd/N), else None."""
    hop = os.path.abspath(path)
    for _ in range(40):  # the link chain: a link to /dev/stdout is stdout
        if _FD_PATH.match(hop):
            return hop
        if not os.path.islink(hop):
            return None
        hop = os.path.normpath(os.path.join(os.path.dirname(hop), os.readlink(hop)))
    return None


def _own_fd(path: str) -> int | None:
    """The descriptor of this process that ``path`` names (/dev/stdout: 1), else None."""
    hop = _fd_path(path)
    if hop is None:
        return None
    std = {"/dev/stdin": 0, "/dev/stdout": 1, "/dev/stderr": 2}
    if hop in std:
        return std[hop]
    parts = hop.split("/")  # ["", "dev", "fd", N] or ["", "proc", PID, "fd", N]
    if parts[1] == "dev" or parts[2] in ("self", "thread-self", str(os.getpid())):
        return int(parts[-1])
    return None


def output_kind(path: str) -> str:
    """How ``path`` is written: "file" (a regular file or none yet; a symbolic link is
    followed) or "stream" (written through, see the module docstring). Raises
    OutputConflictError for a target that is not to be written."""
    if _fd_path(path) is not None:
        return "stream"
    try:
        st = os.stat(path)  # follows links
    except OSError:
        return "file"  # new (or a dangling link: its target is created), or the write will say
    mode = st.st_mode
    if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
        return "stream"
    if stat.S_ISDIR(mode):
        raise OutputConflictError(f"{path} is a folder: give a file name")
    if not stat.S_ISREG(mode):
        what = ("a socket" if stat.S_ISSOCK(mode) else "a block device (a disk)"
                if stat.S_ISBLK(mode) else "not a regular file")
        raise OutputConflictError(f"{path} is {what}: an output is written to a file, "
                                  "a character device such as /dev/null or a pipe")
    try:
        with open(path, "rb") as f:
            head = f.read(_SNIFF)
    except OSError:
        return "file"  # unreadable: the write decides (and reports) whether it may replace it
    if is_key_material(head, st.st_size):
        raise OutputConflictError(f"{path} holds a key or certificate (a signing identity or "
                                  "a trust anchor): an output never replaces one")
    return "file"


@dataclass(frozen=True)
class Output:
    """One file to write: ``data`` to ``path``. ``private``: readable by the owner only."""

    path: str
    data: str | bytes
    private: bool = False


def same_file(a: str, b: str) -> bool:
    """True when paths ``a`` and ``b`` name one file (existing or not)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet): the real paths decide
        return False


def check_outputs(outputs: dict[str, str | None], inputs: dict[str, str | None]) -> None:
    """Raise OutputConflictError unless every output is a non-empty path that is neither an
    input nor another output, and is a file or stream that may be written (:func:`output_kind`).

    outputs, inputs : {option or role as the user gave it (e.g. "--csv", "MEASURED"): path or
        None when not given}. The message names both options and the path.
    """
    given = [(k, v) for k, v in outputs.items() if v is not None]
    for name, path in given:
        if not str(path).strip():
            raise OutputConflictError(f"{name} needs a file name (got an empty one)")
    for name, path in given:
        for role, src in inputs.items():
            if src is not None and str(src).strip() and same_file(path, src):
                raise OutputConflictError(
                    f"{name} {path} is the {role} file: an output never replaces an input")
    for i, (name, path) in enumerate(given):
        for other, path2 in given[i + 1:]:
            if same_file(path, path2):
                both = path if path == path2 else f"{path} and {path2}"
                raise OutputConflictError(f"{name} and {other} name the same file ({both}); "
                                          "give each output its own file")
    for name, path in given:
        try:
            output_kind(path)
        except OutputConflictError as e:
            raise OutputConflictError(f"{name} {e}") from e


def write_all(outputs: list[Output]) -> None:
    """Write every output or none (see the module docstring); streams (devices, pipes) last.

    Raises OutputConflictError for a target that is not to be written (checked again here:
    the target may have changed since :func:`check_outputs`), else OSError naming the target
    that failed (``filename``), with what was left when a rename could not be undone in the
    message.
    """
    kinds = [output_kind(out.path) for out in outputs]
    streams = [out for out, kind in zip(outputs, kinds) if kind == "stream"]
    staged: list[tuple[Output, str]] = []  # (output, temporary file beside it)
    made: list[str] = []  # folders created here, removed again on failure
    try:
        for out, kind in zip(outputs, kinds):
            if kind == "file":
                # A symbolic link is followed: its target file is replaced, the link stays.
                real = (Output(os.path.realpath(out.path), out.data, out.private)
                        if os.path.islink(out.path) else out)
                staged.append((real, _stage(real, made, out.path)))
    except BaseException:
        for _, tmp in staged:
            _remove(tmp)
        for folder in reversed(made):
            _rmdir(folder)
        raise
    _commit(staged, made)
    for out in streams:
        _write_through(out, written=[o.path for o, k in zip(outputs, kinds) if k == "file"])


def _write_through(out: Output, written: list[str]) -> None:
    """Write ``out`` to the device or pipe it names, neither creating nor truncating it. A
    descriptor of this process (/dev/stdout) is written through a duplicate: it shares the
    position with what the process prints, so both land in order even on a regular file."""
    try:
        own = _own_fd(out.path)
        if own is not None:
            for stream in (sys.stdout, sys.stderr):
                if stream is not None:
                    stream.flush()
            fd = os.dup(own)
        else:
            fd = os.open(out.path, os.O_WRONLY | os.O_APPEND | os.O_NOCTTY)
        with os.fdopen(fd, "wb") as f:
            data = out.data
            f.write(data.encode("utf-8") if isinstance(data, str) else data)
    except OSError as e:
        msg = e.strerror or str(e)
        if written:
            msg += "; written already: " + ", ".join(written)
        raise OSError(e.errno, msg, out.path) from e


def _stage(out: Output, made: list[str], given: str | None = None) -> str:
    path = out.path
    given = given or path  # the name the user gave, for messages
    try:
        if not path or os.path.isdir(path):
            raise IsADirectoryError(21, "is a folder or no file name", given)
        folder = os.path.dirname(os.path.abspath(path))
        _makedirs(folder, made)
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", dir=folder)
    except OSError as e:
        raise OSError(e.errno, e.strerror, given) from e
    try:
        with os.fdopen(fd, "wb") as f:
            # mkstemp makes 0600; an ordinary output gets the usual permissions.
            os.fchmod(f.fileno(), 0o600 if out.private else 0o666 & ~_umask())
            data = out.data
            f.write(data.encode("utf-8") if isinstance(data, str) else data)
            f.flush()
            os.fsync(f.fileno())
    except BaseException as e:
        _remove(tmp)
        if isinstance(e, OSError):
            raise OSError(e.errno, e.strerror, given) from e
        raise
    return tmp


def _commit(staged: list[tuple[Output, str]], made: list[str]) -> None:
    """Rename each temporary file onto its target; on a failure undo the renames done."""
    done: list[tuple[str, bool, str | None]] = []  # (target, existed, link to old content)
    try:
        for out, tmp in staged:
            existed = os.path.lexists(out.path)
            keep = _keep(out.path) if existed else None
            try:
                os.replace(tmp, out.path)
            except BaseException:
                if keep is not None:
                    _remove(keep)
                raise
            done.append((out.path, existed, keep))
    except BaseException as e:
        left = _undo(done)
        for _, tmp in staged:
            _remove(tmp)
        for folder in reversed(made):
            _rmdir(folder)
        if isinstance(e, OSError):
            failed = staged[len(done)][0].path
            msg = e.strerror or str(e)
            if left:
                msg += "; could not undo: " + "; ".join(left)
            raise OSError(e.errno, msg, failed) from e
        raise
    for _, _, keep in done:
        if keep is not None:
            _remove(keep)
    for folder in {os.path.dirname(os.path.abspath(out.path)) for out, _ in staged}:
        _fsync_dir(folder)


def _keep(path: str) -> str | None:
    """A hard link to ``path``'s current content beside it, or None where links are not
    supported (then a failed later rename cannot restore this target, and says so)."""
    folder = os.path.dirname(os.path.abspath(path))
    for _ in range(100):
        name = os.path.join(folder, f".keep-{os.urandom(6).hex()}")
        try:
            os.link(path, name, follow_symlinks=False)
            return name
        except FileExistsError:
            continue
        except OSError:
            return None
    return None


def _undo(done: list[tuple[str, bool, str | None]]) -> list[str]:
    """Put back the targets replaced so far (newest first); return what could not be."""
    left = []
    for path, existed, keep in reversed(done):
        if existed and keep is None:
            left.append(f"{path} was replaced (its previous content could not be kept)")
            continue
        try:
            if keep is not None:
                os.replace(keep, path)
            else:
                os.unlink(path)  # it did not exist before this run
        except OSError as e:
            left.append(f"{path} holds this run's output ({e.strerror})"
                        + (f"; its previous content is in {keep}" if keep else ""))
    return left


def _makedirs(folder: str, made: list[str]) -> None:
    """Create ``folder`` and the folders above it that are missing (each appended to ``made``).
    NotADirectoryError naming the first of them that exists but is no folder: mkdir said only
    "File exists" (``--json n.csv/x.json``)."""
    missing = []
    f = folder
    while not os.path.isdir(f):
        if os.path.lexists(f):
            what = "a file, not a folder" if os.path.isfile(f) else "not a folder"
            raise NotADirectoryError(errno.ENOTDIR, f"its folder {f} is {what}")
        missing.append(f)
        parent = os.path.dirname(f)
        if parent == f:
            break
        f = parent
    for m in reversed(missing):
        os.mkdir(m)
        made.append(m)


def _remove(path: str) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def _rmdir(folder: str) -> None:
    try:
        os.rmdir(folder)
    except OSError:
        pass


def _fsync_dir(folder: str) -> None:
    """Make the renames durable (best effort: some systems cannot open a folder)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _umask() -> int:
    """The process's umask, read without changing it where the system says it (Linux):
    setting and restoring it is not safe while other threads create files."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
