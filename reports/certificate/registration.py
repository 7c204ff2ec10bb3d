"""Section 6 of the certificate, the registration: the transform and its facts, what
the measurement leaves open, and an inspection plan's alignment (datums or RPS points)."""

from __future__ import annotations

import math

import numpy as np

from engine.pipeline import Run

from .layout import Layout, esc


def registration(c: Layout) -> list:
    """6  Registration: the transform beside its facts, then what the measurement leaves
    open in plain words."""
    from reportlab.lib.units import mm
    from reportlab.platypus import CondPageBreak
    from reportlab.platypus import Paragraph as P
    from reportlab.platypus import Spacer, Table

    S, W, res = c.styles, c.width, c.res
    mat = _matrix(c, res.registration.T_nominal_measured)
    out = [CondPageBreak(75 * mm),  # the heading stays with its table
           P("6  Registration" + ("" if c.plan is None else " and alignment"), S["h"]),
           P(esc(alignment_statement(c.run)), S["base"]), Spacer(1, 1.5 * mm),
           Table([[[P("T_nominal_measured (maps measured coordinates into the nominal "
                      "frame, mm)", S["small"]), Spacer(1, 1 * mm), mat],
                   c.kv(_registration_rows(c), [26 * mm, W - 26 * mm - 86 * mm])]],
                 colWidths=[84 * mm, W - 84 * mm],
                 style=[("VALIGN", (0, 0), (-1, -1), "TOP"),
                        ("LEFTPADDING", (0, 0), (-1, -1), 0),
                        ("RIGHTPADDING", (0, 0), (-1, -1), 0)])]
    if res.trust_statements:
        # In plain words: what the measurement leaves open, and why the verdict holds (or not).
        out.append(Spacer(1, 1.5 * mm))
        out.append(P("What the measurement does not fix", S["cellb"]))
        for sentence in res.trust_statements:
            out.append(P("• " + esc(sentence[:1].upper() + sentence[1:]) + ".", S["small"]))
    return out + _plan_alignment(c)


def alignment_statement(run: Run) -> str:
    """How the part was aligned and how sure that is, in plain words: what a best fit over all
    points checks, the starting poses tried, how the second-best pose compares and whether the
    points are of this part."""
    res = run.result
    reg = res.registration
    if res.plan is None or res.plan.alignment is None:
        what = ("Best fit over all points: it checks form only, not location (no datums place "
                "the part, so a part made in the right shape but in the wrong place passes)")
    else:
        what = ("The part is found by a best fit over all points, then placed by the plan's "
                "datums (below): the characteristics relative to datums check location too")
    tried = f"{reg.hypotheses:,} starting poses were tried"
    if reg.runner_up_score is None:
        second = "no second, distinct pose was found"
    elif reg.symmetric:
        second = ("the second-best pose is a symmetry of the template: it gives the same "
                  "deviations")
    else:
        ratio = reg.runner_up_score / reg.score if reg.score > 0 else math.inf
        second = ("the second-best distinct pose fits " + (
            f"{ratio:.1f} times worse" if math.isfinite(ratio) else "worse") +
            f" (fit score {reg.runner_up_score:.4f} mm against {reg.score:.4f} mm)")
        if res.ambiguous:
            second += f" and moves deviations by up to {res.ambiguity_spread:.4f} mm"
    n = res.deviations.signed.size
    near = round(100 * reg.near_fraction)
    fits = ("so the points are of this part" if reg.near_fraction >= 0.5 else
            "so the points may not be of this part")
    return (f"{what}. {tried}; {second}. {'All' if near == 100 else f'{near}% of the'} {n:,} "
            f"points lie within {reg.near_distance:.3g} mm ({reg.near_rule}) of the "
            f"nominal at this pose, {fits}.")


def _matrix(c: Layout, T: np.ndarray):
    """A 4x4 pose as a table of numbers (rotation 6 decimals, translation 4)."""
    from reportlab.lib.units import mm

    return c.table([[f"{v:+.6f}" if j < 3 else f"{v:+.4f}" for j, v in enumerate(row)]
                    for row in T], [20 * mm] * 4, header=False,
                   styles=[("FONT", (0, 0), (-1, -1), "Courier", 7),
                           ("ALIGN", (0, 0), (-1, -1), "RIGHT")])


