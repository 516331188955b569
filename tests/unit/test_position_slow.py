"""Position Slow and Position mode's sideways and backward limits, after PX4 v1.15.2:
FlightTaskManualAccelerationSlow::update (its limits from velocity_limits, the MC_SLOW_MAP_*
knobs, else MC_SLOW_DEF_*), StickAccelerationXY::generateSetpoints (velocity constraint,
acceleration scaled with it, MPC_VEL_MAN_SIDE/BACK), FlightTaskManualAltitude::_scaleSticks and
StickYaw (the vertical and yaw-rate constraints), mavlink_receiver's SET_VELOCITY_LIMITS, and the
commander taking POSCTL sub mode SLOW as NAVIGATION_STATE_POSITION_SLOW."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import development

from gateway.ci.lockstep import Sim as LockstepSim
from gateway.mavlink.wip_dialect import SET_VELOCITY_LIMITS
from tests.unit.test_vehicles_flight import Sim, take_off
from tests.unit.test_vehicles_manual import CENTRED, fly
from vehicles.manual_control import Sticks
from vehicles.params import ParamStore
from vehicles.position_slow import ManualPositionSlow, VelocityLimits
from vehicles.types import CommandResult, NavState


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def _constraints(params=None, last=None):
    limits = VelocityLimits()
    if last is not None:
        limits.publish(*last)
    task = ManualPositionSlow(ParamStore(params or {}), limits)
    task.constrain()
    return (task.velocity_constraint, task.velocity_constraint_up,
            task.velocity_constraint_down, math.degrees(task.yawspeed_constraint))


def test_without_limits_or_knobs_the_defaults_apply():
    assert _constraints() == pytest.approx((3.0, 1.0, 1.0, 45.0))  # MC_SLOW_DEF_*


def test_set_velocity_limits_apply_above_their_floors_and_nan_keeps_the_default():
    assert _constraints(last=(1.5, 0.5, math.radians(20.0))) == pytest.approx(
        (1.5, 0.5, 0.5, 20.0))
    # below MC_SLOW_MIN_HVEL/VVEL/YAWR (0.3 m/s, 0.3 m/s, 3 deg/s): the floors
    assert _constraints(last=(0.0, -2.0, 0.0)) == pytest.approx((0.3, 0.3, 0.3, 3.0))
    # NaN: not limited by the message, so the default of that limit
    assert _constraints(last=(math.nan, 2.0, math.nan)) == pytest.approx((3.0, 2.0, 2.0, 45.0))
    # infinite (or huge) limits are finite-checked as PX4_ISFINITE: inf is no limit
    assert _constraints(last=(math.inf, 3e38, -math.inf)) == pytest.approx(
        (3.0, 3e38, 3e38, 45.0))


def test_a_mapped_knob_reads_zero_half_way_between_floor_and_limit():
    # no aux input: interpolate(0, -1, 1, floor / limit, 1) of MPC_VEL_MANUAL (10), of
    # MPC_Z_VEL_MAX_UP (3) and _DN (1.5), of MPC_MAN_Y_MAX (150 deg/s)
    h, up, down, yaw = _constraints({"MC_SLOW_MAP_HVEL": 1, "MC_SLOW_MAP_VVEL": 6,
                                     "MC_SLOW_MAP_YAWR": 3})
    assert h == pytest.approx(10.0 * (0.3 / 10.0 + 1.0) / 2.0)
    assert up == pytest.approx(3.0 * (0.3 / 3.0 + 1.0) / 2.0)
    assert down == pytest.approx(1.5 * (0.3 / 1.5 + 1.0) / 2.0)
    assert yaw == pytest.approx(150.0 * (3.0 / 150.0 + 1.0) / 2.0)
    # the knob scales the MAVLink limit when both are there
    assert _constraints({"MC_SLOW_MAP_HVEL": 2}, last=(2.0, math.nan, math.nan))[0] == \
        pytest.approx(2.0 * (0.3 / 2.0 + 1.0) / 2.0)


def _position_slow(sim):
    take_off(sim)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSITION_SLOW) is CommandResult.ACCEPTED
    assert sim.v.status.nav_state is NavState.POSITION_SLOW


def test_position_slow_flies_the_sticks_at_the_slow_limits(sim):
    _position_slow(sim)
    fly(sim, 8.0, Sticks(pitch=1.0))  # full forward: MC_SLOW_DEF_HVEL, not MPC_VEL_MANUAL
    assert sim.v.state.velocity_ned_mps[0] == pytest.approx(3.0, abs=0.15)
    fly(sim, 6.0, CENTRED)
    assert abs(sim.v.state.velocity_ned_mps[0]) < 0.2
    fly(sim, 3.0, Sticks(throttle=1.0))  # full up: MC_SLOW_DEF_VVEL
    assert sim.v.state.velocity_ned_mps[2] == pytest.approx(-1.0, abs=0.1)
    fly(sim, 3.0, CENTRED)
    yaw0 = sim.v.state.euler_rad()[2]
    fly(sim, 2.0, Sticks(yaw=1.0))  # full yaw: MC_SLOW_DEF_YAWR (45 deg/s), not 150
    turned = math.degrees(math.remainder(sim.v.state.euler_rad()[2] - yaw0, math.tau))
    assert 60.0 < turned < 90.0
    # a limit sent in flight applies at once
    sim.v.set_velocity_limits(1.0, math.nan, math.nan)
    fly(sim, 8.0, Sticks(pitch=1.0))
    assert math.hypot(*sim.v.state.velocity_ned_mps[:2]) == pytest.approx(1.0, abs=0.1)
    assert sim.v.status.nav_state is NavState.POSITION_SLOW


def test_position_slow_needs_sticks_as_position_mode_does(sim):
    take_off(sim)
    assert sim.v.set_nav_state(sim.t, NavState.POSITION_SLOW) is \
        CommandResult.TEMPORARILY_REJECTED


def test_position_mode_backward_and_sideways_limits(sim):
    sim.v.params.set("MPC_VEL_MAN_BACK", 2.0)
    sim.v.params.set("MPC_VEL_MAN_SIDE", 4.0)
    take_off(sim)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    fly(sim, 8.0, Sticks(pitch=-1.0))  # full back: MPC_VEL_MAN_BACK
    assert sim.v.state.velocity_ned_mps[0] == pytest.approx(-2.0, abs=0.15)
    fly(sim, 6.0, CENTRED)
    fly(sim, 8.0, Sticks(roll=1.0))  # full right: MPC_VEL_MAN_SIDE
    assert sim.v.state.velocity_ned_mps[1] == pytest.approx(4.0, abs=0.2)
    assert abs(sim.v.state.velocity_ned_mps[0]) < 0.2


def test_set_velocity_limits_on_the_wire_and_do_set_mode_position_slow():
    """A client's SET_VELOCITY_LIMITS (development.xml, id 354, CRC_EXTRA 210) reaches the
    vehicle whatever its target fields; DO_SET_MODE POSCTL/SLOW is Position Slow."""
    assert SET_VELOCITY_LIMITS.id == 354 and development.mavlink_map[354] is SET_VELOCITY_LIMITS
    with LockstepSim(1) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
        api.send(SET_VELOCITY_LIMITS(9, 9, 2.5, math.nan, 0.5))
        sim.run_until(lambda: False, timeout_s=0.2)
        assert sim.vehicles[0]._autopilot.velocity_limits.last[0] == 2.5
        assert math.isnan(sim.vehicles[0]._autopilot.velocity_limits.last[1])
        api.send(SET_VELOCITY_LIMITS(1, 1, math.inf, 3e38, -1.0))  # hostile values: stored
        sim.run_until(lambda: False, timeout_s=0.2)
        assert sim.vehicles[0]._autopilot.velocity_limits.last[:2] == (math.inf,
                                                                     pytest.approx(3e38))
        # QGC's or MAVSDK's mode change: custom main mode POSCTL (3), sub mode SLOW (2); armed
        # it needs stick input (disarmed, PX4 grants any mode)
        assert api.arm() == 0
        assert api.command_long(176, 1, 3, 2) == 1  # TEMPORARILY_REJECTED: no sticks yet
        api.send(api.mav.manual_control_encode(1, 0, 0, 500, 0, 0))
        assert api.command_long(176, 1, 3, 2) == 0
        assert sim.run_until(lambda: sim.status(0).nav_state is NavState.POSITION_SLOW,
                             timeout_s=2)
        assert sim.simulation.internal_errors == 0
