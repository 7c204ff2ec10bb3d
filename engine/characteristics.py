"""The characteristics of an inspection plan, judged at the poses their datums give.

After the soft registration (any pose, all points) every characteristic is evaluated as a
drawing means it:

* profile relative to datums: the part placed by those datums (engine.datums; freedom they leave
  best-fitted on the characteristic's own region), the deviations of the region's points;
* profile, form only (no datums): the region's points refitted alone (``lsq``: least squares;
  ``minimax``: the smallest largest excursion from the zone's centre);
* flatness: the minimum zone of the region's measured points (engine.features);
* position: the hole's least-squares axis (3D cylinder) or centre (2D circle) at the pose its
  datums give, against the nominal's (fitted to the region's nominal points); the freedom the
  datums leave stays at the plan's alignment;
* size: the least-squares diameter of the hole (pose-independent).

Each reports a ``value`` in the drawing's convention (profile: twice the largest |d - zone
centre|, the width of the smallest zone centred like the tolerance zone that holds every point;
flatness: the minimum zone's width; position: the diameter of the smallest cylinder / circle
about the true position holding the axis or centre; size: the diameter) and passes when the
value lies within its zone. Profiles follow the decision rule point by point (guarded: each
point's nominal-sampling margin); a characteristic whose points or datums are missing is
INCONCLUSIVE, never guessed. The part: REJECT if any characteristic is out, else INCONCLUSIVE if
any cannot be trusted, else ACCEPT.

Every region a datum or characteristic uses is also reported as the feature the drawing names
(RegionFeature: a plane, cylinder or sphere with the least-squares fits of its nominal points and
of its measured points at the plan's alignment, or a freeform surface): what exports such as
QIF 3.0 write as datum features and toleranced features.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .choices import DecisionRule, Fit
from .datums import Alignment, align, align_rps
from .errors import InputError
from .fits import minimax_pose
from .pose import apply_transform
from .plan import FEATURES_2D, FEATURES_3D, MIN_POINTS, RESERVED_ID, Characteristic, Plan
from .progress import report, within
from .tolerance import Tolerance
from .verdict import ACCEPT, INCONCLUSIVE, REJECT, Statistics, pointwise_verdict

WORST = 10


@dataclass(frozen=True)
class CharacteristicResult:
    """One characteristic judged.

    value : in the drawing's convention (module docstring), mm; None when it could not be
    measured. indices : the measured points it used; deviations : their signed deviations at
    the characteristic's pose (profiles), mm. worst : up to 10 of ``indices`` farthest outside
    (or nearest to leaving) the zone, worst first. facts : what else the outputs show (fitted
    diameter, axis, the datums' fits, the freedom left).
    """

    characteristic: Characteristic
    value: float | None
    verdict: str
    reason: str
    indices: np.ndarray
    deviations: np.ndarray | None = None
    worst: tuple[int, ...] = ()
    facts: dict = field(default_factory=dict)


@dataclass(frozen=True)
class PlanResult:
    """A plan's outcome: the part's alignment, its deviations there, and every characteristic.

    alignment : the plan's ``[alignment]`` (None for best-fit: the registration's pose stands).
    T_nominal_measured : the pose of the per-point outputs; deviations : (n,) signed deviations
    there, mm; regions : (n,) each point's regions ('a+b', '' for none).
    """

    verdict: str
    reasons: tuple[str, ...]
    method: str
    alignment: Alignment | None
    T_nominal_measured: np.ndarray
    deviations: np.ndarray
    regions: np.ndarray
    members: dict
    characteristics: tuple[CharacteristicResult, ...]
    zone_in_verdict: bool = False
    """Whether the inspection's zone over all points is one of the characteristics (``tol``);
    else it is only the zone of the per-point statistics."""
    features: tuple = ()
    """RegionFeature of every region a datum or characteristic uses, in the plan's order."""


@dataclass(frozen=True)
class RegionFeature:
    """A region as the feature a drawing names (what exports such as QIF 3.0 write).

    feature : plane | cylinder | sphere (a datum's feature; flatness: a plane; position and
        size: a cylinder), or freeform (a profile's surface, or any region of a 2D template):
        no geometry.
    nominal : the least-squares feature of the region's nominal points, nominal frame, mm
        (plane: point, normal (outward); cylinder: point, direction, diameter, internal (a
        hole); sphere: centre, diameter, internal); None when they do not determine it.
    measured : the same (without internal) fitted to the region's measured points at the
        plan's alignment (the pose of the per-point outputs), with form_error (peak to valley
        of the residuals, mm) and n_points; None when they do not determine it.
    """

    region: str
    feature: str
    nominal: dict | None = None
    measured: dict | None = None
    datums: tuple[tuple[str, str], ...] = ()
    """(label, fit) of the plan's datums on this region."""


