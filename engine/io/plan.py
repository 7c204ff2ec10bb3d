"""Inspection plan files (``.toml``, read with the standard library's tomllib) ->
engine.gdt.plan.Plan.

The format (units mm, coordinates in the nominal frame; issue 12 is its contract)::

    [part]                 number, name, revision, drawing, cad_revision   (all optional)
    [measurement]          how the part was measured (all optional): device, device_serial,
                           calibration_date (YYYY-MM-DD), probe, program, temperature_c (°C);
                           the instrument for the uncertainty budget (engine.uncertainty):
                           uncertainty_mm (a stated expanded U, k = 2, mm) or mpe_a_um and
                           mpe_l_per_um (MPE_E = A + L/K µm, K in mm per µm), probing_um (µm),
                           expansion_per_k (the part's CTE, 1/K, with temperature_c)
    [[region]]             name; exactly one of box = [[x, y, z], [x, y, z]], labels = "glob",
                           group = "name"; optional measured_labels = "glob"
    [[datum]]              label, region, feature (plane | cylinder | sphere | line | circle),
                           fit = "tangent" (default) | "lsq"
    [alignment]            method = "best-fit" (default) | "datums" | "rps";
                           datums: reference = [primary, secondary, tertiary],
                           best_fit_regions = [region, ...]
    [[rps]]                label, nominal = [x, y, z], lock = subset of ["x", "y", "z"]  (rps only)
    [[characteristic]]     id, type, region, then by type:
                           profile:  zone = z (-z/2 .. +z/2) or lower and upper; datums = [...]
                                     (omitted: form only, refit with fit = "lsq" | "minimax")
                           flatness: zone (0 .. zone); form only, no datums
                           position: zone (a diameter, 0 .. zone); datums (at least one)
                           size:     nominal (diameter), lower and upper (offsets about it)

Everything decidable from the file alone is checked here: TOML syntax, unknown tables and keys,
types, choices, names that must exist and be unique, zones. Each problem raises
:class:`~engine.errors.InputError` naming the file, the table and the key::

    plan.toml: [[characteristic]] #3 (id "3"): 'zone' must be > 0, got -0.1

Whether a region selects any nominal point (a ``group`` the nominal has), and whether a region has enough measured points for
its feature, depend on the nominal and measured files and are checked by the inspection.
"""

from __future__ import annotations

import datetime as dt
import difflib
import functools
import hashlib
import json
import math
import os
import re

import tomllib

from engine.errors import InputError
from engine.errors import SettingsError
from engine.tolerance import ZONE_LIMIT_MM, check_zone
from engine.gdt.plan import (ALIGNMENTS, AXES, CHARACTERISTICS, DATUM_FITS, FEATURES_2D,
                             FEATURES_3D, MAX_CHARACTERISTICS, MAX_DATUMS, PROFILE_FITS,
                             RESERVED_ID, Alignment, Characteristic, Datum, Measurement, Part,
                             Plan, Region, RpsPoint)
from engine.uncertainty import Instrument

from . import formats
from .points import read_bytes

ARRAY_TABLES = {"region": "name", "datum": "label", "characteristic": "id", "rps": "label"}
"""The plan's arrays of tables ([[name]]) and the key that identifies each entry."""
TABLES = ("part", "alignment", "measurement")
"""The plan's single tables ([name])."""
ORDER = ("part", "measurement", "region", "datum", "alignment", "characteristic", "rps")
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
                       "fit"),
}
"""Every key each table may hold."""
SELECTORS = ("box", "labels", "group")
"""A region selects its nominal points by exactly one of these."""

_TOML_WHERE = re.compile(r"\s*\((?:at line (\d+), column (\d+)|at end of document)\)$")


def read_plan(path: str | os.PathLike) -> Plan:
    """Read and check an inspection plan (TOML; a QIF 3.0 MBD through engine.io.qif_plan,
    whose regions name groups :func:`engine.io.qif_plan.qif_face_groups` resolves on the STEP
    nominal); its ``sha256`` is that of the bytes parsed.
    InputNotFoundError when the file is missing; InputError naming the file, the table and the
    key for anything else wrong with it."""
    path = os.fspath(path)
    if formats.kind_of(path) == formats.QIF:
        from .qif_plan import read_qif_plan

        return read_qif_plan(path)
    raw = read_bytes(path)
    if formats.kind_of(path) != formats.PLAN:
        raise InputError(f"an inspection plan is a {' or '.join(formats.PLAN_SUFFIXES)} file, "
                         f"not '{formats.suffix_of(path) or '(no suffix)'}'", path)
    return _plan_of(raw, path)


