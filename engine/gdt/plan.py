"""An inspection plan: what a drawing asks of the part, as data (read by engine.io.plan).

Without a plan the product answers one question: after a best fit over all points, is every point
within the zone? A plan states, like the drawing's feature control frames:

* regions: named sets of nominal points (a box in nominal coordinates, a glob on the nominal's
  point labels, or a named group: a mesh's face group, a DXF layer), optionally with the measured points' labels;
* datums: features fitted to a region's measured points (plane, cylinder, sphere in 3D; line,
  circle in 2D), tangent (outside the material, ASME Y14.5 / ISO 5459 default) or least squares;
* the alignment: how the part is placed before it is judged: a best fit (today's behaviour), a
  datum reference frame (primary, secondary, tertiary; the freedom they leave best-fitted on named
  regions), or reference point system (RPS) points;
* characteristics: profile (relative to datums, or form only), the form family (flatness,
  straightness, circularity, cylindricity: engine.gdt.form), the orientation family
  (parallelism, perpendicularity, angularity relative to datums: engine.gdt.orientation),
  the location family (position of holes, pins, widths, spheres and patterns, coaxiality,
  concentricity, symmetry: engine.gdt.location) and size (engine.gdt.size), each with its
  zone.

Units mm; coordinates in the nominal frame. Every object here is frozen.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from ..errors import InputError
from ..uncertainty import Instrument

FEATURES_3D = ("plane", "cylinder", "sphere", "width")
FEATURES_2D = ("line", "circle")
DATUM_FITS = ("tangent", "lsq")
ALIGNMENTS = ("best-fit", "datums", "rps")
FORM = ("flatness", "straightness", "circularity", "cylindricity")
"""The form family (ASME Y14.5 / ISO 1101): the feature's own shape, relative to no datum."""
ORIENTATION = ("parallelism", "perpendicularity", "angularity")
"""The orientation family: a plane (zone between two planes) or an axis (``diametral``: a
cylindrical zone) at the required orientation to its datums."""
LOCATION = ("position", "coaxiality", "concentricity", "symmetry")
"""The location family (engine.gdt.location): a feature of size's axis, centre plane or
centre relative to datums."""
RUNOUT = ("circular_runout", "total_runout")
"""The runout family (engine.gdt.runout): a surface of revolution (radial) or a face normal to
the datum axis (axial), turned about a datum axis: the full indicator movement."""
DIMENSIONS = ("radius", "angle", "distance")
"""Dimensions with limits about a nominal (engine.gdt.dimensions): a cylinder's or sphere's
radius (mm), the angle between two features (degrees) and the distance between two features
(mm), each judged on least-squares fits, relative to no datum."""
CHARACTERISTICS = ("profile", "flatness", "position", "size") + FORM[1:] + ORIENTATION \
    + LOCATION[1:] + RUNOUT + ("line_profile",) + DIMENSIONS
ZONE_ONLY = LOCATION + FORM + ORIENTATION + RUNOUT
"""Types whose value is >= 0 by definition with an upper limit only (0 .. zone)."""
SYMBOLS = {"profile": "⌓", "flatness": "⏥", "position": "⌖", "size": "⌀",
           "straightness": "⏤", "circularity": "○", "cylindricity": "⌭",
           "parallelism": "∥", "perpendicularity": "⟂", "angularity": "∠",
           "coaxiality": "◎", "concentricity": "◎", "symmetry": "⌯",
           "circular_runout": "↗", "total_runout": "⌰", "line_profile": "⌒",
           "radius": "R", "angle": "∡", "distance": "↔"}
