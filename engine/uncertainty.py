"""The measurement uncertainty of each point's deviation, and the budget it comes from
(ISO/IEC Guide 98-3, GUM: standard uncertainties combined by root-sum-of-squares, expanded with
a coverage factor k = 2).

The guarded decision rule (engine.verdict, ISO 14253-1) decides with each point's expanded
uncertainty U: a point conforms when it lies inside the tolerance zone shrunk by its U, does not
conform when it lies outside the zone grown by its U, and is inconclusive in between.

The terms, each a standard uncertainty u (mm) per point, and their assumptions:

* ``stated``: an expanded uncertainty U_s the user states for the instrument (``--uncertainty``,
  or ``uncertainty_mm`` in the plan's ``[measurement]``), k = 2 (normal): u = U_s / 2. It takes
  the place of the three instrument terms below.
* ``length``: the instrument's length-measurement error MPE_E = A + L / K (µm; ISO 10360-2),
  taken as a rectangular distribution over +-MPE_E: u = MPE_E / sqrt(3). L is the point's
  distance (mm) from the centroid of the fitted points, the origin the best fit measures from
  (a scale error moves a point by at most that distance times the error).
* ``probing``: the probing error MPE_P (µm; ISO 10360-5), rectangular: u = MPE_P / sqrt(3).
* ``temperature``: the part at t °C, measured without temperature compensation, expands by
  L x alpha x (t - 20 °C) against its 20 °C drawing (ISO 1); the uncorrected expansion is taken
  as a rectangular distribution over +-that: u = L x alpha x |t - 20| / sqrt(3).
* ``pose``: the registration's pose is fitted to the points by least squares; its covariance
  s^2 (J^T J)^+ (s from the fit's residuals, engine.trust.pose_covariance) propagated to the
  point: u = sqrt(J_i cov J_i^T) (normal). Directions the points do not fix at all carry no
  variance here: engine.pose_sensitivity scans them instead.
* ``sampling``: the nominal-sampling margin m (curvature x spacing^2 / 8; 0 against exact lines,
  arcs and B-rep faces), the most a chord between samples can sag below the true surface, taken
  as rectangular over +-m: u = m / sqrt(3).

U = k x sqrt(sum of u^2), k = 2.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .errors import SettingsError

COVERAGE_FACTOR = 2.0
REFERENCE_TEMPERATURE_C = 20.0
"""ISO 1: the temperature at which a drawing's dimensions hold."""
SQRT3 = float(np.sqrt(3.0))


@dataclass(frozen=True)
class Instrument:
    """What the user states about the measuring instrument and the conditions (all optional).

    Either ``uncertainty_mm`` (a stated expanded uncertainty) or the MPE terms; with none of
    them, only the registration's pose and the nominal's sampling enter the budget.
    """

    uncertainty_mm: float | None = None
    """An expanded uncertainty U (k = 2, mm) of the instrument, stated by the user; replaces
    the MPE, probing and temperature terms."""
    mpe_a_um: float | None = None
    """A of the length-measurement MPE_E = A + L / K, µm."""
    mpe_l_per_um: float | None = None
    """K of MPE_E = A + L / K: mm of measured length per µm (e.g. 250: 1 µm per 250 mm)."""
    probing_um: float | None = None
    """The probing error MPE_P, µm."""
    temperature_c: float | None = None
    """The part's temperature during the measurement, °C."""
    expansion_per_k: float | None = None
    """The part's coefficient of thermal expansion, 1/K (aluminium 23e-6, steel 11.5e-6)."""

    def __post_init__(self):
        for key, value in asdict(self).items():
            if value is not None and not np.isfinite(value):
                raise SettingsError(f"{key} must be a finite number, got {value!r}")
        for key in ("uncertainty_mm", "mpe_a_um", "probing_um", "expansion_per_k"):
            v = getattr(self, key)
            if v is not None and v < 0:
                raise SettingsError(f"{key} must not be negative, got {v:g}")
        if self.mpe_l_per_um is not None and not self.mpe_l_per_um > 0:
            raise SettingsError(f"mpe_l_per_um (K of MPE = A + L/K) must be > 0, got "
                                f"{self.mpe_l_per_um:g}")
        if self.expansion_per_k is not None and self.temperature_c is None:
            raise SettingsError("expansion_per_k needs temperature_c (the part's temperature, "
                                "°C) for the thermal term")

    @property
    def states_anything(self) -> bool:
        """Whether any term of the instrument is given (a temperature alone is none)."""
        return any(v is not None for v in (self.uncertainty_mm, self.mpe_a_um,
                                           self.mpe_l_per_um, self.probing_um,
                                           self.expansion_per_k))

    def to_json(self) -> dict:
        return asdict(self)

    @classmethod
    def from_json(cls, d: dict | None) -> "Instrument | None":
        if d is None:
            return None
        return cls(**{k: None if d.get(k) is None else float(d[k])
                      for k in cls.__dataclass_fields__})


@dataclass(frozen=True)
class Term:
    """One term of the budget: a standard uncertainty per point."""

    key: str
    """stated | length | probing | temperature | pose | sampling."""
    name: str
    """In words, for the certificate."""
    distribution: str
    """"rectangular" or "normal"."""
    divisor: float
    """What the bound (or the expanded value) is divided by to give u: sqrt(3), 2 or 1."""
    u: np.ndarray
    """(n,) standard uncertainty per point, mm."""
    basis: str
    """Where the value comes from and what is assumed, in words."""


