"""The window on a 1366×768 laptop screen: a virtual X display of that size of its own."""

import json
import os
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def probe(width: int, height: int) -> dict:
    env = dict(os.environ, QT_QPA_PLATFORM="xcb", PYTHONPATH=ROOT)
    done = subprocess.run(["xvfb-run", "-a", "-s", f"-screen 0 {width}x{height}x24",
                           sys.executable, os.path.join(HERE, "window_probe.py")],
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def laptop():
    return probe(1366, 768)


def test_the_window_fits_a_1366_by_768_screen(laptop):
    """Its minimum size, with a title bar, borders and a task bar, fits the screen; it starts
    no larger than the screen; maximised there, it is the size it was given."""
    assert laptop["screen"] == [1366, 768]
    for key in ("minimum_hint", "minimum"):
        w, h = laptop[key]
        assert w + 2 * 8 <= 1366 and h + 30 + 40 <= 768, (key, laptop[key])
    assert laptop["started"][0] <= 1366 and laptop["started"][1] <= 768
    assert laptop["size"] == [1366 - 16, 768 - 70]


def test_at_1366_by_768_the_3d_view_takes_most_of_the_window(laptop):
    """Maximised on a laptop, the 3D view (issue 26: at least 55% of the window) and its
    rendered picture, the view less its row of buttons, too."""
    area = laptop["size"][0] * laptop["size"][1]
    assert laptop["viewport"][0] * laptop["viewport"][1] >= 0.55 * area, laptop
    assert laptop["render"][0] * laptop["render"][1] >= 0.50 * area, laptop


def test_at_1366_by_768_the_table_shows_a_dozen_rows_under_whole_headers(laptop):
    assert laptop["rows_seen"] >= 12
    for title, width, text, line in laptop["headers"][:-1]:
        # The title and the sort arrow beside it (about a line's height) fit the column.
        assert width >= text + line, (title, width, text)
    assert laptop["table_right"] <= 1366 - 16
