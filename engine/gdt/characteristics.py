"""The characteristics of an inspection plan, judged at the poses their datums give.

After the soft registration (any pose, all points) every characteristic is evaluated as a
drawing means it:

* profile relative to datums: the part placed by those datums (engine.gdt.datums; freedom they leave
  best-fitted on the characteristic's own region), the deviations of the region's points;
* profile, form only (no datums): the region's points refitted alone (``lsq``: least squares;
  ``minimax``: the smallest largest excursion from the zone's centre);
* flatness: the minimum zone of the region's measured points (engine.gdt.features);
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

from dataclasses import replace

import numpy as np

from ..choices import DecisionRule
from ..errors import InputError
from ..pose import apply_transform, in_plane
from ..progress import report, within
from ..tolerance import Tolerance
from ..verdict import INCONCLUSIVE, REJECT, Statistics
from .datums import Alignment
from .frame_probe import probed
from .judgement import PROGRESS_REPORTS, Shared, judge, plan_verdict
from .plan import FEATURES_2D, FEATURES_3D, RESERVED_ID, Characteristic, Plan, datum_parts
from .region_features import feature_masks, region_features, rps_alignment
from .results import CharacteristicResult, Geometry, PlanResult

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
    # An angle's limits are degrees, not a zone of the deviation.
    widths = [c.width for c in plan.characteristics if c.unit == "mm"]
    return Tolerance.symmetric(0.5 * max(widths or [c.width for c in plan.characteristics]))


def check_plan(plan: Plan, geo: Geometry, members: dict[str, np.ndarray], n: int,
               regions: np.ndarray, doubt=None, probe=None) -> PlanResult:
    """Evaluate ``plan`` on the registered part (module docstring). A verdict the scatter of
    its datums' points decides is made INCONCLUSIVE (engine.gdt.frame_probe), then the points
    in doubt have their say. doubt : the points that may have been measured on another face
    (:func:`_in_doubt`), None: none. probe : the ids of the characteristics probed (None:
    every one)."""
    results, alignment, T_part = _judged_characteristics(plan, geo, members, probe)
    if doubt is not None:
        results = _in_doubt(results, plan, geo, members, doubt)
    everything = np.arange(n)
    d_part = geo.evaluate(T_part, everything)[1]
    verdict, reasons = plan_verdict(results, alignment)
    return PlanResult(verdict, reasons, plan.alignment.method, alignment, T_part, d_part,
                      regions, members, tuple(results),
                      features=region_features(plan, geo, members, T_part))


def _judged_characteristics(plan: Plan, geo: Geometry, members: dict[str, np.ndarray],
                            probe=None) -> tuple[list[CharacteristicResult], Alignment | None,
                                           np.ndarray]:
    """(every characteristic's result, probed as :func:`check_plan` says, the plan's
    alignment (None for a best fit), the part's pose T_part)."""
    shared = Shared(plan, geo, members)
    a = plan.alignment
    alignment = None
    T_part = geo.T0
    if a.method == "datums":
        alignment = shared.placed(tuple(a.reference), tuple(a.best_fit_regions), geo.T0)
        T_part = alignment.T_nominal_measured
    elif a.method == "rps":
        fit_idx = np.unique(np.concatenate([members[r] for r in a.best_fit_regions])) \
            if a.best_fit_regions else None
        alignment = rps_alignment(plan, geo, fit_idx)
        T_part = alignment.T_nominal_measured
    results = []
    n_chars = len(plan.characteristics)
    every = max(1, n_chars // PROGRESS_REPORTS)
    for k, c in enumerate(plan.characteristics):
        if k % every == 0:
            report(f"judging characteristic {k + 1:,} of {n_chars:,}", k / n_chars)
        try:
            with within(k / n_chars, (k + 1) / n_chars):  # a minimax refit reports too
                idx = members[c.region] if not c.regions else \
                    np.unique(np.concatenate([members[r] for r in c.regions]))
                results.append(judge(c, idx, geo, shared, T_part))
        except InputError as e:  # a plan the nominal shows wrong: name the plan
            if e.path is not None:
                raise
            if plan.n_source is None:
                raise InputError(e.message, plan.path) from None
            # A plan read from the model's own PMI (QIF) cannot be corrected by the
            # inspector: this characteristic cannot be judged, the others still are.
            results.append(CharacteristicResult(c, None, INCONCLUSIVE, "it cannot be judged "
                                                f"as the model states it: {e.message}", idx))
    return probed(results, geo, shared, T_part, probe), alignment, T_part


def inspect_plan(result, plan: Plan, nominal, nominal_labels: np.ndarray | None,
                 measured: np.ndarray, labels: np.ndarray | None, zone_in_verdict: bool,
                 nominal_groups: dict[str, np.ndarray] | None = None, surface=None,
                 sample_of=None, exact_feature=None, rivals=None):
    """The InspectionResult ``result`` of a 3D inspection judged by ``plan``: its verdict and
    reasons become the plan's (with the zone of ``result`` as one more profile characteristic
    over all points when ``zone_in_verdict``), ``plan`` holds the PlanResult, and the per-point
    outputs are at the plan's alignment. nominal_labels, nominal_groups : the nominal file's
    point labels and groups (engine.pointset.PointSet), which regions may select. surface : what
    the deviations are measured on (engine.surface.Surface, as engine.inspection.inspect
    measured them: an exact one is a STEP model's faces); None: the nominal's sample, with its
    sampling margins. sample_of(feet) -> the
    nominal sample whose regions each foot (closest surface point) takes (None: the nearest;
    a STEP model: the nearest of the foot's own face, whose samples its edges share with the
    next face's). exact_feature : see Geometry.exact_feature (a STEP model's faces). rivals :
    a STEP model's points in doubt between faces (engine.step_model.face_rivals), or None."""
    from .regions import nominal_members
    from ..surface import Posed, SampledSurface
    from ..uncertainty import expanded_at

    posed = Posed(surface or SampledSurface(nominal), measured)
    exact = posed.surface.exact
    # A STEP model's box regions take the faces crossing them (its samples lie on edges).
    masks = nominal_members(plan, nominal.points, nominal_labels, nominal_groups,
                            triangles=nominal.triangles if exact else None)

    def evaluate(T, idx):
        X, dv = posed.at(T, idx)
        return X, dv.signed, dv.normal

    def margin(idx, T, form_only=False):
        if result.decision_rule != DecisionRule.GUARDED:
            return None
        if result.uncertainty is None:  # guarded by the sampling margin alone (older runs)
            return posed.margins_at(T, idx)
        return expanded_at(result.uncertainty, idx, posed.margins_at(T, idx),
                           ("pose",) if form_only else ())

    geo = Geometry(evaluate, result.registration.T_nominal_measured, margin, nominal.points,
                   nominal.normals, masks, *_centre_and_length(result.registered), labels,
                   exact_feature, measured)
    planned = _judged(result, plan, geo, sample_of or (lambda f: nominal.tree.query(f)[1]),
                      zone_in_verdict, by_foot=exact, rivals=rivals)
    result = replace(result, verdict=planned.verdict, reasons=planned.reasons, plan=planned)
    if planned.alignment is None:
        return result
    # The per-point outputs at the plan's alignment: where the drawing places the part.
    X, dv = posed.at(planned.T_nominal_measured)
    return _at_plan_pose(result, X, dv, None if result.margin is None else posed.margins_at(
        planned.T_nominal_measured))


def inspect_plan_2d(result, plan: Plan, index, labels: np.ndarray | None,
                    zone_in_verdict: bool):
    """:func:`inspect_plan` for a 2D template (``index``: its engine.contour.ContourIndex):
    the plan works in the template's plane on the registered points' x, y (poses 3x3 there,
    starting from the identity); the part's pose and per-point outputs are lifted back into
    3D. Template lines and arcs are exact: no sampling margin. A region's ``group`` selects
    the samples of a DXF layer's contours (its name compared without case, as DXF does)."""
    from ..contour import deviations_2d
    from ..deviation import Deviations
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
        from ..uncertainty import expanded_at

        if result.decision_rule != DecisionRule.GUARDED or result.uncertainty is None:
            return None
        return expanded_at(result.uncertainty, idx, np.zeros(len(idx)),
                           ("pose",) if form_only else ())

    geo = Geometry(evaluate, np.eye(3), margin, samples, normals, masks,
                   *_centre_and_length(P2), labels, points=P2)
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


def _judged(result, plan: Plan, geo: Geometry, sample_of, zone_in_verdict: bool,
            by_foot: bool = False, rivals=None) -> PlanResult:
    """The plan checked on ``geo``, with the inspection's own zone as a characteristic over all
    points when ``zone_in_verdict``; everything INCONCLUSIVE when the registration, on which
    the regions rest, cannot be trusted. by_foot : a box holds the points whose closest point
    lies in it (engine.gdt.regions.measured_members). rivals : a STEP model's points in doubt
    (engine.step_model.face_rivals), judged by :func:`_in_doubt`; None: none."""
    from .regions import measured_members, region_column
    from ..verdict import pose_trusted

    dim = geo.nominal_points.shape[1]
    for d in plan.datums:
        if d.feature not in (FEATURES_2D if dim == 2 else FEATURES_3D):
            raise InputError(f"[[datum]] '{d.label}': a {d.feature} datum needs a "
                             f"{'3D nominal' if dim == 2 else '2D template'}; this nominal is "
                             f"{'a 2D template' if dim == 2 else '3D'}", plan.path)
    reg = result.registration
    n = result.registered.shape[0]
    geo = replace(geo, nominal_masks=feature_masks(plan, geo))
    # A point belongs where it lies: in the region of the sample nearest its closest point on
    # the surface (not its nearest sample, which may lie on the next face).
    foot = result.deviations.foot[:, :geo.nominal_points.shape[1]]
    samples = sample_of(foot)
    members = measured_members(plan, geo.nominal_masks, samples, geo.labels,
                               foot if by_foot else None)
    doubt = None if rivals is None else rivals(
        result.registered, result.deviations.signed, samples, geo.nominal_masks, members)
    planned = check_plan(plan, geo, members, n, region_column(plan, members, n), doubt)
    results = list(planned.characteristics)
    if zone_in_verdict:
        tol = result.tolerance
        d = result.deviations.signed
        whole = Characteristic(RESERVED_ID, "profile", "(all points)", tol.lower, tol.upper)
        results.insert(0, CharacteristicResult(
            whole, float(2.0 * np.max(np.abs(d - tol.centre))),
            result.verdict, result.reasons[0], np.arange(d.size), d, result.statistics.worst))
    verdict, reasons = plan_verdict(results, planned.alignment)
    if plan.not_judged:  # the part is ACCEPT only when every characteristic of its source is
        reasons = (plan.not_judged_summary, *reasons)
        verdict = REJECT if verdict == REJECT else INCONCLUSIVE
    if not pose_trusted(reg):
        results = [replace(r, verdict=INCONCLUSIVE, reason=f"the registration cannot be "
                           f"trusted: {result.reasons[0]}") for r in results]
        verdict, reasons = INCONCLUSIVE, result.reasons
    return replace(planned, verdict=verdict, reasons=reasons, characteristics=tuple(results),
                   zone_in_verdict=zone_in_verdict)


def _in_doubt(results: list[CharacteristicResult], plan: Plan, geo: Geometry,
              members: dict[str, np.ndarray], doubt) -> list[CharacteristicResult]:
    """``results`` where the points in doubt decide: each characteristic judged again without
    them, INCONCLUSIVE where its verdict changes (saying both), the same result where not.
    Both verdicts are the frame probe's (engine.gdt.frame_probe): without those points a
    datum's frame may be uncertain where it was not with them (an ACCEPT both ways, but
    INCONCLUSIVE without them, is INCONCLUSIVE). The probe runs again only on the
    characteristics those points touch.

    doubt : ({region: indices of its members that may have been measured on a face outside
    it}, (n,) each point's rival face id, 0 for none), engine.step_model.face_rivals. A region
    most of whose points are in doubt keeps them all (it is judged as it is)."""
    drop, rival = doubt
    drop = {r: i for r, i in drop.items() if 0 < len(i) <= len(members[r]) // 2}
    if not drop:
        return results
    kept = {r: np.setdiff1d(m, drop[r]) if r in drop else m for r, m in members.items()}
    labels = [d.label for d in plan.datums]

    def touched_by(c) -> list[str]:
        """The regions in doubt that ``c`` is judged on or relative to."""
        near = [plan.datum(x).region for ref in c.datums for x in datum_parts(ref, labels) or ()]
        return [r for r in dict.fromkeys([*(c.regions or (c.region,)), *near]) if r in drop]

    probe = {r.characteristic.id for r in results if touched_by(r.characteristic)}
    try:
        again = _judged_characteristics(plan, geo, kept, probe)[0]
    except InputError as e:  # without them a feature cannot be fitted: its verdict is open
        again = [replace(r, verdict=INCONCLUSIVE, value=None, reason=e.message)
                 for r in results]
    out = []
    for a, b in zip(results, again):
        touched = touched_by(a.characteristic)
        if a.verdict == b.verdict or not touched:
            out.append(a)
            continue
        idx = np.unique(np.concatenate([drop[r] for r in touched]))
        faces = np.unique(rival[idx])
        named = ("face " if faces.size == 1 else "faces ") + ", ".join(map(str, faces))
        shown = ", ".join(f"'{r}'" for r in touched)
        out.append(replace(a, verdict=INCONCLUSIVE, reason=(
            f"{idx.size} measured point{'s' if idx.size > 1 else ''} of {shown} lie nearly as "
            f"near another face as their own ({named}): judged with them "
            f"{a.verdict} ({_shown(a.value)}), without them {b.verdict} ({_shown(b.value)}); "
            "which face they were measured on decides")))
    return out


def _shown(value: float | None) -> str:
    return "no value" if value is None else f"{value:.4g} mm"


def _at_plan_pose(result, X: np.ndarray, dv, margin):
    """``result`` with its per-point outputs (points, deviations, in-tolerance, statistics,
    margins) at the plan's alignment: where the drawing places the part."""
    tol = result.tolerance
    return replace(result, registered=X, deviations=dv,
                   in_tolerance=(dv.signed >= tol.lower) & (dv.signed <= tol.upper),
                   statistics=Statistics.of(dv.signed, tol), margin=margin)
