"""The progress line ``qa-inspect inspect`` draws on the terminal (standard error) during a run
that takes a while: a bar, the per cent done and the stage (engine.progress reports both). A
quick run draws nothing; the line is erased at the end, so that the summary stands alone."""

from __future__ import annotations

import shutil
import sys
import time

DELAY_S = 2.0
"""A run draws its progress line only once it has lasted this long: most runs end sooner."""
REDRAW_S = 0.1
"""The line is redrawn at most this often."""
BAR = 20
"""Characters of the bar."""


class StageLine:
    """An engine.progress listener (call it with (stage, fraction)) that draws one line on
    ``stream`` (a terminal): ``[#######.............]  35%  judging characteristic 3,501 of
    10,000``, cut to the terminal's width. :meth:`close` erases it."""

    def __init__(self, stream=None, clock=time.monotonic):
        self.stream, self.clock = stream or sys.stderr, clock
        self.start = clock()
        self._drawn = None  # when the line was last drawn
        self._width = 0  # characters on the line now

    def __call__(self, stage: str, fraction: float) -> None:
        now = self.clock()
        if now - self.start < DELAY_S or (self._drawn is not None
                                           and now - self._drawn < REDRAW_S):
            return
        self._drawn = now
        self._draw(stage_line(stage, fraction))

    def close(self) -> None:
        if self._width:
            self._draw("")
            self._width = 0

    def _draw(self, text: str) -> None:
        text = text[:max(shutil.get_terminal_size().columns - 1, 10)]
        # Spaces over what is left of a longer line before: a carriage return only goes back.
        self.stream.write("\r" + text.ljust(self._width) + ("\r" if not text else ""))
        self.stream.flush()
        self._width = len(text)


def stage_line(stage: str, fraction: float) -> str:
    """The progress line's text for ``stage`` at ``fraction`` (0..1) of the run."""
    filled = int(round(BAR * fraction))
    return f"[{'#' * filled}{'.' * (BAR - filled)}] {100 * fraction:3.0f}%  {stage}"