"""Each characteristic type's symbol on a drawing (ASME Y14.5 / ISO 1101), in one place."""
SIZE_FEATURES = ("cylinder", "sphere", "width")
"""Features of size a ``feature`` key may name for size and location: a cylinder (a hole or a
pin, told apart by the material side), a sphere, a width (two opposed parallel planes: a slot
or a tab)."""
SIZE_METHODS = ("lsq", "two-point", "min-circumscribed", "max-inscribed")
"""How a size is taken (ISO 14405-1): least squares (GG), two-point local sizes (LP: their
smallest and largest), the minimum circumscribed (GN) or maximum inscribed (GX) feature."""
SIZE_METHOD_WORDS = {"lsq": "least-squares", "two-point": "two-point",
                     "min-circumscribed": "minimum circumscribed",
                     "max-inscribed": "maximum inscribed"}
"""Each size method in words, as results and QIF descriptions say it."""
MODIFIERS = ("RFS", "MMC", "LMC")
"""Material condition of a toleranced feature of size: regardless of feature size (the
default), maximum or least material condition (a bonus tolerance)."""
DIMENSION_FEATURES = {"radius": ("cylinder", "sphere"), "angle": ("plane", "cylinder"),
                      "distance": ("plane", "cylinder", "sphere")}
"""The features each dimension is taken on (a cylinder in an angle or a distance: its axis; a
sphere in a distance: its centre)."""
UNITS = {"angle": "degree"}
"""The unit of a characteristic's value and limits where it is not mm."""
DEFAULT_SECTIONS = 8
"""Cross-sections a circularity (and a straightness) is judged on by default."""
ORIENTATION_ANGLE = {"parallelism": 0.0, "perpendicularity": 90.0}
"""The basic angle (degrees) of parallelism and perpendicularity; angularity states its own."""
PROFILE_FITS = ("lsq", "minimax")
"""How a form-only profile refits its region: least squares, or minimax (the smallest zone)."""
MAX_DATUMS = 3
"""A datum reference frame has at most a primary, a secondary and a tertiary datum."""
AXES = ("x", "y", "z")
"""The nominal frame's axes an RPS point may lock, in this order."""
CONSTRAINED_DOFS = {"plane": 3, "cylinder": 4, "sphere": 3, "line": 2, "circle": 2}
"""Degrees of freedom a datum feature can constrain on its own (a plane: the translation along
its normal and the two tilts; a cylinder: its axis' direction and position; a sphere: its
centre; in 2D a line: its direction and offset; a circle: its centre)."""
MIN_POINTS = {"plane": 3, "cylinder": 5, "sphere": 4, "line": 2, "circle": 3, "width": 6}
"""Fewest measured points that determine the feature (fewer: the characteristics that need it
are INCONCLUSIVE, never guessed)."""


SUMMARY_KINDS = 8
"""The kinds of characteristics not judged a plan's summary names, at most (the rest counted)."""
SUMMARY_WORDS = 80
"""The characters of a kind's name in that summary, at most."""
MAX_CHARACTERISTICS = 10_000
"""The most characteristics a plan may hold (engine.io.plan refuses more): a first-article
inspection of a large assembly has a few thousand; each costs its own judgement, and ten
thousand take a few seconds on top of their regions' work."""

RESERVED_ID = "tol"
"""The characteristic id of the zone over all points that --tol adds to a plan: no plan may use
it."""

@dataclass(frozen=True)
class Part:
    """What the certificate names: part number, name, drawing revision, drawing number and the
    CAD model's revision (each may be empty)."""

    number: str = ""
    name: str = ""
    revision: str = ""
    drawing: str = ""
    cad_revision: str = ""


@dataclass(frozen=True)
class Measurement:
    """How the part was measured (``[measurement]``): what the certificate's traceability block
    states (each may be empty), and the instrument's performance for the uncertainty budget."""

    device: str = ""
    device_serial: str = ""
    calibration_date: str = ""
    """ISO 8601 date, YYYY-MM-DD."""
    probe: str = ""
    """The probe and stylus (e.g. "TP20, stylus M2 ruby 2 mm x 20 mm")."""
    program: str = ""
    """The measurement program (its name or file)."""
    temperature_c: float | None = None
    """The part's temperature during the measurement, °C."""
    instrument: Instrument | None = None
    """The instrument's stated performance (engine.uncertainty), None when the plan states
    none: its temperature is ``temperature_c``."""