@functools.lru_cache(maxsize=4)
def _plan_of(raw: bytes, path: str) -> Plan:
    """The plan these bytes of ``path`` hold. Cached by the bytes themselves: a run asks for
    its plan when it chooses the zone and again with the nominal (engine.pipeline), and the same
    bytes always give the same (frozen) Plan, so they are parsed once (10,000 characteristics
    take seconds); a file changed in between is read anew."""
    # Counted before parsing too: tomllib takes about 30 s over 100,000 of them.
    _not_too_many(len(_CHARACTERISTIC_HEADER.findall(raw)), path)
    tables = _tables(_parse(raw, path), path)
    _not_too_many(len(tables["characteristic"]), path)
    regions = tuple(_region(t) for t in tables["region"])
    _unique(tables["region"], "name")
    region_names = [r.name for r in regions]
    datums = tuple(_datum(t, region_names) for t in tables["datum"])
    _unique(tables["datum"], "label")
    _same_dimension(tables["datum"], datums)
    rps = tuple(_rps_point(t) for t in tables["rps"])
    _unique(tables["rps"], "label")
    alignment = _alignment(tables["alignment"][0], datums, region_names, bool(rps))
    characteristics = tuple(_characteristic(t, region_names, datums)
                            for t in tables["characteristic"])
    _unique(tables["characteristic"], "id")
    part, measurement = tables["part"], tables["measurement"]
    plan = Plan(path=path, sha256=hashlib.sha256(raw).hexdigest(),
                part=_part(part[0]) if part else Part(), regions=regions, datums=datums,
                alignment=alignment, characteristics=characteristics, rps=rps,
                measurement=_measurement(measurement[0]) if measurement else Measurement())
    check_zones(plan)
    return plan


def check_zones(plan: Plan, size: float | None = None) -> None:
    """Raise InputError naming the plan and the characteristic whose zone no drawing gives, by
    the rule every zone obeys (engine.tolerance.check_zone): :func:`read_plan` checks what needs
    no nominal (a limit beyond 1e6 mm), engine.pipeline.load_nominal the part's ``size`` (its
    nominal's bounding-box diagonal, mm) once the nominal is read."""
    for i, c in enumerate(plan.characteristics, start=1):
        try:
            check_zone(c.lower, c.upper, size)
        except SettingsError as e:
            raise _Table(plan.path, "characteristic", {"id": c.id}, i).refuse(str(e)) from None


_CHARACTERISTIC_HEADER = re.compile(rb'^[ \t]*\[\[[ \t]*"?characteristic"?[ \t]*\]\]', re.M)
"""A line opening a [[characteristic]] table."""


def _not_too_many(count: int, path: str) -> None:
    """Refuse a plan of more than MAX_CHARACTERISTICS characteristics."""
    if count > MAX_CHARACTERISTICS:
        raise InputError(f"holds {count:,} characteristics; a plan may hold at most "
                         f"{MAX_CHARACTERISTICS:,} (split it into plans of parts of the "
                         "drawing)", path)


def _parse(raw: bytes, path: str) -> dict:
    """The TOML document; InputError with the line of a syntax error."""
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError(f"is not UTF-8 text (byte {e.start} cannot be decoded); a TOML plan "
                         "is UTF-8", path, raw[:e.start].count(b"\n") + 1) from None
    try:
        return tomllib.loads(text)
    except RecursionError:
        raise InputError("its tables or arrays are nested too deeply to be a plan (a plan "
                         "nests them a few levels at most)", path) from None
    except tomllib.TOMLDecodeError as e:
        message = str(e)
        where = _TOML_WHERE.search(message)
        line = len(text.splitlines()) or 1  # "at end of document"
        if where and where.group(1):
            line = int(where.group(1))
            message = message[:where.start()] + f" (column {where.group(2)})"
        elif where:
            message = message[:where.start()] + " (at the end of the file)"
        raise InputError(f"not valid TOML: {message}", path, line) from None