@dataclass(frozen=True)
class UncertaintyBudget:
    """Each point's expanded uncertainty U and the terms it combines."""

    terms: tuple[Term, ...]
    expanded: np.ndarray
    """(n,) U = k x sqrt(sum of the terms' u^2), mm."""
    length_mm: np.ndarray
    """(n,) L: each point's distance from the centroid of the fitted points, mm."""
    k: float = COVERAGE_FACTOR
    instrument: Instrument | None = None


def budget(points: np.ndarray, normals: np.ndarray, fitted: np.ndarray, residual_rms: float,
           cond, sampling: np.ndarray | None, instrument: Instrument | None
           ) -> UncertaintyBudget:
    """The budget of every point.

    points, normals : (n, 3) or (n, 2) measured points at the fitted pose (nominal frame, mm)
        and the nominal's normals at their feet; fitted : (n,) bool, the points the pose was
        fitted to; residual_rms : the fit's RMS residual over them (mm); cond : the fit's
        engine.trust.Conditioning; sampling : (n,) nominal-sampling margin, mm (None: 0);
        instrument : what the user states (None: nothing).
    """
    from .trust import deviation_jacobian, deviation_sigma, pose_covariance

    X = np.asarray(points, float)
    n, dim = X.shape
    centre = np.asarray(cond.centre, float) if cond is not None and len(cond.centre) else (
        X[fitted].mean(axis=0) if np.any(fitted) else np.zeros(dim))
    L = np.linalg.norm(X - centre, axis=1)
    terms = list(_instrument_terms(instrument, L))
    dof = 6 if dim == 3 else 3
    pose = np.zeros(n)
    if (cond is not None and cond.length and len(cond.centre) and np.isfinite(residual_rms)
            and int(np.count_nonzero(fitted)) > dof):
        cov = pose_covariance(deviation_jacobian(X[fitted], normals[fitted], cond),
                              residual_rms, cond)
        pose = deviation_sigma(deviation_jacobian(X, normals, cond), cov)
    terms.append(Term("pose", "registration (pose of the best fit)", "normal", 1.0, pose,
                      "the least-squares pose's covariance from the fit's residuals "
                      f"(RMS {residual_rms:.4g} mm), propagated to each point"))
    m = np.zeros(n) if sampling is None else np.asarray(sampling, float)
    terms.append(Term("sampling", "nominal sampling", "rectangular", SQRT3, m / SQRT3,
                      "chord sag between nominal samples, curvature x spacing² / 8 (0 for "
                      "exact lines, arcs and B-rep faces), rectangular"))
    u2 = sum(t.u * t.u for t in terms)
    return UncertaintyBudget(tuple(terms), COVERAGE_FACTOR * np.sqrt(u2), L,
                             COVERAGE_FACTOR, instrument)


def _instrument_terms(ins: Instrument | None, L: np.ndarray):
    """The instrument's terms (none when it states nothing)."""
    n = L.size
    if ins is None:
        return
    if ins.uncertainty_mm is not None:
        yield Term("stated", "instrument (stated expanded uncertainty)", "normal", 2.0,
                   np.full(n, ins.uncertainty_mm / 2.0),
                   f"U = {ins.uncertainty_mm:g} mm stated for the instrument, k = 2")
        return
    if ins.mpe_a_um is not None or ins.mpe_l_per_um is not None:
        a = ins.mpe_a_um or 0.0
        # An array even without the L / K part: expanded_at indexes each term per point.
        mpe_um = a + (L / ins.mpe_l_per_um if ins.mpe_l_per_um else np.zeros(n))
        k_text = f" + L/{ins.mpe_l_per_um:g}" if ins.mpe_l_per_um else ""
        yield Term("length", "instrument length error MPE_E", "rectangular", SQRT3,
                   mpe_um / 1000.0 / SQRT3,
                   f"MPE_E = {a:g}{k_text} µm (L: distance from the centroid of the fitted "
                   "points, mm), rectangular")
    if ins.probing_um is not None:
        yield Term("probing", "probing error MPE_P", "rectangular", SQRT3,
                   np.full(n, ins.probing_um / 1000.0 / SQRT3),
                   f"MPE_P = {ins.probing_um:g} µm, rectangular")
    if ins.expansion_per_k is not None and ins.temperature_c is not None:
        dt = abs(ins.temperature_c - REFERENCE_TEMPERATURE_C)
        yield Term("temperature", "temperature (uncompensated expansion)", "rectangular",
                   SQRT3, L * ins.expansion_per_k * dt / SQRT3,
                   f"part at {ins.temperature_c:g} °C, CTE {ins.expansion_per_k:g}/K: "
                   f"L x CTE x {dt:g} K against 20 °C, rectangular")


def expanded_at(b: UncertaintyBudget, idx: np.ndarray,
                sampling: np.ndarray | None = None, without: tuple[str, ...] = ()
                ) -> np.ndarray:
    """(len(idx),) U of the points ``idx``, with their sampling term taken from the margins
    ``sampling`` (mm; another pose's, e.g. an inspection plan's alignment) instead of the
    budget's (None: as budgeted), and without the terms whose keys are in ``without`` (e.g.
    "pose" for a value no rigid motion changes: a flatness, a diameter)."""
    idx = np.asarray(idx)
    u2 = sum(t.u[idx] ** 2 for t in b.terms
             if (t.key != "sampling" or sampling is None) and t.key not in without)
    if sampling is not None:
        u2 = u2 + (np.asarray(sampling, float) / SQRT3) ** 2
    return b.k * np.sqrt(u2)