@dataclass(frozen=True)
class Region:
    """A named set of nominal points, by exactly one selector.

    box : ((3,), (3,)) lower and upper corners of an axis-aligned box, nominal frame, mm;
    labels : fnmatch glob on the nominal point file's label column;
    group : the names of groups of the nominal (one or more, their union): a mesh's face
        group (OBJ ``g``/``o``, a PLY face property's number), a 2D template's DXF layer
        (compared without case), a STEP face ``face:N`` (engine.gdt.regions);
    measured_labels : fnmatch glob: measured points with these labels belong here (else a
        measured point belongs to the region of its nearest nominal point).
    """

    name: str
    box: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    labels: str | None = None
    group: str | tuple[str, ...] | None = None
    measured_labels: str | None = None


@dataclass(frozen=True)
class Datum:
    label: str
    region: str
    feature: str
    """plane | cylinder | sphere (3D); line | circle (2D)."""
    fit: str = "tangent"
    """tangent: outside the material, minimising the largest gap; lsq: least squares."""


@dataclass(frozen=True)
class RpsPoint:
    """A reference point: the measured point labelled ``label`` is moved onto ``nominal`` along
    the locked axes of the nominal frame ("x", "y", "z")."""

    label: str
    nominal: tuple[float, float, float]
    lock: tuple[str, ...]
    """A non-empty subset of ``AXES``, in that order."""


@dataclass(frozen=True)
class Alignment:
    method: str = "best-fit"
    reference: tuple[str, ...] = ()
    """Datum labels, primary first."""
    best_fit_regions: tuple[str, ...] = ()
    """Regions whose points best-fit the degrees of freedom the datums leave free (method
    "datums" only)."""


