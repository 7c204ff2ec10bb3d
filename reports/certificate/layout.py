"""The certificate's page machinery: its fonts and paragraph styles, the text of a
Paragraph, the signature boxes, the page frame (title, verdict chip, page x of y, the UNSIGNED
DRAFT mark) and :class:`Layout`, what every section shares."""

from __future__ import annotations

import datetime as dt
import math
import os
from dataclasses import dataclass

from engine.gdt.plan import Plan
from engine.pipeline import Run
from engine.section import Section

from .. import figures
from ..messages import VERDICT_RGB, VERDICT_WORD, printable
from ..results import SOFTWARE_NAME, software_version
from ..signing import Attachment, Identity, SignatureSlot
from .policy import CertificateInfo


TITLE = "Dimensional Inspection Certificate"
DEMONSTRATION_NOTE = "Demonstration identity (qa-inspect keygen), not for production use."
"""What the certificate says where it names a demonstration signer (reports.signing.DEMO_MARK
in its certificate): on the first page (section 1) and beside the signatures (section 11)."""


def register_fonts():
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


def paragraph_styles():
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


def esc(text) -> str:
    """``text`` for a Paragraph, which reads markup (<font size=80>, &amp;): shown literally,
    its control characters written out (reports.messages.printable)."""
    from xml.sax.saxutils import escape

    return escape(printable("" if text is None else text))


class Slot:
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


def numbered_canvas(number: str, verdict: str, draft: bool, issued: dt.datetime):
    """The canvas class of a certificate: numbered pages, and the PDF's creation and
    modification dates the issue time ``issued`` (UTC), not the clock's (with reportlab's
    invariant mode, which takes its ID from the content alone: the same certificate issued at
    the same time is the same bytes)."""
    from reportlab.pdfgen.canvas import Canvas

    stamp = issued.astimezone(dt.timezone.utc).strftime("D:%Y%m%d%H%M%S+00'00'")

    class NumberedCanvas(Canvas):
        """Defers pages so each can say 'page x of y'."""

        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            self._pages = []
            self.setDateFormatter(lambda *_: stamp)

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
GRID_RGB = (0.78, 0.80, 0.84)
_HEAD_RGB = (0.91, 0.93, 0.96)
_ZEBRA_RGB = (0.97, 0.975, 0.98)


@dataclass(frozen=True)
class Layout:
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
    """Paragraph styles by name (:func:`paragraph_styles`)."""
    width: float
    """Text width, points (A4 less the margins)."""
    slots: dict[str, SignatureSlot]
    """Where each signature box landed, filled by the layout."""
    sections: tuple[Section, ...] = ()
    """The planar sections (engine.section), a page each."""

    @property
    def res(self):
        return self.run.result

    @property
    def plan(self):
        """The inspection plan's outcome (engine.gdt.characteristics.PlanResult), or None."""
        return self.run.result.plan

    @property
    def plan_read(self) -> Plan:
        """The inspection plan as read (a plan's sections only ask with one)."""
        if self.run.plan is None:
            raise ValueError("the certificate's inspection has no plan")
        return self.run.plan

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
        cmds = [("GRID", (0, 0), (-1, -1), 0.4, colors.Color(*GRID_RGB)),
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
        rows = [[P(esc(k), S["cellb"]), P(esc(v) if v not in (None, "") else "—", S["cell"])]
                for k, v in pairs]
        return self.table(rows, widths, header=False,
                          styles=[("BACKGROUND", (0, 0), (0, -1), colors.Color(*_HEAD_RGB))])
