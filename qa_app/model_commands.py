"""``qa-inspect faces`` and ``qa-inspect plan``: what a model and a plan hold, before any
measurement. ``faces PART.stp``: every face of the STEP nominal with the id a plan's region
names (``group = "face:N"``); ``plan SOURCE``: a TOML or QIF 3.0 plan as a table, and with
``--toml`` as a TOML plan to review and edit (reports.faces, reports.plan_table,
reports.plan_toml). Bad input raises engine.errors.InputError (exit 65, naming the file and
the item), a usage error qa_app.usage.UsageError (64); qa_app.cli runs them guarded."""

from __future__ import annotations

import os
import sys

from engine.errors import InputError


def _usage(message: str, command: str):
    from qa_app.usage import UsageError

    return UsageError(f"qa-inspect {command}: {message}", command)


def _check_outputs(command: str, outputs: dict, inputs: dict) -> None:
    from reports.outputs import OutputConflictError, check_outputs

    try:
        check_outputs(outputs, inputs)
    except OutputConflictError as e:
        raise _usage(str(e), command) from e


def _write(command: str, path: str, text: str) -> None:
    from reports.outputs import Output, OutputConflictError, write_all

    try:
        write_all([Output(path, text)])  # a temporary file beside it, then renamed onto it
    except OutputConflictError as e:  # the target changed into a folder, a key … meanwhile
        raise _usage(str(e), command) from e


def _read_step(path: str, role: str):
    from engine.io import formats
    from engine.io.step import read_step

    formats.check_file(path)
    if formats.kind_of(path) != formats.STEP:
        raise InputError(f"{role} must be a STEP model ({', '.join(formats.STEP_SUFFIXES)}), "
                         f"not '{formats.suffix_of(path) or '(no suffix)'}'", path)
    return read_step(path)


def cmd_faces(args) -> int:
    """Print every face of a STEP model (and write them as CSV with ``--csv``)."""
    from reports.faces import faces_csv, faces_table
    from reports.messages import printable

    csv_path = None if args.csv == "-" else args.csv
    _check_outputs("faces", {"--csv": csv_path}, {"PART": args.part})
    step = _read_step(args.part, "the model whose faces are listed")
    areas = [step.face_area(f.id) for f in step.faces]
    if args.csv == "-":
        sys.stdout.write(faces_csv(step, areas))
        return 0
    if csv_path is not None:
        _write("faces", csv_path, faces_csv(step, areas))
    sys.stdout.write(faces_table(step, areas))
    if csv_path is not None:
        print(printable(f"faces written to {csv_path} ({step.n_faces} rows)"))
    return 0


class PlanSource:
    """A plan as ``qa-inspect plan`` shows it: the Plan, its regions' STEP faces where known,
    the source's names and order of its characteristics, the heading lines and notes on the
    regions (a QIF's features)."""

    def __init__(self, source: str, nominal: str | None):
        from engine.io import formats

        self.faces: dict[str, tuple[int, ...]] = {}
        self.names: dict[str, str] = {}
        self.order: list[str] | None = None
        self.region_notes: dict[str, str] = {}
        self.qif = formats.kind_of(source) == formats.QIF
        if self.qif:
            self._read_qif(source, nominal)
        else:
            from engine.io.plan import read_plan
            from reports.plan_table import region_faces

            self.plan = read_plan(source)
            self.faces = region_faces(self.plan)
            self.heading = [f"{source}: inspection plan (TOML); values in mm"]

    def _read_qif(self, source: str, nominal: str | None) -> None:
        from engine.io.qif_plan import check_qif_nominal, qif_document, qif_face_groups
        from reports.plan_table import region_faces

        doc = qif_document(source)
        self.plan = doc.plan
        self.names = {cid: name for cid, (_, name) in doc.names.items()}
        self.order = list(doc.names)
        scale = "" if doc.scale == 1.0 else f", geometry scale {doc.scale:g}"
        self.heading = [f"{source}: QIF 3.0, unit {doc.unit or '?'} ({doc.mm_per_unit:g} mm)"
                        f"{scale}; values in mm"]
        if nominal is not None:
            check_qif_nominal(source, nominal)
            step = _read_step(nominal, "--nominal")
            self.faces = region_faces(self.plan, qif_face_groups(source, step))
            self.heading.append(f"features matched by geometry to the faces of {nominal} "
                                "(qa-inspect faces lists them)")
        else:
            self.heading.append("features not matched to faces: give --nominal PART.stp")
        for r in self.plan.regions:
            parts = [p.partition("/") for p in str(r.group)[4:].split("+")]
            self.region_notes[r.name] = "QIF " + ", ".join(
                f"feature {i} ({doc.features[i].kind}"
                + (f" {doc.features[i].name}" if doc.features[i].name else "")
                + (f", its face {face}" if face else "") + ")"
                for i, _, face in parts if i in doc.features)

    def toml(self, source: str, nominal: str | None) -> str:
        from reports.plan_toml import plan_toml
        from reports.results import software_version

        header = [f"Inspection plan written by qa-inspect {software_version()} from "
                  f"{os.path.basename(source)} (sha256 {self.plan.sha256})"]
        if self.qif:
            header.append("Each region is a QIF feature's faces of "
                          f"{os.path.basename(nominal or '')} (matched by geometry): "
                          "qa-inspect faces lists them")
        header.append("Units mm, the nominal's frame. Review it before use: it is read as "
                      "any hand-written plan is.")
        # A QIF region becomes its faces; a TOML region keeps its own selector as written.
        return plan_toml(self.plan, self.faces if self.qif else {}, header, self.names,
                         self.region_notes)


def cmd_plan(args) -> int:
    """Print a plan as a table (and write it as a TOML plan with ``--toml``)."""
    from engine.io import formats
    from reports.messages import printable
    from reports.plan_table import plan_table

    qif = formats.kind_of(args.source) == formats.QIF
    if args.toml is not None:
        if formats.kind_of(args.toml) != formats.PLAN:
            raise _usage(f"--toml writes a TOML plan: give it a name ending in .toml, not "
                         f"'{formats.suffix_of(args.toml) or '(no suffix)'}'", "plan")
        if qif and args.nominal is None:
            raise _usage("--toml with a QIF plan needs --nominal PART.stp: its features are "
                         "written as the STEP model's faces", "plan")
    _check_outputs("plan", {"--toml": args.toml}, {"SOURCE": args.source,
                                                  "--nominal": args.nominal})
    if args.nominal is not None and not qif:
        print("qa-inspect: note: --nominal is used with a QIF plan only (a TOML plan names "
              "its faces itself)", file=sys.stderr)
    view = PlanSource(args.source, args.nominal if qif else None)
    if args.toml is not None:
        _write("plan", args.toml, view.toml(args.source, args.nominal))
    sys.stdout.write(plan_table(view.plan, view.faces, [printable(h) for h in view.heading],
                                view.names, view.order))
    if args.toml is not None:
        print(printable(f"TOML plan written to {args.toml} ({len(view.plan.characteristics)} "
                        f"characteristics, {len(view.plan.not_judged)} not judged: "
                        "[[not_judged]] tables)"))
    return 0
