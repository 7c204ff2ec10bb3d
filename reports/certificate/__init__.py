"""The inspection certificate: a PDF laid out after ISO/IEC 17025 §7.8 and AS9102 Form 3.

:func:`make_certificate` builds it from one :class:`engine.pipeline.Run`: the figures, the
evidence files embedded in it (per-point CSV, QIF 3.0 results, the JSON results with the settings
needed to re-run the inspection) and, given an identity, a PAdES signature over all of it.
Without an identity every page says UNSIGNED DRAFT.

The package: :mod:`.policy` (what a certificate states, and the refusals), :mod:`.layout` (the
page machinery and :class:`~.layout.Layout`, what every section shares), :mod:`.document` (the
draft, the finished certificate and :func:`build_pdf`, which lays the sections out in order)
and one module per group of sections: :mod:`.identification` (1), :mod:`.result` (2),
:mod:`.requirement` (3), :mod:`.method` (4, 5), :mod:`.registration` (6), :mod:`.maps` (7, 8),
:mod:`.points` (9), :mod:`.statement` (10, 11).
"""

from .document import (CertificateDraft, build_pdf, draft_certificate, finish_certificate,
                       make_certificate)
from .layout import REASONS_SHOWN, TITLE
from .points import APPENDIX_POINTS, MAX_OUT_ROWS, WORST_ROWS, worst_labels
from .policy import (TRACEABILITY, CertificateError, CertificateInfo, CertificationError,
                     certificate_number, certified_info, check_inspector, check_trustworthy,
                     plan_info, same_person)
from .registration import alignment_statement
from .statement import excursion_words

__all__ = [
    "APPENDIX_POINTS", "CertificateDraft", "CertificateError", "CertificateInfo",
    "CertificationError", "MAX_OUT_ROWS", "REASONS_SHOWN", "TITLE", "TRACEABILITY",
    "WORST_ROWS", "alignment_statement", "build_pdf", "certificate_number", "certified_info",
    "check_inspector", "check_trustworthy", "draft_certificate", "excursion_words",
    "finish_certificate", "make_certificate", "plan_info", "same_person", "worst_labels",
]