_FIT_WORDS = {"tangent": "tangent", "lsq": "least squares"}


def _plan_alignment(c: Layout) -> list:
    """The inspection plan's alignment: in words, what it rests on, and the pose the map and
    the point list are at (none without a plan)."""
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether, Spacer, Table
    from reportlab.platypus import Paragraph as P

    if c.plan is None:
        return []
    S, W = c.styles, c.width
    out = [Spacer(1, 2 * mm), P("Alignment by the inspection plan", S["cellb"]),
           P(esc(_alignment_words(c.plan, c.run.plan)) + ".", S["base"]), Spacer(1, 1 * mm)]
    notes = [P("The deviation map, the histogram and the point list (sections 7 to 9) show "
               "the part at this alignment; a characteristic relative to datums is evaluated at "
               "the pose its own datums give.", S["small"])]
    if c.plan.alignment is not None:
        table, note = _alignment_table(c)
        out.append(table)
        notes[:0] = [P(esc(note), S["small"]), Spacer(1, 1.5 * mm)]
    pose = [P("T_nominal_measured at this alignment (maps measured coordinates into the "
              "nominal frame, mm)", S["small"]), Spacer(1, 1 * mm),
            _matrix(c, c.plan.T_nominal_measured)]
    # The notes and the pose may go over to the next page (before the map), not the table.
    return [KeepTogether(out),
            Table([[notes, pose]], colWidths=[W - 84 * mm, 84 * mm],
                  style=[("VALIGN", (0, 0), (-1, -1), "TOP"),
                         ("LEFTPADDING", (0, 0), (-1, -1), 0),
                         ("RIGHTPADDING", (0, 0), (0, -1), 4 * mm),
                         ("RIGHTPADDING", (1, 0), (1, -1), 0),
                         ("TOPPADDING", (0, 0), (-1, -1), 2 * mm)])]


def _alignment_table(c: Layout):
    """(table, note): each datum's feature, fit, points, freedom taken and form error; or each
    RPS point's locked axes and nominal position."""
    from reportlab.lib.units import mm

    W, al, plan = c.width, c.plan.alignment, c.plan_read
    if c.plan.method == "rps":
        rows = [["RPS point", "Locked along", "Nominal position (mm)"]]
        rows += [[p.label, ", ".join(p.lock), _vec(p.nominal)] for p in plan.rps]
        gap = al.datums[0].gap
        return (c.table(rows, [30 * mm, 30 * mm, W - 60 * mm]),
                "Each point is moved onto its nominal position along its locked axes (least "
                f"squares when they ask more than {_freedoms(c)}); largest remaining distance "
                f"along a locked axis {'—' if not math.isfinite(gap) else f'{gap:.4f}'} mm.")
    rows = [["Datum", "Feature", "Fit", "Region", "Points", "Freedom taken", "Form error (mm)"]]
    regions = {d.label: d.region for d in plan.datums}
    for d in al.datums:
        rows.append([d.label, d.feature, _FIT_WORDS[d.fit], regions.get(d.label, "—"),
                     f"{d.n_points}", f"{d.constrained} of {3 if c.is_2d else 6}",
                     "—" if not math.isfinite(d.gap) else f"{d.gap:.4f}"])
    return (c.table(rows, [16 * mm, 20 * mm, 26 * mm, 26 * mm, 16 * mm, 30 * mm, W - 134 * mm],
                    styles=[("ALIGN", (4, 0), (-1, -1), "CENTER")]),
            "Tangent: the datum rests on the high points of its face, outside the material "
            "(ASME Y14.5 / ISO 5459); least squares: the average through the points. Form "
            "error: the largest gap between the face's points and its datum (least squares: the "
            f"largest distance either side). Freedom taken: of {_freedoms(c)}.")


def _freedoms(c: Layout) -> str:
    return ("the part's three ways to move in its plane (two shifts, one turn)" if c.is_2d else
            "the part's six ways to move (three shifts, three turns)")