class _Table:
    """One table of the plan: its keys read with their types checked, and errors that name the
    file, the table (``[[datum]] #2 (label "B")``) and the key."""

    def __init__(self, path: str, name: str, data: dict, index: int | None = None):
        self.path, self.data = path, data
        self.title = _notation(name)
        if index is not None:
            key = ARRAY_TABLES[name]
            ident = data.get(key)
            self.title += f" #{index}" + (f" ({key} {_show(ident)})"
                                          if isinstance(ident, str) and ident else "")
        known = KEYS[name]
        for key in data:
            if key not in known:
                raise self.fail(key, f"is not a key of {_notation(name)}"
                                f"{_did_you_mean(key, known)}; its keys are {', '.join(known)}")

    def fail(self, key: str, message: str) -> InputError:
        """The error to raise about ``key`` of this table."""
        return self.refuse(f"'{key}' {message}")

    def refuse(self, message: str) -> InputError:
        """The error to raise about this table."""
        return InputError(f"{self.title}: {message}", self.path)

    def __contains__(self, key: str) -> bool:
        return key in self.data

    def text(self, key: str, required: bool = False, choices: tuple[str, ...] = (),
             default: str | None = None) -> str | None:
        """A non-empty string (one of ``choices`` when given), or ``default`` when absent."""
        if key not in self.data:
            if required:
                raise self.fail(key, "is missing")
            return default
        value = self.data[key]
        if not isinstance(value, str):
            raise self.fail(key, f"must be a string (in quotes), got {_show(value)} "
                            f"({_kind(value)})")
        if not value.strip():
            raise self.fail(key, "must not be empty")
        self._printable(key, value)
        if choices and value not in choices:
            raise self.fail(key, f"must be one of {', '.join(choices)}; got {_show(value)}")
        return value

    def number(self, key: str) -> float | None:
        """A finite number (an integer is fine), or None when absent."""
        if key not in self.data:
            return None
        value = self.data[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(key, f"must be a number, got {_show(value)} ({_kind(value)})")
        if not math.isfinite(value):
            raise self.fail(key, f"must be a finite number, got {_show(value)}")
        return float(value)

    def texts(self, key: str, example: str) -> tuple[str, ...]:
        """An array of distinct non-empty strings (``example`` shows one), () when absent."""
        value = self.data.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, str) and v.strip()
                                                  for v in value):
            raise self.fail(key, f"must be an array of names, e.g. {example}; got "
                            f"{_show(value)}")
        for i, v in enumerate(value):
            self._printable(key, v)
            if v in value[:i]:
                raise self.fail(key, f"names {_show(v)} twice")
        return tuple(value)

    def _printable(self, key: str, value: str) -> None:
        """Refuse a string holding a control character (a line break, a tab, an escape ...):
        it is printed on the terminal, the certificate and the QIF, where a line break in an id
        would forge a line of the report (issue 22)."""
        bad = _CONTROL.search(value)
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
            raise self.fail(key, f"must be {form} (mm), got {_show(value)}")
        if not all(math.isfinite(v) for row in rows for v in row):
            raise self.fail(key, f"must hold finite numbers, got {_show(value)}")
        return [(float(x), float(y), float(z)) for x, y, z in rows]


def _tables(doc: dict, path: str) -> dict[str, list[_Table]]:
    """The document's tables by name ([part] and [alignment] as lists of at most one), every
    top-level name and shape checked."""
    out: dict[str, list[_Table]] = {name: [] for name in ORDER}
    for name, value in doc.items():
        if name not in out:
            what = "table" if isinstance(value, (dict, list)) else "key"
            home = [_notation(n) for n in ORDER if name in KEYS[n]]
            hint = f" (it belongs in {' or '.join(home)})" if home and what == "key" else ""
            raise InputError(f"unknown {what} '{name}'{_did_you_mean(name, ORDER)} at the top "
                             f"level{hint}; a plan has {', '.join(map(_notation, ORDER))}", path)
        if name in TABLES:
            if not isinstance(value, dict):
                raise InputError(f"'{name}' must be a table [{name}], got {_show(value)}", path)
            out[name].append(_Table(path, name, value))
            continue
        if not isinstance(value, list):
            raise InputError(f"'{name}' must be an array of tables: write [[{name}]] (one per "
                             f"{name}), not [{name}]", path)
        for i, entry in enumerate(value, start=1):
            if not isinstance(entry, dict):
                raise InputError(f"[[{name}]] #{i} must be a table, got {_show(entry)}", path)
            out[name].append(_Table(path, name, entry, i))
    if not out["alignment"]:
        out["alignment"].append(_Table(path, "alignment", {}))
    return out


def _part(t: _Table) -> Part:
    return Part(**{key: t.text(key, default="") for key in KEYS["part"]})