@dataclass(frozen=True)
class Geometry:
    """What the plan's evaluation needs of the part, whatever its kind (3D or a 2D template).

    evaluate(T, idx) -> (X, d, normals): measured points ``idx`` at pose T (nominal frame),
    signed deviations (mm) and the nominal's outward normals there. T0 : the registration's
    pose. margin(idx, T, form_only=False) -> the guarded rule's per-point guard band at T, mm:
    the expanded uncertainty U (engine.uncertainty) with the nominal-sampling margins there
    (``form_only``: without the registration's pose term); None (simple rule).
    nominal_points : (N, dim); nominal_normals(idx) -> their outward normals; nominal_masks :
    {region: (N,) bool}; centre, length: the measured points' centroid and RMS radius at T0
    (rotations are scaled by it); labels : (n,) the measured points' labels, or None.
    """

    evaluate: object
    T0: np.ndarray
    margin: object
    nominal_points: np.ndarray
    nominal_normals: object
    nominal_masks: dict
    centre: np.ndarray
    length: float
    labels: np.ndarray | None = None
    exact_feature: object = None
    """exact_feature(kind, mask) -> a region's nominal feature (as :func:`_nominal_feature`)
    from the model's exact surface when its samples ``mask`` all lie on one surface of that
    kind (a STEP model's plane, cylinder or sphere faces), else None; None: always fitted."""


def statistics_zone(plan: Plan) -> Tolerance:
    """The zone of the per-point statistics when the plan alone states the requirement: the
    widest profile zone of its characteristics (else +-half the widest zone of any); it is not
    part of the verdict."""
    if not plan.characteristics:
        raise InputError("the plan has no [[characteristic]]: add one, or give a zone over all "
                         "points (--tol)", plan.path)
    profiles = [c for c in plan.characteristics if c.type == "profile"]
    if profiles:
        c = max(profiles, key=lambda c: c.width)
        return Tolerance(c.lower, c.upper)
    return Tolerance.symmetric(0.5 * max(c.width for c in plan.characteristics))


