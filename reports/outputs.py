"""The files one run writes: checked against its inputs and each other before any work, then
written all together or not at all.

* :func:`check_outputs` refuses an output that is empty, that is one of the run's inputs, or that
  names the same file as another output (compared by resolved real path, and by inode where the
  file exists: ``./x`` and ``x``, symbolic and hard links all name one file).
* :func:`write_all` writes every output to a temporary file beside its target, and renames them
  onto their targets only when every one was written. A failure removes every temporary file and
  leaves each target as it was; a rename that fails midway undoes the renames already done (a
  replaced target gets its previous content back from a hard link kept until the end).
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass

from engine.errors import SettingsError


class OutputConflictError(SettingsError):
    """An output path is empty, is an input, or is another output (a usage error)."""


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
    input nor another output.

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


def write_all(outputs: list[Output]) -> None:
    """Write every output or none (see the module docstring).

    Raises OSError naming the target that failed (``filename``), with what was left when a
    rename could not be undone in the message.
    """
    staged: list[tuple[Output, str]] = []  # (output, temporary file beside it)
    made: list[str] = []  # folders created here, removed again on failure
    try:
        for out in outputs:
            staged.append((out, _stage(out, made)))
    except BaseException:
        for _, tmp in staged:
            _remove(tmp)
        for folder in reversed(made):
            _rmdir(folder)
        raise
    _commit(staged, made)


def _stage(out: Output, made: list[str]) -> str:
    path = out.path
    try:
        if not path or os.path.isdir(path):
            raise IsADirectoryError(21, "is a folder or no file name", path)
        folder = os.path.dirname(os.path.abspath(path))
        _makedirs(folder, made)
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", dir=folder)
    except OSError as e:
        raise OSError(e.errno, e.strerror, path) from e
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
            raise OSError(e.errno, e.strerror, path) from e
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
    missing = []
    f = folder
    while not os.path.isdir(f):
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
    from .results import _umask

    return _umask()
