"""Screenshots of the desktop app with the belly-fairing sample inspected at ±0.25 mm, at
1366×768 and 1920×1080, each on its own virtual X display (Xvfb).

    PYTHONPATH=. .venv/bin/python scripts/app_screenshots.py docs/screenshots

writes ``app_1366x768.png`` and ``app_1920x1080.png`` (and ``app_2d_*.png``: the fuselage
frame's DXF template in the 2D view; ``app_bracket_*.png``: the seat bracket, a bare-point
nominal drawn as a shaded display mesh; ``app_steps_*.png``: the belly fairing with the steps
in front and the decision rule's list open; ``app_characteristic_*.png``: NIST CTC-01 with
its failing slot's position selected, shown on the part). The lead's screenshot script calls
:func:`app_screenshots`. Needs ``xvfb-run`` (package xvfb).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIZES = ((1366, 768), (1920, 1080))
BELLY = os.path.join(ROOT, "samples", "belly_fairing")
FRAME = os.path.join(ROOT, "samples", "fuselage_frame")
CASES = {
    "app": ([os.path.join(BELLY, "nominal.csv"), os.path.join(BELLY, "measured.csv")], 0.25),
    "app_2d": ([os.path.join(FRAME, "template.dxf"), os.path.join(FRAME, "measured.csv")], 0.05),
    "app_bracket": ([os.path.join(ROOT, "samples", "seat_bracket", "nominal.xyz"),
                     os.path.join(ROOT, "samples", "seat_bracket", "measured.csv")], 0.1),
}
"""Each screenshot's files and symmetric zone (±mm)."""
STEPS_SHOWN = {"app_steps": ([os.path.join(BELLY, "nominal.csv"),
                              os.path.join(BELLY, "measured.csv")], 0.25)}
"""Screenshots with the inspection's steps in front of the results and the decision rule's
list open (its longest choice shown whole)."""
CASES.update(STEPS_SHOWN)
CHARACTERISTIC = {"app_characteristic": "1443"}
"""Screenshots of NIST CTC-01 inspected with its QIF plan, its slot moved 0.6 mm along x (its
position 1443, ⌀0.75 to A|B|C, REJECTed), with that characteristic selected: its faces, datums
and frame shown on the part (points planted on the exact faces by tests/ctc01.py)."""
CASES.update({k: ([], 0.0) for k in CHARACTERISTIC})


def app_screenshots(out_dir: str, sizes=SIZES, cases=("app",)) -> list[str]:
    """Write the screenshots into ``out_dir`` (created if need be); returns their paths.

    sizes : the screens, (width, height) pixels; cases : keys of CASES. Each screen is a fresh
    ``xvfb-run`` with this file run in it (``--one``), so that the window meets that screen's
    size as on a laptop; the window fills the screen, as maximised.
    """
    os.makedirs(out_dir, exist_ok=True)
    env = dict(os.environ, QT_QPA_PLATFORM="xcb",
               PYTHONPATH=os.pathsep.join(p for p in (ROOT, os.environ.get("PYTHONPATH")) if p))
    paths = []
    for case in cases:
        for w, h in sizes:
            path = os.path.join(os.path.abspath(out_dir), f"{case}_{w}x{h}.png")
            subprocess.run(["xvfb-run", "-a", "-s", f"-screen 0 {w}x{h}x24", sys.executable,
                            os.path.abspath(__file__), "--one", case, path], env=env, check=True)
            paths.append(path)
    return paths


def shoot(case: str, path: str) -> None:
    """On the current X display: the window with ``case`` inspected, filling the screen, its
    worst point chosen in the table; the screen saved as PNG to ``path`` (written whole, then
    renamed)."""
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication

    from qa_app.desktop.window import MainWindow

    app = QApplication.instance() or QApplication([])
    with tempfile.TemporaryDirectory() as tmp:
        w = MainWindow(synchronous=True,
                       settings=QSettings(os.path.join(tmp, "qa-app.ini"), QSettings.IniFormat))
        files, tol = CASES[case]
        if case in CHARACTERISTIC:
            sys.path.insert(0, os.path.join(ROOT, "tests"))
            from ctc01 import QIF, SLOT, STP, measured_csv

            w.controller.open_files([STP, measured_csv(tmp, moved=SLOT, by=(0.6, 0.0, 0.0))])
            w.controller.open_plan(QIF)  # the plan's zone: statistics only
        else:
            w.controller.open_files(files)
            w.tolerance.set_zone(-tol, tol)
        w.setGeometry(w.screen().availableGeometry())
        w.show()
        w.inspect()
        for _ in range(20):
            app.processEvents()
        if case in CHARACTERISTIC:
            ids = [r.characteristic.id for r in w.session.run.result.plan.characteristics]
            w.characteristics.view.selectRow(ids.index(CHARACTERISTIC[case]))
        else:
            w.table.selectRow(0)
        if case in STEPS_SHOWN:
            w.steps_dock.raise_()
            w.tolerance.rule.showPopup()
        for _ in range(20):
            app.processEvents()
        img = w.screen().grabWindow(0)
        tmp_png = path + ".tmp.png"
        if not img.save(tmp_png, "PNG"):
            raise OSError(f"{tmp_png}: could not write the screenshot")
        os.replace(tmp_png, path)
        w.close()


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out", nargs="?", metavar="OUT_DIR", help="the folder the PNGs are written to")
    p.add_argument("--one", nargs=2, metavar=("CASE", "PNG"),
                   help="one screenshot of CASE on the current X display (how each screen's "
                        "xvfb-run runs this file)")
    args = p.parse_args(argv)
    if (args.out is None) == (args.one is None):
        p.error("give OUT_DIR, or --one CASE PNG")
    if args.one is not None and args.one[0] not in CASES:
        p.error(f"--one: unknown case {args.one[0]!r}; cases: {', '.join(CASES)}")
    return args


if __name__ == "__main__":
    args = parse_args()
    if args.one is not None:
        shoot(*args.one)
    else:
        for p in app_screenshots(args.out, cases=tuple(CASES)):
            print(p)
