"""What a user is told about a failure: one wording for the command line and the desktop app."""

from __future__ import annotations

from engine.errors import Cancelled, InputError, SettingsError


def user_message(e: BaseException) -> str:
    """The one-line message for ``e`` (the command line prefixes it with ``qa-inspect: error:``)."""
    from .signing import OutputExistsError

    if isinstance(e, (InputError, SettingsError, OutputExistsError)):
        return str(e)
    if isinstance(e, Cancelled):
        return "cancelled; no result was written"
    if isinstance(e, OSError):
        return f"cannot write {e.filename or 'output'}: {e.strerror}"
    return (f"internal error ({type(e).__name__}: {e}); no result was written. Please report "
            "this with the input files.")
