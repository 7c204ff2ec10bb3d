"""``qa-app [NOMINAL [MEASURED]] [--tol T] [--plan PLAN.toml]``: open the main window; with both
files given, load them (and the plan) and inspect at once. As with ``qa-inspect inspect``, a plan
without ``--tol`` is the requirement alone; ``--tol`` with a plan adds its zone over all points."""

from __future__ import annotations

import argparse
import sys
import threading
import traceback


def install_excepthooks(session, post) -> None:
    """Unexpected errors, in the GUI thread or a worker, reach the user in the message bar
    instead of killing the window (napari's way); ``post`` queues the message into the GUI
    thread (widgets must not be touched from another thread)."""
    from reports.messages import user_message

    def show(exc_type, exc, tb):
        traceback.print_exception(exc_type, exc, tb)
        text = user_message(exc)
        post(lambda: session.tell("error", text))

    sys.excepthook = show
    threading.excepthook = lambda args: show(args.exc_type, args.exc_value, args.exc_traceback)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="qa-app", description=__doc__)
    p.add_argument("nominal", nargs="?", help="the nominal (points, mesh, grid or DXF template)")
    p.add_argument("measured", nargs="?", help="the measured points")
    p.add_argument("--tol", type=float, help="symmetric tolerance ±T mm to start with")
    p.add_argument("--plan", metavar="PLAN.toml", help="inspection plan: regions, datums, "
                   "alignment and characteristics (the verdict is theirs)")
    args = p.parse_args(argv)

    from PySide6.QtWidgets import QApplication

    from .window import MainWindow

    app = QApplication.instance() or QApplication(sys.argv[:1])
    app.setApplicationName("qa-app")
    app.setOrganizationName("qa-inspect")
    win = MainWindow()
    install_excepthooks(win.session, win._invoker.call.emit)
    if args.tol is not None and args.tol > 0:
        win.tolerance.set_zone(-args.tol, args.tol)
    files = [f for f in (args.nominal, args.measured) if f]
    if files:
        win.controller.open_files(files)
    win.showMaximized()  # the 3D view takes most of the screen (issue 26)

    def inspect():
        if args.plan and args.tol is not None and args.tol > 0:
            win.tolerance.set_zone(-args.tol, args.tol)  # the user's zone joins the plan's
        if win.session.can_inspect:
            win.inspect()

    if args.plan:
        win.controller.open_plan(args.plan, on_done=inspect)  # read in the worker
    else:
        inspect()
    return app.exec()
