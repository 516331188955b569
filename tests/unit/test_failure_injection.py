"""Failure injection (MAV_CMD_INJECT_FAILURE) as PX4 SITL with SYS_FAILURE_EN: the GPS off →
no fixes → the estimator is unaided after EKF2_NOAID_TOUT → the position is lost → Descend
(failsafe.cpp's mode fallback: Return and Land need a position) → landed and disarmed; refused
with DENIED when SYS_FAILURE_EN is 0; units and types it does not simulate are UNSUPPORTED."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.testing import Sim
from vehicles.types import NavState

GPS, OFF, OK = 4, 1, 0


def hover(sim: Sim, alt_m: float = 10.0) -> None:
    assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
    api = sim.api(0)
    assert api.arm() == 0 and api.takeoff() == 0
    assert sim.run_until(lambda: sim.status(0).nav_state is NavState.AUTO_LOITER, timeout_s=30)
    sim.advance(3.0)


def test_gps_off_in_hold_descends_lands_and_disarms():
    with Sim(params={"MIS_TAKEOFF_ALT": 10.0}) as sim:
        hover(sim)
        api = sim.api(0)
        t0 = sim.now
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OFF, 0) == 0
        assert sim.run_until(lambda: not sim.status(0).position_valid, timeout_s=10)
        lost_after = sim.now - t0
        assert 5.0 <= lost_after < 5.5  # EKF2_NOAID_TOUT
        assert sim.run_until(lambda: sim.status(0).nav_state is NavState.DESCEND, timeout_s=1)
        assert sim.status(0).failsafe
        # Down at about MPC_LAND_SPEED (0.7 m/s) from 10 m, then disarmed after landing.
        assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=40)
        truth = sim.vehicles[0].truth
        assert truth.position_ned_m[2] > -0.3
        assert math.hypot(*truth.position_ned_m[:2]) < 5.0  # it drifts a little, no more
        texts = [m.text for m in api.messages("STATUSTEXT")]
        assert "Failsafe activated" in texts and "Disarmed by landing" in texts
        # The GPS back: the position is valid again.
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OK, 0) == 0
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)


@pytest.mark.parametrize("params, unit, kind, result", [
    ({"SYS_FAILURE_EN": 0}, GPS, OFF, 2),  # DENIED: failure injection disabled
    ({}, 101, OFF, 3),  # a motor: not simulated here, UNSUPPORTED
    ({}, GPS, 2, 3),  # GPS stuck: UNSUPPORTED
])
def test_refusals(params, unit, kind, result):
    with Sim(params=params) as sim:
        sim.advance(1.0)
        assert sim.api(0).command_long(M.MAV_CMD_INJECT_FAILURE, unit, kind, 0) == result
        sim.advance(7.0)
        assert sim.status(0).position_valid
