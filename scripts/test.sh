#!/usr/bin/env bash
# Set up, then run the whole test suite (import-layer contracts included): first everything but the
# 3D viewport on Qt's offscreen platform, then the desktop app's real 3D viewport and workflow
# tests (tests/xvfb) on a virtual X display. Extra arguments go to the first pytest run, and the
# second runs only when none are given. The first runs on every core (pytest-xdist).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# One pytest worker per core (pytest-xdist), each test file kept on one worker so that its
# module fixtures are built once: about half the wall time of one process on two cores.
QT_QPA_PLATFORM=offscreen .venv/bin/python -m pytest -n auto --dist loadfile "$@"
if [ $# -eq 0 ]; then
    if ! command -v xvfb-run >/dev/null 2>&1; then
        echo "test: xvfb-run is missing: run scripts/setup.sh as root (or apt-get install xvfb)" >&2
        exit 1
    fi
    QA_GUI_DISPLAY=xvfb QT_QPA_PLATFORM=xcb \
        xvfb-run -a -s "-screen 0 1600x1200x24" .venv/bin/python -m pytest tests/xvfb \
        -q
fi
