"""The inspection certificate: a PDF laid out after ISO/IEC 17025 §7.8 and AS9102 Form 3.

:func:`make_certificate` builds it from one :class:`engine.pipeline.Run`: the figures, the
evidence files embedded in it (per-point CSV, QIF 3.0 results, the JSON results with the settings
needed to re-run the inspection) and, given an identity, a PAdES signature over all of it.
Without an identity every page says UNSIGNED DRAFT.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import io
import json
import math
import os
from dataclasses import asdict, dataclass, replace

import numpy as np

from engine.errors import QAError, SettingsError
from engine.verdict import ACCEPT, INCONCLUSIVE, REJECT
from engine.pipeline import Run

from . import callouts, figures
from .messages import VERDICT_RGB, VERDICT_WORD, limits_text, printable
from .qif import qif_results_document
from .results import SOFTWARE_NAME, points_csv, result_json, run_document, software_version
from .signing import (
    APPROVER_FIELD,
    INSPECTOR_FIELD,
    Attachment,
    Identity,
    SignatureSlot,
    finish_pdf,
)

TITLE = "Dimensional Inspection Certificate"
WORST_ROWS = 25
"""In-tolerance points listed after every out-of-tolerance point, worst first."""
MAX_OUT_ROWS = 1000
"""Out-of-tolerance rows printed; the attached CSV always holds every point."""
APPENDIX_POINTS = 250
"""Up to this many measured points, section 9 lists every one (about five pages); beyond, it
lists the out-of-tolerance points and those nearest a limit and says that the complete list is
the attached points.csv."""


@dataclass(frozen=True)
class CertificateInfo:
    """What the inspector states about the part and the inspection (all optional text)."""

    part_number: str | None = None
    part_name: str | None = None
    revision: str | None = None
    serial: str | None = None
    order: str | None = None
    inspector: str | None = None
    organisation: str | None = None
    device: str | None = None
    notes: str | None = None
    device_serial: str | None = None
    calibration_date: str | None = None
    """The device's last calibration, YYYY-MM-DD."""
    probe: str | None = None
    """The probe and stylus."""
    temperature_c: float | None = None
    """The part's temperature during the measurement, °C."""
    program: str | None = None
    """The measurement program (its name or file)."""
    drawing: str | None = None
    """The drawing number (its revision is ``revision``)."""
    cad_revision: str | None = None
    """The revision of the CAD model (the nominal)."""


TRACEABILITY = (("device", "Device"), ("device_serial", "Device serial"),
                ("calibration_date", "Calibrated on"), ("probe", "Probe / stylus"),
                ("temperature_c", "Temperature"), ("program", "Program"),
                ("drawing", "Drawing"), ("cad_revision", "CAD revision"))
"""The certificate's traceability fields (CertificateInfo) and their labels, in print order."""


class CertificationError(SettingsError):
    """What the certificate would state contradicts its signature (a usage error: nothing is
    written)."""


class CertificateError(QAError, RuntimeError):
    """No certificate can be made from this run: it would certify what the result does not
    support, or its layout failed. A bug, never the user's doing (unlike
    :class:`CertificationError`): nothing is written."""


def same_person(a: str | None, b: str | None) -> bool:
    """Whether two spellings of a name are the same name (case and spacing aside)."""
    def norm(s):
        return " ".join(str(s or "").split()).casefold()

    return bool(norm(a)) and norm(a) == norm(b)


def check_inspector(info: CertificateInfo, identity: Identity | None) -> None:
    """Raise CertificationError when the inspector named is not the signer (known as soon as
    the identity is loaded, before any inspection)."""
    if identity is not None and info.inspector and info.inspector.strip() and not same_person(
            info.inspector, identity.common_name):
        raise CertificationError(
            f"the inspector named, '{info.inspector}', is not the signer: the signing identity "
            f"{identity.path} belongs to '{identity.common_name}'. A certificate names the "
            "person who signs it: leave the inspector out (--inspector), or sign with that "
            "inspector's own identity")


def certified_info(info: CertificateInfo, identity: Identity | None,
                   verdict: str) -> CertificateInfo:
    """``info`` as a certificate of ``verdict`` states it: signed, its inspector is the signer
    (the subject's common name of the signing certificate).

    Raises CertificationError when the inspector named is another person, or when a signed
    ACCEPTED certificate does not identify its part by part number and serial number (an
    unsigned draft may lack them).
    """
    check_inspector(info, identity)
    if identity is None:
        return info
    if verdict == ACCEPT:
        missing = [what for what, v in (("its part number (--part-number)", info.part_number),
                                        ("its serial number (--serial)", info.serial))
                   if not (v and v.strip())]
        if missing:
            raise CertificationError(
                f"the part is ACCEPTED, but a signed ACCEPTED certificate must identify the "
                f"part it accepts: give {' and '.join(missing)}; nothing was written")
    return replace(info, inspector=identity.common_name)


def plan_info(info: CertificateInfo, run: Run) -> CertificateInfo:
    """``info`` with the part number, name, revision, drawing and CAD revision of the run's
    inspection plan (``[part]``) and its traceability fields (``[measurement]``: device, serial,
    calibration date, probe, program, temperature) where the inspector gave none.

    Given ones win: the inspector states which part is on the table (one plan may serve several
    dash numbers, or a revision whose change does not touch the characteristics). An auditor
    must still see a plan written for another part or revision, so section 1 prints the plan's
    value beside any that differs, and results.json keeps it (``certificate.plan_part``).
    A temperature given that differs from the plan's, when the plan's instrument uses it for
    the thermal term of the uncertainty budget, raises CertificationError.
    """
    if run.plan is None:
        return info
    part, how = run.plan.part, run.plan.measurement
    ins = how.instrument
    if (info.temperature_c is not None and ins is not None and ins.expansion_per_k is not None
            and run.settings.instrument is None and info.temperature_c != how.temperature_c):
        raise CertificationError(
            f"the part temperature given, {info.temperature_c:g} °C, is not the inspection "
            f"plan's [measurement] temperature_c = {how.temperature_c:g} °C that its "
            "uncertainty budget uses (thermal expansion): correct one of them")
    planned = {"part_number": part.number, "part_name": part.name, "revision": part.revision,
               "drawing": part.drawing, "cad_revision": part.cad_revision,
               "device": how.device, "device_serial": how.device_serial,
               "calibration_date": how.calibration_date, "probe": how.probe,
               "program": how.program, "temperature_c": how.temperature_c}
    return replace(info, **{k: v for k, v in planned.items()
                            if _given(v) and not _given(getattr(info, k))})


def _given(v) -> bool:
    return v is not None and (not isinstance(v, str) or bool(v.strip()))


def certificate_number(run: Run, issued: dt.datetime) -> str:
    """QA-YYYYMMDD-XXXXXXXX: the date and a hash of the inputs, settings and issue time."""
    h = hashlib.sha256()
    for r in run.inputs:
        h.update(r.sha256.encode())
    h.update(json.dumps(run.settings.to_json(), sort_keys=True).encode())
    h.update(issued.isoformat().encode())
    return f"QA-{issued:%Y%m%d}-{h.hexdigest()[:8].upper()}"


