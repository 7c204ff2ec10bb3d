"""The two front ends, side by side over engine.pipeline and reports: ``cli`` (qa-inspect, no
Qt) and ``desktop`` (qa-app, PySide6 + pyvistaqt; its session model and controller are Qt-free)."""
