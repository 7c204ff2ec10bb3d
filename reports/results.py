"""Machine-readable results: the JSON document and the per-point CSV, written atomically.

The JSON names and the CSV columns are a contract scripts depend on (see the README). Points
are numbered from 1 in input order, as the desktop app numbers them: the CSV's ``point``
column, and ``point`` (with the point's ``label`` from the measured file, or null) wherever the
JSON names one (``deviations.worst``, ``registration.gross_outliers.excluded``, a
characteristic's ``worst``).
"""

from __future__ import annotations

import csv
import io
import json
import os

import numpy as np

from engine.choices import DecisionRule, Fit
from engine.gdt.plan import DEFAULT_SECTIONS, DIMENSIONS, ORIENTATION, RESERVED_ID, SYMBOLS
from engine.inspection import InspectionResult
from engine.pipeline import InputRecord, Run
from reports.messages import spreadsheet_text

SOFTWARE_NAME = "qa-inspect"
CSV_COLUMNS = ("point", "label", "x", "y", "z", "x_reg", "y_reg", "z_reg", "deviation",
               "in_tolerance", "excluded_from_alignment")
"""Columns of every per-point CSV; with the guarded decision rule (or an instrument stated) a
``margin`` column (the nominal-sampling margin) and an ``uncertainty`` column (the point's
expanded uncertainty U, k = 2) follow.
``excluded_from_alignment`` is true only on the gross outliers the final fit excluded from the
alignment (engine.outliers); they are judged like every other point."""


def software_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("qa-inspect")
    except PackageNotFoundError:  # running from a source tree that was not installed
        return "0+unknown"


def run_document(run: Run) -> dict:
    """The JSON document of one run of the pipeline: :func:`result_document`, the settings
    needed to re-run it (``settings``), what the user should know about the inputs
    (``warnings``, sentences) and, with a crop or plane removal, which measured points were
    inspected (``scene``, :func:`scene_json`)."""
    doc = result_document(run.result, run.inputs, run.timings_s, run.measured.labels)
    doc["settings"] = run.settings.to_json()
    doc["warnings"] = list(run.warnings)
    if run.selection is not None:
        doc["scene"] = scene_json(run.selection)
    return doc


def scene_json(sel) -> dict:
    """Which measured points an inspection kept (engine.scene.Selection): the counts, the crop
    box and the plane removed."""
    plane = sel.plane
    doc = {
        "n_read": sel.n_read, "n_kept": sel.n_kept,
        "crop": None if sel.box is None else list(sel.box),
        "n_outside_crop": sel.n_outside_box,
        "plane": None if plane is None else {
            "normal": [float(v) for v in plane.normal], "offset_mm": _num(plane.offset),
            "distance_mm": _num(plane.distance), "distance_rule": plane.rule,
            "sigma_mm": _num(plane.sigma), "spacing_mm": _num(plane.spacing),
            "n_removed": sel.n_on_plane},
        "definition": "the measured points inspected: those inside the crop box (xmin, ymin, "
                      "zmin, xmax, ymax, zmax, mm, the measured file's frame, faces included), "
                      "less those within distance_mm of the dominant plane among them "
                      "(normal . x = offset_mm, seeded RANSAC, refitted by least squares); the "
                      "per-point outputs number the kept points from 1 in input order",
    }
    if sel.n_objects:
        doc["objects"] = {
            "n_objects": sel.n_objects, "n_other_objects_points": sel.n_other_objects,
            "link_mm": _num(sel.object_link),
            "definition": "with the plane removed, the points linked within link_mm of each "
                          "other are one object; each object that could be the part was "
                          "registered to the nominal, and the objects most of whose points lie "
                          "near the nominal at the pose that claims the most points are the "
                          "part: the other objects' points are not inspected"}
    return doc