def check_plan(plan: Plan, geo: Geometry, members: dict[str, np.ndarray], n: int,
               regions: np.ndarray) -> PlanResult:
    """Evaluate ``plan`` on the registered part (module docstring)."""
    shared = _Shared(plan, geo, members)
    a = plan.alignment
    alignment = None
    T_part = geo.T0
    if a.method == "datums":
        alignment = shared.placed(tuple(a.reference), tuple(a.best_fit_regions), geo.T0)
        T_part = alignment.T_nominal_measured
    elif a.method == "rps":
        fit_idx = np.unique(np.concatenate([members[r] for r in a.best_fit_regions])) \
            if a.best_fit_regions else None
        alignment = _rps(plan, geo, fit_idx)
        T_part = alignment.T_nominal_measured
    results = []
    n_chars = len(plan.characteristics)
    every = max(1, n_chars // PROGRESS_REPORTS)
    for k, c in enumerate(plan.characteristics):
        if k % every == 0:
            report(f"judging characteristic {k + 1:,} of {n_chars:,}", k / n_chars)
        try:
            with within(k / n_chars, (k + 1) / n_chars):  # a minimax refit reports too
                results.append(_judge(c, members[c.region], geo, shared, T_part))
        except InputError as e:  # a plan the nominal shows wrong: name the plan
            if e.path is not None:
                raise
            raise InputError(e.message, plan.path) from None
    everything = np.arange(n)
    d_part = geo.evaluate(T_part, everything)[1]
    verdict, reasons = _verdict(results, alignment)
    return PlanResult(verdict, reasons, a.method, alignment, T_part, d_part, regions, members,
                      tuple(results),
                      features=region_features(plan, geo, members, T_part))


PROGRESS_REPORTS = 200
"""At most this many progress reports over a plan's characteristics (engine.progress): one for
each would cost the desktop app a repaint per characteristic."""


class _Shared:
    """What the characteristics of one plan evaluation share, computed once each: the poses
    their datums give, and each region's fits and deviations (a plan may hold thousands of
    characteristics on a few regions; only the judgement against each one's zone is its
    own). Every entry depends on the plan, the part and its key alone, never on the order in
    which the characteristics ask for it, so a shared result is the one a plan of that single
    characteristic gives."""

    def __init__(self, plan: Plan, geo: Geometry, members: dict[str, np.ndarray]):
        self.datums = {d.label: d for d in plan.datums}
        self.geo, self.members = geo, members
        self.memo: dict = {}

    def once(self, key: tuple, compute):
        """compute()'s value, computed on the first call with ``key`` only; a FeatureError
        (the region's points do not determine its feature) is kept and raised again."""
        from .features import FeatureError

        if key not in self.memo:
            try:
                self.memo[key] = compute()
            except FeatureError as e:
                self.memo[key] = e
        got = self.memo[key]
        if isinstance(got, FeatureError):
            raise got.with_traceback(None)
        return got

    def placed(self, labels: tuple, best_fit: tuple, T_start: np.ndarray) -> Alignment:
        """The part placed by the datums ``labels`` (primary first), the freedom they leave
        best-fitted on the regions ``best_fit``, from ``T_start`` (engine.datums.align)."""
        return self.once(("placed", labels, best_fit, id(T_start)),
                         lambda: self._align(labels, best_fit, T_start))

    def _align(self, labels: tuple, best_fit: tuple, T_start: np.ndarray) -> Alignment:
        geo, members = self.geo, self.members
        ds = [self.datums[x] for x in labels]
        fit_idx = np.unique(np.concatenate([members[r] for r in best_fit])) \
            if best_fit else None
        return align(geo.evaluate, T_start, ds, [members[d.region] for d in ds], geo.centre,
                     geo.length, fit_idx, [_invariants(d, geo) for d in ds])


def _verdict(results, alignment: Alignment | None) -> tuple[str, tuple[str, ...]]:
    verdict, reasons = part_verdict(results)
    if alignment is not None and not alignment.complete:
        reasons = (f"the part's alignment is incomplete: {alignment.message}", *reasons)
    return verdict, reasons


def part_verdict(results) -> tuple[str, tuple[str, ...]]:
    """REJECT if any characteristic is out, else INCONCLUSIVE if any cannot be trusted, else
    ACCEPT; the reasons name them."""
    out = [r for r in results if r.verdict == REJECT]
    unsure = [r for r in results if r.verdict == INCONCLUSIVE]
    if out:
        return REJECT, tuple(f"characteristic {r.characteristic.id} ({r.characteristic.type}) "
                             f"is out of tolerance: {r.reason}" for r in out)
    if unsure:
        return INCONCLUSIVE, tuple(f"characteristic {r.characteristic.id} "
                                   f"({r.characteristic.type}) cannot be decided: {r.reason}"
                                   for r in unsure)
    return ACCEPT, (f"all {len(results)} characteristics are within tolerance",)


def _judge(c: Characteristic, idx: np.ndarray, geo: Geometry, shared: _Shared, T_part):
    planar = geo.nominal_points.shape[1] == 2
    need = {"profile": 1, "flatness": MIN_POINTS["line" if planar else "plane"]}.get(
        c.type, MIN_POINTS["circle" if planar else "cylinder"])
    if idx.size < need:
        return CharacteristicResult(c, None, INCONCLUSIVE,
                                    f"region '{c.region}' has {idx.size} measured points; "
                                    f"{c.type} needs at least {need}", idx)
    from .features import FeatureError

    try:
        if c.type == "profile":
            return _profile(c, idx, geo, shared)
        if c.type == "flatness":
            return _flatness(c, idx, geo, shared)
        return _hole(c, idx, geo, shared, T_part)
    except FeatureError as e:
        # The region's points do not determine its feature (all on a line, ...): say so.
        return CharacteristicResult(c, None, INCONCLUSIVE, f"region '{c.region}': {e.message}",
                                    idx)


def _untrusted(c, idx, al: Alignment):
    return CharacteristicResult(c, None, INCONCLUSIVE,
                                f"its datums cannot place the part: {al.message}", idx,
                                facts={"datums": [f.label for f in al.datums]})


def _own(shared_result: CharacteristicResult, c: Characteristic) -> CharacteristicResult:
    """A result computed for another characteristic on the same region, as ``c``'s: its
    reason names only the region, its points and its datums, which they share."""
    return replace(shared_result, characteristic=c)


def _profile(c: Characteristic, idx: np.ndarray, geo: Geometry, shared: _Shared):
    tol = Tolerance(c.lower, c.upper)
    # The pose depends on the region and the datums or the refit; a minimax refit also on the
    # zone it centres on.
    key = ("profile", c.region, tuple(c.datums)) if c.datums else \
        ("profile", c.region, c.fit) + ((c.lower, c.upper) if c.fit == "minimax" else ())
    got = shared.once(key, lambda: _profile_pose(c, idx, geo, shared))
    if isinstance(got, CharacteristicResult):
        return _own(got, c)
    T, d, margin, facts = got
    verdict, reason = pointwise_verdict(d, tol, margin)
    centre = 0.5 * (c.lower + c.upper)
    value = float(2.0 * np.max(np.abs(d - centre)))
    ex = tol.excess(d)
    worst = tuple(int(idx[i]) for i in np.argsort(-ex, kind="stable")[:WORST])
    return CharacteristicResult(c, value, verdict, reason, idx, d, worst,
                                {**facts, "T_nominal_measured": T})


def _profile_pose(c: Characteristic, idx: np.ndarray, geo: Geometry, shared: _Shared):
    """(pose T, the region's deviations d there, their guard band, facts) of a profile, or an
    INCONCLUSIVE result when its datums cannot place the part."""
    facts: dict = {}
    if c.datums:
        al = shared.placed(tuple(c.datums), (c.region,), geo.T0)
        if not al.complete:
            return _untrusted(c, idx, al)
        T = al.T_nominal_measured
        facts["free"] = [f.describe() for f in al.free]
    elif c.fit == Fit.MINIMAX:
        def evaluate(Tc):
            return geo.evaluate(Tc, idx)

        T = minimax_pose(evaluate, geo.T0, c.lower, c.upper).T
    else:
        T = align(geo.evaluate, geo.T0, [], [], geo.centre, geo.length, idx).T_nominal_measured
    return T, geo.evaluate(T, idx)[1], geo.margin(idx, T), facts


def _flatness(c: Characteristic, idx: np.ndarray, geo: Geometry, shared: _Shared):
    got = shared.once(("flatness", c.region), lambda: _flat(c, idx, geo))
    if isinstance(got, CharacteristicResult):
        return _own(got, c)
    width, normal, guard = got
    return _by_value(c, idx, width, {"normal": normal}, "minimum-zone width", guard)


def _flat(c: Characteristic, idx: np.ndarray, geo: Geometry):
    """(minimum-zone width, its normal, the width's uncertainty bound) of the region's points,
    or an INCONCLUSIVE result when they do not determine its plane."""
    from .features import flatness

    X, _, n = geo.evaluate(geo.T0, idx)
    hint = n.mean(axis=0) / np.linalg.norm(n.mean(axis=0))
    if X.shape[1] == 3:
        flat = X - X.mean(axis=0)
        flat -= np.outer(flat @ hint, hint)
        ev = np.linalg.eigvalsh(flat.T @ flat)  # (0, smaller, larger) spreads in the plane
        if ev[1] < SPAN ** 2 * ev[2]:
            return CharacteristicResult(c, None, INCONCLUSIVE, f"the {idx.size} points of "
                                        f"region '{c.region}' lie along a line: they do not "
                                        "determine a plane", idx)
    f = flatness(X, hint)
    turn = float(np.degrees(np.arccos(np.clip(f.normal @ hint, -1.0, 1.0))))
    if turn > np.degrees(FACING):
        return CharacteristicResult(c, None, INCONCLUSIVE, f"the points' minimum zone stands "
                                    f"at {turn:.0f}° to the nominal face: they do not "
                                    "determine its plane", idx)
    return f.width, f.normal, _value_guard(geo, idx, geo.T0, form_only=True)


def _value_guard(geo: Geometry, idx: np.ndarray, T, form_only: bool) -> float | None:
    """Under the guarded rule, how far the points' uncertainty can move a value computed from
    them: twice the largest expanded U among the points ``idx`` at pose T (each point's error
    within its U moves a minimum-zone width, a least-squares diameter or a position diameter by
    at most that), without the registration's pose term for a value no rigid motion changes
    (``form_only``: a flatness, a diameter); None under the simple rule."""
    m = geo.margin(idx, T, form_only=form_only)
    return None if m is None or len(m) == 0 else 2.0 * float(np.max(m))


def _by_value(c: Characteristic, idx, value: float, facts: dict, what: str,
              guard: float | None = None):
    """The characteristic judged by its value against its limits; with ``guard`` (the value's
    uncertainty bound, :func:`_value_guard`) by ISO 14253-1: ACCEPT inside the limits shrunk
    by it, REJECT outside them grown by it, else INCONCLUSIVE. Flatness and position have an
    upper limit only (their value cannot be below 0): no guard on the lower side."""
    lo, hi = (c.nominal or 0.0) + c.lower, (c.nominal or 0.0) + c.upper
    inside = lo <= value <= hi
    reason = (f"{what} {value:.4f} mm {'within' if inside else 'outside'} "
              f"[{lo:.4f}, {hi:.4f}] mm")
    verdict = ACCEPT if inside else REJECT
    if guard is not None:
        g_lo = 0.0 if c.type in ("flatness", "position") else guard
        facts = {**facts, "uncertainty_bound": guard}
        if value > hi + guard or value < lo - g_lo:
            verdict = REJECT
            reason += f", by more than its uncertainty ±{guard:.4f} mm"
        elif not lo + g_lo <= value <= hi - guard:
            verdict = INCONCLUSIVE
            reason += (f", within its uncertainty ±{guard:.4f} mm (twice the largest U of its "
                       "points) of a limit: conformance is not proven either way (ISO 14253-1)")
        else:
            reason += f" by more than its uncertainty ±{guard:.4f} mm"
    return CharacteristicResult(c, float(value), verdict, reason, idx, facts=facts)


def _hole(c: Characteristic, idx: np.ndarray, geo: Geometry, shared: _Shared, T_part):
    """Size or position of the hole of ``c``'s region (a cylinder in 3D, a circle in 2D)."""
    nom, normals = shared.once(("hole", c.region), lambda: _nominal_hole(geo, c.region))
    if nom.form_error > HOLE_FORM * nom.radius:
        raise InputError(f"[[characteristic]] '{c.id}': region '{c.region}' is no hole: its "
                         f"nominal points lie up to {nom.form_error:.3g} mm off their "
                         f"best {'circle' if normals.shape[1] == 2 else 'cylinder'}")
    if c.type == "size":
        got = shared.once(("size", c.region), lambda: _size(c, idx, geo, normals, nom))
        if isinstance(got, CharacteristicResult):
            return _own(got, c)
        diameter, form_error, guard = got
        return _by_value(c, idx, diameter, {"fit": "least squares", "form_error": form_error},
                         "least-squares diameter", guard)
    al = shared.placed(tuple(c.datums), (), T_part)
    if not al.complete:
        return _untrusted(c, idx, al)
    _check_located(c, shared.once(("loose", c.region, tuple(c.datums)),
                                  lambda: _loose(al, nom, geo)))
    got = shared.once(("position", c.region, tuple(c.datums)),
                      lambda: _position(c, idx, geo, normals, nom, al))
    if isinstance(got, CharacteristicResult):
        return _own(got, c)
    value, facts, guard = got
    return _by_value(c, idx, value, dict(facts), "position (diameter)", guard)


def _nominal_hole(geo: Geometry, region: str):
    """(the region's nominal hole: the model's exact cylinder where it has one, else the fit
    to its samples; the samples' normals)."""
    mask = geo.nominal_masks[region]
    nominal, normals = geo.nominal_points[mask], geo.nominal_normals(np.flatnonzero(mask))
    nom = _hole_fit(nominal, normals)
    exact = _exact_nominal(geo, "cylinder", mask) if nominal.shape[1] == 3 else None
    if exact is not None:  # the model's own axis and radius, not a fit to its samples
        nom = replace(nom, point=exact["point"], direction=exact["direction"],
                      radius=0.5 * exact["diameter"], form_error=0.0)
    return nom, normals


def _size(c: Characteristic, idx: np.ndarray, geo: Geometry, normals: np.ndarray, nom):
    """(least-squares diameter, form error, its uncertainty bound) of the region's measured
    hole, or an INCONCLUSIVE result when its points do not determine it."""
    got = _measured_hole(c, idx, geo.evaluate(geo.T0, idx)[0], normals, nom)
    if isinstance(got, CharacteristicResult):
        return got
    return 2.0 * got.radius, got.form_error, _value_guard(geo, idx, geo.T0, True)


def _position(c: Characteristic, idx: np.ndarray, geo: Geometry, normals: np.ndarray, nom,
              al: Alignment):
    """(position diameter, facts, its uncertainty bound) of the region's measured hole at
    the pose its datums give (``al``), or an INCONCLUSIVE result when its points do not
    determine it."""
    from .features import position_value

    got = _measured_hole(c, idx, geo.evaluate(al.T_nominal_measured, idx)[0], normals, nom)
    if isinstance(got, CharacteristicResult):
        return got
    if normals.shape[1] == 2:
        value = position_value(got.centre, nom.centre).value
        facts = {"centre": got.centre, "nominal_centre": nom.centre}
    else:
        value = position_value(got.ends, nom.point, nom.direction).value
        facts = {"axis_ends": got.ends, "nominal_point": nom.point,
                 "nominal_direction": nom.direction}
    facts["free"] = [f.describe() for f in al.free]
    return value, facts, _value_guard(geo, idx, al.T_nominal_measured, form_only=False)


def _loose(al: Alignment, nom, geo: Geometry) -> list:
    """The motions the datums of ``al`` leave free that move the nominal hole ``nom``."""
    from .datums import invariant_motions, moving

    feature = {"centre": nom.centre} if geo.nominal_points.shape[1] == 2 else \
        {"point": nom.point, "direction": nom.direction}
    kind = "circle" if geo.nominal_points.shape[1] == 2 else "cylinder"
    return moving(al.free_basis, invariant_motions(kind, feature, geo.centre, geo.length),
                  geo.centre, geo.length)


def _check_located(c: Characteristic, loose: list) -> None:
    """A position is relative to datums that locate the hole: none of the motions they leave
    free (``loose``: :func:`_loose`) may move the nominal hole (a plane alone leaves it free to
    slide)."""
    if loose:
        raise InputError(f"[[characteristic]] '{c.id}': its datums {'|'.join(c.datums)} leave "
                         f"the hole free to move ({'; '.join(f.describe() for f in loose)}): a "
                         "position needs datums that locate it")


def _hole_fit(X: np.ndarray, normals: np.ndarray):
    """The least-squares circle (2D) or cylinder (3D, its axis started from the normals)."""
    from .features import fit_circle_lsq, fit_cylinder_lsq

    return fit_circle_lsq(X) if X.shape[1] == 2 else _cylinder(fit_cylinder_lsq, X, normals)


def _measured_hole(c: Characteristic, idx: np.ndarray, X: np.ndarray, normals: np.ndarray,
                   nom):
    """The measured hole's fit, or an INCONCLUSIVE result when its points do not determine it
    (the fit did not settle, or its axis turned from the nominal's by more than FACING: a hole
    probed on a narrow arc)."""
    radial = X - (nom.centre if X.shape[1] == 2 else nom.point)
    if X.shape[1] == 3:
        radial -= np.outer(radial @ nom.direction, nom.direction)
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    across = np.linalg.svd(np.column_stack([radial, np.ones(len(X))]) / np.sqrt(len(X)),
                           compute_uv=False)
    if across[2] < HOLE_SPREAD:  # (3D: a 4th, along the axis, is zero)
        return CharacteristicResult(c, None, INCONCLUSIVE, f"the {idx.size} points of region "
                                    f"'{c.region}' do not determine the hole (they cover too "
                                    "little of its circumference)", idx)
    got = _hole_fit(X, normals)
    turn = 0.0 if X.shape[1] == 2 else float(np.degrees(np.arccos(np.clip(
        abs(got.direction @ nom.direction), 0.0, 1.0))))
    if got.converged and turn <= np.degrees(FACING):
        return got
    why = f"its axis turns {turn:.0f}° from the nominal's" if got.converged else \
        "the fit does not settle"
    return CharacteristicResult(c, None, INCONCLUSIVE, f"the {idx.size} points of region "
                                f"'{c.region}' do not determine the hole ({why})", idx)


def _cylinder(fit_cylinder_lsq, X: np.ndarray, normals: np.ndarray):
    """The least-squares cylinder of X, started from the nominal region's axis direction: the
    one its surface normals are all perpendicular to (the smallest eigenvector of sum n n^T)."""
    _, vecs = np.linalg.eigh(normals.T @ normals)
    return fit_cylinder_lsq(X, vecs[:, 0])


_IMPLIED_FEATURE = {"flatness": "plane", "position": "cylinder", "size": "cylinder"}
FACING = np.radians(10.0)
"""How far a sample's normal may turn from its feature's and still be of it (engine.regions
boxes take in strips of the neighbouring faces), and how far a measured feature's fitted plane
or axis may turn from the nominal's before its points are taken not to determine it."""
SPAN = 0.05
"""A flatness needs its points spread both ways over the face: the smaller in-plane spread at
least this fraction of the larger (points along a line leave the plane free to turn about it)."""
HOLE_SPREAD = 0.05
"""A hole's points determine its centre and size apart when the smallest singular value of
[radial direction, 1] per point (over the square root of their number) is at least this: about
a 75-degree arc; a 45-degree arc has 0.018, which turns 1 um of probing noise into 50 um of
size."""
HOLE_FORM = 0.02
"""A region is a hole when its nominal points lie within this fraction of its radius of their
least-squares cylinder (circle); a tessellated hole of 32 facets is within 0.5%."""


def region_features(plan: Plan, geo: Geometry, members: dict[str, np.ndarray],
                    T: np.ndarray) -> tuple[RegionFeature, ...]:
    """Every region a datum or characteristic uses, in the plan's order, as its feature
    (RegionFeature): the nominal fitted to the region's nominal points, the measured to its
    measured points at pose ``T``."""
    kinds = _region_kinds(plan)
    datums: dict[str, list] = {}
    for d in plan.datums:
        datums.setdefault(d.region, []).append((d.label, d.fit))
    out = []
    for r in plan.regions:
        kind = kinds.get(r.name)
        if kind is None:
            continue
        on = tuple(datums.get(r.name, ()))
        if kind not in ("plane", "cylinder", "sphere") or geo.nominal_points.shape[1] != 3:
            out.append(RegionFeature(r.name, "freeform", datums=on))
            continue
        mask = geo.nominal_masks[r.name]
        normals = geo.nominal_normals(np.flatnonzero(mask))
        idx = members[r.name]
        measured = _fit_feature(kind, geo.evaluate(T, idx)[0], normals) if idx.size else None
        out.append(RegionFeature(r.name, kind, _region_nominal(kind, geo, mask), measured, on))
    return tuple(out)


def _region_kinds(plan: Plan) -> dict[str, str]:
    """{region: the feature it is}: its datum's feature, else what its characteristic implies
    (flatness a plane, position and size a hole), else freeform (a profile's surface)."""
    kinds: dict[str, str] = {}
    for d in plan.datums:
        kinds.setdefault(d.region, d.feature)
    for c in plan.characteristics:
        kinds.setdefault(c.region, _IMPLIED_FEATURE.get(c.type, "freeform"))
    return kinds


def _feature_masks(plan: Plan, geo: Geometry) -> dict[str, np.ndarray]:
    """The regions' nominal masks, those of a plane (line) or a cylinder kept to the samples
    that face as the feature does (within FACING of the region's mean normal; at right angles
    to a hole's axis within FACING): a box takes in strips of the neighbouring faces, whose
    points must not join a datum or tilt its nominal."""
    out = dict(geo.nominal_masks)
    planar = geo.nominal_points.shape[1] == 2
    for name, kind in _region_kinds(plan).items():
        if kind not in ("plane", "line", "cylinder") or (planar and kind == "cylinder"):
            continue
        idx = np.flatnonzero(out[name])
        n = geo.nominal_normals(idx)
        if kind == "cylinder":
            axis = np.linalg.eigh(n.T @ n)[1][:, 0]
            keep = np.abs(n @ axis) <= np.sin(FACING)
        else:
            mean = n.sum(axis=0)
            keep = n @ (mean / (np.linalg.norm(mean) or 1.0)) >= np.cos(FACING)
        if keep.sum() < MIN_POINTS[kind]:
            raise InputError(f"[[region]] '{name}': its nominal points do not form a {kind} "
                             f"(only {int(keep.sum())} of {idx.size} face as one does)",
                             plan.path)
        mask = np.zeros_like(out[name])
        mask[idx[keep]] = True
        out[name] = mask
    return out


def _nominal_feature(kind: str, points: np.ndarray, normals: np.ndarray) -> dict | None:
    """The least-squares ``kind`` of a region's nominal points (kept by _feature_masks to those
    facing as the feature does); a cylinder or sphere says whether it is a hole (internal: the
    outward normals point towards its axis / centre)."""
    fit = _fit_feature(kind, points, normals)
    if fit is None:
        return None
    out = {k: v for k, v in fit.items() if k not in ("form_error", "n_points")}
    if kind not in ("plane", "line"):
        radial = points - out.get("centre", out.get("point"))
        if kind == "cylinder":
            radial -= np.outer(radial @ out["direction"], out["direction"])
        out["internal"] = bool(np.sum(radial * normals) < 0.0)
    return out


def _exact_nominal(geo: Geometry, kind: str, mask: np.ndarray) -> dict | None:
    """The region's nominal ``kind`` from the model's exact surface, or None (see
    Geometry.exact_feature)."""
    return None if geo.exact_feature is None else geo.exact_feature(kind, mask)


def _region_nominal(kind: str, geo: Geometry, mask: np.ndarray) -> dict | None:
    """A region's nominal feature: the model's exact surface where it has one, else the
    least-squares fit to the region's nominal samples (``mask``)."""
    exact = _exact_nominal(geo, kind, mask)
    if exact is not None:
        return exact
    return _nominal_feature(kind, geo.nominal_points[mask],
                            geo.nominal_normals(np.flatnonzero(mask)))


def _invariants(datum, geo: Geometry) -> np.ndarray | None:
    """The motions that leave datum's ideal nominal feature in place (engine.datums), from the
    least-squares feature of its region's nominal points; None when they do not form it."""
    from .datums import invariant_motions

    nominal = _region_nominal(datum.feature, geo, geo.nominal_masks[datum.region])
    if nominal is None:
        return None
    return invariant_motions(datum.feature, nominal, geo.centre, geo.length)


def _fit_feature(kind: str, X: np.ndarray, normals: np.ndarray) -> dict | None:
    """The least-squares ``kind`` of the points X (the region's nominal outward ``normals``
    orient a plane and start a cylinder's axis); None when X does not determine it."""
    from .features import (FeatureError, fit_circle_lsq, fit_cylinder_lsq, fit_plane_lsq,
                           fit_sphere_lsq)

    try:
        if kind in ("plane", "line"):
            f = fit_plane_lsq(X, normals.sum(axis=0))
            out = {"point": f.centroid, "normal": f.normal}
        elif kind == "circle":
            f = fit_circle_lsq(X)
            out = {"centre": f.centre, "diameter": 2.0 * f.radius}
        elif kind == "cylinder":
            f = _cylinder(fit_cylinder_lsq, X, normals)
            out = {"point": f.point, "direction": f.direction, "diameter": 2.0 * f.radius}
        else:
            f = fit_sphere_lsq(X)
            out = {"centre": f.centre, "diameter": 2.0 * f.radius}
    except FeatureError:
        return None
    return {**out, "form_error": f.form_error, "n_points": f.n_points}


def _rps(plan: Plan, geo: Geometry, best_fit: np.ndarray | None) -> Alignment:
    """The RPS alignment: each [[rps]] point's measured point (by its label) locked onto its
    nominal position along its locked axes."""
    if geo.labels is None:
        raise InputError("[alignment] method 'rps' finds its points by their labels, and the "
                         "measured file has none", plan.path)
    where: dict = {}
    for i, s in enumerate(geo.labels):
        where.setdefault(str(s), []).append(i)
    dim = geo.nominal_points.shape[1]
    idx, targets, axes = [], [], []
    for p in plan.rps:
        found = where.get(p.label, [])
        if len(found) != 1:
            raise InputError(f"[[rps]] '{p.label}': {len(found)} measured points carry this "
                             "label; it must name exactly one", plan.path)
        if dim == 2 and "z" in p.lock:
            raise InputError(f"[[rps]] '{p.label}': a 2D template's points lock x and y only, "
                             "not z", plan.path)
        for a in p.lock:
            e = np.zeros(dim)
            e["xyz".index(a)] = 1.0
            idx.append(found[0])
            targets.append(np.asarray(p.nominal, float)[:dim])
            axes.append(e)
    return align_rps(geo.evaluate, geo.T0, np.array(idx), np.array(targets), np.array(axes),
                     geo.centre, geo.length, best_fit)


def inspect_plan(result, plan: Plan, nominal, nominal_labels: np.ndarray | None,
                 measured: np.ndarray, labels: np.ndarray | None, zone_in_verdict: bool,
                 nominal_groups: dict[str, np.ndarray] | None = None, exact=None,
                 sample_of=None, exact_feature=None):
    """The InspectionResult ``result`` of a 3D inspection judged by ``plan``: its verdict and
    reasons become the plan's (with the zone of ``result`` as one more profile characteristic
    over all points when ``zone_in_verdict``), ``plan`` holds the PlanResult, and the per-point
    outputs are at the plan's alignment. nominal_labels, nominal_groups : the nominal file's
    point labels and groups (engine.pointset.PointSet), which regions may select. exact(X) ->
    Deviations from the true surface (a STEP model's faces; engine.inspection.inspect), None:
    deviations on the nominal's sample, with its sampling margins. sample_of(feet) -> the
    nominal sample whose regions each foot (closest surface point) takes (None: the nearest;
    a STEP model: the nearest of the foot's own face, whose samples its edges share with the
    next face's). exact_feature : see Geometry.exact_feature (a STEP model's faces)."""
    from .deviation import point_to_surface
    from .regions import nominal_members
    from .uncertainty import expanded_at
    from .verdict import margins_3d

    masks = nominal_members(plan, nominal.points, nominal_labels, nominal_groups)
    surface = exact or (lambda X: point_to_surface(nominal, X))

    def evaluate(T, idx):
        X = apply_transform(T, measured[idx])
        dv = surface(X)
        return X, dv.signed, dv.normal

    def sampling(idx, T):
        if exact is not None:
            return np.zeros(len(idx))
        X = apply_transform(T, measured[idx])
        return margins_3d(nominal, point_to_surface(nominal, X).foot)

    def margin(idx, T, form_only=False):
        if result.decision_rule != DecisionRule.GUARDED:
            return None
        if result.uncertainty is None:  # guarded by the sampling margin alone (older runs)
            return sampling(idx, T)
        return expanded_at(result.uncertainty, idx, sampling(idx, T),
                           ("pose",) if form_only else ())

    geo = Geometry(evaluate, result.registration.T_nominal_measured, margin, nominal.points,
                   nominal.normals, masks, *_centre_and_length(result.registered), labels,
                   exact_feature)
    planned = _judged(result, plan, geo, sample_of or (lambda f: nominal.tree.query(f)[1]),
                      zone_in_verdict)
    result = replace(result, verdict=planned.verdict, reasons=planned.reasons, plan=planned)
    if planned.alignment is None:
        return result
    # The per-point outputs at the plan's alignment: where the drawing places the part.
    X = apply_transform(planned.T_nominal_measured, measured)
    dv = surface(X)
    return _at_plan_pose(result, X, dv, None if result.margin is None else sampling(
        np.arange(len(X)), planned.T_nominal_measured))


def inspect_plan_2d(result, plan: Plan, index, labels: np.ndarray | None,
                    zone_in_verdict: bool):
    """:func:`inspect_plan` for a 2D template (``index``: its engine.contour.ContourIndex):
    the plan works in the template's plane on the registered points' x, y (poses 3x3 there,
    starting from the identity); the part's pose and per-point outputs are lifted back into
    3D. Template lines and arcs are exact: no sampling margin. A region's ``group`` selects
    the samples of a DXF layer's contours (its name compared without case, as DXF does)."""
    from .contour import deviations_2d
    from .deviation import Deviations
    from .registration import in_plane
    from .regions import nominal_members

    P2 = result.registered[:, :2]
    samples = index.tree.data
    t = index.t
    layers = None
    if t.layer is not None:  # each sample's layer is its primitive's
        of_sample = t.layer[index.owner]
        layers = {name: np.flatnonzero(of_sample == i) for i, name in enumerate(t.layers)}
    masks = nominal_members(plan, samples, None, layers, fold_case=True)

    def evaluate(T, idx):
        X = apply_transform(T, P2[idx])
        dv = deviations_2d(index, X)
        return X, dv.signed, dv.normal

    def normals(idx):
        return deviations_2d(index, samples[idx]).normal

    def margin(idx, T, form_only=False):  # lines and arcs are exact: the budget's other terms
        from .uncertainty import expanded_at

        if result.decision_rule != DecisionRule.GUARDED or result.uncertainty is None:
            return None
        return expanded_at(result.uncertainty, idx, np.zeros(len(idx)),
                           ("pose",) if form_only else ())

    geo = Geometry(evaluate, np.eye(3), margin, samples, normals, masks,
                   *_centre_and_length(P2), labels)
    planned = _judged(result, plan, geo, lambda f: index.tree.query(f)[1], zone_in_verdict)
    T2 = planned.T_nominal_measured
    planned = replace(planned, T_nominal_measured=in_plane(T2)
                      @ result.registration.T_nominal_measured)
    result = replace(result, verdict=planned.verdict, reasons=planned.reasons, plan=planned)
    if planned.alignment is None:
        return result
    X2 = apply_transform(T2, P2)
    d2 = deviations_2d(index, X2)
    zeros = np.zeros(X2.shape[0])
    dv = Deviations(d2.signed, np.column_stack([d2.foot, zeros]),
                    np.column_stack([d2.normal, zeros]), zeros.astype(bool))
    return _at_plan_pose(result, np.column_stack([X2, result.registered[:, 2]]), dv, None)


def _centre_and_length(X: np.ndarray) -> tuple[np.ndarray, float]:
    """The points' centroid and RMS radius (mm): the centre and lever of the plan's poses."""
    centre = X.mean(axis=0)
    return centre, float(np.sqrt(np.mean(np.sum((X - centre) ** 2, axis=1)))) or 1.0


def _judged(result, plan: Plan, geo: Geometry, sample_of, zone_in_verdict: bool) -> PlanResult:
    """The plan checked on ``geo``, with the inspection's own zone as a characteristic over all
    points when ``zone_in_verdict``; everything INCONCLUSIVE when the registration, on which
    the regions rest, cannot be trusted."""
    from .regions import measured_members, region_column
    from .verdict import pose_trusted

    dim = geo.nominal_points.shape[1]
    for d in plan.datums:
        if d.feature not in (FEATURES_2D if dim == 2 else FEATURES_3D):
            raise InputError(f"[[datum]] '{d.label}': a {d.feature} datum needs a "
                             f"{'3D nominal' if dim == 2 else '2D template'}; this nominal is "
                             f"{'a 2D template' if dim == 2 else '3D'}", plan.path)
    reg = result.registration
    n = result.registered.shape[0]
    geo = replace(geo, nominal_masks=_feature_masks(plan, geo))
    # A point belongs where it lies: in the region of the sample nearest its closest point on
    # the surface (not its nearest sample, which may lie on the next face).
    foot = result.deviations.foot[:, :geo.nominal_points.shape[1]]
    members = measured_members(plan, geo.nominal_masks, sample_of(foot), geo.labels)
    planned = check_plan(plan, geo, members, n, region_column(plan, members, n))
    results = list(planned.characteristics)
    if zone_in_verdict:
        tol = result.tolerance
        d = result.deviations.signed
        whole = Characteristic(RESERVED_ID, "profile", "(all points)", tol.lower, tol.upper)
        results.insert(0, CharacteristicResult(
            whole, float(2.0 * np.max(np.abs(d - 0.5 * (tol.lower + tol.upper)))),
            result.verdict, result.reasons[0], np.arange(d.size), d, result.statistics.worst))
    verdict, reasons = _verdict(results, planned.alignment)
    if not pose_trusted(reg):
        results = [replace(r, verdict=INCONCLUSIVE, reason=f"the registration cannot be "
                           f"trusted: {result.reasons[0]}") for r in results]
        verdict, reasons = INCONCLUSIVE, result.reasons
    return replace(planned, verdict=verdict, reasons=reasons, characteristics=tuple(results),
                   zone_in_verdict=zone_in_verdict)


def _at_plan_pose(result, X: np.ndarray, dv, margin):
    """``result`` with its per-point outputs (points, deviations, in-tolerance, statistics,
    margins) at the plan's alignment: where the drawing places the part."""
    tol = result.tolerance
    return replace(result, registered=X, deviations=dv,
                   in_tolerance=(dv.signed >= tol.lower) & (dv.signed <= tol.upper),
                   statistics=Statistics.of(dv.signed, tol), margin=margin)
