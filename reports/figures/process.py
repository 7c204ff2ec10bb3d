"""The figure server: :func:`reports.figures.render.render_3d` in a worker process
(``python -m reports.figures``, whose loop is :func:`serve`), or in this process behind the
same interface.
"""

from __future__ import annotations

import os

import numpy as np

from engine.errors import QAError

from .colours import Zone
from .render import View, render_3d


class RenderError(QAError, RuntimeError):
    """The 3D figures could not be rendered (the worker process died or its render failed)."""


class RenderProcess:
    """Runs :func:`render_3d` in a worker process (``python -m reports.figures``) started at
    once, so that importing pyvista/VTK and starting OpenGL (about 1 s) overlap the inspection on
    another core. Requests and replies are pickled over the worker's stdin/stdout."""

    def __init__(self):
        import subprocess
        import sys

        self._proc = subprocess.Popen([sys.executable, "-m", "reports.figures"],
                                      stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                      stderr=subprocess.DEVNULL, cwd=_project_root())
        self._pending = 0

    def submit(self, nominal_points, triangles, feet, normals, d, tol, worst, **kw):
        """Send a :func:`render_3d` request; the returned object's ``result()`` waits for the
        views. The request (megabytes for a big nominal) is written by a thread: the worker may
        still be warming up, and the caller works on meanwhile."""
        import pickle
        import threading

        request = (nominal_points, triangles, feet, normals, d,
                   Zone(float(tol.lower), float(tol.upper)), worst, kw)
        failure = []

        def send():
            try:
                pickle.dump(request, self._proc.stdin, protocol=pickle.HIGHEST_PROTOCOL)
                self._proc.stdin.flush()
            except OSError as e:
                failure.append(e)

        sender = threading.Thread(target=send, daemon=True)
        sender.start()
        self._pending += 1
        return _Reply(self, sender, failure)

    def close(self):
        if self._pending:
            # A request nobody will read (the caller failed meanwhile): the worker would block
            # writing its reply, so stop it now.
            self._proc.kill()
        try:
            self._proc.stdin.close()
            self._proc.wait(timeout=10)
        except Exception:  # closing must never mask the caller's own outcome
            self._proc.kill()
            self._proc.wait()
        finally:
            self._proc.stdout.close()


class _Reply:
    def __init__(self, owner, sender, failure):
        self._owner, self._sender, self._failure = owner, sender, failure

    def result(self) -> list[View]:
        import pickle

        proc = self._owner._proc
        self._sender.join()
        try:
            if self._failure:
                raise self._failure[0]
            ok, value = pickle.load(proc.stdout)
            self._owner._pending -= 1
        except (OSError, EOFError, pickle.UnpicklingError) as e:
            raise RenderError(f"the 3D rendering process failed "
                              f"(exit code {proc.poll()})") from e
        if not ok:
            raise RenderError(f"3D rendering failed: {value}")
        return value


class InProcessRenderer:
    """:class:`RenderProcess`'s interface, rendering in this process when asked."""

    def submit(self, *args, **kw):
        import concurrent.futures

        f = concurrent.futures.Future()
        f.set_result(render_3d(*args, **kw))
        return f

    def close(self):
        pass


def _project_root() -> str:
    # This file is reports/figures/process.py: the project is three folders up.
    return os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def serve() -> None:
    """The worker's loop: warm up, then answer requests until stdin closes."""
    import pickle
    import sys
    import traceback

    z = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    try:
        render_3d(z, np.array([[0, 1, 2]]), z, np.tile([0.0, 0.0, 1.0], (3, 1)), np.zeros(3),
                  Zone(-1.0, 1.0), [], size=(64, 48))
    except Exception:
        pass  # the real request will report the problem
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    while True:
        try:
            pts, tris, feet, normals, d, zone, worst, kw = pickle.load(inp)
        except EOFError:
            out.flush()
            os._exit(0)  # skip VTK's slow teardown; nothing is left to write
        reply: tuple[bool, list[View] | str]  # the views, or the error's text
        try:
            reply = (True, render_3d(pts, tris, feet, normals, d, zone, worst, **kw))
        except Exception as e:
            reply = (False, f"{type(e).__name__}: {e}\n{traceback.format_exc(limit=3)}")
        pickle.dump(reply, out, protocol=pickle.HIGHEST_PROTOCOL)
        out.flush()
