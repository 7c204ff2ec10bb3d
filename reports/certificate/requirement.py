"""Section 3 of the certificate, the requirement: the tolerance zone (or the inspection
plan's characteristics), the sign, the decision rule, the units and the measurement
uncertainty budget."""

from __future__ import annotations

import os

from engine.choices import DecisionRule
from engine.verdict import LEFT_OUT_ALLOWED, MAX_LEFT_OUT_FRACTION

from .layout import Layout, esc
from .result import type_word


def requirement(c: Layout) -> list:
    """3  Requirement: the tolerance zone, the sign, the decision rule, the units."""
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph as P

    res, W, zone = c.res, c.width, c.zone
    tol = res.tolerance
    if c.plan is not None:
        return [P("3  Requirement", c.styles["h"]), c.kv(_plan_requirement(c),
                                                          [28 * mm, W - 28 * mm]),
                *_uncertainty_budget(c)]
    return [P("3  Requirement", c.styles["h"]), c.kv([
        ("Tolerance zone", f"{'Line' if c.is_2d else 'Surface'} profile, deviation from the "
                           f"nominal {zone} (lower limit {tol.lower:+.3f}, upper limit "
                           f"{tol.upper:+.3f}); limits are in tolerance"),
        ("Sign", "Positive along the nominal's outward normal (excess material), negative "
                 "into the material (missing material)"),
        # Lower case on purpose: the verdict words appear on a certificate only as its verdict.
        ("Decision rule", ("Pointwise, simple acceptance: the part is accepted only if every "
                           "measured point lies inside the zone, rejected if any point lies "
                           "outside" if res.decision_rule == DecisionRule.SIMPLE else
                           "Pointwise, guarded " + _guarded_words(res))
                          + "; the result is inconclusive when the registration cannot be "
                            "trusted (not converged, the points do not match the nominal, or "
                            f"more than {100 * MAX_LEFT_OUT_FRACTION:.0f}% of them, and more "
                            f"than {LEFT_OUT_ALLOWED}, left out of the alignment as gross "
                            "outliers), "
                            "or when the verdict could differ within what the measurement "
                            "leaves open: along a direction the points do not fix, within ±3 "
                            "sigma of one they fix only weakly, or at another pose that fits "
                            "nearly as well. " + _uncertainty_sentence(res)),
        ("Units", "millimetres"),
    ], [28 * mm, W - 28 * mm]), *_uncertainty_budget(c)]


def _guarded_words(res) -> str:
    """The guarded rule in words: with each point's expanded uncertainty U (or, in a session
    older than uncertainty budgets, its nominal-sampling margin)."""
    if res.uncertainty is None:
        return ("(ISO 14253-1 style): the part is accepted only if every point lies inside the "
                "zone shrunk by its nominal-sampling margin, rejected only if a point lies "
                "outside the zone grown by it, inconclusive in between")
    return ("(ISO 14253-1): each point's deviation is uncertain by its expanded measurement "
            "uncertainty U (the budget below); the part is accepted only if every point lies "
            "inside the zone shrunk by its U (conformance proven), rejected only if a point "
            "lies outside the zone grown by its U (non-conformance proven), inconclusive when "
            "a point lies between")


def _uncertainty_sentence(res) -> str:
    """Whether measurement uncertainty entered the decision, in a sentence."""
    if res.decision_rule == DecisionRule.GUARDED:
        return ("Measurement uncertainty is deducted from the zone as stated." if
                res.uncertainty is not None else "Measurement uncertainty is not deducted "
                "from the zone.")
    if res.uncertainty is not None:
        return (f"Measurement uncertainty (U up to {float(res.uncertainty.expanded.max()):.4f} "
                "mm, below) is stated but not deducted from the zone (simple acceptance).")
    return "Measurement uncertainty is not deducted from the zone (simple acceptance)."