def result_document(result: InspectionResult, inputs: list[InputRecord],
                    timings_s: dict, labels: np.ndarray | None = None) -> dict:
    """The JSON document of one inspection (plain dict of JSON types); labels : (n,) the
    measured points' labels (None: the file has none)."""
    reg = result.registration
    st = result.statistics
    dev = result.deviations.signed
    return {
        "verdict": result.verdict,
        "reasons": list(result.reasons),
        "transform": [[float(v) for v in row] for row in reg.T_nominal_measured],
        "transform_convention": "T_nominal_measured: row-major 4x4, maps measured coordinates "
                                "(mm) into the nominal frame",
        "registration": {
            "converged": bool(reg.converged),
            "iterations": int(reg.iterations),
            "rms": _num(reg.rms),
            "rms_definition": reg.rms_definition,
            "n_inliers": int(reg.n_inliers),
            "outlier_cut": _num(reg.outlier_cut),
            "gross_outliers": _gross_outliers(reg, dev, labels),
            "score": _num(reg.score),
            "hypotheses": int(reg.hypotheses),
            "runner_up_score": None if reg.runner_up_score is None else _num(reg.runner_up_score),
            "ambiguous": bool(result.ambiguous),
            "ambiguity_spread_mm": _num(result.ambiguity_spread),
            "ambiguity_definition": "true when the best distinct other pose scores within 1.5x "
                                    "of the chosen one and moves some point's deviation by more "
                                    "than 10% of the zone width (a symmetry that leaves the "
                                    "deviations unchanged is not ambiguous); a reported fact: "
                                    "the verdict is INCONCLUSIVE only when it differs at that "
                                    "pose (see pose_sensitivity)",
            **_conditioning(result.conditioning),
            "score_definition": "truncated RMS sqrt(mean(min(d^2, cut^2))) in mm over a seeded "
                                "subset of at most 4096 measured points, the same for the "
                                "runner-up pose; lower is better",
            "message": reg.message,
        },
        "deviations": {
            "count": st.count, "min": st.min, "max": st.max, "mean": st.mean, "std": st.std,
            "rms": st.rms, "max_abs": st.max_abs, "n_out": st.n_out,
            "fraction_in": st.fraction_in,
            "worst": [{**point_ref(i, labels), "deviation": float(dev[i])} for i in st.worst],
            "sign": "positive along the nominal's outward normal (excess material)",
            "normals_source": result.normals_source,
            "method": DEVIATION_METHODS.get(result.normals_source, DEVIATION_METHODS["facets"]),
            "units": "mm",
        },
        "tolerance": {"lower": result.tolerance.lower, "upper": result.tolerance.upper},
        "fit": result.fit,
        "fit_definition": FIT_DEFINITIONS[result.fit],
        "decision_rule": result.decision_rule,
        "decision_rule_definition": RULE_DEFINITIONS[result.decision_rule],
        **({} if result.margin is None else {"margin": {
            "max": _num(float(result.margin.max())) if result.margin.size else 0.0,
            "mean": _num(float(result.margin.mean())) if result.margin.size else 0.0,
            "definition": "per point, at its nearest nominal sample: max over the principal "
                          "directions of curvature x (sample spacing along it)^2 / 8, mm (how far "
                          "a chord between samples sags below the surface); 0 for a 2D "
                          "template's exact lines and arcs"}}),
        **({} if result.uncertainty is None else {
            "uncertainty": uncertainty_json(result.uncertainty, result.decision_rule)}),
        "inputs": [{"role": r.role, "path": r.path, "sha256": r.sha256, "n_points": r.n_points,
                    **({} if r.n_primitives is None else {"n_primitives": r.n_primitives}),
                    **({} if r.n_faces is None else {"n_faces": r.n_faces})}
                   for r in inputs],
        "software": {"name": SOFTWARE_NAME, "version": software_version()},
        "timings_s": {k: round(float(v), 6) for k, v in timings_s.items()},
        **_json_safe(result.extra),
        "pose_sensitivity": pose_sensitivity_json(result),
        **({} if result.plan is None else plan_json(result.plan, inputs, labels)),
    }


def point_ref(i: int, labels: np.ndarray | None) -> dict:
    """A measured point as the JSON names it: ``point`` its number from 1 in input order (as
    the app and the CSV number it) and ``label`` its label in the measured file (None: none)."""
    label = None if labels is None else str(labels[int(i)])
    return {"point": int(i) + 1, "label": label or None}


