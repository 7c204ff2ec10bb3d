"""One table of an inspection plan file: its keys read with their types checked, and errors
that name the file, the table and the key (engine.io.plan reads the plan with it)."""

from __future__ import annotations

import difflib
import json
import math
import re
from typing import TYPE_CHECKING, Literal, overload

from engine.errors import InputError, SettingsError
from engine.tolerance import check_zone

if TYPE_CHECKING:
    from engine.gdt.plan import Plan

ARRAY_TABLES = {"region": "name", "datum": "label", "characteristic": "id", "rps": "label",
                "not_judged": "id"}
"""The plan's arrays of tables ([[name]]) and the key that identifies each entry."""
TABLES = ("part", "alignment", "measurement")
"""The plan's single tables ([name])."""
ORDER = ("part", "measurement", "region", "datum", "alignment", "characteristic", "rps",
         "not_judged")
KEYS = {
    "part": ("number", "name", "revision", "drawing", "cad_revision"),
    "measurement": ("device", "device_serial", "calibration_date", "probe", "program",
                    "temperature_c", "uncertainty_mm", "mpe_a_um", "mpe_l_per_um", "probing_um",
                    "expansion_per_k"),
    "region": ("name", "box", "labels", "group", "measured_labels"),
    "datum": ("label", "region", "feature", "fit"),
    "alignment": ("method", "reference", "best_fit_regions"),
    "rps": ("label", "nominal", "lock"),
    "characteristic": ("id", "type", "region", "zone", "lower", "upper", "nominal", "datums",
                       "fit", "direction", "sections", "diametral", "angle", "feature",
                       "method", "modifier", "regions", "spacing", "all_around", "features",
                       "name", "designator", "source"),
    # A characteristic of the plan's source that the plan cannot judge (written by
    # ``qa-inspect plan --toml`` from a QIF): the part is then never ACCEPT.
    "not_judged": ("id", "type", "name", "reason"),
}
"""Every key each table may hold."""


class Table:
    """One table of the plan: its keys read with their types checked, and errors that name the
    file, the table (``[[datum]] #2 (label "B")``) and the key."""

    def __init__(self, path: str, name: str, data: dict, index: int | None = None):
        self.path, self.data = path, data
        self.title = notation(name)
        if index is not None:
            key = ARRAY_TABLES[name]
            ident = data.get(key)
            self.title += f" #{index}" + (f" ({key} {show(ident)})"
                                          if isinstance(ident, str) and ident else "")
        known = KEYS[name]
        for key in data:
            if key not in known:
                raise self.fail(key, f"is not a key of {notation(name)}"
                                f"{did_you_mean(key, known)}; its keys are {', '.join(known)}")

    def fail(self, key: str, message: str) -> InputError:
        """The error to raise about ``key`` of this table."""
        return self.refuse(f"'{key}' {message}")

    def refuse(self, message: str) -> InputError:
        """The error to raise about this table."""
        return InputError(f"{self.title}: {message}", self.path)

    def __contains__(self, key: str) -> bool:
        return key in self.data

    @overload
    def text(self, key: str, required: Literal[True], choices: tuple[str, ...] = (),
             default: str | None = None) -> str: ...

    @overload
    def text(self, key: str, required: bool = False, choices: tuple[str, ...] = (), *,
             default: str) -> str: ...

    @overload
    def text(self, key: str, required: bool = False, choices: tuple[str, ...] = (),
             default: str | None = None) -> str | None: ...

    def text(self, key: str, required: bool = False, choices: tuple[str, ...] = (),
             default: str | None = None) -> str | None:
        """A non-empty string (one of ``choices`` when given), or ``default`` when absent."""
        if key not in self.data:
            if required:
                raise self.fail(key, "is missing")
            return default
        value = self.data[key]
        if not isinstance(value, str):
            raise self.fail(key, f"must be a string (in quotes), got {show(value)} "
                            f"({kind_of(value)})")
        if not value.strip():
            raise self.fail(key, "must not be empty")
        self._printable(key, value)
        if choices and value not in choices:
            raise self.fail(key, f"must be one of {', '.join(choices)}; got {show(value)}")
        return value

    def number(self, key: str) -> float | None:
        """A finite number (an integer is fine), or None when absent."""
        if key not in self.data:
            return None
        value = self.data[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(key, f"must be a number, got {show(value)} ({kind_of(value)})")
        if not math.isfinite(value):
            raise self.fail(key, f"must be a finite number, got {show(value)}")
        return float(value)

    def texts(self, key: str, example: str) -> tuple[str, ...]:
        """An array of distinct non-empty strings (``example`` shows one), () when absent."""
        value = self.data.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, str) and v.strip()
                                                  for v in value):
            raise self.fail(key, f"must be an array of names, e.g. {example}; got "
                            f"{show(value)}")
        for i, v in enumerate(value):
            self._printable(key, v)
            if v in value[:i]:
                raise self.fail(key, f"names {show(v)} twice")
        return tuple(value)

    def _printable(self, key: str, value: str) -> None:
        """Refuse a string holding a control character (a line break, a tab, an escape ...):
        it is printed on the terminal, the certificate and the QIF, where a line break in an id
        would forge a line of the report (issue 22)."""
        bad = CONTROL.search(value)
        if bad:
            raise self.fail(key, f"holds a control character (U+{ord(bad.group()):04X}) in "
                            f"{value!r}: names, ids and labels are printed on lines of their "
                            "own and must be plain text")

    def points(self, key: str, count: int, form: str) -> list[tuple[float, float, float]]:
        """``count`` points [x, y, z] of finite numbers, mm (one: the key holds [x, y, z]; more:
        an array of them), written as ``form`` in the error."""
        value = self.data[key]
        rows = [value] if count == 1 else value
        if not (isinstance(rows, list) and len(rows) == count and all(
                isinstance(row, list) and len(row) == 3 and all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in row)
                for row in rows)):
            raise self.fail(key, f"must be {form} (mm), got {show(value)}")
        if not all(math.isfinite(v) for row in rows for v in row):
            raise self.fail(key, f"must hold finite numbers, got {show(value)}")
        return [(float(x), float(y), float(z)) for x, y, z in rows]


