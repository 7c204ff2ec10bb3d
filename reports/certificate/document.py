"""The certificate made: laid out as a draft where the inspection ran
(:func:`draft_certificate`), finished and signed where the key is (:func:`finish_certificate`),
or both at once (:func:`make_certificate`); :func:`build_pdf` lays out its sections in order."""

from __future__ import annotations

import datetime as dt
import io
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from engine.pipeline import Run
from engine.section import Section

from .. import figures
from ..messages import VERDICT_WORD
from ..qif import plan_source, qif_results_document
from ..results import SOFTWARE_NAME, points_csv, result_json, run_document, software_version
from ..signing import (
    APPROVER_FIELD,
    INSPECTOR_FIELD,
    Attachment,
    Identity,
    SignatureSlot,
    finish_pdf,
)
from .identification import identification
from .layout import TITLE, Layout, numbered_canvas, paragraph_styles, register_fonts
from .maps import deviation_map, histogram
from .method import inputs, method
from .points import characteristics, worst_labels
from .policy import (CertificateError, CertificateInfo, certificate_number, certified_info,
                     check_trustworthy, plan_info)
from .registration import registration
from .requirement import requirement
from .result import result
from .sections import section_pages
from .statement import evidence, statement_and_signatures


def make_certificate(run: Run, info: CertificateInfo, identity: Identity | None,
                     issued: dt.datetime | None = None, renderer=None,
                     sections: Sequence[Section] = ()) -> bytes:
    """The finished certificate PDF (signed when ``identity`` is given).

    renderer : a :class:`reports.figures.RenderProcess` started earlier (default: render in
        this process). sections : planar sections of the run (engine.section), a page each.
    """
    return finish_certificate(draft_certificate(run, info, identity, issued, renderer,
                                                sections), identity)


@dataclass(frozen=True)
class CertificateDraft:
    """A certificate laid out for its signer but not yet finished: the PDF, the files to embed,
    the signature boxes and the signature's reason and location. Made where the inspection ran
    (:func:`draft_certificate`, which needs only the signer's public identity), finished and
    signed where the key is (:func:`finish_certificate`); picklable."""

    pdf: bytes
    attachments: list[Attachment]
    slots: dict[str, SignatureSlot]
    reason: str
    location: str


def draft_certificate(run: Run, info: CertificateInfo, identity: Identity | None,
                      issued: dt.datetime | None = None, renderer=None,
                      sections: Sequence[Section] = ()) -> CertificateDraft:
    """Lay out the certificate of ``run`` as ``identity`` will sign it (None: an unsigned
    draft). ``identity`` may be :meth:`Identity.public`: no key is used here. Raises
    CertificationError as :func:`certified_info` does; renderer : as for
    :func:`make_certificate`; sections : as for :func:`make_certificate`."""
    check_trustworthy(run)
    res = run.result
    info = certified_info(plan_info(info, run), identity, res.verdict)
    views = None
    if run.template is None:  # 3D: the renders run while the evidence files are written
        nom = run.nominal
        if nom is None:
            raise ValueError("a 3D inspection without its nominal")
        pending = (renderer or figures.InProcessRenderer()).submit(
            nom.points, nom.triangles, res.deviations.foot, res.deviations.normal,
            res.deviations.signed, res.tolerance, worst_labels(run),
            nominal_normals=None if nom.triangles is not None else nom.normals(np.arange(nom.n)))
    issued = (issued or dt.datetime.now(dt.timezone.utc)).replace(microsecond=0)
    number = certificate_number(run, issued)
    cert_doc = {k: v for k, v in asdict(info).items()}
    cert_doc.update(number=number, issued=issued.isoformat().replace("+00:00", "Z"),
                    signed_by=None if identity is None else identity.common_name)
    if run.plan is not None:
        # What the plan's [part] states (its drawing and CAD revision when it gives them).
        cert_doc["plan_part"] = {k: v for k, v in asdict(run.plan.part).items()
                                 if v or k in ("number", "name", "revision")}
    doc = dict(run_document(run), certificate=cert_doc)
    if sections:
        doc["sections"] = [s.document() for s in sections]
    attachments = [
        Attachment("points.csv", points_csv(res, run.measured.points,
                                            run.measured.labels).encode(),
                   "text/csv", "Every measured point: input and registered coordinates (mm), "
                               "signed deviation, in tolerance"),
        Attachment("results.qif", qif_results_document(
            doc, res.registered, res.deviations.signed, res.in_tolerance,
            run.measured.labels, res.outlier, plan_source(run)), "application/xml",
            "QIF 3.0 results document"),
        Attachment("results.json", result_json(doc).encode(), "application/json",
                   "qa-inspect results with the settings to re-run the inspection"),
    ]
    if identity is not None:
        import pyhanko.sign.signers  # noqa: F401  (the import overlaps the render)
    if run.template is None:
        views = pending.result()
    pdf, slots = build_pdf(run, info, number, issued, identity, attachments, views, sections)
    return CertificateDraft(pdf, attachments, slots,
                            f"Inspection certificate {number}: {VERDICT_WORD[res.verdict]}",
                            info.organisation or "")


def finish_certificate(draft: CertificateDraft, identity: Identity | None) -> bytes:
    """The certificate PDF of ``draft``, signed with ``identity`` (which must be the identity,
    key included, that the draft was laid out for; None: the unsigned draft)."""
    return finish_pdf(draft.pdf, draft.attachments, draft.slots, identity,
                      reason=draft.reason, location=draft.location)


def build_pdf(run: Run, info: CertificateInfo, number: str, issued: dt.datetime,
              identity: Identity | None, attachments: list[Attachment],
              views: list[figures.View] | None, sections: Sequence[Section] = ()
              ) -> tuple[bytes, dict[str, SignatureSlot]]:
    """Lay out the certificate; return the PDF and where the signature boxes are.

    views : the 3D renders (None for a 2D template, whose map is drawn here); sections : the
    planar sections, a page each after section 8.
    """
    from reportlab.lib.pagesizes import A4
    from reportlab.lib.units import mm
    from reportlab.platypus import SimpleDocTemplate

    register_fonts()
    c = Layout(run, info, number, issued, identity, attachments, views, run_document(run),
               paragraph_styles(), A4[0] - 36 * mm, {}, tuple(sections))
    story = [flowable for section in _SECTIONS for flowable in section(c)]
    res = run.result
    buf = io.BytesIO()
    pdf = SimpleDocTemplate(buf, pagesize=A4, leftMargin=18 * mm, rightMargin=18 * mm,
                            topMargin=(26 if identity else 30) * mm, bottomMargin=22 * mm,
                            title=f"{TITLE} {number}", author=info.inspector or "",
                            subject=f"{VERDICT_WORD[res.verdict]}: "
                                    f"{info.part_number or ''} {info.serial or ''}".strip(),
                            creator=f"{SOFTWARE_NAME} {software_version()}",
                            pageCompression=0, invariant=1)
    pdf.build(story, canvasmaker=numbered_canvas(number, res.verdict, identity is None, issued))
    if set(c.slots) != {INSPECTOR_FIELD, APPROVER_FIELD}:
        raise CertificateError("signature boxes were not laid out")
    return buf.getvalue(), c.slots


_SECTIONS = (identification, result, requirement, method, inputs, registration,
             deviation_map, histogram, section_pages, characteristics, evidence,
             statement_and_signatures)
"""The certificate's sections in their order; each returns its flowables."""
