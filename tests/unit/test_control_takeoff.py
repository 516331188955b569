"""PX4's smooth takeoff (vehicles/control/takeoff.py): PX4's own unit test (TakeoffTest.cpp),
reproduced input for input."""

from __future__ import annotations

import pytest

from vehicles.control.takeoff import TakeoffHandling, TakeoffState
from vehicles.types import GRAVITY_MPS2


def test_initialization():
    assert TakeoffHandling().state is TakeoffState.DISARMED


def test_regular_takeoff_ramp():
    """TakeoffTest.RegularTakeoffRamp: spool-up 1 s, ramp 2 s, initial ramp value from a
    velocity gain of g / 0.5 (so the ramp starts at -0.5 m/s)."""
    t = TakeoffHandling(spoolup_time_s=1.0, ramp_time_s=2.0, velocity_p_gain=GRAVITY_MPS2 / 0.5)
    assert t.update_state(False, True, False, 0.0) is TakeoffState.DISARMED
    assert t.update_state(True, False, False, 0.5) is TakeoffState.SPOOLUP
    assert t.update_state(True, False, False, 2.0) is TakeoffState.READY_FOR_TAKEOFF
    assert t.update_state(True, False, True, 3.0) is TakeoffState.RAMPUP
    t.update_state(True, False, True, 4.0)
    assert [t.update_ramp(0.5, 1.5) for _ in range(5)] == pytest.approx([0.0, 0.5, 1.0, 1.5,
                                                                          1.5], abs=1e-6)
    assert t.update_state(True, False, True, 6.5) is TakeoffState.FLIGHT


def test_landing_makes_it_ready_again_and_disarming_resets_it():
    t = TakeoffHandling(spoolup_time_s=1.0, ramp_time_s=0.0)
    t.update_state(True, True, True, 0.0)
    t.update_state(True, True, True, 1.0)
    t.update_ramp(0.02, 1.5)  # a ramp time of 0: done at once
    assert t.update_state(True, False, True, 1.02) is TakeoffState.FLIGHT
    assert t.update_state(True, True, False, 5.0) is TakeoffState.READY_FOR_TAKEOFF
    assert t.update_state(False, True, False, 6.0) is TakeoffState.DISARMED


def test_modes_without_climb_rate_control_skip_the_takeoff():
    t = TakeoffHandling()
    assert t.update_state(True, True, False, 0.0, skip_takeoff=True) is TakeoffState.FLIGHT


def test_before_the_ramp_the_limit_asks_for_no_thrust():
    t = TakeoffHandling(velocity_p_gain=4.0)
    assert t.update_ramp(0.02, 1.5) == pytest.approx(-GRAVITY_MPS2 / 4.0)
