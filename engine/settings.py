"""The settings of one inspection besides its two files (a light module: the desktop app's
session holds them without loading the engine)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from .choices import DecisionRule, Fit
from .errors import SettingsError
from .scene import check_box
from .seeds import DEFAULT_SEED
from .tolerance import Tolerance
from .uncertainty import Instrument


@dataclass(frozen=True)
class InspectionSettings:
    """Everything besides the two files that decides an inspection's outcome.

    Stored in the results document (``settings``) so that a certificate can be re-checked.
    """

    tol_lower: float | None
    """Lower limit of the tolerance zone, mm. None with ``tol_upper`` None and a ``plan``: the
    plan's characteristics are the requirement, and the zone is the plan's
    (engine.pipeline.zone_of, when the nominal is loaded; as ``--plan`` without ``--tol``)."""
    tol_upper: float | None
    """Upper limit of the tolerance zone, mm (None: as ``tol_lower``)."""
    layers: tuple[str, ...] | None = None
    """DXF template: the layers taken (None: every layer)."""
    units: str | None = None
    """DXF template: its units, overriding the drawing's $INSUNITS."""
    scale: float | None = None
    """Airfoil ordinate template: chord length, mm."""
    fit: Fit = Fit.LSQ
    """Least squares, or minimax (smallest largest excursion from the zone's centre); a word
    ("lsq", "minimax") is taken as its member."""
    decision_rule: DecisionRule = DecisionRule.SIMPLE
    """Simple, or guarded (limits guarded by each point's expanded uncertainty, ISO 14253-1); a
    word ("simple", "guarded") is taken as its member."""
    plan: str | None = None
    """An inspection plan (TOML, engine.io.plan): datums, alignment, characteristics."""
    zone_in_verdict: bool = True
    """Whether the zone [tol_lower, tol_upper] over all points is part of the verdict. Without
    a plan it is the verdict; with one it is one more profile characteristic when the user gave
    it (--tol), and only the zone of the per-point statistics when the plan chose it."""
    instrument: Instrument | None = None
    """What the user states about the measuring instrument (``--uncertainty``, the app's
    session): the guarded rule decides with each point's expanded uncertainty
    (engine.uncertainty). None: the plan's ``[measurement]`` when it states one, else none."""
    guard: str = "uncertainty"
    """The guarded rule's guard band: "uncertainty", each point's expanded uncertainty U; or
    "sampling", its nominal-sampling margin alone (how certificates made before uncertainty
    budgets were judged: ``verify`` re-runs them so)."""
    crop: tuple[float, float, float, float, float, float] | None = None
    """Keep only the measured points inside this box (xmin, ymin, zmin, xmax, ymax, zmax), mm,
    in the measured file's coordinates, faces included (engine.scene); None: every point."""
    remove_plane: bool = False
    """Remove the dominant plane (the table under the part) from the measured points, after the
    crop (engine.scene.dominant_plane)."""
    plane_distance: float | None = None
    """With ``remove_plane``: the points within this distance of the plane are removed, mm;
    None: the distance engine.scene.dominant_plane chooses from the data."""
    seed: int = DEFAULT_SEED
    """The seed of every random choice of the inspection (seeded subsets of the points, RANSAC,
    the nominal's coarse levels), >= 0; each draws its own stream from it (engine.seeds). The
    same files, settings and seed give the same numbers; 0, the default, gives the numbers
    inspections had before the seed could be chosen. Always in the JSON (a re-run needs it)."""

    def __post_init__(self):
        # A word given for a choice becomes its member; one that names none is left as it is,
        # for engine.inspection's check to refuse with the choices (SettingsError).
        for name, kind in (("fit", Fit), ("decision_rule", DecisionRule)):
            value = getattr(self, name)
            if isinstance(value, str) and value in {m.value for m in kind}:
                object.__setattr__(self, name, kind(value))

    @property
    def tolerance(self) -> Tolerance:
        """The zone; SettingsError while it is left to the plan (engine.pipeline.zone_of)."""
        if self.tol_lower is None or self.tol_upper is None:
            raise SettingsError("the tolerance zone is left to the plan: it is known once the "
                                "plan is read (engine.pipeline.zone_of)")
        return Tolerance(self.tol_lower, self.tol_upper)

    def to_json(self) -> dict:
        d = asdict(self)
        d["layers"] = None if self.layers is None else list(self.layers)
        if self.guard == "uncertainty":
            del d["guard"]  # the default; an "instrument" key (null or not) says so
        # Off, the scene options are left out: the settings of an inspection without them
        # read as they did before they existed (a batch's resume key, a certificate's JSON).
        if self.crop is None:
            del d["crop"]
        else:
            d["crop"] = list(self.crop)
        if not self.remove_plane:
            del d["remove_plane"]
        if self.plane_distance is None:
            del d["plane_distance"]
        return d

    @classmethod
    def from_json(cls, d: dict) -> "InspectionSettings":
        layers = d.get("layers")
        return cls(float(d["tol_lower"]), float(d["tol_upper"]),
                   None if layers is None else tuple(str(x) for x in layers),
                   d.get("units"), None if d.get("scale") is None else float(d["scale"]),
                   d.get("fit", Fit.LSQ), d.get("decision_rule", DecisionRule.SIMPLE),
                   d.get("plan"),
                   bool(d.get("zone_in_verdict", True)),
                   Instrument.from_json(d.get("instrument")),
                   # Settings without "instrument" are older than uncertainty budgets: their
                   # guarded rule guarded by the sampling margin alone.
                   d.get("guard") or ("uncertainty" if "instrument" in d else "sampling"),
                   None if d.get("crop") is None else check_box(d["crop"]),
                   bool(d.get("remove_plane", False)),
                   None if d.get("plane_distance") is None else float(d["plane_distance"]),
                   # Settings without "seed" are older than it: their inspections drew seed 0's.
                   int(d.get("seed", DEFAULT_SEED)))

