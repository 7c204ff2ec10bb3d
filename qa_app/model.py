"""The inspection session as plain Python: inputs, settings, results, the current step, and the
events views subscribe to. No Qt here (checked by an import-linter contract): the model never
knows its widgets.
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import replace

from reports.settings import InspectionSettings


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


class Session:
    """One inspection session.

    Events (arguments): ``inputs_changed()``, ``settings_changed()``, ``step_changed(step)``,
    ``progress(stage, fraction)``, ``result_changed(run or None)``, ``message(level, text)``
    with level "info", "warning" or "error", ``selection_changed(index or None)``.
    """

    def __init__(self):
        self.nominal_path: str | None = None
        self.measured_path: str | None = None
        self.settings = InspectionSettings(-0.1, 0.1)
        self.run = None  # reports.pipeline.Run of the last inspection, or None
        self.running = False
        self.selected: int | None = None
        self.inputs_changed = Event()
        self.settings_changed = Event()
        self.step_changed = Event()
        self.progress = Event()
        self.result_changed = Event()
        self.message = Event()
        self.selection_changed = Event()

    # ------------------------------------------------------------------ state
    @property
    def step(self) -> Step:
        if self.running:
            return Step.RUNNING
        if self.nominal_path is None:
            return Step.NEED_NOMINAL
        if self.measured_path is None:
            return Step.NEED_MEASURED
        return Step.INSPECTED if self.run is not None else Step.READY

    @property
    def can_inspect(self) -> bool:
        return self.step in (Step.READY, Step.INSPECTED)

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

    def _inputs_changed(self) -> None:
        self.set_run(None)
        self.inputs_changed.emit()
        self.step_changed.emit(self.step)

    def set_settings(self, **changes) -> None:
        new = replace(self.settings, **changes)
        if new != self.settings:
            self.settings = new
            self.set_run(None)  # a result belongs to the settings it was made with
            self.settings_changed.emit()
            self.step_changed.emit(self.step)

    def set_running(self, running: bool) -> None:
        self.running = running
        self.step_changed.emit(self.step)

    def set_run(self, run) -> None:
        if run is None and self.run is None:
            return
        self.run = run
        self.selected = None
        self.result_changed.emit(run)
        self.step_changed.emit(self.step)

    def select(self, index: int | None) -> None:
        if index != self.selected:
            self.selected = index
            self.selection_changed.emit(index)

    def tell(self, level: str, text: str) -> None:
        self.message.emit(level, text)
