"""One status line for long runs (``cornet fly``, ``cornet run --speed max``).

On a terminal the line is redrawn in place (carriage return + erase-line) at most
``redraw_s`` of wall time apart, with a bar when the caller knows how far along it is; anywhere
else (a CI log, a pipe) it prints a plain line at most every ``plain_period_s`` of simulated
time, so logs stay short and diff-able. The wall clock is read only to throttle redraws.

    line = ProgressLine(sys.stderr)
    line.update(now_s, "t=12 s rtf=64x mode=AUTO_MISSION item=3/6", fraction=0.5)
    ...
    line.close()          # ends the in-place line so what follows starts on a fresh one
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TextIO

BAR_WIDTH = 24
ERASE_LINE = "\r\x1b[K"


def bar(fraction: float, width: int = BAR_WIDTH) -> str:
    """``[#########...............]  37%`` for a fraction in [0, 1] (clamped)."""
    f = min(max(fraction, 0.0), 1.0)
    filled = int(round(f * width))
    return f"[{'#' * filled}{'.' * (width - filled)}] {100 * f:3.0f}%"


class ProgressLine:
    def __init__(self, stream: TextIO, *, tty: bool | None = None, redraw_s: float = 0.1,
                 plain_period_s: float = 10.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.stream = stream
        if tty is None:
            isatty = getattr(stream, "isatty", None)
            tty = bool(isatty and isatty())
        self.tty = tty
        self.redraw_s = redraw_s
        self.plain_period_s = plain_period_s
        self._clock = clock
        self._last_draw = -float("inf")
        self._last_plain_sim = -float("inf")
        self._shown = False  # an in-place line is on the terminal

    def update(self, now_s: float, text: str, fraction: float | None = None, *,
               force: bool = False) -> None:
        if self.tty:
            wall = self._clock()
            if not force and wall - self._last_draw < self.redraw_s:
                return
            self._last_draw = wall
            line = text if fraction is None else f"{bar(fraction)} {text}"
            self.stream.write(ERASE_LINE + line)
            self._shown = True
        else:
            if not force and now_s - self._last_plain_sim < self.plain_period_s:
                return
            self._last_plain_sim = now_s
            self.stream.write(text + "\n")
        self.stream.flush()

    def clear(self) -> None:
        """Erase the in-place line (before other output, e.g. a log record)."""
        if self.tty and self._shown:
            self.stream.write(ERASE_LINE)
            self.stream.flush()
            self._shown = False

    def close(self) -> None:
        """Leave the last in-place line on screen and move to a new line."""
        if self.tty and self._shown:
            self.stream.write("\n")
            self.stream.flush()
            self._shown = False