INSTRUMENT_KEYS = ("uncertainty_mm", "mpe_a_um", "mpe_l_per_um", "probing_um",
                   "expansion_per_k")
"""The [measurement] keys of the instrument's performance (engine.uncertainty.Instrument)."""


def _measurement(t: _Table) -> Measurement:
    """[measurement]: the traceability fields and the instrument (None when it states no
    term; a stated uncertainty and MPE terms together are refused)."""
    numbers = {k: t.number(k) for k in INSTRUMENT_KEYS}
    temperature = t.number("temperature_c")
    if temperature is not None and not -100.0 < temperature < 200.0:
        raise t.fail("temperature_c", f"must be a temperature in °C, got {temperature:g}")
    if numbers["uncertainty_mm"] is not None:
        if not numbers["uncertainty_mm"] > 0:  # as --uncertainty: 0 would claim a perfect one
            raise t.fail("uncertainty_mm", "must be > 0 (an expanded uncertainty, mm), got "
                         f"{numbers['uncertainty_mm']:g}")
        for k in INSTRUMENT_KEYS[1:]:
            if numbers[k] is not None:
                raise t.fail(k, "and 'uncertainty_mm' are both given: a stated expanded "
                             "uncertainty replaces the MPE, probing and temperature terms")
    instrument = None
    if any(v is not None for v in numbers.values()):
        try:
            instrument = Instrument(temperature_c=temperature, **numbers)
        except SettingsError as e:
            key = next((k for k in (*INSTRUMENT_KEYS, "temperature_c") if str(e).startswith(k)),
                       "expansion_per_k")
            raise t.fail(key, str(e).split(" ", 1)[1]) from None
    return Measurement(**{k: t.text(k, default="") for k in
                          ("device", "device_serial", "probe", "program")},
                       calibration_date=_date(t, "calibration_date"), temperature_c=temperature,
                       instrument=instrument)


def _date(t: _Table, key: str) -> str:
    """A date (TOML's own, 2024-05-01, or a string "2024-05-01") as YYYY-MM-DD; "" absent."""
    value = t.data.get(key)
    if value is None:
        return ""
    if isinstance(value, dt.datetime):
        value = value.date()
    if isinstance(value, dt.date):
        return value.isoformat()
    text = t.text(key) or ""
    try:
        return dt.date.fromisoformat(text.strip()).isoformat()
    except ValueError:
        raise t.fail(key, f"must be a date YYYY-MM-DD, got {_show(value)}") from None


def _region(t: _Table) -> Region:
    name = t.text("name", required=True)
    given = [f"'{key}'" for key in SELECTORS if key in t]
    if len(given) != 1:
        raise t.refuse(f"a region selects its nominal points by exactly one of 'box', 'labels' "
                       f"or 'group'; it gives {' and '.join(given) or 'none'}")
    box = None
    if "box" in t:
        low, high = t.points("box", 2, "two corners [[x, y, z], [x, y, z]]")
        for axis, a, b in zip(AXES, low, high):
            if not a < b:
                raise t.fail("box", f"lower corner {_show(t.data['box'][0])} must be below the "
                             f"upper corner {_show(t.data['box'][1])} on every axis ({axis}: "
                             f"{a:g} >= {b:g})")
        box = (low, high)
    return Region(name=name, box=box, labels=t.text("labels"), group=t.text("group"),
                  measured_labels=t.text("measured_labels"))


def _datum(t: _Table, regions: list[str]) -> Datum:
    label = t.text("label", required=True)
    region = _reference(t, "region", regions, "region", "name")
    feature = t.text("feature", required=True, choices=FEATURES_3D + FEATURES_2D)
    fit = t.text("fit", choices=DATUM_FITS, default="tangent")
    return Datum(label=label, region=region, feature=feature, fit=fit)


def _rps_point(t: _Table) -> RpsPoint:
    label = t.text("label", required=True)
    if "nominal" not in t:
        raise t.fail("nominal", "is missing (the point's nominal position [x, y, z], mm)")
    nominal = t.points("nominal", 1, "a point [x, y, z]")[0]
    if "lock" not in t:
        raise t.fail("lock", "is missing (the axes the point fixes, e.g. lock = [\"x\", \"z\"])")
    lock = t.texts("lock", '["x", "y", "z"]')
    if not lock or not set(lock) <= set(AXES):
        raise t.fail("lock", f"must name some of the axes {', '.join(AXES)}, got "
                     f"{_show(list(lock))}")
    return RpsPoint(label=label, nominal=nominal, lock=tuple(a for a in AXES if a in lock))