def plan_json(planned, inputs: list[InputRecord], labels: np.ndarray | None = None) -> dict:
    """The plan's part of the results: ``plan`` (the file), ``alignment`` and
    ``characteristics`` (each with its value in the drawing's convention and its verdict)."""
    rec = next((r for r in inputs if r.role == "plan"), None)
    al = planned.alignment
    alignment = {"method": planned.method,
                 "T_nominal_measured": [[float(v) for v in row]
                                        for row in planned.T_nominal_measured]}
    if al is not None:
        alignment.update({
            "reference": [d.label for d in al.datums],
            "datums": [{"label": d.label, "feature": d.feature, "fit": d.fit,
                        "n_points": d.n_points, "constrained_dofs": d.constrained,
                        "form_error": _num(d.gap), "size_offset_mm": _num(d.offset)}
                       for d in al.datums],
            "free_dofs": [f.describe() for f in al.free],
            "free_dofs_best_fitted": bool(al.best_fitted),
            "complete": bool(al.complete), "message": al.message,
            "form_error_definition": "tangent datum: the largest gap between the datum's points "
                                     "and its simulator; least squares: the largest |residual| "
                                     "(mm)"})
    return {
        "plan": None if rec is None else {"path": rec.path, "sha256": rec.sha256},
        "alignment": alignment,
        "tolerance_in_verdict": bool(planned.zone_in_verdict),
        "tolerance_definition": "with a plan, 'deviations', 'tolerance' and the per-point CSV "
                                "are at the plan's alignment; the tolerance is a characteristic "
                                "over all points ('tol') when given, else only the zone of the "
                                "per-point statistics (the plan's widest profile zone)",
        "characteristics": [_characteristic_json(r, labels, rec) for r in planned.characteristics],
        **({} if not any(r.characteristic.type in DIMENSIONS for r in planned.characteristics)
           else {"dimension_value_definition": DIMENSION_DEFINITION}),
        "features": [_json_safe({"region": f.region, "feature": f.feature,
                                 "datums": [{"label": a, "fit": b} for a, b in f.datums],
                                 "nominal": f.nominal, "measured": f.measured})
                     for f in planned.features],
        "feature_definition": (
            "each region a datum or characteristic uses, as the feature the drawing names "
            "(a datum's feature; flatness: plane; position, size: cylinder; else freeform, "
            "without geometry) and the datums established on it; nominal: least squares of the region's nominal points, "
            "measured: of its measured points at the plan's alignment, nominal frame (mm); "
            "internal: a hole; form_error: peak to valley of the residuals; null: the points "
            "do not determine the feature"),
        "characteristic_value_definition": (
            "profile: twice the largest |deviation - zone centre| over the region's points "
            "(the width of the smallest zone, centred like the tolerance zone, holding every "
            "point); flatness: the minimum-zone width; position: the diameter of the smallest "
            "cylinder (circle, sphere) about the true position holding the fitted axis "
            "(centre), of a width the distance of two planes about the true median plane "
            "holding the fitted median plane, at MMC / LMC judged against zone + bonus "
            "('allowed'); size: by its 'method', the least-squares (lsq), two-point (the "
            "smallest and largest local sizes), minimum circumscribed or maximum inscribed "
            "diameter or width; coaxiality, concentricity: the diameter of the smallest "
            "cylinder about the primary datum's axis holding the least-squares axis; symmetry: "
            "the width of the zone about the true median plane holding the two-point pairs' "
            "midpoints; straightness: the diameter of the smallest cylinder "
            "holding the derived median line (the least-squares centres of 'sections' slabs "
            "along the axis), or along 'direction' the largest minimum-zone width of two lines "
            "holding a slab of the face (a line element); circularity: the largest "
            "minimum-zone radial separation of two concentric circles over the slabs; "
            "cylindricity: the minimum-zone radial separation of two coaxial cylinders; "
            "parallelism, perpendicularity, angularity: at the pose the datums give, the width "
            "of the smallest zone of two planes at the basic angle to the primary datum, or "
            "(diametral) the diameter of the smallest cylinder at that angle holding the "
            "least-squares axis between the planes bounding the feature along it, or (feature "
            "width) the width of the smallest zone of two planes at that angle holding the "
            "derived median plane (the midpoints of the width's two-point pairs); a rotation "
            "the datums leave free turns the zone to its smallest; circular_runout: the "
            "largest full indicator movement (max - min of the distance from the datum axis, "
            "or on a face normal to it of the coordinate along it) over 'sections' slabs along "
            "the axis (annuli about it); total_runout: the same over the whole surface; the "
            "datum axis: a cylinder datum's (tangent: the smallest circumscribed / largest "
            "inscribed cylinder's; lsq: least squares), a common datum's 'A-B' the least "
            "squares of both features, a radius each; line_profile: the largest profile value "
            "over the sections every 'spacing' mm normal to 'direction' (form only: each "
            "section refitted in its plane) (mm)"),
    }