def _uncertainty_budget(c: Layout) -> list:
    """The uncertainty budget (engine.uncertainty): per term its basis, distribution, divisor
    and standard uncertainty (largest and mean over the points), then the expanded U; nothing
    when no budget was made (simple rule, no instrument stated)."""
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether, Spacer
    from reportlab.platypus import Paragraph as P

    b = c.res.uncertainty
    if b is None:
        return []
    S = c.styles
    rows = [["Term", "Basis and assumption", "Distribution", "Divisor", "u max", "u mean"]]
    for t in b.terms:
        rows.append([P(esc(t.name[:1].upper() + t.name[1:]), S["cell"]),
                     P(esc(t.basis), S["cell"]), t.distribution,
                     "√3" if abs(t.divisor - 3 ** 0.5) < 1e-12 else f"{t.divisor:g}",
                     f"{float(t.u.max()):.4f}", f"{float(t.u.mean()):.4f}"])
    rows.append([P("<b>Expanded U</b>", S["cell"]),
                 P(f"k = {b.k:g} x root-sum-of-squares of the terms, per point", S["cell"]),
                 "", "", f"{float(b.expanded.max()):.4f}", f"{float(b.expanded.mean()):.4f}"])
    n = len(rows) - 1
    ins = b.instrument
    note = ("No instrument stated: the instrument's own error is not in this budget; state it "
            "with --uncertainty or the plan's [measurement]." if ins is None or
            not ins.states_anything else "")
    return [KeepTogether([
        Spacer(1, 2 * mm), P("Measurement uncertainty budget (mm, per point)", S["cellb"]),
        Spacer(1, 1 * mm),
        c.table(rows, [34 * mm, c.width - 112 * mm, 20 * mm, 14 * mm, 22 * mm, 22 * mm],
                styles=[("ALIGN", (2, 0), (-1, -1), "CENTER"),
                        ("FONT", (4, n), (-1, n), "Vera-Bold", 7.5)]),
        P("Standard uncertainties u combined by root-sum-of-squares (GUM); a bound taken as a "
          "rectangular distribution gives u = bound / √3, a stated expanded uncertainty "
          "u = U / 2. L: a point's distance from the centroid of the fitted points (largest "
          f"{float(b.length_mm.max()):.1f} mm). Each point's U is in the attached points.csv "
          "(column 'uncertainty'). " + note, S["small"])])]


def _plan_requirement(c: Layout) -> list[tuple[str, str]]:
    """Section 3 of a plan: its characteristics are the requirement; the zone of the per-point
    statistics is stated apart, with whether it is one of them."""
    res, zone, plan = c.res, c.zone, c.plan_read
    rec = next(r for r in c.run.inputs if r.role == "plan")
    guarded = res.decision_rule == DecisionRule.GUARDED
    return [
        ("Requirement", f"The {len(plan.characteristics)} characteristics of the inspection "
                        f"plan {os.path.basename(rec.path)} (SHA-256 {rec.sha256[:16]}…, "
                        "section 5)" + (f", and the {type_word(c, 'profile')} of every "
                                        "measured point "
                                        "(characteristic 'tol')" if c.plan.zone_in_verdict
                                        else "") +
                        ", listed in section 2 with their tolerances"),
        # Lower case on purpose: the verdict words appear on a certificate only as its verdict.
        ("Decision rule", "The part is accepted only if every characteristic lies within its "
                          "tolerance, rejected if any lies outside, inconclusive if any cannot "
                          "be decided (too few measured points on its region, or datums that "
                          "cannot place the part) or when the registration cannot be trusted. "
                          "A profile lies within its tolerance when every point of its region "
                          "lies inside the zone" + (
                              " shrunk by its expanded measurement uncertainty U (the budget "
                              "below), outside when a point lies outside the zone grown by it "
                              "(ISO 14253-1; inconclusive in between)"
                              if guarded else "") +
                          "; flatness, position and size when the measured value lies within "
                          "their limits (limits are in tolerance)" + (
                              ", shrunk by the value's uncertainty bound (twice the largest U "
                              "of its points; flatness and position have an upper limit only), "
                              "outside when it lies outside them grown by it, inconclusive in "
                              "between." if guarded else ". " + _uncertainty_sentence(res))),
        ("Zone of the statistics",
         f"{zone}: {type_word(c, 'profile')} of every measured point, judged at the best fit "
         "over all "
         "points (characteristic 'tol' in section 2)" if c.plan.zone_in_verdict else
         f"{zone}, the plan's widest profile zone: it colours the statistics, the deviation "
         "map, the histogram and the point list (sections 2, 7 to 9) and is not itself part "
         "of the verdict"),
        ("Sign", "Positive along the nominal's outward normal (excess material), negative "
                 "into the material (missing material)"),
        ("Units", "millimetres"),
    ]
