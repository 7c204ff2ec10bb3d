"""What ``qa-inspect inspect`` prints after a run: the verdict and its reasons, the deviations,
the registration, the measured selection, the template, the plan's characteristics, and the files
written, each line made printable."""

from __future__ import annotations

import os


def _plan_summary(plan) -> list[str]:
    """The plan's alignment and one line per characteristic: id, type, region, datums, value
    against its zone, verdict."""
    from reports.messages import alignment_text, limits_text

    lines = []
    if plan.alignment is not None:
        lines.append(f"  alignment: {alignment_text(plan)}")
    for r in plan.characteristics:
        c = r.characteristic
        ref = f" |{'|'.join(c.datums)}" if c.datums else ""
        value = "—" if r.value is None else f"{r.value:.4f}" + (
            "°" if c.unit == "degree" else " mm")
        where = " & ".join(c.regions) if c.features else c.region  # an angle's, a distance's
        lines.append(f"  [{c.id}] {c.type} {where}{ref}: {value}, {limits_text(c)}, "
                     f"{r.indices.size} points: {r.verdict}")
    return lines


def _selection_line(sel) -> str:
    """The measured points a crop and plane removal kept, in words."""
    parts = [f"{sel.n_read:,} read"]
    if sel.box is not None:
        parts.append(f"{sel.n_outside_box:,} outside the crop box")
    if sel.plane is not None:
        parts.append(f"{sel.n_on_plane:,} on the dominant plane (within "
                     f"{sel.plane.distance:.3g} mm)")
    if sel.n_other_objects:
        parts.append(f"{sel.n_other_objects:,} on other objects than the part "
                     f"({sel.n_objects:,} objects found)")
    return f"  measured points: {', '.join(parts)}; {sel.n_kept:,} inspected"


def summary_text(result, written, selection=None) -> str:
    """``inspect``'s summary of ``result`` (engine.inspection), ``written`` the files written
    and ``selection`` the measured scene's (engine.scene), or None."""
    st = result.statistics
    reg = result.registration
    tol = result.tolerance
    lines = [
        f"{result.verdict}: {'; '.join(result.reasons)}",
        f"  deviations {st.min:+.4f} … {st.max:+.4f} mm, max |d| {st.max_abs:.4f} mm, "
        f"rms {st.rms:.4f} mm; zone {tol.lower:+.4f} … {tol.upper:+.4f} mm; "
        f"{st.n_out} of {st.count} out of tolerance"
        + ("" if result.plan is None or result.plan.zone_in_verdict else
           " (the zone of the plan's widest profile, for these statistics only: the verdict "
           "is the characteristics')"),
        f"  registration: {'converged' if reg.converged else 'NOT converged'} after "
        f"{reg.iterations} iterations, rms {reg.rms:.4f} mm over {reg.n_inliers} fitted points, "
        f"{reg.hypotheses} pose hypotheses",
    ]
    if selection is not None:
        lines.append(_selection_line(selection))
    if result.normals_source == "estimated":
        lines.append("  note: the nominal has no normals; the deviation sign comes from normals "
                     "estimated from its points")
    tpl = result.extra.get("template")
    if tpl:
        lines.append(f"  template: {tpl['contours']} contour(s), {tpl['closed']} closed, "
                     f"{tpl['primitives']} primitives, units {tpl['units']}"
                     + ("; symmetric: equivalent poses give the same deviations"
                        if tpl["symmetric"] else ""))
    if result.plan is not None:
        lines += _plan_summary(result.plan)
    flat = result.extra.get("flatness")
    if flat:
        lines.append(f"  measured plane: flatness {flat['peak_to_valley']:.4f} mm peak to "
                     f"valley, {flat['rms']:.4f} mm rms")
    if written:
        lines.append("results: " + ", ".join(os.path.abspath(w) for w in written))
    from reports.messages import printable

    # Each line escaped before they are joined: a reason may quote a file name or a label.
    return "\n".join(printable(line) for line in lines)
