"""The real 3D viewport (pyvistaqt's QOpenGLWidget) needs an X display: scripts/test.sh runs
this folder in its own pytest process under Xvfb (QA_GUI_DISPLAY=xvfb, QT_QPA_PLATFORM=xcb)."""

import os

import pytest


def pytest_configure(config):
    if os.environ.get("QT_QPA_PLATFORM") != "xcb" or not os.environ.get("DISPLAY"):
        raise pytest.UsageError(
            "tests/xvfb need an X display: run them through scripts/test.sh (which uses "
            "xvfb-run with QT_QPA_PLATFORM=xcb), not on Qt's offscreen platform")