def _alignment_words(planned, plan) -> str:
    """The alignment in a sentence: '3-2-1 on datums A|B|C, tangent planes; remaining freedom:
    none'."""
    al = planned.alignment
    if al is None:
        return ("Best fit over all points (the registration's pose): the plan names no datums "
                "to place the part")
    ds = al.datums
    if planned.method == "rps":
        head = (f"RPS (reference point system) on {ds[0].n_points} locked coordinates of "
                f"{len(plan.rps)} points ({', '.join(p.label for p in plan.rps)})")
    elif len(ds) == 1:
        head = f"Datum {ds[0].label} ({ds[0].feature}, {_FIT_WORDS[ds[0].fit]})"
    else:
        kind = "3-2-1" if [d.constrained for d in ds] == [3, 2, 1] else "Datum reference frame"
        same = len({(d.feature, d.fit) for d in ds}) == 1
        what = (f"{_FIT_WORDS[ds[0].fit]} {ds[0].feature}s" if same else
                ", ".join(f"{d.label} {d.feature} ({_FIT_WORDS[d.fit]})" for d in ds))
        head = f"{kind} on datums {'|'.join(d.label for d in ds)}, {what}"
    free = ", ".join(_free_words(f) for f in al.free)
    who = "it leaves" if len(ds) == 1 else "they leave"
    if not al.free:
        tail = "remaining freedom: none"
    elif al.best_fitted:
        tail = (f"the freedom {who} ({free}) best-fitted on regions "
                f"{', '.join(plan.alignment.best_fit_regions)}")
    else:
        tail = f"the freedom {who} ({free}) stays where the registration placed the part"
    return (f"{head}; {tail}" + ("" if al.complete else
                                 f"; incomplete: {al.message}"))


def _free_words(f) -> str:
    """A free direction with its axis named when it is one of the nominal frame's."""
    axis = next((("+" if a > 0 else "-") + "xyz"[k] for k, a in enumerate(f.along)
                 if abs(a) > 1 - 1e-6), None) or _vec(f.along)
    if f.type == "translation":
        return f"shift along {axis}"
    return f"turn about {axis} through ({', '.join(f'{a:.2f}' for a in f.through)})"


def _registration_rows(c: Layout) -> list[tuple[str, str]]:
    """The (label, value) facts of section 6: convergence, what is not fixed, the poses."""
    res = c.res
    reg = res.registration
    cond = res.conditioning
    weak = "none: every direction constrained" if cond is None or not cond.weak else "; ".join(
        f"{w.type} {'along' if w.type == 'translation' else 'about'} {_vec(w.axis)}"
        for w in cond.weak)
    rows = [("Converged", f"{'yes' if reg.converged else 'NO'} after {reg.iterations} "
                          "iterations"),
            ("Unconstrained", weak),
            ("Pose uncertainty", "—" if cond is None or cond.pose_sigma_mm is None else
             f"{cond.pose_sigma_mm:.4f} mm (1 sigma at the worst point, from the residuals)"),
            ("Other poses", (f"a nearly-as-good pose moves deviations by up to "
                             f"{res.ambiguity_spread:.4f} mm") if res.ambiguous else
             "none with different deviations"),
            ("Verdict holds", _verdict_stability(res)),
            ("Excluded from the alignment",
             f"{int(res.outlier.sum())} point(s) (gross outliers), judged like every other "
             "point" if res.outlier.any() else "none: every point was fitted"),
            ("RMS", f"{reg.rms:.4f} mm over the {reg.n_inliers} fitted points")]
    if "flatness" in c.doc:
        f = c.doc["flatness"]
        rows.append(("Flatness", f"{f['peak_to_valley']:.4f} mm peak to valley "
                                 f"(measured plane)"))
    return rows


def _verdict_stability(res) -> str:
    """Whether the verdict is the same at every pose the measurement allows, in words."""
    sens = res.pose_sensitivity
    if sens is None:
        return "not assessed: the pose cannot be trusted"
    if not sens.probes:
        return (f"yes: every direction is fixed (nearest point {sens.min_limit_margin_mm:.4f} mm "
                "from a limit)")
    word = "yes" if sens.verdict_stable else "NO"
    return (f"{word}: over the poses the measurement allows, deviations change by up to "
            f"{sens.max_change_mm:.4f} mm; the nearest point lies "
            f"{sens.min_limit_margin_mm:.4f} mm from a limit")


def _vec(v) -> str:
    return "(" + ", ".join(f"{x:+.2f}" for x in v) + ")"
