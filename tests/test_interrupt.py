"""Ctrl-C during a kd-tree query on several threads (engine.neighbours.query): scipy's worker
threads went on reading the arrays the main thread's unwinding freed, and a STEP plan's run
interrupted in its datum fits crashed after "interrupted" (exit 139). The interrupt is held
back until the query ends, then raised as it would have been."""

import os
import threading

import numpy as np
from scipy.spatial import cKDTree

from engine.neighbours import PARALLEL_QUERIES, query


CHILD = """
import os, signal, time
import numpy as np
from scipy.spatial import cKDTree
from engine.neighbours import query


class Interrupted:
    # A kd-tree whose query gets a Ctrl-C as it starts, and says whether it then ran to its end.
    def __init__(self, tree):
        self.tree, self.finished = tree, False

    def query(self, *a, **k):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.05)  # the signal's Python handler runs here
        out = self.tree.query(*a, **k)
        self.finished = True
        return out


# Ctrl-C as a terminal delivers it: a process started in the background (a CI runner's) may
# have inherited SIGINT ignored, and Python then never raises KeyboardInterrupt.
signal.signal(signal.SIGINT, signal.default_int_handler)
rng = np.random.default_rng(0)
tree = Interrupted(cKDTree(rng.uniform(size=(20_000, 3))))
try:
    query(tree, rng.uniform(size=(200_000, 3)), k=4)
    print("not interrupted")
except KeyboardInterrupt:
    restored = signal.getsignal(signal.SIGINT) is signal.default_int_handler
    print("interrupted", tree.finished, restored)
"""


def test_ctrl_c_during_a_threaded_query_waits_for_it_then_interrupts():
    """In a process of its own (signals reach the main thread, which pytest's workers may not
    give a test): a Ctrl-C as a 200,000-point query starts on several threads reaches Python
    once the query has returned, and the handler is the one before (scipy's own query,
    interrupted in its wait, raised at once and crashed: 'interrupted', then a segfault)."""
    import subprocess
    import sys

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ, PYTHONPATH=root)
    done = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, (done.returncode, done.stderr[-2000:])
    assert done.stdout.split() == ["interrupted", "True", "True"], done.stdout


def test_a_query_off_the_main_thread_is_untouched():
    """Signals reach the main thread only: elsewhere (the app's worker) nothing is held."""
    tree = cKDTree(np.random.default_rng(1).uniform(size=(1000, 3)))
    pts = np.random.default_rng(2).uniform(size=(PARALLEL_QUERIES, 3))
    out = {}
    t = threading.Thread(target=lambda: out.update(r=query(tree, pts, k=2)))
    t.start()
    t.join()
    d, i = out["r"]
    d0, i0 = tree.query(pts, k=2)
    assert np.array_equal(i, i0) and np.array_equal(d, d0)