def _exclusion_rule(reg) -> str:
    """The gross-outlier rule as applied, in words (engine.outliers)."""
    text = reg.gross_rule.describe()
    return text[:1].upper() + text[1:]


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


def check_trustworthy(run: Run) -> None:
    """A certificate may say ACCEPTED only from a converged registration whose pose the
    judge trusted; anything else here is a bug upstream, and no certificate is made."""
    res = run.result
    reg = res.registration
    if res.plan is not None:
        # A plan's verdict is its characteristics': each inside its limits, on a registration
        # whose regions can be trusted (the per-point zone is only the statistics').
        within = all(r.verdict == ACCEPT and _within(r) for r in res.plan.characteristics)
        if res.verdict == ACCEPT and not (_registration_trusted(res) and within):
            raise CertificateError("refusing to certify ACCEPTED: the registration is not "
                                   "trustworthy or a characteristic is not within its limits")
        return
    # Weak or free directions and a runner-up pose are facts; the verdict is trusted when it
    # is the same at every pose they allow (engine.pose_sensitivity).
    sens = res.pose_sensitivity
    trusted = (_registration_trusted(res) and res.conditioning is not None and sens is not None
               and sens.verdict_stable)
    d, tol = res.deviations.signed, res.tolerance
    m = 0.0  # the guarded rule's guard band: U, or the sampling margin alone (older sessions)
    if res.decision_rule == "guarded":
        m = res.margin if res.uncertainty is None else res.uncertainty.expanded
    inside = bool(np.all((d >= tol.lower + m) & (d <= tol.upper - m)))
    if res.verdict == ACCEPT and not (trusted and inside):
        raise CertificateError("refusing to certify ACCEPTED: the registration is not "
                               "trustworthy or a point is not inside its zone")


def _within(r) -> bool:
    """Whether a characteristic's own numbers lie inside its limits: every deviation of a
    profile, the value of the others (about the nominal of a size)."""
    c = r.characteristic
    if r.value is None:
        return False
    if c.type == "profile":
        return r.deviations is not None and bool(np.all((r.deviations >= c.lower) &
                                                        (r.deviations <= c.upper)))
    return (c.nominal or 0.0) + c.lower <= r.value <= (c.nominal or 0.0) + c.upper


