"""manual_control_setpoint as PX4's ManualControl module publishes it: what the MANUAL_CONTROL
stream echoes (gateway/mavlink/telemetry_requested.py).

After PX4 ``modules/manual_control/ManualControl.cpp`` (Run, processInput) and
``ManualControlSelector.cpp``:
- Run is called by every sample of the chosen input and otherwise 200 ms after the last call
  (ScheduleDelayed(200_ms)).
- Every Run with a valid input publishes it again (the same sticks when no new sample came). A
  sample is valid while it is younger than COM_RC_LOSS_T.
- The first Run without a valid input publishes the setpoint, marked invalid, once. At boot that
  is the zero setpoint. After a loss it holds the last sticks, which the selector keeps.
- Inputs the selector refuses (another source while the chosen one is fresh, COM_RC_IN_MODE)
  publish nothing: their samples trigger no Run.
Counted lazily: ``count(now_s)`` is how many publications there have been by ``now_s``. Pure:
time is an argument.
"""

from __future__ import annotations

from typing import Generic, TypeVar

T = TypeVar("T")  # the sample: vehicles/manual_control.py's Sticks

RUN_PERIOD_US = 200_000  # ManualControl::Run's ScheduleDelayed(200_ms)


def _us(seconds: float) -> int:
    return round(seconds * 1e6)


class SetpointPublications(Generic[T]):
    """How many manual_control_setpoint publications there have been, and the last one's
    sticks (PX4 ranges: vehicles/manual_control.py ``Sticks``)."""

    def __init__(self, zero: T) -> None:
        """``zero``: the zero setpoint, which the first Run at boot publishes (invalid)."""
        self._settled = 1
        self.input_s: float | None = None  # when the last accepted sample came
        self.sticks = zero

    def on_input(self, now_s: float, sticks: T, timeout_s: float) -> None:
        """An accepted sample at ``now_s``: its Run publishes it."""
        self._settled = self.count(now_s, timeout_s) + 1
        self.input_s = now_s
        self.sticks = sticks

    def count(self, now_s: float, timeout_s: float) -> int:
        """The publications by ``now_s`` (``latest``'s count)."""
        return self.latest(now_s, timeout_s)[0]

    def latest(self, now_s: float, timeout_s: float) -> tuple[int, float, bool]:
        """(how many publications by ``now_s``, when the last one was, whether it was valid):
        the settled ones, then the timer's Runs since the last sample (strictly before
        ``now_s``). Each Run while the sample is younger than ``timeout_s`` (COM_RC_LOSS_T)
        publishes it again, and the first later Run publishes the invalid setpoint."""
        if self.input_s is None:
            return self._settled, 0.0, False
        gap_us = _us(now_s - self.input_s)
        runs = (gap_us - 1) // RUN_PERIOD_US if gap_us > 0 else 0
        timeout_us = _us(timeout_s)
        valid_runs = (timeout_us - 1) // RUN_PERIOD_US if timeout_us > 0 else 0
        lost = runs > valid_runs
        n = min(runs, valid_runs) + (1 if lost else 0)
        return self._settled + n, self.input_s + n * RUN_PERIOD_US * 1e-6, not lost