DIMENSION_DEFINITION = (
    "radius, angle, distance: their 'unit' says the unit of value, zone, lower, upper and "
    "nominal ('mm', or 'degree' for an angle); the limits are nominal + lower .. nominal + "
    "upper; radius: half the least-squares diameter of a cylinder or sphere; angle: between "
    "the least-squares planes (their normals) or axes of its two 'regions' ('features'), 90 "
    "degrees less the angle between a plane's normal and an axis, on the branch (a or 180 - a) "
    "the nominal model's features make with 'nominal'; distance: two planes: the smaller's "
    "points' centroid from the larger's fitted plane (larger: the wider across its narrowest "
    "way); a "
    "plane and an axis or centre: from the axis' middle or the centre to the plane; two axes: "
    "the shorter's middle from the longer's line; an axis and a centre, two centres: point to "
    "line, point to point; model_value: the same on the nominal model")


def _characteristic_json(r, labels: np.ndarray | None = None,
                         plan: InputRecord | None = None) -> dict:
    c = r.characteristic
    out = {"id": c.id, **({"name": c.name} if c.name else {}),
           **({"designator": c.designator} if c.designator else {}),
           "source": _source(c, plan),
           "type": c.type, "region": c.region, "datums": list(c.datums),
           "zone": _num(c.width), "lower": _num(c.lower), "upper": _num(c.upper),
           "value": None if r.value is None else _num(r.value),
           "n_points": int(r.indices.size), "verdict": r.verdict, "reason": r.reason,
           "worst": [point_ref(i, labels) for i in r.worst]}
    if c.type == "size":
        out.update(nominal=_num(c.nominal), method=c.method)
    if c.type in ("size", "position", "coaxiality", "concentricity", "symmetry") + ORIENTATION:
        out["feature"] = c.feature  # (an orientation's: plane, cylinder (its axis) or width)
    if c.type == "position":
        out.update(modifier=c.modifier, bonus=None, allowed=None, actual_mating_size=None)
    if c.regions:
        out["regions"] = list(c.regions)
    if c.type in ("profile", "line_profile") and not c.datums:
        out["fit"] = c.fit
    if c.type in ("straightness", "circularity", "circular_runout"):
        out["sections"] = c.sections or DEFAULT_SECTIONS
    if c.type in ("profile", "line_profile"):
        out["all_around"] = bool(c.all_around)
    if c.type == "straightness" or c.type in ORIENTATION:
        out["diametral"] = bool(c.diametral)
    if c.direction is not None:
        out["direction"] = [float(v) for v in c.direction]
    if c.type == "angularity":
        out["angle"] = _num(c.angle)
    if c.type in DIMENSIONS:  # value, zone, lower, upper and nominal in ``unit``
        out.update(nominal=_num(c.nominal), unit=c.unit)
        if c.features:
            out["features"] = list(c.features)
        else:
            out["feature"] = c.feature
    out["symbol"] = SYMBOLS.get(c.type, "")
    out.update(_json_safe({k: v for k, v in r.facts.items() if k != "T_nominal_measured"}))
    return out


def _source(c, plan: InputRecord | None) -> dict:
    """Where a characteristic comes from: the plan file's name and the item in it (a QIF
    element and its id; a TOML plan's table), or the --tol zone added to the plan."""
    if c.id == RESERVED_ID and c.region == "(all points)":
        return {"file": None, "item": "--tol: the zone over all points"}
    return {"file": None if plan is None else os.path.basename(plan.path),
            "item": c.source or f"[[characteristic]] id = \"{c.id}\""}


def uncertainty_json(b, rule: str) -> dict:
    """The uncertainty budget (engine.uncertainty): each term's largest and mean standard
    uncertainty, the expanded U, the instrument stated and how U enters the decision."""
    U = b.expanded
    return {
        "k": b.k,
        "expanded_max_mm": _num(float(U.max())) if U.size else 0.0,
        "expanded_mean_mm": _num(float(U.mean())) if U.size else 0.0,
        "length_max_mm": _num(float(b.length_mm.max())) if U.size else 0.0,
        "terms": [{"term": t.key, "name": t.name, "distribution": t.distribution,
                   "divisor": _num(t.divisor),
                   "u_max_mm": _num(float(t.u.max())) if t.u.size else 0.0,
                   "u_mean_mm": _num(float(t.u.mean())) if t.u.size else 0.0,
                   "basis": t.basis} for t in b.terms],
        "instrument": None if b.instrument is None else b.instrument.to_json(),
        "used_by_decision_rule": rule == DecisionRule.GUARDED,
        "definition": "per point: U = k x sqrt(sum of the terms' standard uncertainties u^2), "
                      "k = 2 (GUM); a bound taken as rectangular gives u = bound / sqrt(3), a "
                      "stated expanded uncertainty u = U / 2, the pose's covariance its own "
                      "standard deviation; L is the point's distance from the centroid of the "
                      "fitted points. The guarded rule (ISO 14253-1) accepts inside the zone "
                      "shrunk by each point's U, rejects outside the zone grown by it, and is "
                      "inconclusive in between; the per-point U is the CSV's 'uncertainty'",
    }