@dataclass(frozen=True)
class Characteristic:
    """One requirement of the drawing.

    id : the balloon number. type : one of ``CHARACTERISTICS``.
    lower, upper : the zone, mm. Profile: limits of the signed deviation (zone = 0.1 is
        -0.05 .. +0.05). Flatness and position: 0 .. zone (position: a diameter). Size: limits
        of the fitted diameter about ``nominal``.
    datums : datum labels the characteristic is relative to, primary first; empty: form only
        (a profile then refits its region with ``fit``).
    """

    id: str
    type: str
    region: str
    lower: float
    upper: float
    datums: tuple[str, ...] = ()
    fit: str = "lsq"
    """A form-only profile's refit (``PROFILE_FITS``); not used by the other types."""
    nominal: float | None = None
    """Size only: the nominal diameter, mm (``lower`` and ``upper`` are offsets about it)."""
    direction: tuple[float, float, float] | None = None
    """Straightness of a surface's line elements: the direction they run along, nominal frame
    (a unit vector); None: a cylinder's derived median line."""
    sections: int | None = None
    """Circularity and straightness: how many cross-sections along the feature (None: the
    default, ``DEFAULT_SECTIONS``)."""
    diametral: bool = False
    """Orientation: the toleranced feature is a cylinder's axis and the zone a cylinder (else a
    plane between two planes)."""
    angle: float | None = None
    """Angularity: the basic angle to the primary datum, degrees."""
    kind: str | None = None
    """The plan's ``feature``: the feature of size of a size or location (``SIZE_FEATURES``);
    None: a cylinder (a hole or a pin)."""
    method: str = "lsq"
    """Size: how the size is taken (``SIZE_METHODS``)."""
    modifier: str = "RFS"
    """Position: the toleranced feature's material condition (``MODIFIERS``)."""
    regions: tuple[str, ...] = ()
    """A pattern's regions (``region`` is the first): all located together in one datum
    reference frame; () for one feature."""
    spacing: float | None = None
    """Line profile: the distance between its cross-sections (planes normal to
    ``direction``), mm."""
    all_around: bool = False
    """Profile: the drawing's all-around symbol (the region's faces as one; a region is
    already any set of faces, so it is recorded, not computed differently)."""
    features: tuple[str, ...] = ()
    """An angle or a distance: the feature each of its two ``regions`` is (plane, cylinder:
    its axis, sphere: its centre); () for the other types."""
    name: str = ""
    """Its name in the plan's source (a QIF characteristic's Name, e.g. "Position.1"), or ""."""
    designator: str = ""
    """Its balloon number on the drawing (a QIF characteristic's Designator, e.g. "14"), or "":
    the certificate's balloon then shows ``id``."""
    source: str = ""
    """The item of a source other than the plan's own table it was read from: a QIF
    characteristic nominal's element and id ("PositionCharacteristicNominal 1443"); ""."""

    @property
    def width(self) -> float:
        return self.upper - self.lower

    @property
    def balloon(self) -> str:
        """Its number as the drawing's balloon shows it: the designator (the k-th of the
        characteristics a source's one was split into keeps its ".k"), else the id."""
        if not self.designator:
            return self.id
        item = self.source.rsplit(" ", 1)[-1]
        split = self.id[len(item):] if item and self.id.startswith(item + ".") else ""
        return self.designator + split

    @property
    def called(self) -> str:
        """How a message names it: "characteristic p1 (size)"; from a QIF, by its balloon with
        its name and id: "characteristic 3 (size; Linear Size.3, id 1479)"."""
        more = ", ".join(x for x in (self.name, f"id {self.id}" if self.designator else "")
                         if x)
        return f"characteristic {self.balloon} ({self.type}{'; ' + more if more else ''})"

    @property
    def feature(self) -> str:
        """The feature its region must be: plane | cylinder, or freeform (a profile)."""
        return implied_feature(self.type, self.direction is not None, self.diametral,
                               self.kind)

    @property
    def all_regions(self) -> tuple[str, ...]:
        """The regions judged: a pattern's, else the one region."""
        return self.regions or (self.region,)

    @property
    def region_features(self) -> tuple[tuple[str, str], ...]:
        """(region, the feature it is judged as) for each of its regions: an angle's and a
        distance's own ``features``, else ``feature`` for all."""
        if self.features:
            return tuple(zip(self.all_regions, self.features))
        return tuple((r, self.feature) for r in self.all_regions)

    @property
    def unit(self) -> str:
        """The unit of its value and limits: "degree" for an angle, else "mm"."""
        return UNITS.get(self.type, "mm")


def implied_feature(kind: str, direction: bool = False, diametral: bool = False,
                    feature: str | None = None) -> str:
    """The feature a characteristic of type ``kind`` is judged on: a plane (flatness, a
    straightness along a ``direction``, an orientation without ``diametral``), the ``feature``
    a size or location names (a width always for a symmetry), a cylinder (position, size,
    coaxiality, circularity, cylindricity, a straightness of the median line, an orientation
    of an axis), else freeform (a profile's surface; a runout's, a cylinder or a face normal to
    its datum axis, which the datum axis tells apart)."""
    if kind == "symmetry":
        return "width"
    if feature is not None and kind in ("size", "position", "radius") + ORIENTATION:
        return feature  # (an orientation's: a width's median plane)
    if kind in ("angle", "distance"):
        return "freeform"  # two features: Characteristic.region_features
    if kind == "flatness" or (kind == "straightness" and direction) or (
            kind in ORIENTATION and not diametral):
        return "plane"
    return "freeform" if kind in ("profile", "line_profile") + RUNOUT else "cylinder"


@dataclass(frozen=True)
class NotJudged:
    """A characteristic of the plan's source that the plan layer cannot judge yet (a QIF
    perpendicularity, a position at MMC …): kept, with why, so that nothing is dropped
    silently; it makes the part INCONCLUSIVE (engine.gdt.characteristics)."""

    id: str
    type: str
    """The source's word for it (e.g. "perpendicularity", "distance between")."""
    name: str
    """Its name or designator in the source (e.g. "Perpendicularity.1"), or ""."""
    reason: str


