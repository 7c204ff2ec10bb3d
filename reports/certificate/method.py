"""Sections 4 and 5 of the certificate: the method (registration, fit criterion, deviation
method, normals, the inspector's notes) and the inputs with their SHA-256s."""

from __future__ import annotations

import os

from engine.choices import Fit

from .layout import Layout, esc


def method(c: Layout) -> list:
    """4  Method: registration, fit criterion, deviation method, normals; then the notes."""
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph as P

    S, W, res, doc, is_2d = c.styles, c.width, c.res, c.doc, c.is_2d
    reg = res.registration
    out = [P("4  Method", S["h"]), c.kv([
        ("Registration", "Soft registration without fixture: global search over "
                         f"{reg.hypotheses} pose hypotheses, then modified ICP with "
                         "coarse-to-fine sampling of the nominal" +
                         (" (template plane fitted to the points; both faces tried)"
                          if is_2d and "flatness" in doc else "")),
        ("Fit criterion", (
            "Least squares of point-to-" + ("contour" if is_2d else "surface") + " distances "
            "(a best fit: it spreads the error, and a local defect can pull the pose)"
            if res.fit == Fit.LSQ else
            "Minimax (Chebyshev): the pose that minimises the largest excursion from the zone's "
            "centre, started from the least-squares pose; it answers whether the part can be "
            "placed inside its zone (largest normalised excursion "
            f"{doc['minimax']['least_squares_excursion']:.3f} at the least-squares pose, "
            f"{doc['minimax']['excursion']:.3f} at this pose; ≤ 1 fits)")
            + ". " + _exclusion_rule(reg)),
        *([] if c.plan is None else [(
            "Alignment", "Then the part is placed as the inspection plan says (section 6), "
                         "and each characteristic is evaluated there (section 3)")]),
        ("Deviation method", doc["deviations"]["method"]),
        ("Normals", {"file": "from the nominal file (I J K)", "mesh": "from the mesh faces",
                     "grid": "from the grid cells", "estimated": "estimated from the nominal "
                     "points (no normals in the file)", "contour": "contour normals",
                     "B-rep": "the STEP model's faces (outward)"}.get(
                         res.normals_source, res.normals_source)),
    ], [28 * mm, W - 28 * mm])]
    if c.info.notes:
        # Paragraphs of their own: a long note flows over pages (a table cell cannot).
        out.append(P("Notes", S["cellb"]))
        for para in str(c.info.notes).split("\n"):
            out.append(P(esc(para), S["base"]))
    return out


def _exclusion_rule(reg) -> str:
    """The gross-outlier rule as applied, in words (engine.outliers)."""
    text = reg.gross_rule.describe()
    return text[:1].upper() + text[1:]


def inputs(c: Layout) -> list:
    """5  Inputs: each input file with its size and SHA-256."""
    from reportlab.lib.units import mm
    from reportlab.platypus import CondPageBreak
    from reportlab.platypus import Paragraph as P

    S = c.styles
    rows = [["Role", "File", "Size", "SHA-256"]]
    for r in c.run.inputs:
        size = (f"{r.n_points} points" if r.n_points is not None else
                f"{r.n_primitives} primitives" if r.n_primitives is not None else
                f"{r.n_faces} B-rep faces" if r.n_faces is not None else
                f"{len(c.run.plan.characteristics)} characteristics" if r.role == "plan" and
                c.run.plan is not None else "—")
        rows.append([r.role, P(esc(os.path.basename(r.path)), S["cell"]), size,
                     P(r.sha256, S["mono"])])
    return [CondPageBreak(45 * mm), P("5  Inputs", S["h"]),
            c.table(rows, [18 * mm, 50 * mm, 24 * mm, c.width - 92 * mm])]
