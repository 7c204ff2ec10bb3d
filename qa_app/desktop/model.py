"""The inspection session as plain Python: inputs, settings, results, the current step, and the
events views subscribe to. No Qt here (checked by an import-linter contract): the model never
knows its widgets.
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass, replace

from engine.choices import DecisionRule
from engine.settings import InspectionSettings


class Event:
    """A list of callbacks; ``emit`` calls each with the event's arguments."""

    def __init__(self):
        self._callbacks: list[Callable] = []

    def connect(self, callback: Callable) -> None:
        self._callbacks.append(callback)

    def disconnect(self, callback: Callable) -> None:
        self._callbacks.remove(callback)

    def emit(self, *args) -> None:
        for cb in list(self._callbacks):
            cb(*args)


class Step(enum.Enum):
    """Where the inspector is in the workflow (what makes sense to do next)."""

    NEED_NOMINAL = "Open the nominal (CAD points, mesh or DXF template)"
    NEED_MEASURED = "Open the measured points"
    READY = "Set the tolerance and inspect"
    RUNNING = "Inspecting…"
    INSPECTED = "Review the result; export the certificate"
    STALE = "Out of date: settings or files changed since this inspection; press Inspect"


AUTO_RULE = "auto"
"""The session's decision rule when the user leaves it to the inspection, as the command line
without --decision-rule: guarded when an instrument is stated (the plan's [measurement]), else
simple (engine.pipeline.inspection_settings, given None)."""


def engine_rule(rule: str) -> str | None:
    """The decision rule to give engine.pipeline.inspection_settings (None: automatic)."""
    return None if rule == AUTO_RULE else rule


def resolved_rule(rule: str, run) -> str:
    """The rule ``rule`` comes to for the inputs of ``run``: automatic is guarded when the
    run's uncertainty budget holds an instrument's term, else simple."""
    if rule != AUTO_RULE:
        return rule
    unc = getattr(run.result, "uncertainty", None)
    stated = unc is not None and any(t.key not in ("pose", "sampling") for t in unc.terms)
    return DecisionRule.GUARDED if stated else DecisionRule.SIMPLE


