"""What a user is told: the verdict's word and colour, and the wording of failures — one for the
command line, the certificate and the desktop app."""

from __future__ import annotations

import re

from engine.choices import Verdict
from engine.errors import Cancelled, InputError, SettingsError
from engine.gdt.plan import SYMBOLS

# Keyed by the verdicts (engine.choices, a light module: it does not load the engine into the
# desktop app's start-up); a verdict read back from a JSON document, a plain word, finds its entry.
VERDICT_WORD = {Verdict.ACCEPT: "ACCEPTED", Verdict.REJECT: "REJECTED",
                Verdict.INCONCLUSIVE: "INCONCLUSIVE"}
VERDICT_RGB = {Verdict.ACCEPT: (0.11, 0.49, 0.22), Verdict.REJECT: (0.72, 0.11, 0.11),
               Verdict.INCONCLUSIVE: (0.80, 0.52, 0.0)}


_UNPRINTABLE = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028\u2029\u202a-\u202e"
                          "\u2066-\u2069\ud800-\udfff\ufffe\uffff]")
"""What :func:`printable` escapes: C0 and C1 controls and DEL (line breaks, tabs, the escape
that starts ANSI terminal sequences), the Unicode line and paragraph separators, the
bidirectional marks and overrides (which reorder what follows them on the line), lone
surrogates (a file name's bytes that are not UTF-8) and the two noncharacters XML forbids."""


def printable(text) -> str:
    """``text`` from an input (a file name, a point label, a DXF layer, a STEP product name, a
    session field, anything read from a file) as it may be shown on one line of the terminal,
    the certificate or the QIF: each character of ``_UNPRINTABLE`` written as a Python string
    literal writes it (``\\n``, ``\\x1b``, ``\\u2028``, ``\\udcff``), the rest as it is.
    A line break in a file name then cannot start a forged line ("ACCEPT: ...") and an escape
    sequence cannot clear the screen or recolour it. Escape a line's pieces before joining
    lines: the joining line breaks are the only ones left."""
    return _UNPRINTABLE.sub(lambda m: repr(m.group())[1:-1], str(text))


_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def spreadsheet_text(text) -> str:
    """``text`` from an input (a point label, a face or product name, a file name, a message
    quoting one) as a CSV cell: a cell a spreadsheet would take for a formula (it begins with
    ``=``, ``+``, ``-``, ``@``, a tab or a carriage return, and is not a plain number) gets a
    leading apostrophe, so that opening a results file cannot run ``=HYPERLINK(…)`` or
    ``=cmd|…`` written into a STEP file's face name (OWASP's CSV-injection rule)."""
    text = str(text)
    if not text.startswith(_FORMULA_START):
        return text
    try:
        float(text)
    except ValueError:
        return "'" + text
    return text


def user_message(e: BaseException) -> str:
    """The one-line message for ``e`` (the command line prefixes it with ``qa-inspect: error:``),
    with whatever it quotes from the inputs :func:`printable`."""
    return printable(_message(e))


def _message(e: BaseException) -> str:
    from .signing import OutputExistsError

    if isinstance(e, (InputError, SettingsError, OutputExistsError)):
        return str(e)
    if isinstance(e, Cancelled):
        return "cancelled; no result was written"
    if isinstance(e, OSError):
        return f"cannot write {e.filename or 'output'}: {e.strerror}"
    return (f"internal error ({type(e).__name__}: {e}); no result was written. Please report "
            "this with the input files.")


SYMBOL = SYMBOLS
"""The characteristic's symbol on a drawing (ASME Y14.5 / ISO 1101): engine.gdt.plan.SYMBOLS."""


def limits_text(c) -> str:
    """A plan characteristic's requirement as a drawing states it: 'zone 0.0200 mm' for a
    profile (centred: else its limits), flatness or position; '⌀8.0000 -0.0500/+0.0500 mm' for
    a size (a sphere's 'S⌀…', a width's without a sign)."""
    if c.type == "size":
        sign = {"width": "", "sphere": "S⌀"}.get(c.kind or "", "⌀")
        return f"{sign}{c.nominal:.4f} {c.lower:+.4f}/{c.upper:+.4f} mm"
    if c.type == "angle":
        return f"{c.nominal:.4f}° {c.lower:+.4f}/{c.upper:+.4f}°"
    if c.type in ("radius", "distance"):
        mark = {"radius": "SR" if c.kind == "sphere" else "R"}.get(c.type, "")
        return f"{mark}{c.nominal:.4f} {c.lower:+.4f}/{c.upper:+.4f} mm"
    if c.type == "profile" and abs(c.lower + c.upper) > 1e-12:
        return f"zone {c.width:.4f} mm ({c.lower:+.4f} … {c.upper:+.4f})"
    return f"zone {c.width:.4f} mm"


def alignment_text(planned) -> str | None:
    """A plan's alignment in one line ("datums on A plane (tangent, 16 points), ...; free:
    none"), or None for a best fit (the registration's pose stands). planned :
    engine.gdt.characteristics.PlanResult."""
    al = planned.alignment
    if al is None:
        return None
    fits = ", ".join(f"{d.label} {d.feature} ({d.fit}, {d.n_points} points)" for d in al.datums)
    free = "; ".join(f.describe() for f in al.free) or "none"
    return (f"{planned.method} on {fits}; free: {free}"
            + (" (best-fitted)" if al.best_fitted and al.free else ""))