def pose_sensitivity_json(result: InspectionResult) -> dict | None:
    """Whether the verdict holds over the poses the measurement allows (None: the pose could
    not be trusted at all), and what the measurement does not fix, in plain words."""
    sens = result.pose_sensitivity
    if sens is None:
        return None
    return {
        "verdict_stable": bool(sens.verdict_stable),
        "verdict_at_fitted_pose": sens.verdict,
        "max_change_mm": _num(sens.max_change_mm),
        "min_limit_margin_mm": _num(sens.min_limit_margin_mm),
        "worst_margin_mm": _num(sens.worst_margin_mm),
        "points_evaluated": int(sens.points_evaluated),
        "probes": [{"kind": p.kind, "axis": None if p.axis is None else list(p.axis),
                    "through": None if p.through is None else list(p.through),
                    "free": bool(p.free),
                    "sigma_mm": None if p.sigma_mm is None else _num(p.sigma_mm),
                    "amplitudes_mm": [_num(a) for a in p.amplitudes],
                    "verdicts": list(p.verdicts), "plausible": [bool(o) for o in p.plausible],
                    "every_point": [bool(e) for e in p.every_point],
                    "stopped_where_points_stop_fitting": [bool(e) for e in p.ends],
                    "max_change_mm": _num(p.max_change_mm), "invariant": bool(p.invariant)}
                   for p in sens.probes],
        "statements": list(result.trust_statements),
        "definition": "the pointwise verdict re-evaluated with the part moved along each weak "
                      "direction by +-1.5 and +-3 sigma, along each free one scanned outward "
                      "both ways from the fitted pose (steps growing by at most 1.5x, cut where "
                      "deviations change, refined to where the points stop fitting) up to half "
                      "the fitted points' RMS radius (a rotation: that arc at that radius) or to "
                      "where the points stop fitting (RMS of deviations above 1.5x the fitted "
                      "pose's plus 2% of the zone, or a point carried past the nominal's border), "
                      "at a runner-up pose scoring within 1.5x, and (kind uncertainty) for "
                      "each point nearer a limit than 3 sigma of its deviation under the full "
                      "pose covariance from the residuals, at the pose 3 sigma away that moves "
                      "it most towards that limit; the verdict is INCONCLUSIVE "
                      "when it differs at any pose where the points fit. every_point: the "
                      "verdict there is that of every point (each point the motion displaces by "
                      "at least its distance to a limit evaluated exactly), else of a seeded "
                      "subset of 16384; stopped_where_points_stop_fitting: per side (negative, "
                      "positive). amplitudes_mm: motion at the "
                      "RMS radius; min_limit_margin_mm: signed distance (positive inside) to its "
                      "nearest limit of the point closest to one; max_change_mm: largest "
                      "|deviation change| over the poses probed",
    }


DEVIATION_METHODS = {
    "contour": "exact distance to the template's line segments and circular arcs (splines and "
               "ellipses flattened within 0.1 um); positive outward for closed contours (into "
               "holes), to the left of the drawn direction for open ones",
    "B-rep": "exact B-rep: the distance to the nearest face of the STEP model with its trim "
             "respected (an edge or vertex where the nearest point lies on one), positive along "
             "the face's outward normal; no nominal-sampling margin",
    "facets": "local facets around the nearest nominal points, curvature-corrected with the "
              "nominal normals"}
"""The deviation method in words, by the result's ``normals_source``."""
FIT_DEFINITIONS = {
    Fit.LSQ: "least squares of point-to-surface distances over every point but those excluded "
           "from the alignment as gross outliers (a best fit: it spreads the error and can "
           "hide a local defect in the pose)",
    Fit.MINIMAX: "the rigid pose minimising the largest |deviation - zone centre| / half-width "
               "over every point but those excluded from the alignment as gross outliers "
               "(Chebyshev), from the least-squares pose: answers 'can "
               "the part be placed inside its zone?'"}
