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
                           group = "name" or ["name", ...] (their union); optional
                           measured_labels = "glob"
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
                           position: zone (a diameter, 0 .. zone); datums (at least one);
                                     regions = [...] instead of region (a pattern);
                                     modifier = "RFS" (default) | "MMC" | "LMC" (needs a
                                     size on the same region)
                           coaxiality, concentricity: zone; datums (a cylinder first)
                           symmetry: zone; datums (a plane first); a width's centre plane
                           size:     nominal (diameter or width), lower and upper (offsets
                                     about it); method = "lsq" (default) | "two-point" |
                                     "min-circumscribed" | "max-inscribed"
                           size and location: feature = "cylinder" (default) | "sphere" |
                                     "width" (two opposed parallel planes)
                           straightness: zone; direction = [x, y, z] (a plane's line elements)
                                     or none (a cylinder's median line, diametral); sections
                           circularity: zone; sections (default 8); cylindricity: zone
                           parallelism, perpendicularity, angularity: zone; datums (at least
                                     one); diametral = true (an axis) or feature = "width"
                                     (its median plane); angularity: angle (deg)
                           circular_runout, total_runout: zone; datums = one axis (a
                                     cylinder datum, or a common datum "A-B"); sections
                           line_profile: as profile; direction (the sections' normal) and
                                     spacing (mm); profile and line_profile: all_around = true
                           radius, angle, distance: engine.io.plan_dimensions
Everything decidable from the file alone is checked here: TOML syntax, unknown tables and keys,
types, choices, names that must exist and be unique, zones. Each problem raises
:class:`~engine.errors.InputError` naming the file, the table and the key::

    plan.toml: [[characteristic]] #3 (id "3"): 'zone' must be > 0, got -0.1

Whether a region selects any nominal point (a ``group`` the nominal has), and whether a region
has enough measured points for its feature, depend on the nominal and measured files and are
checked by the inspection.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import functools
import hashlib
import math
import os
import re

import tomllib

from engine.errors import InputError
from engine.errors import SettingsError
from engine.tolerance import ZONE_LIMIT_MM
from engine.gdt.plan import (ALIGNMENTS, AXES, CHARACTERISTICS, DATUM_FITS, DIMENSIONS,
                             FEATURES_2D, FEATURES_3D, FORM, LOCATION, MAX_DATUMS,
                             ORIENTATION, PROFILE_FITS, RUNOUT, datum_parts, known_datum_parts,
                             not_too_many, RESERVED_ID, Alignment, Characteristic, Datum,
                             Measurement, NotJudged, Part, Plan, Region, RpsPoint)
from engine.uncertainty import Instrument

from . import formats
from .plan_dimensions import dimension
from .plan_location import (about_an_axis, datum_kind, material_sizes,
                            one_feature_per_region, size_options)
from .plan_tables import (KEYS, ORDER, TABLES, Table, check_zones, did_you_mean, known,
                          notation, show)
from .points import read_bytes

SELECTORS = ("box", "labels", "group")
"""A region selects its nominal points by exactly one of these."""

DATUM_MODIFIER = re.compile(r"^\s*(.+?)\s*\(\s*([ML])\s*\)\s*$")
"""A datum reference with a material modifier, as a feature control frame writes it: "B(M)"."""
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
    not_too_many(len(_CHARACTERISTIC_HEADER.findall(raw)), path)
    tables = _tables(_parse(raw, path), path)
    not_too_many(len(tables["characteristic"]) + len(tables["not_judged"]), path)
    regions = tuple(_region(t) for t in tables["region"])
    _unique(tables["region"], "name")
    region_names = [r.name for r in regions]
    datums = tuple(_datum(t, region_names) for t in tables["datum"])
    _unique(tables["datum"], "label")
    _same_dimension(tables["datum"], datums)
    rps = tuple(_rps_point(t) for t in tables["rps"])
    _unique(tables["rps"], "label")
    alignment = _alignment(tables["alignment"][0], datums, region_names, bool(rps))
    characteristics = tuple(dataclasses.replace(
        _characteristic(t, region_names, datums), name=t.text("name", default="") or "",
        designator=t.text("designator", default="") or "",
        source=t.text("source", default="") or "") for t in tables["characteristic"])
    not_judged = tuple(NotJudged(*(t.text(k, required=k != "name", default="") or ""
                                   for k in KEYS["not_judged"])) for t in tables["not_judged"])
    _unique(tables["characteristic"] + tables["not_judged"], "id")
    one_feature_per_region(tables["characteristic"], characteristics, datums)
    material_sizes(tables["characteristic"], characteristics)
    part, measurement = tables["part"], tables["measurement"]
    plan = Plan(path=path, sha256=hashlib.sha256(raw).hexdigest(),
                part=_part(part[0]) if part else Part(), regions=regions, datums=datums,
                alignment=alignment, characteristics=characteristics, rps=rps,
                measurement=_measurement(measurement[0]) if measurement else Measurement(),
                not_judged=not_judged)
    check_zones(plan)
    return plan


_CHARACTERISTIC_HEADER = re.compile(rb'^[ \t]*\[\[[ \t]*"?characteristic"?[ \t]*\]\]', re.M)
"""A line opening a [[characteristic]] table."""


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


def _tables(doc: dict, path: str) -> dict[str, list[Table]]:
    """The document's tables by name ([part] and [alignment] as lists of at most one), every
    top-level name and shape checked."""
    out: dict[str, list[Table]] = {name: [] for name in ORDER}
    for name, value in doc.items():
        if name not in out:
            what = "table" if isinstance(value, (dict, list)) else "key"
            home = [notation(n) for n in ORDER if name in KEYS[n]]
            hint = f" (it belongs in {' or '.join(home)})" if home and what == "key" else ""
            raise InputError(f"unknown {what} '{name}'{did_you_mean(name, ORDER)} at the top "
                             f"level{hint}; a plan has {', '.join(map(notation, ORDER))}", path)
        if name in TABLES:
            if not isinstance(value, dict):
                raise InputError(f"'{name}' must be a table [{name}], got {show(value)}", path)
            out[name].append(Table(path, name, value))
            continue
        if not isinstance(value, list):
            raise InputError(f"'{name}' must be an array of tables: write [[{name}]] (one per "
                             f"{name}), not [{name}]", path)
        for i, entry in enumerate(value, start=1):
            if not isinstance(entry, dict):
                raise InputError(f"[[{name}]] #{i} must be a table, got {show(entry)}", path)
            out[name].append(Table(path, name, entry, i))
    if not out["alignment"]:
        out["alignment"].append(Table(path, "alignment", {}))
    return out


def _part(t: Table) -> Part:
    return Part(**{key: t.text(key, default="") for key in KEYS["part"]})


INSTRUMENT_KEYS = ("uncertainty_mm", "mpe_a_um", "mpe_l_per_um", "probing_um",
                   "expansion_per_k")
"""The [measurement] keys of the instrument's performance (engine.uncertainty.Instrument)."""


def _measurement(t: Table) -> Measurement:
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


def _date(t: Table, key: str) -> str:
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
        raise t.fail(key, f"must be a date YYYY-MM-DD, got {show(value)}") from None


def _region(t: Table) -> Region:
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
                raise t.fail("box", f"lower corner {show(t.data['box'][0])} must be below the "
                             f"upper corner {show(t.data['box'][1])} on every axis ({axis}: "
                             f"{a:g} >= {b:g})")
        box = (low, high)
    group = t.data.get("group")
    if isinstance(group, list):
        group = t.texts("group", '["face:62", "face:63"]')
        if not group:
            raise t.fail("group", "is empty: name at least one group")
    else:
        group = t.text("group")
    return Region(name=name, box=box, labels=t.text("labels"), group=group,
                  measured_labels=t.text("measured_labels"))


def _datum(t: Table, regions: list[str]) -> Datum:
    label = t.text("label", required=True)
    region = _reference(t, "region", regions, "region", "name")
    feature = t.text("feature", required=True, choices=FEATURES_3D + FEATURES_2D)
    fit = t.text("fit", choices=DATUM_FITS, default="tangent")
    return Datum(label=label, region=region, feature=feature, fit=fit)


def _rps_point(t: Table) -> RpsPoint:
    label = t.text("label", required=True)
    if "nominal" not in t:
        raise t.fail("nominal", "is missing (the point's nominal position [x, y, z], mm)")
    nominal = t.points("nominal", 1, "a point [x, y, z]")[0]
    if "lock" not in t:
        raise t.fail("lock", "is missing (the axes the point fixes, e.g. lock = [\"x\", \"z\"])")
    lock = t.texts("lock", '["x", "y", "z"]')
    if not lock or not set(lock) <= set(AXES):
        raise t.fail("lock", f"must name some of the axes {', '.join(AXES)}, got "
                     f"{show(list(lock))}")
    return RpsPoint(label=label, nominal=nominal, lock=tuple(a for a in AXES if a in lock))


def _alignment(t: Table, datums: tuple[Datum, ...], regions: list[str],
               has_rps: bool) -> Alignment:
    method = t.text("method", choices=ALIGNMENTS, default="best-fit")
    for key in ("reference", "best_fit_regions"):
        if key in t and method != "datums":
            raise t.fail(key, f"applies to method \"datums\" only (method is {show(method)})")
    if method == "rps" and not has_rps:
        raise t.fail("method", "\"rps\" needs [[rps]] points (label, nominal, lock); the plan "
                     "has none")
    if method != "rps" and has_rps:
        raise t.fail("method", f"is {show(method)} but the plan has [[rps]] points; they "
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
            raise t.fail("best_fit_regions", f"names {show(name)}, which is not the name of "
                         f"any [[region]]{known(regions)}")
    return Alignment(method=method, reference=reference, best_fit_regions=best_fit)


def _characteristic(t: Table, regions: list[str], datums: tuple[Datum, ...]) -> Characteristic:
    ident = t.text("id", required=True)
    if ident.strip().lower() == RESERVED_ID:
        raise t.fail("id", f"'{ident}' is reserved for the zone over all points that --tol "
                     "adds to a plan (characteristic 'tol'); choose another id")
    kind = t.text("type", required=True, choices=CHARACTERISTICS)
    if kind in DIMENSIONS:
        return dimension(t, ident, kind, regions)
    region, pattern = _regions(t, kind, regions)
    lower, upper, nominal = _limits(t, kind)
    refs = _datum_references(t, "datums", datums)
    if (kind in FORM or kind == "size") and refs:
        raise t.fail("datums", "must not be given: " + (f"{kind} is form only" if kind in
                     FORM else "a size is the feature's own") + ", relative to no datum")
    if (kind in LOCATION or kind in ORIENTATION) and not refs:
        raise t.fail("datums", f"is missing or empty: a {kind} is " + (
                     "located" if kind in LOCATION else "oriented") + " relative to at "
                     "least one datum (e.g. datums = [\"A\", \"B\", \"C\"])")
    for label in refs:
        for part in known_datum_parts(label, [d.label for d in datums]):
            datum = next(d for d in datums if d.label == part)
            if datum.region in (region, *pattern):
                raise t.fail("datums", f"names datum {show(part)}, which is on region "
                             f"{show(datum.region)} itself: a feature cannot be related to "
                             "itself")
    if kind in RUNOUT:
        about_an_axis(t, kind, refs, datums)
    if "fit" in t and (kind not in PROFILES or refs):
        raise t.fail("fit", "applies to a form-only profile or line profile (one without "
                     "'datums') only")
    fit = t.text("fit", choices=PROFILE_FITS, default="lsq")
    c = Characteristic(id=ident, type=kind, region=region, lower=lower, upper=upper,
                       datums=refs, fit=fit, nominal=nominal, regions=pattern,
                       **_form_options(t, kind), **size_options(t, kind))
    datum_kind(t, c, datums)
    return c


def _regions(t: Table, kind: str, regions: list[str]) -> tuple[str, tuple[str, ...]]:
    """(the characteristic's region, a pattern's regions or ()): ``region``, or ``regions``
    (a position's pattern: two or more regions located together)."""
    if "regions" not in t:
        return _reference(t, "region", regions, "region", "name"), ()
    if kind != "position":
        raise t.fail("regions", f"applies to position only (a pattern located together), "
                     f"not {kind}: give 'region'")
    if "region" in t:
        raise t.fail("regions", "and 'region' are both given: a pattern gives 'regions' only")
    pattern = t.texts("regions", '["hole1", "hole2"]')
    if len(pattern) < 2:
        raise t.fail("regions", f"names {len(pattern)} region; a pattern has two or more "
                     "(one feature: give 'region')")
    for name in pattern:
        if name not in regions:
            raise t.fail("regions", f"names {show(name)}, which is not the name of any "
                         f"[[region]]{known(regions)}")
    return pattern[0], pattern


PROFILES = ("profile", "line_profile")


def _form_options(t: Table, kind: str) -> dict:
    """``direction``, ``sections``, ``diametral``, ``angle``, ``spacing`` and ``all_around``,
    each where its type takes it (engine.gdt.plan.Characteristic)."""
    takes = {"direction": ("straightness", "line_profile"),
             "sections": ("straightness", "circularity", "circular_runout"),
             "diametral": ("straightness",) + ORIENTATION, "angle": ("angularity",),
             "spacing": ("line_profile",), "all_around": PROFILES, "features": DIMENSIONS[1:]}
    for key, kinds in takes.items():
        if key in t and kind not in kinds:
            raise t.fail(key, f"applies to {' and '.join(kinds)} only, not {kind}")
    out: dict = {}
    if "direction" in t:
        d = t.points("direction", 1, "a direction [x, y, z]")[0]
        norm = math.sqrt(sum(v * v for v in d))
        if norm == 0.0:
            raise t.fail("direction", "must be a non-zero vector [x, y, z]")
        out["direction"] = tuple(v / norm for v in d)
    if "sections" in t:
        n = t.data["sections"]
        least = 3 if kind == "straightness" and "direction" not in t else 1
        if isinstance(n, bool) or not isinstance(n, int) or not least <= n <= MAX_SECTIONS:
            raise t.fail("sections", f"must be a whole number from {least} to {MAX_SECTIONS} "
                         f"(cross-sections along the feature), got {show(n)}")
        out["sections"] = n
    if "diametral" in t:
        value = t.data["diametral"]
        if not isinstance(value, bool):
            raise t.fail("diametral", f"must be true or false, got {show(value)}")
        if kind == "straightness" and value == ("direction" in t):
            raise t.fail("diametral", "true is a cylinder's median line (no 'direction'); a "
                         "surface's line elements along 'direction' have a zone of two lines")
        out["diametral"] = value
    out["diametral"] = out.get("diametral", kind == "straightness" and "direction" not in t)
    out.update(_line_profile_options(t, kind))
    if kind == "angularity":
        angle = t.number("angle")
        if angle is None:
            raise t.fail("angle", "is missing: an angularity states its basic angle to the "
                         "primary datum, degrees (e.g. angle = 30)")
        if not 0.0 < angle < 180.0:
            raise t.fail("angle", f"must be between 0 and 180 degrees, got {show(angle)}")
        out["angle"] = angle
    return out


MAX_SECTIONS = 1000
"""The most cross-sections a circularity, straightness or circular runout may ask for."""


def _line_profile_options(t: Table, kind: str) -> dict:
    """A line profile's ``direction`` (the sections' normal) and ``spacing`` (mm, required);
    a profile's ``all_around``."""
    out: dict = {}
    if kind == "line_profile":
        for key, what in (("direction", "the normal of its section planes, e.g. [1, 0, 0]"),
                          ("spacing", "the distance between its sections, mm")):
            if key not in t:
                raise t.fail(key, f"is missing: a line profile needs {what}")
        spacing = t.number("spacing")
        if spacing is None or not spacing > 0.0:  # None (absent) is refused above
            raise t.fail("spacing", f"must be > 0 (mm), got {show(t.data['spacing'])}")
        out["spacing"] = spacing
    if "all_around" in t:
        if not isinstance(t.data["all_around"], bool):
            raise t.fail("all_around", f"must be true or false, got "
                         f"{show(t.data['all_around'])}")
        out["all_around"] = t.data["all_around"]
    return out


def _limits(t: Table, kind: str) -> tuple[float, float, float | None]:
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
                         f"{show(t.data['nominal'])}")
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
    if kind in PROFILES and (lower is not None or upper is not None):
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
        raise t.fail("zone", f"must be > 0, got {show(t.data['zone'])}")
    return (-zone / 2, zone / 2, None) if kind in PROFILES else (0.0, zone, None)


def _explicit_limits(t: Table, lower: float | None,
                     upper: float | None) -> tuple[float, float]:
    if lower is None or upper is None:
        raise t.fail("lower" if lower is None else "upper",
                     "is missing: 'lower' and 'upper' are given together")
    if not lower < upper:
        raise t.fail("upper", f"must be above 'lower', got lower {lower:g}, upper {upper:g}")
    return lower, upper


def _reference(t: Table, key: str, names: list[str], table: str, name_key: str) -> str:
    """The key's value, which must be the ``name_key`` of one of the [[table]] entries."""
    value = t.text(key, required=True)
    if value not in names:
        raise t.fail(key, f"{show(value)} is not the {name_key} of any [[{table}]]"
                     f"{known(names)}")
    return value


def _datum_references(t: Table, key: str, datums: tuple[Datum, ...]) -> tuple[str, ...]:
    """A datum reference frame: at most MAX_DATUMS distinct datum labels, primary first."""
    refs = t.texts(key, '["A", "B", "C"]')
    labels = [d.label for d in datums]
    for label in refs:
        shifted = DATUM_MODIFIER.match(label)
        if shifted and shifted.group(1) in labels:
            raise t.fail(key, f"names {show(label)}: a datum feature at "
                         f"{'MMC' if shifted.group(2) == 'M' else 'LMC'} (datum shift) is not "
                         f"supported yet; write {show(shifted.group(1))} to judge it "
                         "regardless of its size")
        parts = datum_parts(label, labels)
        if parts is None:
            raise t.fail(key, f"names {show(label)}, which is not the label of any "
                         f"[[datum]]{known(labels)}, nor a common datum of two (\"A-B\")")
        kinds = {next(d for d in datums if d.label == p).feature for p in parts}
        if len(parts) > 1 and (len(parts) != 2 or len(kinds) != 1 or
                               kinds - {"plane", "cylinder"}):
            raise t.fail(key, f"names the common datum {show(label)}: a common datum joins "
                         "two datums of one kind, two coaxial cylinders or two coplanar "
                         f"planes; its parts are {' and '.join(sorted(kinds))}")
    if len(refs) > MAX_DATUMS:
        raise t.fail(key, f"names {len(refs)} datums; a datum reference frame has at most "
                     f"{MAX_DATUMS} (primary, secondary, tertiary)")
    return refs


def _unique(tables: list[Table], key: str) -> None:
    """Refuse two entries of one array of tables with the same ``key``."""
    first: dict[str, Table] = {}
    for t in tables:
        value = t.data[key]
        if value in first:
            raise t.fail(key, f"{show(value)} is also the {key} of "
                         f"{first[value].title.split(' (')[0]}")
        first[value] = t


def _same_dimension(tables: list[Table], datums: tuple[Datum, ...]) -> None:
    """A plan's datums are all 3D features or all 2D features (one nominal is one or the other)."""
    for t, datum in zip(tables, datums):
        first = datums[0]
        if (datum.feature in FEATURES_2D) != (first.feature in FEATURES_2D):
            raise t.fail("feature", f"{show(datum.feature)} does not go with datum "
                         f"{show(first.label)}'s {show(first.feature)}: a plan's datums are "
                         f"all 3D ({', '.join(FEATURES_3D)}) or all 2D ({', '.join(FEATURES_2D)})")
