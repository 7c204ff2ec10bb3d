"""Sections 10 and 11 of the certificate: the attached evidence with its SHA-256s, and the
statement of conformity with the signature boxes."""

from __future__ import annotations

import hashlib
import os

from engine.pipeline import Run
from engine.verdict import ACCEPT, INCONCLUSIVE, REJECT

from ..signing import APPROVER_FIELD, INSPECTOR_FIELD
from .layout import DEMONSTRATION_NOTE, REASONS_SHOWN, Layout, Slot, esc
from .points import point_name
from .result import type_word


def evidence(c: Layout) -> list:
    """10  Attached evidence: each embedded file with its content and SHA-256."""
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether
    from reportlab.platypus import Paragraph as P

    S = c.styles
    rows = [["File", "Content", "SHA-256"]]
    for a in c.attachments:
        rows.append([a.name, P(esc(a.description), S["cell"]),
                     P(hashlib.sha256(a.data).hexdigest(), S["mono"])])
    return [KeepTogether([
        P("10  Attached evidence (embedded in this PDF, covered by the signature)", S["h"]),
        c.table(rows, [22 * mm, 62 * mm, c.width - 84 * mm]),
        P("Extract them with any PDF reader's attachment panel or "
          "<font name='Courier'>pdfdetach -saveall</font>.", S["small"])])]


def statement_and_signatures(c: Layout) -> list:
    """11  Statement of conformity and signatures, kept together on one page; the signature
    boxes record where they land in ``c.slots``."""
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether, Spacer, Table
    from reportlab.platypus import Paragraph as P

    S, W, res, identity, zone = c.styles, c.width, c.res, c.identity, c.zone
    st = res.statistics
    if c.plan is not None and res.verdict != INCONCLUSIVE:
        statement = _plan_statement(c)
    elif res.verdict == ACCEPT:
        statement = (f"The part identified above conforms to the stated requirement: all "
                     f"{st.count} measured points lie within the tolerance zone {zone}, "
                     "under the decision rule stated in section 3.")
    elif res.verdict == REJECT:
        statement = (f"The part identified above does not conform to the stated requirement: "
                     f"{st.n_out} of {st.count} measured points lie outside the tolerance zone "
                     f"{zone}; {excursion_words(c.run)}.")
    else:
        statement = ("No statement of conformity can be made: " + c.reasons_shown +
                     ". The part is neither accepted nor rejected by this certificate.")
    sig_text = (f"Signed digitally by {esc(identity.common_name)}"
                f"{', ' + esc(identity.organisation) if identity.organisation else ''}; "
                f"issuing CA SHA-256 fingerprint "
                f"<font name='Courier'>{esc(identity.ca_fingerprint or 'not in the file')}"
                f"</font>." + (f" <b>{DEMONSTRATION_NOTE}</b>" if identity.demonstration
                               else "")
                if identity else "<b>UNSIGNED DRAFT</b>: this document carries no signature "
                "and is not a valid certificate.")
    bw = (W - 8 * mm) / 2
    return [KeepTogether([
        P("11  Statement of conformity and signatures", S["h"]),
        P(esc(statement), S["base"]), Spacer(1, 2 * mm),
        P(sig_text, S["small"]),
        P("Verify the signature and the evidence: <font name='Courier'>qa-inspect verify "
          "certificate.pdf --trust ca.pem [--nominal FILE --measured FILE"
          + ("" if c.plan is None else " --plan FILE") + "]</font> or any "
          "PAdES-capable reader with the issuing CA as trust anchor.", S["small"]),
        Spacer(1, 3 * mm),
        Table([[Slot(INSPECTOR_FIELD, "Inspector signature", bw, 24 * mm, c.slots,
                     None if identity else "UNSIGNED DRAFT"),
                Slot(APPROVER_FIELD, "Approver signature (optional, second signature)",
                     bw, 24 * mm, c.slots)]],
              colWidths=[bw + 4 * mm, bw + 4 * mm],
              style=[("LEFTPADDING", (0, 0), (-1, -1), 0)])])]


def _plan_statement(c: Layout) -> str:
    """The statement of conformity to an inspection plan (accepted or rejected)."""
    rec = next(r for r in c.run.inputs if r.role == "plan")
    name = os.path.basename(rec.path)
    results = c.plan.characteristics
    if c.res.verdict == ACCEPT:
        return (f"The part identified above conforms to the inspection plan {name}: all "
                f"{len(results)} characteristics lie within their tolerances, under the "
                "decision rule stated in section 3.")
    out = [f"{ch.id} ({type_word(c, ch.type)} of "
           + ("all points)" if ch.region == "(all points)" else f"region {ch.region})")
           for ch in (r.characteristic for r in results if r.verdict == REJECT)]
    one = len(out) == 1
    if len(out) > REASONS_SHOWN:  # the statement and signatures keep to one page
        out = out[:REASONS_SHOWN] + [f"{len(out) - REASONS_SHOWN} more"]
    listed = out[0] if one else ", ".join(out[:-1]) + " and " + out[-1]
    return (f"The part identified above does not conform to the inspection plan {name}: "
            f"characteristic{'' if one else 's'} {listed} {'lies' if one else 'lie'} outside "
            f"{'its tolerance' if one else 'their tolerances'} (section 2; {len(results)} "
            "characteristics in all).")


def excursion_words(run: Run) -> str:
    """The worst point's excursion with its sign explained: which limit it passes, by how much,
    and what its deviation means for the material."""
    res = run.result
    d, tol = res.deviations.signed, res.tolerance
    i = int(run.worst_order[0])
    below = d[i] < tol.lower
    limit = tol.lower if below else tol.upper
    return (f"the worst, point {point_name(run, i)}, lies {abs(d[i] - limit):.4f} mm "
            f"{'below the lower' if below else 'above the upper'} limit: its deviation "
            f"{d[i]:+.4f} mm is {'negative, material missing' if d[i] < 0 else 'positive, excess material'} "
            f"(the measured surface lies {'inside' if d[i] < 0 else 'outside'} the nominal, "
            f"{'into' if d[i] < 0 else 'away from'} the material)")
