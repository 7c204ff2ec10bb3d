"""Progress reports and cancellation for long computations, without threading a callback through
every function.

A caller that wants to follow (or stop) a computation runs it inside ``with reporting(cb):``; the
engine calls :func:`report` at its stages and iterations, which calls ``cb(stage, fraction)`` in
the same thread (contextvars: each worker thread has its own). The callback may raise
:class:`engine.errors.Cancelled` to stop the computation there; nothing is returned then.
A stage that reports its own progress from 0 to 1 (a plan's characteristics, one by one) runs
inside ``with within(lo, hi):``, which moves the listener's fraction over its share of the run.
"""

from __future__ import annotations

import contextvars
from collections.abc import Callable, Iterator
from contextlib import contextmanager

Callback = Callable[[str, float], None]
_current: contextvars.ContextVar[Callback | None] = contextvars.ContextVar("qa_progress",
                                                                           default=None)


def report(stage: str, fraction: float) -> None:
    """Tell the current listener (if any) that ``stage`` is under way, ``fraction`` (0..1) of the
    whole done."""
    cb = _current.get()
    if cb is not None:
        cb(stage, min(max(float(fraction), 0.0), 1.0))


@contextmanager
def reporting(callback: Callback | None) -> Iterator[None]:
    token = _current.set(callback)
    try:
        yield
    finally:
        _current.reset(token)


@contextmanager
def within(lo: float, hi: float) -> Iterator[None]:
    """Inside, a report of ``fraction`` (0..1 of this part of the run) reaches the listener as
    ``lo + fraction * (hi - lo)`` (of the whole run)."""
    cb = _current.get()
    if cb is None:
        yield
        return
    token = _current.set(lambda stage, fraction: cb(stage, lo + fraction * (hi - lo)))
    try:
        yield
    finally:
        _current.reset(token)
