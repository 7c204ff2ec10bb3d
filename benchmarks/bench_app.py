"""The desktop app's responsiveness and display speed; prints a table. Needs an X display:

    xvfb-run -a -s "-screen 0 1600x1200x24" env QT_QPA_PLATFORM=xcb \\
        .venv/bin/python benchmarks/bench_app.py

For each case the window (engine in its worker thread, as the app runs it) opens the nominal and
the measured file and inspects; a 5 ms timer in the GUI thread records the longest gap between
its ticks, i.e. the longest time the event loop was blocked, during the run (loading,
registration, deviations, view preparation in the worker) and while the result is put on screen.
"open → shown" is from the Inspect action to the first frame of the 3D view with the coloured
points (files read in the worker). Cases: the belly-fairing sample (60k grid / 1,100 points) and
a 1M-point grid nominal (I J K normals) with 200,000 measured points, both as CSV files
(generated into a temporary folder, not timed).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def make_big(folder: str) -> tuple[str, str]:
    import samples.generate as gen
    from engine.pose import apply_transform, make_transform

    nu, nv = 1414, 707
    X, Y = np.meshgrid(np.linspace(-250, 250, nu), np.linspace(-125, 125, nv))
    x, y = X.ravel(), Y.ravel()
    nom = np.column_stack([x, y, gen.fairing_height(x, y), gen.fairing_normal(x, y)])
    rng = np.random.default_rng(7)
    mx, my = rng.uniform(-240, 240, 200_000), rng.uniform(-120, 120, 200_000)
    q = np.column_stack([mx, my, gen.fairing_height(mx, my)])
    q = q + rng.normal(0, 0.003, len(q))[:, None] * gen.fairing_normal(mx, my)
    T = make_transform(gen.rotation([0.4, -0.7, 0.2], 137.0), np.array([1520.0, -830.0, 410.0]))
    nominal = os.path.join(folder, "nominal_1M.csv")
    measured = os.path.join(folder, "measured_200k.csv")
    np.savetxt(nominal, nom, fmt="%.6f", delimiter=",", header=f"grid: {nu} x {nv}\nx,y,z,i,j,k",
               comments="# ")
    np.savetxt(measured, apply_transform(T, q), fmt="%.6f", delimiter=",", header="x,y,z",
               comments="")
    return nominal, measured


SHOW = {}
STATE = {"last": 0.0, "phase": None}


def _timed_show_run():
    """Time the viewport's drawing of a result (it runs in the GUI thread)."""
    from qa_app.desktop.viewport import Viewport3D

    original = Viewport3D.show_run

    def show_run(self, run):
        t = time.perf_counter()
        original(self, run)
        if run is not None:
            SHOW["s"] = time.perf_counter() - t
            # The drawing is reported on its own; the event-loop gap it made is not counted as
            # a block during the run.
            STATE["last"] = time.perf_counter()

    Viewport3D.show_run = show_run


def run_case(app, name, nominal, measured, tol):
    from PySide6.QtCore import QEventLoop, QSettings, QTimer

    from qa_app.desktop.model import Step
    from qa_app.desktop.window import MainWindow

    folder = tempfile.mkdtemp()
    w = MainWindow(settings=QSettings(os.path.join(folder, "s.ini"), QSettings.IniFormat))
    w.show()
    w.warm_up.join()  # the app loads the engine while the inspector picks the files
    for _ in range(20):
        app.processEvents()
    gaps = {"run": 0.0, "show": 0.0}
    state = STATE
    state.update(last=time.perf_counter(), phase=None)

    def tick():
        now = time.perf_counter()
        if state["phase"]:
            gaps[state["phase"]] = max(gaps[state["phase"]], now - state["last"])
        state["last"] = now

    timer = QTimer()
    timer.setInterval(5)
    timer.timeout.connect(tick)
    timer.start()
    w.controller.open_files([nominal, measured])
    w.tolerance.set_zone(-tol, tol)
    shown = {}
    w.session.result_changed.connect(lambda run: run is not None and shown.setdefault(
        "t", time.perf_counter()))
    state["phase"] = "run"
    state["last"] = t0 = time.perf_counter()
    loop = QEventLoop()
    w.session.step_changed.connect(lambda step: step == Step.INSPECTED and loop.quit())
    w.session.message.connect(lambda level, text: level == "error" and loop.quit())
    w.act_inspect.trigger()
    loop.exec()  # the GUI thread idles in Qt's event loop, as in the app
    if w.session.step != Step.INSPECTED:
        raise SystemExit(w.message_bar.text)
    # The result is in the views; the 3D view's first frame is drawn when Qt paints it.
    state["phase"] = "show"
    QTimer.singleShot(300, loop.quit)
    loop.exec()
    t_shown = time.perf_counter() - 0.3
    timer.stop()
    verdict = w.session.run.result.verdict
    n_nom = w.session.run.nominal.n
    n_mea = w.session.run.result.deviations.signed.size
    w.close()
    return (name, n_nom, n_mea, t_shown - t0, SHOW["s"], gaps["run"], gaps["show"], verdict)


def main() -> None:
    if os.environ.get("QT_QPA_PLATFORM") != "xcb":
        raise SystemExit("run under an X display with QT_QPA_PLATFORM=xcb (see the docstring)")
    from PySide6.QtWidgets import QApplication

    app = QApplication([])
    _timed_show_run()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        rows.append(run_case(app, "belly fairing sample", os.path.join(
            ROOT, "samples/belly_fairing/nominal.csv"), os.path.join(
            ROOT, "samples/belly_fairing/measured.csv"), 0.25))
        t = time.perf_counter()
        nominal, measured = make_big(tmp)
        print(f"(generated the 1M/200k CSV files in {time.perf_counter() - t:.1f} s)")
        rows.append(run_case(app, "1M grid / 200k points", nominal, measured, 0.05))
    print("| case | nominal | measured | inspect → shown s | drawing the result s | longest GUI "
          "block before drawing ms | longest GUI block after ms | verdict |")
    print("|---|---|---|---|---|---|---|---|")
    for name, nn, nm, t, draw, g_run, g_show, verdict in rows:
        print(f"| {name} | {nn:,} | {nm:,} | {t:.2f} | {draw:.2f} | {1000 * g_run:.0f} | "
              f"{1000 * g_show:.0f} | {verdict} |")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    return p.parse_args(argv)  # no arguments: --help, and a stray one refused before any work


if __name__ == "__main__":
    parse_args()
    main()
