"""What a lot's run reports: the quantities tracked per part (max |d|, mean d, the points out,
each plan characteristic's value) and their SPC series, ``summary.json`` and ``summary.csv``,
the part number that titles them, and the summary printed at the end."""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass

import numpy as np

from engine.pipeline import LoadedNominal
from engine.spc import Kind, mean_deviation_kind

from .lot import ERROR, VERDICTS, Batch, Part, exit_code


@dataclass(frozen=True)
class Tracked:
    """A characteristic tracked over the parts of a batch (for SPC): its value's limits.

    lower, upper : the limits the value must respect (None: no limit on that side), in
        ``unit``; definition : what the value is, in words; kind : what SPC may judge of it
        (engine.spc.Kind: a value, a value >= 0 with an upper limit, a count, or information
        only when the fit forces it to ~0).
    """

    id: str
    name: str
    unit: str
    lower: float | None
    upper: float | None
    definition: str
    kind: Kind = Kind.MEASURED


def tracked_characteristics(loaded: LoadedNominal) -> list[Tracked]:
    """The characteristics whose values a batch summarises: the plan's (with ``tol``, the
    profile over all points, first when the zone is part of the verdict), or without a plan
    max |d|, mean d (information only after a least-squares fit, which sets it to ~0) and the
    count of points out of tolerance."""
    settings = loaded.settings
    lo, hi = settings.tol_lower, settings.tol_upper
    if loaded.plan is None:
        mean = mean_deviation_kind(settings.fit)
        judged = mean is not Kind.FORCED
        return [Tracked("max_abs", "max |d|", "mm", None, max(abs(lo), abs(hi)),
                        "largest |signed deviation| over the part's points; upper: the "
                        "largest |limit| of the zone (beyond it a point is outside)",
                        Kind.BOUNDED),
                Tracked("mean", "mean d", "mm", lo if judged else None, hi if judged else None,
                        "mean signed deviation over the part's points; " + (
                            "limits: the zone's" if judged else "no limits: the least-squares "
                            "fit sets it to ~0 (information only)"), mean),
                Tracked("n_out", "points out of tolerance", "points", None, 0.0,
                        "points outside the zone (the part document's deviations.n_out); "
                        "upper: 0", Kind.COUNT)]
    from engine.gdt.plan import DIMENSIONS, RESERVED_ID, Characteristic

    chars = list(loaded.plan.characteristics)
    if settings.zone_in_verdict:
        chars.insert(0, Characteristic(RESERVED_ID, "profile", "(all points)", lo, hi))
    out = []
    for c in chars:
        name = f"{c.type} {c.region}" + (f" |{'|'.join(c.datums)}" if c.datums else "")
        if c.type == "size":
            out.append(Tracked(c.id, name, "mm", c.nominal + c.lower, c.nominal + c.upper,
                               "least-squares diameter; limits: nominal + the zone's"))
        elif c.type in DIMENSIONS:  # a radius, angle (degrees) or distance about its nominal
            nominal = c.nominal or 0.0
            out.append(Tracked(c.id, name, c.unit, nominal + c.lower, nominal + c.upper,
                               f"{c.type} ({c.unit}, see the part's "
                               "dimension_value_definition); limits: nominal + the zone's"))
        else:  # a width or a diameter about the true position: >= 0, an upper limit only
            out.append(Tracked(c.id, name, "mm", None, c.width,
                               f"{c.type} value (the width of the smallest zone holding the "
                               "region, see the part's characteristic_value_definition); "
                               "upper: the zone", Kind.BOUNDED))
    return out


def _values(doc: dict, tracked: list[Tracked]) -> dict[str, float | None]:
    """Each tracked characteristic's value in a part's JSON document (None where it has none)."""
    dev = doc["deviations"]
    by_id = {c["id"]: c.get("value") for c in doc.get("characteristics", [])}
    plain = {"max_abs": dev["max_abs"], "mean": dev["mean"], "n_out": dev["n_out"]}
    return {t.id: (by_id.get(t.id) if "characteristics" in doc else plain.get(t.id))
            for t in tracked}


def summary_row(part: Part, sha256: str | None, doc: dict | None, tracked: list[Tracked],
                error: str | None = None, seconds: float = 0.0, skipped: bool = False) -> dict:
    """One part's row of the summary, from its JSON document (or its error message)."""
    if doc is None:
        return {"serial": part.serial, "file": part.path, "sha256": sha256, "verdict": ERROR,
                "max_abs": None, "n_out": None, "values": {t.id: None for t in tracked},
                "time_s": round(seconds, 6), "skipped": False, "message": error}
    return {"serial": part.serial, "file": part.path, "sha256": sha256,
            "verdict": doc["verdict"], "max_abs": doc["deviations"]["max_abs"],
            "n_out": doc["deviations"]["n_out"], "values": _values(doc, tracked),
            "time_s": doc["timings_s"]["total"], "skipped": skipped,
            "message": (doc["reasons"] or [""])[0]}


def verdict_counts(rows: list[dict]) -> dict[str, int]:
    """How many rows have each verdict, in VERDICTS order (ERROR included)."""
    return {v: sum(r["verdict"] == v for r in rows) for v in VERDICTS}