def make_certificate(run: Run, info: CertificateInfo, identity: Identity | None,
                     issued: dt.datetime | None = None, renderer=None) -> bytes:
    """The finished certificate PDF (signed when ``identity`` is given).

    renderer : a :class:`reports.figures.RenderProcess` started earlier (default: render in
        this process).
    """
    return finish_certificate(draft_certificate(run, info, identity, issued, renderer), identity)


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
                      issued: dt.datetime | None = None, renderer=None) -> CertificateDraft:
    """Lay out the certificate of ``run`` as ``identity`` will sign it (None: an unsigned
    draft). ``identity`` may be :meth:`Identity.public`: no key is used here. Raises
    CertificationError as :func:`certified_info` does; renderer : as for
    :func:`make_certificate`."""
    check_trustworthy(run)
    res = run.result
    info = certified_info(plan_info(info, run), identity, res.verdict)
    views = None
    if run.template is None:  # 3D: the renders run while the evidence files are written
        nom = run.nominal
        pending = (renderer or figures.InProcessRenderer()).submit(
            nom.points, nom.triangles, res.deviations.foot, res.deviations.normal,
            res.deviations.signed, res.tolerance, _worst_labels(run),
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
    attachments = [
        Attachment("points.csv", points_csv(res, run.measured.points,
                                            run.measured.labels).encode(),
                   "text/csv", "Every measured point: input and registered coordinates (mm), "
                               "signed deviation, in tolerance"),
        Attachment("results.qif", qif_results_document(
            doc, res.registered, res.deviations.signed, res.in_tolerance,
            run.measured.labels, res.outlier), "application/xml",
            "QIF 3.0 results document"),
        Attachment("results.json", result_json(doc).encode(), "application/json",
                   "qa-inspect results with the settings to re-run the inspection"),
    ]
    if identity is not None:
        import pyhanko.sign.signers  # noqa: F401  (the import overlaps the render)
    if run.template is None:
        views = pending.result()
    pdf, slots = build_pdf(run, info, number, issued, identity, attachments, views)
    return CertificateDraft(pdf, attachments, slots,
                            f"Inspection certificate {number}: {VERDICT_WORD[res.verdict]}",
                            info.organisation or "")


def finish_certificate(draft: CertificateDraft, identity: Identity | None) -> bytes:
    """The certificate PDF of ``draft``, signed with ``identity`` (which must be the identity,
    key included, that the draft was laid out for; None: the unsigned draft)."""
    return finish_pdf(draft.pdf, draft.attachments, draft.slots, identity,
                      reason=draft.reason, location=draft.location)


# ---------------------------------------------------------------------------- layout
def _fonts():
    from reportlab import rl_config
    from reportlab.lib.fonts import addMapping
    from reportlab.pdfbase import pdfmetrics
    from reportlab.pdfbase.ttfonts import TTFont

    # Binary streams: ASCII85 would triple the time spent on the embedded renders.
    rl_config.useA85 = 0
    if "Vera" in pdfmetrics.getRegisteredFontNames():
        return
    folder = os.path.join(os.path.dirname(rl_config.__file__), "fonts")
    for name, file in (("Vera", "Vera.ttf"), ("Vera-Bold", "VeraBd.ttf"),
                       ("Vera-Italic", "VeraIt.ttf"), ("Vera-BoldItalic", "VeraBI.ttf")):
        pdfmetrics.registerFont(TTFont(name, os.path.join(folder, file)))
    addMapping("Vera", 0, 0, "Vera")
    addMapping("Vera", 1, 0, "Vera-Bold")
    addMapping("Vera", 0, 1, "Vera-Italic")
    addMapping("Vera", 1, 1, "Vera-BoldItalic")


def _styles():
    from reportlab.lib.styles import ParagraphStyle

    base = ParagraphStyle("base", fontName="Vera", fontSize=8.5, leading=11)
    return {
        "base": base,
        "small": ParagraphStyle("small", parent=base, fontSize=7.5, leading=9.5),
        "h": ParagraphStyle("h", parent=base, fontName="Vera-Bold", fontSize=10.5, leading=13,
                            spaceBefore=9, spaceAfter=4,
                            textColor=(0.10, 0.20, 0.36)),
        "cell": ParagraphStyle("cell", parent=base, fontSize=7.5, leading=9.2),
        "cellb": ParagraphStyle("cellb", parent=base, fontName="Vera-Bold", fontSize=7.5,
                                leading=9.2),
        "mono": ParagraphStyle("mono", parent=base, fontName="Courier", fontSize=7, leading=8.6),
        "verdict": ParagraphStyle("verdict", parent=base, fontName="Vera-Bold", fontSize=22,
                                  leading=26, textColor=(1, 1, 1)),
        "verdict_long": ParagraphStyle("verdict_long", parent=base, fontName="Vera-Bold",
                                       fontSize=17, leading=21, textColor=(1, 1, 1)),
        "verdict_sub": ParagraphStyle("verdict_sub", parent=base, fontSize=8.5, leading=11,
                                      textColor=(1, 1, 1)),
    }


def _esc(text) -> str:
    """``text`` for a Paragraph, which reads markup (<font size=80>, &amp;): shown literally,
    its control characters written out (reports.messages.printable)."""
    from xml.sax.saxutils import escape

    return escape(printable("" if text is None else text))


class _Slot:
    """Factory of a flowable that reserves a signature box and records where it landed."""

    def __new__(cls, name, caption, width, height, slots, unsigned_text=None):
        from reportlab.platypus import Flowable

        class Slot(Flowable):
            def wrap(self, aw, ah):
                return width, height + 12

            def draw(self):
                c = self.canv
                c.setFont("Vera-Bold", 7.5)
                c.setFillColorRGB(0.2, 0.2, 0.2)
                c.drawString(0, height + 3, caption)
                c.setStrokeColorRGB(0.6, 0.6, 0.65)
                c.setLineWidth(0.6)
                c.rect(0, 0, width, height)
                if unsigned_text:
                    c.setFont("Vera-Italic", 8)
                    c.setFillColorRGB(0.55, 0.1, 0.1)
                    c.drawCentredString(width / 2, height / 2 - 3, unsigned_text)
                x, y = c.absolutePosition(0, 0)
                slots[name] = SignatureSlot(c.getPageNumber() - 1, (x, y, x + width, y + height))

        return Slot()


def _numbered_canvas(number: str, verdict: str, draft: bool):
    from reportlab.pdfgen.canvas import Canvas

    class NumberedCanvas(Canvas):
        """Defers pages so each can say 'page x of y'."""

        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            self._pages = []

        def showPage(self):
            self._pages.append(dict(self.__dict__))
            self._startPage()

        def save(self):
            n = len(self._pages)
            for k, state in enumerate(self._pages):
                self.__dict__.update(state)
                self._decorate(k + 1, n)
                super().showPage()
            super().save()

        def _decorate(self, page, pages):
            from reportlab.lib.pagesizes import A4

            w, h = A4
            self.saveState()
            self.setFillColorRGB(0.10, 0.20, 0.36)
            self.rect(0, h - 16 * 2.8346, w, 16 * 2.8346, stroke=0, fill=1)
            self.setFillColorRGB(1, 1, 1)
            self.setFont("Vera-Bold", 13)
            self.drawString(18 * 2.8346, h - 9.5 * 2.8346, TITLE)
            self.setFont("Vera", 8)
            self.drawString(18 * 2.8346, h - 13.5 * 2.8346, f"Certificate No. {number}")
            # verdict chip
            word = VERDICT_WORD[verdict]
            self.setFillColorRGB(*VERDICT_RGB[verdict])
            cw = 40 * 2.8346
            self.roundRect(w - 18 * 2.8346 - cw, h - 13 * 2.8346, cw, 9 * 2.8346, 3, stroke=0,
                           fill=1)
            self.setFillColorRGB(1, 1, 1)
            self.setFont("Vera-Bold", 11)
            self.drawCentredString(w - 18 * 2.8346 - cw / 2, h - 9.9 * 2.8346, word)
            # footer
            self.setFillColorRGB(0.35, 0.35, 0.38)
            self.setFont("Vera", 7)
            self.drawString(18 * 2.8346, 10 * 2.8346,
                            f"{SOFTWARE_NAME} {software_version()}  ·  Certificate No. {number}"
                            f"  ·  {word}")
            self.drawRightString(w - 18 * 2.8346, 10 * 2.8346, f"Page {page} of {pages}")
            if page == pages:
                self.setFont("Vera-Bold", 7.5)
                self.drawCentredString(w / 2, 14.5 * 2.8346, "— End of certificate —")
            if draft:
                self.setFillColorRGB(0.75, 0.1, 0.1)
                self.setFont("Vera-Bold", 8)
                self.drawCentredString(w / 2, h - 20 * 2.8346,
                                       "UNSIGNED DRAFT — not a valid certificate")
                self.setFillColorRGB(0.85, 0.15, 0.15, alpha=0.13)
                self.translate(w / 2, h / 2)
                self.rotate(52)
                self.setFont("Vera-Bold", 70)
                self.drawCentredString(0, -20, "UNSIGNED DRAFT")
            self.restoreState()

    return NumberedCanvas


REASONS_SHOWN = 10
"""Reasons (rejected characteristics) the verdict's block and the statement of conformity name;
section 2 lists every characteristic."""
_GRID_RGB = (0.78, 0.80, 0.84)
_HEAD_RGB = (0.91, 0.93, 0.96)
_ZEBRA_RGB = (0.97, 0.975, 0.98)


@dataclass(frozen=True)
class _Layout:
    """What every section of the certificate shares: the run, what the certificate states,
    the styles and the text width. ``slots`` is filled while the document is laid out."""

    run: Run
    info: CertificateInfo
    number: str
    issued: dt.datetime
    identity: Identity | None
    attachments: list[Attachment]
    views: list[figures.View] | None
    doc: dict
    """run_document(run): the results document the certificate states."""
    styles: dict
    """Paragraph styles by name (:func:`_styles`)."""
    width: float
    """Text width, points (A4 less the margins)."""
    slots: dict[str, SignatureSlot]
    """Where each signature box landed, filled by the layout."""

    @property
    def res(self):
        return self.run.result

    @property
    def plan(self):
        """The inspection plan's outcome (engine.gdt.characteristics.PlanResult), or None."""
        return self.run.result.plan

    @property
    def is_2d(self) -> bool:
        return self.run.template is not None

    @property
    def zone(self) -> str:
        """The tolerance zone in words: "±0.250 mm" or "-0.100 mm … +0.300 mm"."""
        tol = self.res.tolerance
        return (f"±{tol.upper:.3f} mm" if math.isclose(-tol.lower, tol.upper) else
                f"{tol.lower:+.3f} mm … {tol.upper:+.3f} mm")

    @property
    def reasons(self) -> str:
        """The verdict's own reasons. The plain-word statements of what the measurement leaves
        open have their own place in section 6."""
        res = self.res
        return "; ".join(r for r in res.reasons if r not in res.trust_statements)

    @property
    def reasons_shown(self) -> str:
        """:attr:`reasons`, the first REASONS_SHOWN of them and how many more: a plan's
        hundreds of rejected characteristics do not fit the verdict's block (one page)."""
        res = self.res
        own = [r for r in res.reasons if r not in res.trust_statements]
        more = len(own) - REASONS_SHOWN
        return "; ".join(own[:REASONS_SHOWN]) + (
            f"; and {more} more, listed in section 2" if more > 0 else "")

    def table(self, rows, widths, header=True, zebra=False, styles=()):
        """A grid table in the certificate's style (header row shaded, zebra rows on request)."""
        from reportlab.lib import colors
        from reportlab.platypus import Table, TableStyle

        t = Table(rows, colWidths=widths, repeatRows=1 if header else 0)
        cmds = [("GRID", (0, 0), (-1, -1), 0.4, colors.Color(*_GRID_RGB)),
                ("VALIGN", (0, 0), (-1, -1), "MIDDLE"),
                ("TOPPADDING", (0, 0), (-1, -1), 2), ("BOTTOMPADDING", (0, 0), (-1, -1), 2),
                ("LEFTPADDING", (0, 0), (-1, -1), 4), ("RIGHTPADDING", (0, 0), (-1, -1), 4),
                ("FONT", (0, 0), (-1, -1), "Vera", 7.5)]
        if header:
            cmds += [("BACKGROUND", (0, 0), (-1, 0), colors.Color(*_HEAD_RGB)),
                     ("FONT", (0, 0), (-1, 0), "Vera-Bold", 7.5)]
        if zebra:
            for r in range(2 if header else 1, len(rows), 2):
                cmds.append(("BACKGROUND", (0, r), (-1, r), colors.Color(*_ZEBRA_RGB)))
        t.setStyle(TableStyle(cmds + list(styles)))
        return t

    def kv(self, pairs, widths):
        """A two-column table of (label, value) pairs; an empty value reads "—"."""
        from reportlab.lib import colors
        from reportlab.platypus import Paragraph as P

        S = self.styles
        rows = [[P(_esc(k), S["cellb"]), P(_esc(v) if v not in (None, "") else "—", S["cell"])]
                for k, v in pairs]
        return self.table(rows, widths, header=False,
                          styles=[("BACKGROUND", (0, 0), (0, -1), colors.Color(*_HEAD_RGB))])


def build_pdf(run: Run, info: CertificateInfo, number: str, issued: dt.datetime,
              identity: Identity | None, attachments: list[Attachment],
              views: list[figures.View] | None) -> tuple[bytes, dict[str, SignatureSlot]]:
    """Lay out the certificate; return the PDF and where the signature boxes are.

    views : the 3D renders (None for a 2D template, whose map is drawn here).
    """
    from reportlab.lib.pagesizes import A4
    from reportlab.lib.units import mm
    from reportlab.platypus import SimpleDocTemplate

    _fonts()
    c = _Layout(run, info, number, issued, identity, attachments, views, run_document(run),
                _styles(), A4[0] - 36 * mm, {})
    story = [flowable for section in _SECTIONS for flowable in section(c)]
    res = run.result
    buf = io.BytesIO()
    pdf = SimpleDocTemplate(buf, pagesize=A4, leftMargin=18 * mm, rightMargin=18 * mm,
                            topMargin=(26 if identity else 30) * mm, bottomMargin=22 * mm,
                            title=f"{TITLE} {number}", author=info.inspector or "",
                            subject=f"{VERDICT_WORD[res.verdict]}: "
                                    f"{info.part_number or ''} {info.serial or ''}".strip(),
                            creator=f"{SOFTWARE_NAME} {software_version()}",
                            pageCompression=0)
    pdf.build(story, canvasmaker=_numbered_canvas(number, res.verdict, identity is None))
    if set(c.slots) != {INSPECTOR_FIELD, APPROVER_FIELD}:
        raise CertificateError("signature boxes were not laid out")
    return buf.getvalue(), c.slots


def _identification(c: _Layout) -> list:
    """1  Identification: the part (left) and the inspection (right)."""
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph as P

    info, identity = c.info, c.identity
    left = c.kv([("Organisation", info.organisation),
                 ("Part number", _stated(c, info.part_number, "number")),
                 ("Part name", _stated(c, info.part_name, "name")),
                 ("Revision", _stated(c, info.revision, "revision")),
                 ("Serial number", info.serial), ("Order", info.order)], [28 * mm, 58 * mm])
    right = c.kv([("Inspector", identity.common_name if identity else info.inspector),
                  ("Date and time", f"{c.issued:%Y-%m-%d %H:%M:%S} UTC"),
                  ("Software", f"{SOFTWARE_NAME} {software_version()}"),
                  ("Certificate No.", c.number),
                  ("Status", "signed (PAdES)" if identity else "UNSIGNED DRAFT")],
                 [28 * mm, 56 * mm])
    return [P("1  Identification", c.styles["h"]), _two_columns(c, left, right),
            *_traceability(c)]


def _two_columns(c: _Layout, left, right):
    """Two flowables side by side, each half the text width."""
    from reportlab.platypus import Table

    return Table([[left, right]], colWidths=[c.width / 2, c.width / 2],
                 style=[("VALIGN", (0, 0), (-1, -1), "TOP"),
                        ("LEFTPADDING", (0, 0), (-1, -1), 0),
                        ("RIGHTPADDING", (0, 0), (-1, -1), 0)])


def _traceability(c: _Layout) -> list:
    """The traceability block of section 1: how the part was measured (device, serial,
    calibration, probe, temperature, program) and against which drawing and CAD revision;
    a field not stated reads "—" (an auditor sees what is missing)."""
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph as P
    from reportlab.platypus import Spacer

    info = c.info
    pairs = [(label, _traceability_value(info, key)) for key, label in TRACEABILITY]
    half = (len(pairs) + 1) // 2
    return [Spacer(1, 2 * mm), P("Traceability", c.styles["cellb"]), Spacer(1, 1 * mm),
            _two_columns(c, c.kv(pairs[:half], [28 * mm, 58 * mm]),
                         c.kv(pairs[half:], [28 * mm, 56 * mm]))]


def _traceability_value(info: CertificateInfo, key: str) -> str | None:
    value = getattr(info, key)
    if key == "temperature_c" and value is not None:
        return f"{value:g} °C"
    return value


def _stated(c: _Layout, value: str | None, field: str) -> str | None:
    """A part field as the inspector stated it, and the inspection plan's beside it when the
    plan states another (:func:`plan_info`)."""
    planned = "" if c.run.plan is None else getattr(c.run.plan.part, field).strip()
    if planned and not same_person(value, planned):
        return f"{value} (the inspection plan states {planned})"
    return value


def _result(c: _Layout) -> list:
    """2  Result: the verdict block with its reasons, and the statistics (placed early: the
    answer comes first)."""
    from reportlab.lib import colors
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph as P
    from reportlab.platypus import Spacer, Table

    S, W, res = c.styles, c.width, c.res
    st = res.statistics
    reasons = c.reasons_shown
    vb = Table([[P(VERDICT_WORD[res.verdict],
                   S["verdict_long" if res.verdict == INCONCLUSIVE else "verdict"]),
                 P(_esc(reasons[:1].upper() + reasons[1:]), S["verdict_sub"])]],
               colWidths=[62 * mm, W - 62 * mm],
               style=[("BACKGROUND", (0, 0), (-1, -1), colors.Color(*VERDICT_RGB[res.verdict])),
                      ("VALIGN", (0, 0), (-1, -1), "MIDDLE"),
                      ("TOPPADDING", (0, 0), (-1, -1), 8), ("BOTTOMPADDING", (0, 0), (-1, -1), 8),
                      ("LEFTPADDING", (0, 0), (-1, -1), 10)])
    stats_rows = [["Points", "Out of tol.", "Min", "Max", "Mean", "Std dev", "RMS",
                   "Max |d|"],
                  [f"{st.count}", f"{st.n_out}", *(figures.fmt_mm(v) for v in
                                                   (st.min, st.max, st.mean)),
                   *(figures.fmt_mm(v, False) for v in (st.std, st.rms, st.max_abs))]]
    return [P("2  Result", S["h"]), vb, Spacer(1, 3 * mm), *_plan_table(c),
            c.table(stats_rows, [W / 8] * 8,
                    styles=[("ALIGN", (0, 0), (-1, -1), "CENTER"),
                            ("FONT", (0, 1), (-1, 1), "Vera-Bold", 8.5)]),
            P("Deviations in mm, positive where the measured surface lies outside the nominal "
              "(excess material), negative inside it (material missing); statistics over every "
              "measured point, points excluded "
              "from the alignment included" + ("." if c.plan is None else
                                               f", at the plan's alignment, against the zone "
                                               f"{c.zone} of the statistics (section 3)."),
              S["small"])]


_TYPE_WORDS = {"profile": "surface profile", "flatness": "flatness", "position": "position",
               "size": "size (diameter)"}


def _type_word(c: _Layout, kind: str) -> str:
    """A characteristic's type in words (a profile of a 2D contour is a line profile)."""
    return "line profile" if kind == "profile" and c.is_2d else _TYPE_WORDS[kind]
_VALUE_WORDS = {
    "profile": "profile: the width of the smallest zone, centred like its tolerance zone, that "
               "holds every point of its region (form: after the region is fitted alone, "
               "whatever the datums)",
    "flatness": "flatness: the distance between the two closest parallel planes that hold the "
                "face's points",
    "position": "position: the diameter of the smallest cylinder about the true position (from "
                "the datums) that holds the hole's fitted axis",
    "size": "size: the diameter of the least-squares fit to the hole's points"}


def _plan_table(c: _Layout) -> list:
    """The inspection plan's characteristics, as a first-article report lists them: balloon,
    symbol, what, requirement, datums, measured value, points, result (none without a plan)."""
    from reportlab.lib import colors
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph as P
    from reportlab.platypus import Spacer

    if c.plan is None:
        return []
    S, W = c.styles, c.width
    rows = [["No.", "", "Characteristic", "Requirement", "Datums", "Measured (mm)", "Points",
             "Result"]]
    cmds = []
    for k, r in enumerate(c.plan.characteristics, start=1):
        ch = r.characteristic
        where = "all points" if ch.region == "(all points)" else f"region {ch.region}"
        rows.append([_balloon(ch.id), _symbol(ch.type),
                     P(f"{_esc(_type_word(c, ch.type))}<br/><font size=6.5>{_esc(where)}</font>",
                       S["cell"]),
                     P(_esc(limits_text(ch).replace("⌀", "Ø")), S["cell"]),
                     "|".join(ch.datums) or ("—" if ch.type == "size" else "form"),
                     "—" if r.value is None else f"{r.value:.4f}", f"{r.indices.size}",
                     VERDICT_WORD[r.verdict]])
        cmds += [("BACKGROUND", (7, k), (7, k), colors.Color(*VERDICT_RGB[r.verdict])),
                 ("TEXTCOLOR", (7, k), (7, k), colors.white),
                 ("FONT", (7, k), (7, k), "Vera-Bold", 7.5)]
    # Why each one is not accepted, unless the verdict's reasons above already say it.
    notes = [f"Characteristic {r.characteristic.id}: {r.reason}."
             for r in c.plan.characteristics if r.verdict != ACCEPT and r.reason not in c.reasons]
    types = dict.fromkeys(r.characteristic.type for r in c.plan.characteristics)
    words = dict(_VALUE_WORDS, **({"position": _VALUE_WORDS["position"].replace(
        "cylinder", "circle").replace("axis", "centre")} if c.is_2d else {}))
    notes.append("Measured value — " + "; ".join(words[t] for t in types) + ". Datums: "
                 "the features the part is placed by (section 6); form: judged by shape alone.")
    return [P("Characteristics of the inspection plan", S["cellb"]), Spacer(1, 1 * mm),
            c.table(rows, [10 * mm, 8 * mm, 28 * mm, 46 * mm, 16 * mm, 27 * mm, 13 * mm,
                           W - 148 * mm],
                    styles=[("ALIGN", (0, 0), (1, -1), "CENTER"),
                            ("ALIGN", (4, 0), (-1, -1), "CENTER"), *cmds]),
            Spacer(1, 1 * mm), *(P(_esc(n), S["small"]) for n in notes), Spacer(1, 3 * mm)]


def _balloon(text: str):
    """A drawing's balloon: the characteristic's number in a circle (a stadium when long)."""
    from reportlab.graphics.shapes import Circle, Drawing, Rect, String
    from reportlab.pdfbase.pdfmetrics import stringWidth

    tw = stringWidth(text, "Vera-Bold", 7)
    w = max(12.0, tw + 6)
    d = Drawing(w + 1, 13)
    if w <= 12.0:
        d.add(Circle(w / 2 + 0.5, 6.5, 6, fillColor=None, strokeWidth=0.7))
    else:
        d.add(Rect(0.5, 0.5, w, 12, rx=6, ry=6, fillColor=None, strokeWidth=0.7))
    d.add(String(w / 2 + 0.5, 4, text, fontName="Vera-Bold", fontSize=7, textAnchor="middle"))
    return d


def _symbol(kind: str):
    """The characteristic's symbol on a drawing (reports.messages.SYMBOL), drawn: the
    certificate's font has no glyphs for them."""
    from reportlab.graphics.shapes import Circle, Drawing, Line, Polygon, Wedge

    d = Drawing(12, 12)
    ink = {"fillColor": None, "strokeWidth": 0.8}
    if kind == "profile":  # a half circle on its diameter
        d.add(Wedge(6, 3, 5, 0, 180, **ink))
    elif kind == "flatness":  # a parallelogram
        d.add(Polygon([1, 3, 8, 3, 11, 9, 4, 9], **ink))
    elif kind == "position":  # a circle and its cross
        d.add(Circle(6, 6, 3.6, **ink))
        d.add(Line(0.5, 6, 11.5, 6, strokeWidth=0.8))
        d.add(Line(6, 0.5, 6, 11.5, strokeWidth=0.8))
    else:  # size: the diameter sign
        d.add(Circle(6, 6, 4, **ink))
        d.add(Line(1.5, 1.5, 10.5, 10.5, strokeWidth=0.8))
    return d


def _requirement(c: _Layout) -> list:
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
                           "outside" if res.decision_rule == "simple" else
                           "Pointwise, guarded " + _guarded_words(res))
                          + "; the result is inconclusive when the registration cannot be "
                            "trusted (not converged, or the points do not match the nominal), "
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
    if res.decision_rule == "guarded":
        return ("Measurement uncertainty is deducted from the zone as stated." if
                res.uncertainty is not None else "Measurement uncertainty is not deducted "
                "from the zone.")
    if res.uncertainty is not None:
        return (f"Measurement uncertainty (U up to {float(res.uncertainty.expanded.max()):.4f} "
                "mm, below) is stated but not deducted from the zone (simple acceptance).")
    return "Measurement uncertainty is not deducted from the zone (simple acceptance)."


