"""``qa-inspect inspect --section z=120 [--section-band MM]``: the planar sections of a run
(engine.section) for the JSON's ``sections`` and the certificate's section pages.

The options are checked before any file is read (:func:`section_spec`, the argparse type of
``--section``; :func:`check_section_options`); a section that cannot be made for the part (it
misses the part, the nominal has no surface) is found after the inspection and before any
output is written (:func:`run_sections`). Both raise SettingsError, which the command line
turns into a usage error (exit 64).
"""

from __future__ import annotations

import argparse
import math

SECTION_HELP = ("a planar section AXIS=MM (x, y or z, nominal frame; e.g. z=120): the nominal's "
                "section curve and the measured points near the plane with their deviations, "
                "as a page of the certificate (Section A-A, ...) and in the JSON's sections "
                "(repeatable)")
BAND_HELP = ("with --section: take the measured points within MM of the plane (default: 0.75 "
             "x their typical spacing, a band 1.5 spacings wide)")


def section_spec(text: str) -> tuple[str, float]:
    """``--section``'s value "z=120" -> ("z", 120.0); argparse.ArgumentTypeError otherwise."""
    axis, eq, value = text.partition("=")
    axis = axis.strip().lower()
    if not eq or axis not in ("x", "y", "z"):
        raise argparse.ArgumentTypeError(f"'{text}' is not a section: give AXIS=MM with AXIS x, "
                                         "y or z, e.g. z=120")
    try:
        offset = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}': '{value.strip()}' is not a number of mm "
                                         "(e.g. z=120)") from None
    if not math.isfinite(offset):
        raise argparse.ArgumentTypeError(f"'{text}': the offset must be a finite number of mm")
    return axis, offset


def check_section_options(sections, band, nominal_path: str) -> None:
    """The section options before any file is read: --section-band needs --section and is a
    positive number of mm; a 2D template (the nominal) has no sections."""
    from engine.errors import SettingsError
    from engine.io import is_template

    if band is not None and not sections:
        raise SettingsError("--section-band applies with --section")
    if band is not None and not band > 0:
        raise SettingsError(f"--section-band must be a positive number of mm, got {band:g}")
    if sections and is_template(nominal_path):
        raise SettingsError("--section cuts a 3D nominal; the nominal is a 2D template (its "
                            "deviation map is already the contour's)")


def run_sections(run, sections, band) -> list:
    """The sections (engine.section.Section) of ``run`` by the planes ``sections`` ((axis,
    offset) pairs), named A-A, B-B, ... in order; [] without any. Raises SettingsError naming
    the section that misses the part."""
    if not sections:
        return []
    from engine.section import axis_plane, section_name, section_of

    return [section_of(run.result, axis_plane(axis, offset), section_name(k), band,
                       nominal=run.nominal, step=run.step, seed=run.settings.seed)
            for k, (axis, offset) in enumerate(sections)]


def results_document(run, sections) -> dict:
    """The results document of ``run`` (reports.results.run_document) with its sections, when
    there are any (without, the document is the run's alone)."""
    from reports.results import run_document

    doc = run_document(run)
    if sections:
        doc["sections"] = [s.document() for s in sections]
    return doc


def summary_lines(sections) -> list[str]:
    """One line per section for the command line's summary."""
    out = []
    for s in sections:
        d, t = s.signed, s.tolerance
        spread = (f"deviations {float(d.min()):+.4f} … {float(d.max()):+.4f} mm, "
                  f"{int(((d < t.lower) | (d > t.upper)).sum())} outside the zone "
                  f"{t.lower:+.4g} … {t.upper:+.4g} mm"
                  if d.size else "no deviation to show")
        out.append(f"  section {s.name}, {s.plane.name}: curve {s.curve.length:.1f} mm; "
                   f"{d.size} points within ±{s.band:.3g} mm of the plane, {spread}")
    return out