def summary_document(batch: Batch, loaded: LoadedNominal, rows: list[dict],
                     tracked: list[Tracked], analyses: list) -> dict:
    """summary.json: the inputs and settings, the tracked characteristics with their limits,
    one row per part in measurement order, the counts per verdict, the exit code and the SPC
    ``analyses`` (engine.spc.Analysis, one per tracked characteristic)."""
    from engine.spc import to_json
    from reports.results import SOFTWARE_NAME, software_version

    return {
        "nominal": {"path": loaded.path, "sha256": loaded.source.record.sha256},
        "plan": None if loaded.plan is None else {"path": loaded.plan.path,
                                                 "sha256": loaded.plan.sha256},
        "settings": loaded.settings.to_json(),
        "characteristics": [asdict(t) for t in tracked],
        "order": "measurement order: the MEASURED arguments as given, each glob's matches "
                 "sorted by name",
        "parts": rows,
        "counts": verdict_counts(rows),
        "skipped": sum(r["skipped"] for r in rows),
        "exit_code": exit_code([r["verdict"] for r in rows]),
        "row_definition": "max_abs: largest |deviation| (mm); n_out: points outside the zone; "
                          "values: each characteristic's value by id (null: none, or ERROR); "
                          "time_s: the inspection's time (the part document's timings_s.total, "
                          "or until the error); skipped: the result of an earlier run for the "
                          "same inputs and settings; message: the first reason, or the error",
        "spc": [{"id": t.id, **to_json(a)} for t, a in zip(tracked, analyses)],
        "software": {"name": SOFTWARE_NAME, "version": software_version()},
    }


def lot_series(tracked: list[Tracked], rows: list[dict]) -> list:
    """Each tracked characteristic over the lot (engine.spc.Series): its values in measurement
    order (NaN for a part without one: an ERROR), the parts' serials, its limits and kind."""
    from engine.spc import Series

    serials = [r["serial"] for r in rows]
    out = []
    for t in tracked:
        values = [np.nan if r["values"].get(t.id) is None else r["values"][t.id] for r in rows]
        out.append(Series(t.name, t.unit, np.array(values, float), serials, t.lower, t.upper,
                          t.kind))
    return out


def summary_csv(tracked: list[Tracked], rows: list[dict]) -> str:
    """summary.csv: one row per part; a ``value_<id>`` column per tracked characteristic."""
    import csv
    import io

    from reports.messages import spreadsheet_text

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["serial", "file", "sha256", "verdict", "max_abs_mm", "n_out"]
               + [f"value_{t.id}" for t in tracked] + ["time_s", "skipped", "message"])
    for r in rows:
        w.writerow([spreadsheet_text(r["serial"]), spreadsheet_text(r["file"]),
                    r["sha256"] or "", r["verdict"],
                    _cell(r["max_abs"]), "" if r["n_out"] is None else r["n_out"]]
                   + [_cell(r["values"][t.id]) for t in tracked]
                   + [f"{r['time_s']:.3f}", "true" if r["skipped"] else "false",
                      spreadsheet_text(r["message"] or "")])
    return buf.getvalue()


def _cell(v) -> str:
    return "" if v is None else repr(float(v))


def write_summary(batch: Batch, loaded: LoadedNominal, rows: list[dict]) -> list[str]:
    """Write summary.csv, summary.json and spc.pdf (the lot's SPC: reports.spc), all or none;
    return their paths."""
    from engine.spc import analyse
    from reports.outputs import Output, write_all
    from reports.results import result_json
    from reports.spc import spc_pdf

    files = batch.summary_files()
    tracked = tracked_characteristics(loaded)
    analyses = [analyse(series) for series in lot_series(tracked, rows)]  # once, for both
    counts = verdict_counts(rows)
    number = part_number(batch, loaded)
    title = (f"{number or os.path.splitext(os.path.basename(loaded.path))[0]}: {len(rows)} parts"
             + (f", plan {os.path.basename(loaded.plan.path)}" if loaded.plan else ""))
    facts = {"part number": number or "none given (--part-number, or the plan's [part]): the "
                                      "title names the nominal's file",
             "parts": len(rows), **counts, "nominal": loaded.path}
    doc = summary_document(batch, loaded, rows, tracked, analyses)
    write_all([Output(files["csv"], summary_csv(tracked, rows)),
               Output(files["json"], result_json(doc)),
               Output(files["spc"], spc_pdf(analyses, title, facts))])
    return [files["csv"], files["json"], files["spc"]]


def part_number(batch: Batch, loaded: LoadedNominal) -> str:
    """The lot's part number: --part-number, else the plan's [part] number, else "" (the
    SPC's title then names the nominal's file, without its extension)."""
    given = (batch.part_number or "").strip()
    return given or (loaded.plan.part.number.strip() if loaded.plan is not None else "")


# ---------------------------------------------------------------------------- progress


def summary_text(rows: list[dict], seconds: float, written: list[str]) -> str:
    """What the command prints at the end: the counts, each ERROR part, the files."""
    from reports.messages import printable

    counts = ", ".join(f"{n} {v}" for v, n in verdict_counts(rows).items())
    skipped = sum(r["skipped"] for r in rows)
    lines = [f"{len(rows)} parts: {counts}"
             + (f"; {skipped} skipped (done by an earlier run)" if skipped else "")
             + f"; {seconds:.1f} s"]
    lines += [f"  ERROR {r['serial']} ({r['file']}): {r['message']}"
              for r in rows if r["verdict"] == ERROR]
    parts = os.path.join(os.path.dirname(os.path.abspath(written[0])), "parts")
    lines.append("results: " + ", ".join(os.path.abspath(w) for w in written) + f", {parts}/")
    # Each line escaped before they are joined: a serial is a file's name, whatever it holds.
    return "\n".join(printable(line) for line in lines)
