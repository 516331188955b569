"""PX4's own unit tests of systemlib::Hysteresis, run against ours.

Source (PX4 v1.15): ``src/lib/hysteresis/HysteresisTest.cpp``, the test of
``systemlib::Hysteresis`` (``src/lib/hysteresis/hysteresis.cpp``): a boolean that takes a
requested value only once the request has held for the delay from its present value, counted
from when the request was first made.

CORNET's shared Hysteresis is ``vehicles/hysteresis.py`` (the land detector's and the stick
gestures'); the hand-rolled ones in vehicles/control/hover_thrust.py (``_valid_hysteresis``) and
vehicles/failure_detector.py are not tested here. Ours has a delay from false only (PX4's
``time_from_true`` fixed at 0, what every user in CORNET sets), set at construction, and time in
seconds. PX4's calls map onto it as:

- ``Hysteresis(init)`` with ``set_hysteresis_time_from(false, T)``: ``Hysteresis(init, T)``
  (``set_hysteresis_time_from(true, T)`` has no counterpart);
- ``set_state_and_update(s, now)``: ``update(now, s)``;
- ``update(now)``: ``update(now, r)``, ``r`` the last request made: in PX4 too,
  ``set_state_and_update`` with the standing request changes nothing before its ``update(now)``
  (the request and its time stay);
- ``get_state()``: ``state``.

Times are PX4's, in microseconds from its SOME_START_TIME, passed in seconds.

Not reproduced, because they need a delay from true (``set_hysteresis_time_from(true, T)`` with
T > 0), which ours does not have: the "change back to false" halves of ``ChangeAfterTime``,
``HysteresisChanged`` and ``ChangeAfterMultipleSets``. Their first halves (false to true, which
only the delay from false governs) are reproduced.
"""

from __future__ import annotations

from vehicles.hysteresis import Hysteresis

SOME_START_TIME = 1558359616134000  # µs


class PX4Hysteresis:
    """systemlib::Hysteresis's calls on ours (see the module docstring)."""

    def __init__(self, init_state: bool, time_from_false_us: int = 0) -> None:
        self.h = Hysteresis(init_state, time_from_false_us * 1e-6)
        self._request = init_state

    def get_state(self) -> bool:
        return self.h.state

    def set_state_and_update(self, new_state: bool, now_us: int) -> None:
        self._request = new_state
        self.h.update(now_us * 1e-6, new_state)

    def update(self, now_us: int) -> None:
        self.h.update(now_us * 1e-6, self._request)


def test_Hysteresis_InitFalse():
    """HysteresisTest.cpp, TEST(Hysteresis, InitFalse): constructed false, it is false."""
    assert PX4Hysteresis(False).get_state() is False


def test_Hysteresis_InitTrue():
    """HysteresisTest.cpp, TEST(Hysteresis, InitTrue): constructed true, it is true."""
    assert PX4Hysteresis(True).get_state() is True


def test_Hysteresis_Zero():
    """HysteresisTest.cpp, TEST(Hysteresis, Zero): with no delays each request takes effect at
    once; a wait changes nothing."""
    time_us = SOME_START_TIME
    hysteresis = PX4Hysteresis(False)
    assert hysteresis.get_state() is False
    hysteresis.set_state_and_update(True, time_us)
    assert hysteresis.get_state() is True
    hysteresis.set_state_and_update(False, time_us)
    assert hysteresis.get_state() is False
    hysteresis.set_state_and_update(True, time_us)
    assert hysteresis.get_state() is True
    time_us += 1000
    hysteresis.update(time_us)
    assert hysteresis.get_state() is True


def test_Hysteresis_ChangeAfterTime():
    """HysteresisTest.cpp, TEST(Hysteresis, ChangeAfterTime), its first half: 5 ms from false:
    still false 4 ms after the request for true, true at 6 ms. (The second half, 3 ms from
    true, is not reproduced: ours has no delay from true.)"""
    time_us = SOME_START_TIME
    hysteresis = PX4Hysteresis(False, time_from_false_us=5000)
    hysteresis.set_state_and_update(True, time_us)
    assert hysteresis.get_state() is False
    time_us += 4000
    hysteresis.update(time_us)
    assert hysteresis.get_state() is False
    time_us += 2000
    hysteresis.update(time_us)
    assert hysteresis.get_state() is True


def test_Hysteresis_HysteresisChanged():
    """HysteresisTest.cpp, TEST(Hysteresis, HysteresisChanged), its first half: 5 ms from
    false: false at 3 ms, true at 6 ms. (The second half, the delay from true changed to 10 ms,
    is not reproduced: ours has no delay from true.)"""
    time_us = SOME_START_TIME
    hysteresis = PX4Hysteresis(False, time_from_false_us=5000)
    hysteresis.set_state_and_update(True, time_us)
    assert hysteresis.get_state() is False
    time_us += 3000
    hysteresis.update(time_us)
    assert hysteresis.get_state() is False
    time_us += 3000
    hysteresis.update(time_us)
    assert hysteresis.get_state() is True


def test_Hysteresis_ChangeAfterMultipleSets():
    """HysteresisTest.cpp, TEST(Hysteresis, ChangeAfterMultipleSets), its first half: 5 ms from
    false, true requested again at 3 ms and 6 ms: the delay counts from the first request, so
    true at 6 ms. (The second half, 5 ms from true, is not reproduced: ours has no delay from
    true.)"""
    time_us = SOME_START_TIME
    hysteresis = PX4Hysteresis(False, time_from_false_us=5000)
    hysteresis.set_state_and_update(True, time_us)
    assert hysteresis.get_state() is False
    time_us += 3000
    hysteresis.set_state_and_update(True, time_us)
    assert hysteresis.get_state() is False
    time_us += 3000
    hysteresis.set_state_and_update(True, time_us)
    assert hysteresis.get_state() is True


def test_Hysteresis_TakeChangeBack():
    """HysteresisTest.cpp, TEST(Hysteresis, TakeChangeBack): 5 ms from false; a request for
    true taken back after 3 ms never takes effect; asked again, it takes effect 5 ms after the
    new request (false at 3 ms, true at 6 ms); false is immediate."""
    time_us = SOME_START_TIME
    hysteresis = PX4Hysteresis(False, time_from_false_us=5000)
    hysteresis.set_state_and_update(True, time_us)
    assert hysteresis.get_state() is False
    time_us += 3000
    hysteresis.update(time_us)
    assert hysteresis.get_state() is False
    hysteresis.set_state_and_update(False, time_us)
    assert hysteresis.get_state() is False
    time_us += 6000
    hysteresis.update(time_us)
    assert hysteresis.get_state() is False

    hysteresis.set_state_and_update(True, time_us)
    assert hysteresis.get_state() is False
    time_us += 3000
    hysteresis.update(time_us)
    assert hysteresis.get_state() is False
    time_us += 3000
    hysteresis.update(time_us)
    assert hysteresis.get_state() is True

    hysteresis.set_state_and_update(False, time_us)
    assert hysteresis.get_state() is False