class Session:
    """One inspection session.

    Events (arguments): ``inputs_changed()``, ``settings_changed()``, ``step_changed(step)``,
    ``progress(stage, fraction)``, ``result_changed(run or None)``, ``message(level, text)``
    with level "info", "warning" or "error", ``selection_changed(index or None)``,
    ``characteristic_changed(row or None)`` (a row of :func:`characteristic_rows`; its points
    are ``highlighted``).

    The inputs are the nominal, the measured points and, optionally, an inspection plan
    (``plan_path``). With a plan, ``settings.zone_in_verdict`` says whether the zone is the
    user's (one more characteristic over all points) or the plan's (statistics only): the
    controller makes the run's settings as the command line does (``--tol`` given or not).

    A result is kept when the files or settings change, but it is then *stale* (step
    ``Step.STALE``, ``stale_reasons`` says why): what an inspection would now see is not what it
    saw, so it may be looked at but not exported. Staleness is a comparison, not a flag: setting
    everything back to what the result was computed with makes it current again. A file changed on
    disk is known only when the controller compares its SHA-256 (``set_changed_inputs``).
    """

    def __init__(self):
        self.nominal_path: str | None = None
        self.measured_path: str | None = None
        self.plan_path: str | None = None
        self.settings = InspectionSettings(-0.1, 0.1, decision_rule=AUTO_RULE)
        self.run = None  # engine.pipeline.Run of the last inspection, or None
        self.display = None
        """What the views prepared for showing ``run`` in the worker (the controller's
        ``prepare``), or None."""
        self.running = False
        self.selected: int | None = None
        self.characteristic: int | None = None
        """The row of :func:`characteristic_rows` selected, or None."""
        self.changed_inputs: tuple[str, ...] = ()
        """Why the run's input files differ from the files on disk now (the controller's SHA-256
        comparison); emptied with each new run."""
        self.inputs_changed = Event()
        self.settings_changed = Event()
        self.step_changed = Event()
        self.progress = Event()
        self.result_changed = Event()
        self.message = Event()
        self.selection_changed = Event()
        self.characteristic_changed = Event()

    # ------------------------------------------------------------------ state
    @property
    def step(self) -> Step:
        if self.running:
            return Step.RUNNING
        if self.nominal_path is None:
            return Step.NEED_NOMINAL
        if self.measured_path is None:
            return Step.NEED_MEASURED
        if self.run is None:
            return Step.READY
        return Step.STALE if self.stale_reasons else Step.INSPECTED

    @property
    def stale_reasons(self) -> list[str]:
        """What differs between the result on screen and an inspection now, one phrase each
        (empty without a result or when the result is current)."""
        run = self.run
        if run is None:
            return []
        out = []
        ran = {rec.role: rec.path for rec in run.inputs}
        for role, path in (("nominal", self.nominal_path), ("measured", self.measured_path),
                           ("plan", self.plan_path)):
            if path != ran.get(role):
                out.append(f"another {role} file is open" if path else f"no {role} file is open")
        was, now = run.settings, self.settings
        out += self._zone_changes(was, now)
        if was.fit != now.fit:
            out.append(f"fit changed from {was.fit} to {now.fit}")
        if was.decision_rule != resolved_rule(now.decision_rule, run):
            out.append(f"decision rule changed from {was.decision_rule} to "
                       f"{now.decision_rule}")
        if was.scale != now.scale:
            out.append("airfoil chord changed")
        if (was.layers, was.units) != (now.layers, now.units):
            out.append("template layers or units changed")
        if was.crop != now.crop:
            out.append("crop box changed")
        if (was.remove_plane, was.plane_distance) != (now.remove_plane, now.plane_distance):
            out.append("plane removal changed")
        return out + list(self.changed_inputs)

    def _zone_changes(self, was, now) -> list[str]:
        """How the zone differs from the run's: the plan's zone (statistics only) is the plan's
        to change, and changing it is changing the plan."""
        plans_zone = self.plan_path is not None and not now.zone_in_verdict
        if plans_zone != (not was.zone_in_verdict):
            mine = f"{now.tol_lower:+.4g} … {now.tol_upper:+.4g} mm"
            return [f"zone changed from the plan's to {mine}" if not plans_zone else
                    f"zone changed from {was.tol_lower:+.4g} … {was.tol_upper:+.4g} mm to the "
                    "plan's"]
        if not plans_zone and (was.tol_lower, was.tol_upper) != (now.tol_lower, now.tol_upper):
            return [f"zone changed from {was.tol_lower:+.4g} … {was.tol_upper:+.4g} mm to "
                    f"{now.tol_lower:+.4g} … {now.tol_upper:+.4g} mm"]
        return []

    @property
    def plans_zone(self) -> bool:
        """True when a plan is open and the zone is left to it (no zone of the user's)."""
        return self.plan_path is not None and not self.settings.zone_in_verdict

    @property
    def stale(self) -> bool:
        return bool(self.stale_reasons)

    @property
    def can_inspect(self) -> bool:
        return self.step in (Step.READY, Step.INSPECTED, Step.STALE)

    @property
    def can_export(self) -> bool:
        return self.step == Step.INSPECTED

    # ------------------------------------------------------------------ changes
    def set_nominal(self, path: str | None) -> None:
        self.nominal_path = path
        self._inputs_changed()

    def set_measured(self, path: str | None) -> None:
        self.measured_path = path
        self._inputs_changed()

    def set_plan(self, path: str | None) -> None:
        self.plan_path = path
        self._inputs_changed()

    def set_inputs(self, nominal: str | None, measured: str | None, plan: str | None) -> None:
        """All three inputs at once (a session reopened): the views see them together."""
        self.nominal_path, self.measured_path, self.plan_path = nominal, measured, plan
        self._inputs_changed()

    def _inputs_changed(self) -> None:
        # The result stays on screen, marked stale when the files differ from its own.
        self.inputs_changed.emit()
        self.step_changed.emit(self.step)

    def set_settings(self, **changes) -> None:
        new = replace(self.settings, **changes)
        if new != self.settings:
            self.settings = new
            # The result stays on screen, marked stale when the settings differ from its own.
            self.settings_changed.emit()
            self.step_changed.emit(self.step)

    def set_changed_inputs(self, reasons) -> None:
        """reasons : phrases naming each input file that differs on disk from the run's."""
        reasons = tuple(reasons)
        if reasons != self.changed_inputs:
            self.changed_inputs = reasons
            self.step_changed.emit(self.step)

    def set_running(self, running: bool) -> None:
        self.running = running
        self.step_changed.emit(self.step)

    def set_run(self, run, display=None) -> None:
        if run is None and self.run is None:
            return
        self.run = run
        self.display = display
        self.selected = None
        self.characteristic = None
        self.changed_inputs = ()
        self.result_changed.emit(run)
        self.step_changed.emit(self.step)

    def select(self, index: int | None) -> None:
        if index != self.selected:
            self.selected = index
            self.selection_changed.emit(index)

    def select_characteristic(self, row: int | None) -> None:
        """Select a row of the characteristics table; its points become ``highlighted``."""
        if row != self.characteristic:
            self.characteristic = row
            self.characteristic_changed.emit(row)

    @property
    def highlighted(self):
        """(k,) int: the measured points of the selected characteristic, or None."""
        if self.characteristic is None or self.run is None:
            return None
        return self.run.result.plan.characteristics[self.characteristic].indices

    def tell(self, level: str, text: str) -> None:
        """Say ``text`` to the user. It may quote a file name, a session's field or a label:
        control characters (a line break, an escape sequence) are written out, so that no input
        can start a line of its own (reports.messages.printable, as on the command line)."""
        from reports.messages import printable

        self.message.emit(level, printable(text))


