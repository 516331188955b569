"""systemlib::Hysteresis (PX4 ``src/lib/hysteresis``): a boolean that takes a requested value only
once the request has held for a delay, counted from when it was first made.

This one has a delay from false only (``time_from_true`` 0, what every user here sets): true once
the condition has held ``delay_s``, false at once. Time is an argument (seconds).
"""

from __future__ import annotations


class Hysteresis:
    def __init__(self, state: bool, delay_s: float) -> None:
        self.delay_s = delay_s
        self.state = state
        self._requested = state
        self._since = 0.0

    def update(self, now_s: float, condition: bool) -> bool:
        """set_state_and_update(condition, now): the state after asking for ``condition``."""
        if condition != self.state:
            if condition != self._requested:
                self._requested = condition
                self._since = now_s
        else:
            self._requested = self.state
        if self._requested != self.state:
            if not self._requested or now_s >= self._since + self.delay_s - 1e-9:
                self.state = self._requested
        return self.state