def notation(name: str) -> str:
    """How the plan file writes the table: [name] or [[name]]."""
    return f"[{name}]" if name in TABLES else f"[[{name}]]"


def known(names: list[str]) -> str:
    return (f" (they are {', '.join(show(n) for n in names)})" if names
            else " (the plan has none)")


def did_you_mean(word: str, choices: tuple[str, ...]) -> str:
    close = difflib.get_close_matches(word, choices, n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def kind_of(value: object) -> str:
    """The TOML type of a value, in words."""
    for types, word in ((bool, "a boolean"), (int, "an integer"), (float, "a number"),
                        (str, "a string"), (list, "an array"), (dict, "a table")):
        if isinstance(value, types):
            return word
    return "a date or time"


CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029]")
"""Control characters and the Unicode line and paragraph separators."""


def show(value: object) -> str:
    """A value as TOML would write it (shortened when long)."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, float):
        text = repr(value)
    elif isinstance(value, (str, int)):
        text = json.dumps(value, ensure_ascii=False)
    elif isinstance(value, list):
        text = "[" + ", ".join(show(v) for v in value) + "]"
    elif isinstance(value, dict):
        text = "{" + ", ".join(f"{k} = {show(v)}" for k, v in value.items()) + "}"
    else:
        text = str(value)
    return text if len(text) <= 60 else text[:57] + "..."


def check_zones(plan: Plan, size: float | None = None) -> None:
    """Raise InputError naming the plan and the characteristic whose zone no drawing gives, by
    the rule every zone obeys (engine.tolerance.check_zone): engine.io.plan.read_plan and
    engine.io.qif_plan check what needs no nominal (a limit beyond 1e6 mm, a QIF disposition of
    1e7 mm), engine.pipeline.load_nominal the part's ``size`` (its nominal's bounding-box
    diagonal, mm) once the nominal is read. A characteristic read from another source (a QIF's)
    is named as there, a TOML's by its table."""
    for i, c in enumerate(plan.characteristics, start=1):
        try:
            check_zone(c.lower, c.upper, size)
        except SettingsError as e:
            if c.source:
                raise InputError(f"characteristic {c.source.rsplit(' ', 1)[-1]}"
                                 f"{f' ({c.name})' if c.name else ''}: {e}",
                                 plan.path) from None
            raise Table(plan.path, "characteristic", {"id": c.id}, i).refuse(str(e)) from None