RULE_DEFINITIONS = {
    DecisionRule.SIMPLE: "accept only if every point lies inside the zone; reject if any lies outside",
    DecisionRule.GUARDED: "ISO 14253-1: accept only if every point lies inside the zone shrunk by its "
               "expanded measurement uncertainty U (k = 2: instrument, pose of the registration, "
               "nominal sampling; see 'uncertainty'); reject only if a point lies outside the "
               "zone grown by its U; otherwise inconclusive"}


def _gross_outliers(reg, dev: np.ndarray, labels: np.ndarray | None = None) -> dict:
    """The points excluded from the alignment, and the rule that excluded them."""
    rule = reg.gross_rule
    excluded = np.flatnonzero(~np.asarray(reg.inlier, bool))
    return {
        "rule": rule.describe(),
        "threshold_mm": _num(rule.threshold_mm),
        "centre_mm": _num(rule.centre_mm),
        "zone_width_mm": None if rule.zone_width_mm is None else _num(rule.zone_width_mm),
        "robust_sigma_mm": _num(rule.robust_sigma_mm),
        "floor_mm": _num(rule.floor_mm),
        "n_excluded": int(excluded.size),
        "excluded": [{**point_ref(i, labels), "deviation": _num(float(dev[i]))}
                     for i in excluded[:GROSS_LISTED]],
        "definition": "points excluded from the alignment (the final least-squares fit) as gross "
                      "outliers by the rule above; every other point is fitted, and every point, "
                      "excluded or not, is judged; 'excluded' lists the first "
                      f"{GROSS_LISTED} by point number (from 1, input order)",
    }


GROSS_LISTED = 100
"""At most this many excluded points are listed by index in the JSON (the CSV marks them all)."""


def _conditioning(cond) -> dict:
    if cond is None:
        return {"weak_directions": [], "pose_uncertainty_mm": None}
    return {
        "weak_directions": [{"type": w.type, "axis": list(w.axis), "strength": w.strength,
                             "sigma_mm": None if w.sigma_mm is None else _num(w.sigma_mm)}
                            for w in cond.weak],
        "conditioning": {"strengths": list(cond.strengths), "length_mm": cond.length,
                         "definition": "eigenvalues of the point-to-surface normal matrix at "
                                       "the final pose (rotations scaled by length_mm), over "
                                       "the largest; a direction is unconstrained below 1e-8, or below 1e-4 when the "
                                       "residuals imply a 1-sigma motion along it above a "
                                       "quarter of the zone width (sigma_mm)"},
        "pose_uncertainty_mm": None if cond.pose_sigma_mm is None else _num(cond.pose_sigma_mm),
    }


def _json_safe(obj):
    """Kind-specific facts (numpy scalars included) as plain JSON types."""
    if isinstance(obj, dict):
        return {str(k): _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        return _json_safe(obj.tolist())
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        return _num(float(obj))
    return obj


def _num(v: float):
    return float(v) if np.isfinite(v) else None


def result_json(doc: dict) -> str:
    return json.dumps(doc, indent=2, allow_nan=False) + "\n"


def points_csv(result: InspectionResult, measured: np.ndarray,
               labels: np.ndarray | None) -> str:
    """One row per measured point in input order (columns: CSV_COLUMNS, plus ``margin`` and
    ``uncertainty`` with the guarded decision rule or an instrument, and ``region`` with an inspection plan: the point's regions joined by
    '+'; the coordinates and deviation are then at the plan's alignment)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    margin = result.margin
    U = None if result.uncertainty is None else result.uncertainty.expanded
    regions = None if result.plan is None else result.plan.regions
    w.writerow(CSV_COLUMNS + (() if margin is None else ("margin",))
               + (() if U is None else ("uncertainty",))
               + (() if regions is None else ("region",)))
    reg = result.registered
    d = result.deviations.signed
    inside = result.in_tolerance
    excluded = result.outlier
    for i in range(measured.shape[0]):
        label = spreadsheet_text(labels[i]) if labels is not None else ""
        row = [i + 1, label, *(f"{v:.6f}" for v in measured[i]), *(f"{v:.6f}" for v in reg[i]),
               f"{d[i]:.6f}", "true" if inside[i] else "false",
               "true" if excluded[i] else "false"]
        if margin is not None:
            row.append(f"{margin[i]:.6f}")
        if U is not None:
            row.append(f"{U[i]:.6f}")
        if regions is not None:
            row.append(spreadsheet_text(regions[i]))
        w.writerow(row)
    return buf.getvalue()