@dataclass(frozen=True)
class CharacteristicRow:
    """One row of the characteristics table, as the inspector reads it on a first-article report.

    indices : (k,) int, the measured points the characteristic used; verdict : ACCEPT, REJECT or
    INCONCLUSIVE; reason : why, in words.
    """

    id: str
    type: str
    """A characteristic type (engine.gdt.plan.CHARACTERISTICS)."""
    symbol: str
    """The drawing's symbol (reports.messages.SYMBOL: "⌓" for a surface profile)."""
    region: str
    datums: str
    """"A|B|C", or "—" for form only."""
    requirement: str
    """The zone as the drawing states it (reports.messages.limits_text)."""
    value: str
    """The measured value in the drawing's convention, mm (an angle's in degrees), or "—"
    when it could not be measured."""
    points: int
    verdict: str
    reason: str
    indices: object
    feature: str | None = None
    """A size's or location's feature (engine.gdt.plan.SIZE_FEATURES; None: a cylinder)."""


def characteristic_rows(run) -> list[CharacteristicRow]:
    """The characteristics of ``run``'s plan, in the plan's order (the zone over all points first
    when it is one of them); empty for a run without a plan."""
    from reports.messages import SYMBOL, limits_text

    planned = None if run is None else getattr(run.result, "plan", None)
    if planned is None:
        return []
    rows = []
    for r in planned.characteristics:
        c = r.characteristic
        rows.append(CharacteristicRow(
            c.id, c.type, SYMBOL.get(c.type, ""), c.region,
            "|".join(c.datums) if c.datums else "—", limits_text(c),
            "—" if r.value is None else
            f"{r.value:.4f}" + ("°" if c.unit == "degree" else " mm"), int(r.indices.size),
            r.verdict,
            r.reason, r.indices, c.kind))
    return rows