@dataclass(frozen=True)
class Plan:
    path: str
    sha256: str
    part: Part
    regions: tuple[Region, ...]
    datums: tuple[Datum, ...]
    alignment: Alignment
    characteristics: tuple[Characteristic, ...]
    rps: tuple[RpsPoint, ...] = ()
    measurement: Measurement = Measurement()
    not_judged: tuple[NotJudged, ...] = ()
    """The source's characteristics left out of ``characteristics`` (a QIF plan's)."""
    n_source: int | None = None
    """How many characteristics the source file holds (a QIF's, judged or not); None: the
    plan's own ``characteristics`` are all of them."""

    @property
    def n_stated(self) -> int:
        """How many characteristics the plan's source states: a QIF's ``n_source``; else the
        characteristics counted once per ``source`` they name (a TOML plan written from a QIF
        names the QIF characteristic each came from, and one may be judged as several: its
        "14 of 47" reads "14 of 47" again, not "14 of 70"), each without one by itself, and
        the ones not judged."""
        if self.n_source is not None:
            return self.n_source
        return len({c.source or ("id", c.id) for c in self.characteristics}) + \
            len(self.not_judged)

    @property
    def not_judged_summary(self) -> str:
        """"N of M characteristics of FILE are not judged yet: TYPES" ("" when all are)."""
        if not self.not_judged:
            return ""
        counts: dict[str, int] = {}
        for c in self.not_judged:
            counts[c.type] = counts.get(c.type, 0) + 1
        # At most SUMMARY_KINDS kinds, each at most SUMMARY_WORDS characters: the verdict that
        # carries it must fit a certificate's cell (200 kinds made a cell taller than a page).
        shown = [(t if len(t) <= SUMMARY_WORDS else t[:SUMMARY_WORDS - 1] + "…")
                 + ("" if k == 1 else f" ({k})") for t, k in list(counts.items())[:SUMMARY_KINDS]]
        more = len(counts) - SUMMARY_KINDS
        types = ", ".join(shown) + (f" and {more} more kinds" if more > 0 else "")
        return (f"{len(self.not_judged)} of {self.n_stated} characteristics of "
                f"{os.path.basename(self.path)} are not judged yet: {types}")

    def region(self, name: str) -> Region:
        return next(r for r in self.regions if r.name == name)

    def datum(self, label: str) -> Datum:
        return next(d for d in self.datums if d.label == label)


COMMON = "-"
"""A common datum joins its datums' labels with this: "A-B" (ASME Y14.5 / ISO 5459)."""


def datum_parts(label: str, labels) -> tuple[str, ...] | None:
    """The datum labels a reference names: itself when it is a datum's label (of ``labels``),
    the labels of a common datum "A-B" when each part is one, else None."""
    if label in labels:
        return (label,)
    parts = tuple(label.split(COMMON))
    return parts if len(parts) > 1 and all(p in labels for p in parts) else None


def not_too_many(count: int, path: str) -> None:
    """Refuse a plan (a TOML's, a QIF's) of more than MAX_CHARACTERISTICS characteristics."""
    if count > MAX_CHARACTERISTICS:
        raise InputError(f"holds {count:,} characteristics; a plan may hold at most "
                         f"{MAX_CHARACTERISTICS:,} (split it into plans of parts of the "
                         "drawing)", path)


def known_datum_parts(label: str, labels) -> tuple[str, ...]:
    """:func:`datum_parts` of a reference the plan must resolve (a characteristic's datum): an
    InputError when it names no datum of ``labels``, nor a common datum of two of them."""
    parts = datum_parts(label, labels)
    if parts is None:
        raise InputError(f"datum reference '{label}' is not the label of any [[datum]], nor a "
                         "common datum of two (\"A-B\")")
    return parts