def _alignment(t: _Table, datums: tuple[Datum, ...], regions: list[str],
               has_rps: bool) -> Alignment:
    method = t.text("method", choices=ALIGNMENTS, default="best-fit")
    for key in ("reference", "best_fit_regions"):
        if key in t and method != "datums":
            raise t.fail(key, f"applies to method \"datums\" only (method is {_show(method)})")
    if method == "rps" and not has_rps:
        raise t.fail("method", "\"rps\" needs [[rps]] points (label, nominal, lock); the plan "
                     "has none")
    if method != "rps" and has_rps:
        raise t.fail("method", f"is {_show(method)} but the plan has [[rps]] points; they "
                     "apply to method \"rps\" only")
    if method != "datums":
        return Alignment(method=method)
    if "reference" not in t:
        raise t.fail("reference", "is missing: method \"datums\" needs the datum labels, "
                     "primary first (e.g. reference = [\"A\", \"B\", \"C\"])")
    reference = _datum_references(t, "reference", datums)
    if not reference:
        raise t.fail("reference", "is empty: method \"datums\" needs at least a primary datum")
    best_fit = t.texts("best_fit_regions", '["skin"]')
    for name in best_fit:
        if name not in regions:
            raise t.fail("best_fit_regions", f"names {_show(name)}, which is not the name of "
                         f"any [[region]]{_known(regions)}")
    return Alignment(method=method, reference=reference, best_fit_regions=best_fit)


def _characteristic(t: _Table, regions: list[str], datums: tuple[Datum, ...]) -> Characteristic:
    ident = t.text("id", required=True)
    if ident.strip().lower() == RESERVED_ID:
        raise t.fail("id", f"'{ident}' is reserved for the zone over all points that --tol "
                     "adds to a plan (characteristic 'tol'); choose another id")
    kind = t.text("type", required=True, choices=CHARACTERISTICS)
    region = _reference(t, "region", regions, "region", "name")
    lower, upper, nominal = _limits(t, kind)
    refs = _datum_references(t, "datums", datums)
    if kind in ("flatness", "size") and refs:
        raise t.fail("datums", "must not be given: " + ("flatness is form only" if kind ==
                     "flatness" else "a size is the feature's own") + ", relative to no datum")
    if kind == "position" and not refs:
        raise t.fail("datums", "is missing or empty: a position is located relative to at "
                     "least one datum (e.g. datums = [\"A\", \"B\", \"C\"])")
    for label in refs:
        datum = next(d for d in datums if d.label == label)
        if datum.region == region:
            raise t.fail("datums", f"names datum {_show(label)}, which is on region "
                         f"{_show(region)} itself: a feature cannot be related to itself")
    if "fit" in t and (kind != "profile" or refs):
        raise t.fail("fit", "applies to a form-only profile (one without 'datums') only")
    fit = t.text("fit", choices=PROFILE_FITS, default="lsq")
    return Characteristic(id=ident, type=kind, region=region, lower=lower, upper=upper,
                          datums=refs, fit=fit, nominal=nominal)


def _limits(t: _Table, kind: str) -> tuple[float, float, float | None]:
    """(lower, upper, nominal) of a characteristic's zone, mm (see engine.gdt.plan.Characteristic)."""
    zone, lower, upper, nominal = (t.number(k) for k in ("zone", "lower", "upper", "nominal"))
    if kind == "size":
        if zone is not None:
            raise t.fail("zone", "does not apply to size: give 'nominal' (the diameter) and "
                         "'lower' and 'upper' (offsets about it)")
        if nominal is None:
            raise t.fail("nominal", "is missing (the nominal diameter, mm)")
        if nominal <= 0:
            raise t.fail("nominal", "must be > 0 (a diameter), got "
                         f"{_show(t.data['nominal'])}")
        if nominal > ZONE_LIMIT_MM:
            raise t.fail("nominal", f"is a diameter of {nominal:g} mm, beyond "
                         "1e6 mm (1 km): no part has such a feature")
        lower, upper = _explicit_limits(t, lower, upper)
        if nominal + lower <= 0:
            raise t.fail("lower", f"leaves no diameter: nominal {nominal:g} + lower {lower:g} "
                         "must be > 0")
        return lower, upper, nominal
    if nominal is not None:
        raise t.fail("nominal", "applies to size only")
    if kind == "profile" and (lower is not None or upper is not None):
        if zone is not None:
            raise t.fail("zone", "and 'lower'/'upper' are both given: give either the zone "
                         "width or its limits")
        return *_explicit_limits(t, lower, upper), None
    for key in ("lower", "upper"):
        if key in t:
            raise t.fail(key, f"does not apply to {kind}: its zone is 0 .. 'zone'")
    if zone is None:
        raise t.fail("zone", "is missing (the zone's total width, mm)")
    if zone <= 0:
        raise t.fail("zone", f"must be > 0, got {_show(t.data['zone'])}")
    return (-zone / 2, zone / 2, None) if kind == "profile" else (0.0, zone, None)


