"""The QIF 3.0 results document of one inspection, from its JSON results document and its
per-point arrays (the format: :mod:`reports.qif`)."""

from __future__ import annotations

import numpy as np

from .measured import write_results
from .model import QIFError, Qif
from .nominal import (write_characteristics, write_datums, write_definitions, write_features,
                      write_header, write_product, write_resources)


def qif_results_document(doc: dict, registered, deviations, in_tolerance, labels=None,
                         outlier=None, plan=None) -> bytes:
    """The QIF 3.0 results document (UTF-8 XML bytes) of one inspection.

    doc : the dict of :func:`reports.results.result_document`, optionally with ``certificate``
        (number, part_number, part_name, serial, revision, order, inspector, organisation,
        device, issued: ISO 8601 time; any may be missing or None).
    registered : (n, 3) measured points in the nominal frame, mm ((n, 2) is taken as z = 0).
    deviations : (n,) signed deviations, mm, positive along the nominal's outward normal.
    in_tolerance : (n,) bool. labels : (n,) str or None. outlier : (n,) bool or None, the
        points excluded from the alignment as gross outliers (InspectionResult.outlier).
    plan : the QIF plan the inspection was judged by (engine.io.qif_plan.QifSource,
        :func:`plan_source`): the document is then that plan's own, its results referencing
        its ids (reports.qif.linked); None: the inspection's own document.

    Raises QIFError when the arguments do not fit together.
    """
    checked = _checked_points(registered, deviations, in_tolerance, labels, outlier)
    if plan is not None:
        from .linked import linked_results_document

        return linked_results_document(doc, plan, *checked)
    q = Qif.of(doc, *checked)
    o: list[str] = []
    for section in (write_header, write_definitions, write_datums, write_resources,
                    write_product, write_features, write_characteristics, write_results):
        section(o.append, q)
    return "".join(o).encode("utf-8")


def plan_source(run):
    """The QIF plan ``run`` (engine.pipeline.Run) was judged by, read again for results that
    reference its ids (engine.io.qif_plan.qif_source: an InputError when the file changed
    since), or None when its plan is no QIF file (or it has none)."""
    from engine.io import formats

    if run.plan is None or formats.kind_of(run.plan.path) != formats.QIF:
        return None
    from engine.io.qif_plan import qif_source

    return qif_source(run.plan.path, run.plan.sha256)


def _checked_points(registered, deviations, in_tolerance, labels, outlier):
    """The per-point arguments as arrays (pts (n, 3), dev (n,), inside (n,), labels,
    outlier (n,) or None); QIFError when their lengths differ."""
    pts = np.asarray(registered, dtype=float)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise QIFError(f"registered must be (n, 3), got shape {pts.shape}")
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    dev = np.asarray(deviations, dtype=float).reshape(-1)
    inside = np.asarray(in_tolerance, dtype=bool).reshape(-1)
    n = pts.shape[0]
    for name, arr in (("deviations", dev), ("in_tolerance", inside)):
        if arr.size != n:
            raise QIFError(f"{name} has {arr.size} entries for {n} points")
    if labels is not None and len(labels) != n:
        raise QIFError(f"labels has {len(labels)} entries for {n} points")
    if outlier is not None:
        outlier = np.asarray(outlier, dtype=bool).reshape(-1)
        if outlier.size != n:
            raise QIFError(f"outlier has {outlier.size} entries for {n} points")
    return pts, dev, inside, labels, outlier