def _uncertainty_budget(c: _Layout) -> list:
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
        rows.append([P(_esc(t.name[:1].upper() + t.name[1:]), S["cell"]),
                     P(_esc(t.basis), S["cell"]), t.distribution,
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


def _plan_requirement(c: _Layout) -> list[tuple[str, str]]:
    """Section 3 of a plan: its characteristics are the requirement; the zone of the per-point
    statistics is stated apart, with whether it is one of them."""
    res, zone, plan = c.res, c.zone, c.run.plan
    rec = next(r for r in c.run.inputs if r.role == "plan")
    guarded = res.decision_rule == "guarded"
    return [
        ("Requirement", f"The {len(plan.characteristics)} characteristics of the inspection "
                        f"plan {os.path.basename(rec.path)} (SHA-256 {rec.sha256[:16]}…, "
                        "section 5)" + (f", and the {_type_word(c, 'profile')} of every "
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
         f"{zone}: {_type_word(c, 'profile')} of every measured point, judged at the best fit "
         "over all "
         "points (characteristic 'tol' in section 2)" if c.plan.zone_in_verdict else
         f"{zone}, the plan's widest profile zone: it colours the statistics, the deviation "
         "map, the histogram and the point list (sections 2, 7 to 9) and is not itself part "
         "of the verdict"),
        ("Sign", "Positive along the nominal's outward normal (excess material), negative "
                 "into the material (missing material)"),
        ("Units", "millimetres"),
    ]


def _method(c: _Layout) -> list:
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
            if res.fit == "lsq" else
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
            out.append(P(_esc(para), S["base"]))
    return out


def _inputs(c: _Layout) -> list:
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
        rows.append([r.role, P(_esc(os.path.basename(r.path)), S["cell"]), size,
                     P(r.sha256, S["mono"])])
    return [CondPageBreak(45 * mm), P("5  Inputs", S["h"]),
            c.table(rows, [18 * mm, 50 * mm, 24 * mm, c.width - 92 * mm])]


def _registration(c: _Layout) -> list:
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
           P(_esc(alignment_statement(c.run)), S["base"]), Spacer(1, 1.5 * mm),
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
            out.append(P("• " + _esc(sentence[:1].upper() + sentence[1:]) + ".", S["small"]))
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
            f"points lie within {reg.near_distance:.3g} mm (1% of the nominal's size) of the "
            f"nominal at this pose, {fits}.")


def _matrix(c: _Layout, T: np.ndarray):
    """A 4x4 pose as a table of numbers (rotation 6 decimals, translation 4)."""
    from reportlab.lib.units import mm

    return c.table([[f"{v:+.6f}" if j < 3 else f"{v:+.4f}" for j, v in enumerate(row)]
                    for row in T], [20 * mm] * 4, header=False,
                   styles=[("FONT", (0, 0), (-1, -1), "Courier", 7),
                           ("ALIGN", (0, 0), (-1, -1), "RIGHT")])


_FIT_WORDS = {"tangent": "tangent", "lsq": "least squares"}


def _plan_alignment(c: _Layout) -> list:
    """The inspection plan's alignment: in words, what it rests on, and the pose the map and
    the point list are at (none without a plan)."""
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether, Spacer, Table
    from reportlab.platypus import Paragraph as P

    if c.plan is None:
        return []
    S, W = c.styles, c.width
    out = [Spacer(1, 2 * mm), P("Alignment by the inspection plan", S["cellb"]),
           P(_esc(_alignment_words(c.plan, c.run.plan)) + ".", S["base"]), Spacer(1, 1 * mm)]
    notes = [P("The deviation map, the histogram and the point list (sections 7 to 9) show "
               "the part at this alignment; a characteristic relative to datums is evaluated at "
               "the pose its own datums give.", S["small"])]
    if c.plan.alignment is not None:
        table, note = _alignment_table(c)
        out.append(table)
        notes[:0] = [P(_esc(note), S["small"]), Spacer(1, 1.5 * mm)]
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


def _alignment_table(c: _Layout):
    """(table, note): each datum's feature, fit, points, freedom taken and form error; or each
    RPS point's locked axes and nominal position."""
    from reportlab.lib.units import mm

    W, al, plan = c.width, c.plan.alignment, c.run.plan
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


def _freedoms(c: _Layout) -> str:
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


def _registration_rows(c: _Layout) -> list[tuple[str, str]]:
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


def _deviation_map(c: _Layout) -> list:
    """7  Deviation map: the 2D contour map drawn here, or the two 3D renders (on the
    registration's page when they fit there, with section 8)."""
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether, Table
    from reportlab.platypus import Paragraph as P

    S, W, res, run, views = c.styles, c.width, c.res, c.run, c.views
    # The heading, the map and its caption together, on this page when they fit (a page
    # break before a fixed height would leave the page above half empty).
    out = [P("7  Deviation map", S["h"])]
    if c.is_2d:
        bar_w = 24 * mm
        drawing, factor = figures.contour_map(run.template.template, res.deviations.foot,
                                              res.deviations.normal, res.deviations.signed,
                                              res.tolerance, _worst_labels(run),
                                              W - bar_w, 128 * mm)
        bar = figures.colour_bar(res.tolerance, bar_w - 2 * mm,
                                 min(drawing.height, 95 * mm), "Deviation (mm)")
        out.append(Table([[drawing, bar]], colWidths=[W - bar_w, bar_w],
                         style=[("VALIGN", (0, 0), (-1, -1), "MIDDLE"),
                                ("LEFTPADDING", (0, 0), (-1, -1), 0),
                                ("RIGHTPADDING", (0, 0), (-1, -1), 0)]))
        out.append(P(f"Template (dark lines) and every measured point at its foot on the "
                     f"contour, with its deviation drawn as a whisker magnified {factor:g} "
                     "times, coloured on the scale at the right; " + _FLAGS_WORDS, S["small"]))
        return [KeepTogether(out)]
    out.append(_map_grid(c, views, W))
    out.append(P(_views_caption(views) + " Parallel projection, nominal frame; every measured "
                 "point drawn at its foot on the nominal surface (shaded), coloured by "
                 "deviation on the scale at the right; " + _FLAGS_WORDS +
                 ("" if c.plan is None else " The part at the plan's alignment "
                  "(section 6), coloured against the zone of the statistics "
                  "(section 3)."), S["small"]))
    return [KeepTogether(out)]


_FLAGS_WORDS = ("flags on the worst point of each separate cluster of out-of-tolerance points "
                "(of the largest deviations when every point is in tolerance).")


def _views_caption(views) -> str:
    names = [v.name for v in views]
    where = (["Left", "right"] if len(views) == 2 else
             ["Top left", "top right", "bottom left", "bottom right"][:len(views)])
    if len(views) == 1:
        return f"{names[0]}."
    return "; ".join(f"{w}: {n}" for w, n in zip(where, names)) + "."


def _map_grid(c: _Layout, views, W: float):
    """The views two to a row with the colour bar beside them."""
    from reportlab.lib import colors
    from reportlab.lib.units import mm
    from reportlab.platypus import Table

    bar_w = 24 * mm
    iw = (W - bar_w - 2 * mm) / 2
    ih = iw * figures.RENDER_SIZE[1] / figures.RENDER_SIZE[0]
    labels = dict(_worst_labels(c.run))
    cells = [figures.map_flowable(v, labels, iw, ih) for v in views]
    rows = [cells[k:k + 2] + [""] * (k + 2 - len(cells)) for k in range(0, len(cells), 2)]
    bar = figures.colour_bar(c.res.tolerance, bar_w - 2 * mm, min(len(rows) * ih, 95 * mm),
                             "Deviation (mm)")
    grid = Table([r + [bar if k == 0 else ""] for k, r in enumerate(rows)],
                 colWidths=[iw, iw, bar_w + 2 * mm], rowHeights=[ih] * len(rows),
                 style=[("GRID", (0, 0), (1, -1), 0.4, colors.Color(*_GRID_RGB)),
                        ("SPAN", (2, 0), (2, -1)), ("VALIGN", (2, 0), (2, -1), "MIDDLE"),
                        ("LEFTPADDING", (0, 0), (-1, -1), 0),
                        ("RIGHTPADDING", (0, 0), (-1, -1), 0),
                        ("TOPPADDING", (0, 0), (-1, -1), 0),
                        ("BOTTOMPADDING", (0, 0), (-1, -1), 0),
                        ("LEFTPADDING", (2, 0), (2, -1), 3 * mm)])
    return grid


def _histogram(c: _Layout) -> list:
    """8  Colour scale and histogram of deviations."""
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether, Table
    from reportlab.platypus import Paragraph as P

    W, tol, d = c.width, c.res.tolerance, c.res.deviations.signed
    legend = figures.legend(tol, d, 50 * mm, 62 * mm)
    hist = figures.histogram(d, tol, W - 56 * mm, 62 * mm)
    return [KeepTogether([P("8  Colour scale and histogram of deviations", c.styles["h"]),
            Table([[legend, hist]], colWidths=[54 * mm, W - 54 * mm],
                  style=[("VALIGN", (0, 0), (-1, -1), "TOP"),
                         ("LEFTPADDING", (0, 0), (-1, -1), 0)]),
            P("Green bands: inside the tolerance zone; blue: below the lower limit "
              "(missing material); red: above the upper limit (excess material). Dashed "
              "lines: the tolerance limits (LTL, UTL).", c.styles["small"])])]


def _characteristics(c: _Layout) -> list:
    """9  Characteristic accountability (AS9102 Form 3 style): every out-of-tolerance point,
    then the in-tolerance points nearest to a limit; without a trusted pose the largest
    deviations, not judged. With a plan (whose characteristics are in section 2): the measured
    points against the zone of the statistics, with their regions."""
    from reportlab.lib import colors
    from reportlab.lib.units import mm
    from reportlab.platypus import CondPageBreak, Spacer
    from reportlab.platypus import Paragraph as P

    S, W, res, run = c.styles, c.width, c.res, c.run
    st, order, d = res.statistics, run.worst_order, res.deviations.signed
    out_idx = order[: min(st.n_out, MAX_OUT_ROWS)]
    near = order.size - st.n_out if order.size <= APPENDIX_POINTS else WORST_ROWS
    rows_idx = list(out_idx) + [i for i in order[st.n_out: st.n_out + near]]
    judged = res.verdict != INCONCLUSIVE if c.plan is None else _registration_trusted(res)
    if not judged:  # no pose to trust: the points are listed, not judged
        out_idx = []
        rows_idx = list(order[:max(near, WORST_ROWS)])
    title, header, words, intro = _point_list_words(c, len(out_idx),
                                                    len(rows_idx) - len(out_idx), judged)
    rows = [header]
    res_styles = []
    for k, i in enumerate(rows_idx):
        p = res.registered[i]
        ok = bool(res.in_tolerance[i])
        result = words[ok] if judged else "not judged"
        name = (P(_esc(_point_name(run, i)) + "<br/><font size=6>excluded from the alignment "
                  f"(gross outlier, d = {d[i]:+.4f} mm)</font>", S["cell"]) if res.outlier[i]
                else _point_name(run, i))
        rows.append([f"{k + 1}", name, c.zone if c.plan is None else
                     P(_esc(c.plan.regions[i] or "—"), S["cell"]),
                     f"{p[0]:.3f}", f"{p[1]:.3f}", f"{p[2]:.3f}", f"{d[i]:+.4f}", result])
        if judged and not ok:
            res_styles.append(("TEXTCOLOR", (7, k + 1), (7, k + 1), colors.Color(0.72, 0.1, 0.1)))
            res_styles.append(("FONT", (7, k + 1), (7, k + 1), "Vera-Bold", 7.5))
    return [CondPageBreak(60 * mm), P(title, S["h"]), P(_esc(intro), S["small"]),
            P(_esc(_every_point_words(c, len(rows_idx))), S["cellb"]), Spacer(1, 2 * mm),
            c.table(rows, [15 * mm, 24 * mm, 30 * mm, 22 * mm, 22 * mm, 22 * mm, 22 * mm,
                           W - 157 * mm], zebra=True,
                    styles=[("ALIGN", (3, 1), (6, -1), "RIGHT"),
                            ("ALIGN", (7, 0), (7, -1), "CENTER"), *res_styles])]


def _registration_trusted(res) -> bool:
    from engine.verdict import pose_trusted

    return pose_trusted(res.registration)


def _every_point_words(c: _Layout, listed: int) -> str:
    """Where every measured point is: this table, or the attached CSV."""
    n = c.res.statistics.count
    if listed == n:
        return (f"This table lists all {n} measured points (they are also in the attached "
                "points.csv, section 10).")
    return (f"This table lists {listed} of the {n:,} measured points. The complete list of "
            f"all {n:,} points, each with its input and registered coordinates, deviation and "
            "result, is the attached file points.csv (section 10), covered by the signature.")


def _point_list_words(c: _Layout, n_out: int, n_near: int, judged: bool):
    """Section 9's title, header row, result words (by in-tolerance) and introduction."""
    n_all = c.res.statistics.n_out
    listed = f"; the worst {MAX_OUT_ROWS} are listed" if n_all > MAX_OUT_ROWS else ""
    tail = (" A point excluded from the alignment (a gross outlier: see section 4) is judged "
            "like every other.")
    if not judged:
        head = (f"The registration cannot be trusted, so no point is judged; the {n_near} "
                "largest deviations at the best pose found are listed for diagnosis.")
    elif c.plan is None:
        head = (f"Every point out of tolerance ({n_all}{listed}), then the {n_near} "
                "in-tolerance points nearest to a limit, worst first.")
    else:
        head = (f"Every point outside the zone of the statistics {c.zone} ({n_all}{listed}), "
                f"then the {n_near} inside it nearest to a limit, worst first, with the regions "
                "of the plan they belong to (—: none). " + (
                    "That zone is also characteristic 'tol' (judged at the best fit over all "
                    "points)." if c.plan.zone_in_verdict else
                    "That zone is not part of the verdict: the characteristics in section 2 "
                    "are."))
    if c.plan is None:
        return ("9  Characteristic accountability (AS9102 Form 3 style)",
                ["Char. No.", "Point", "Requirement", "X (mm)", "Y (mm)", "Z (mm)",
                 "Deviation", "Result"], {True: "PASS", False: "FAIL"},
                head + " Coordinates of the registered points in the nominal frame." + tail)
    return ("9  Measured points", ["No.", "Point", "Region", "X (mm)", "Y (mm)", "Z (mm)",
                                   "Deviation", "In zone"], {True: "inside", False: "outside"},
            head + " Coordinates at the plan's alignment (section 6), in the nominal frame."
            + tail)


def _evidence(c: _Layout) -> list:
    """10  Attached evidence: each embedded file with its content and SHA-256."""
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether
    from reportlab.platypus import Paragraph as P

    S = c.styles
    rows = [["File", "Content", "SHA-256"]]
    for a in c.attachments:
        rows.append([a.name, P(_esc(a.description), S["cell"]),
                     P(hashlib.sha256(a.data).hexdigest(), S["mono"])])
    return [KeepTogether([
        P("10  Attached evidence (embedded in this PDF, covered by the signature)", S["h"]),
        c.table(rows, [22 * mm, 62 * mm, c.width - 84 * mm]),
        P("Extract them with any PDF reader's attachment panel or "
          "<font name='Courier'>pdfdetach -saveall</font>.", S["small"])])]


def _statement_and_signatures(c: _Layout) -> list:
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
    sig_text = (f"Signed digitally by {_esc(identity.common_name)}"
                f"{', ' + _esc(identity.organisation) if identity.organisation else ''}; "
                f"issuing CA SHA-256 fingerprint "
                f"<font name='Courier'>{_esc(identity.ca_fingerprint or 'not in the file')}"
                f"</font>." + (" <b>Demonstration identity (qa-inspect keygen), not for "
                               "production use.</b>" if identity.demonstration else "")
                if identity else "<b>UNSIGNED DRAFT</b>: this document carries no signature "
                "and is not a valid certificate.")
    bw = (W - 8 * mm) / 2
    return [KeepTogether([
        P("11  Statement of conformity and signatures", S["h"]),
        P(_esc(statement), S["base"]), Spacer(1, 2 * mm),
        P(sig_text, S["small"]),
        P("Verify the signature and the evidence: <font name='Courier'>qa-inspect verify "
          "certificate.pdf --trust ca.pem [--nominal FILE --measured FILE"
          + ("" if c.plan is None else " --plan FILE") + "]</font> or any "
          "PAdES-capable reader with the issuing CA as trust anchor.", S["small"]),
        Spacer(1, 3 * mm),
        Table([[_Slot(INSPECTOR_FIELD, "Inspector signature", bw, 24 * mm, c.slots,
                      None if identity else "UNSIGNED DRAFT"),
                _Slot(APPROVER_FIELD, "Approver signature (optional, second signature)",
                      bw, 24 * mm, c.slots)]],
              colWidths=[bw + 4 * mm, bw + 4 * mm],
              style=[("LEFTPADDING", (0, 0), (-1, -1), 0)])])]


def _plan_statement(c: _Layout) -> str:
    """The statement of conformity to an inspection plan (accepted or rejected)."""
    rec = next(r for r in c.run.inputs if r.role == "plan")
    name = os.path.basename(rec.path)
    results = c.plan.characteristics
    if c.res.verdict == ACCEPT:
        return (f"The part identified above conforms to the inspection plan {name}: all "
                f"{len(results)} characteristics lie within their tolerances, under the "
                "decision rule stated in section 3.")
    out = [f"{ch.id} ({_type_word(c, ch.type)} of "
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


_SECTIONS = (_identification, _result, _requirement, _method, _inputs, _registration,
             _deviation_map, _histogram, _characteristics, _evidence, _statement_and_signatures)
"""The certificate's sections in their order; each returns its flowables."""


def _point_name(run: Run, i: int) -> str:
    """Point ``i``'s label (printable: a table cell or callout would break a line at a line
    break in it), or its number."""
    labels = run.measured.labels
    return printable(labels[i]) if labels is not None and str(labels[i]) else f"#{i + 1}"


def _worst_labels(run: Run) -> list[tuple[int, str]]:
    """The flagged points (reports.callouts.callout_points) and their labels."""
    res = run.result
    d, tol = res.deviations.signed, res.tolerance
    idx = callouts.callout_points(res.deviations.foot, d, tol.lower, tol.upper)
    return [(i, f"{_point_name(run, i)}\n{d[i]:+.3f}") for i in idx]


def _vec(v) -> str:
    return "(" + ", ".join(f"{x:+.2f}" for x in v) + ")"


def excursion_words(run: Run) -> str:
    """The worst point's excursion with its sign explained: which limit it passes, by how much,
    and what its deviation means for the material."""
    res = run.result
    d, tol = res.deviations.signed, res.tolerance
    i = int(run.worst_order[0])
    below = d[i] < tol.lower
    limit = tol.lower if below else tol.upper
    return (f"the worst, point {_point_name(run, i)}, lies {abs(d[i] - limit):.4f} mm "
            f"{'below the lower' if below else 'above the upper'} limit: its deviation "
            f"{d[i]:+.4f} mm is {'negative, material missing' if d[i] < 0 else 'positive, excess material'} "
            f"(the measured surface lies {'inside' if d[i] < 0 else 'outside'} the nominal, "
            f"{'into' if d[i] < 0 else 'away from'} the material)")