def _explicit_limits(t: _Table, lower: float | None,
                     upper: float | None) -> tuple[float, float]:
    for key, value in (("lower", lower), ("upper", upper)):
        if value is None:
            raise t.fail(key, "is missing: 'lower' and 'upper' are given together")
    if not lower < upper:
        raise t.fail("upper", f"must be above 'lower', got lower {lower:g}, upper {upper:g}")
    return lower, upper


def _reference(t: _Table, key: str, names: list[str], table: str, name_key: str) -> str:
    """The key's value, which must be the ``name_key`` of one of the [[table]] entries."""
    value = t.text(key, required=True)
    if value not in names:
        raise t.fail(key, f"{_show(value)} is not the {name_key} of any [[{table}]]"
                     f"{_known(names)}")
    return value


def _datum_references(t: _Table, key: str, datums: tuple[Datum, ...]) -> tuple[str, ...]:
    """A datum reference frame: at most MAX_DATUMS distinct datum labels, primary first."""
    refs = t.texts(key, '["A", "B", "C"]')
    labels = [d.label for d in datums]
    for label in refs:
        if label not in labels:
            raise t.fail(key, f"names {_show(label)}, which is not the label of any "
                         f"[[datum]]{_known(labels)}")
    if len(refs) > MAX_DATUMS:
        raise t.fail(key, f"names {len(refs)} datums; a datum reference frame has at most "
                     f"{MAX_DATUMS} (primary, secondary, tertiary)")
    return refs


def _unique(tables: list[_Table], key: str) -> None:
    """Refuse two entries of one array of tables with the same ``key``."""
    first: dict[str, _Table] = {}
    for t in tables:
        value = t.data[key]
        if value in first:
            raise t.fail(key, f"{_show(value)} is also the {key} of "
                         f"{first[value].title.split(' (')[0]}")
        first[value] = t


def _same_dimension(tables: list[_Table], datums: tuple[Datum, ...]) -> None:
    """A plan's datums are all 3D features or all 2D features (one nominal is one or the other)."""
    for t, datum in zip(tables, datums):
        first = datums[0]
        if (datum.feature in FEATURES_2D) != (first.feature in FEATURES_2D):
            raise t.fail("feature", f"{_show(datum.feature)} does not go with datum "
                         f"{_show(first.label)}'s {_show(first.feature)}: a plan's datums are "
                         f"all 3D ({', '.join(FEATURES_3D)}) or all 2D ({', '.join(FEATURES_2D)})")


def _notation(name: str) -> str:
    """How the plan file writes the table: [name] or [[name]]."""
    return f"[{name}]" if name in TABLES else f"[[{name}]]"


def _known(names: list[str]) -> str:
    return (f" (they are {', '.join(_show(n) for n in names)})" if names
            else " (the plan has none)")


def _did_you_mean(word: str, choices: tuple[str, ...]) -> str:
    close = difflib.get_close_matches(word, choices, n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _kind(value: object) -> str:
    """The TOML type of a value, in words."""
    for types, word in ((bool, "a boolean"), (int, "an integer"), (float, "a number"),
                        (str, "a string"), (list, "an array"), (dict, "a table")):
        if isinstance(value, types):
            return word
    return "a date or time"


_CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029]")
"""Control characters and the Unicode line and paragraph separators."""


def _show(value: object) -> str:
    """A value as TOML would write it (shortened when long)."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, float):
        text = repr(value)
    elif isinstance(value, (str, int)):
        text = json.dumps(value, ensure_ascii=False)
    elif isinstance(value, list):
        text = "[" + ", ".join(_show(v) for v in value) + "]"
    elif isinstance(value, dict):
        text = "{" + ", ".join(f"{k} = {_show(v)}" for k, v in value.items()) + "}"
    else:
        text = str(value)
    return text if len(text) <= 60 else text[:57] + "..."
