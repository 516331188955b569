"""Offboard mode and the actions (goto / change_speed / set_home / terminate) on the World."""

import math

import numpy as np
import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from vehicles.control.quat import q_yaw
from vehicles.plan_types import OffboardSetpoint
from vehicles.types import CommandResult, GeoPoint, LandedState, NavState

NAN = math.nan


@pytest.fixture
def sim():
    s = Sim()
    s.run(1.2)
    yield s
    s.close()


def stream(sim, sp, seconds, until=None):
    """Send ``sp`` at 20 Hz (MAVSDK's resend rate) while the world runs."""
    steps = int(round(0.05 / sim.world.dt_s))
    for _ in range(int(round(seconds / 0.05))):
        sim.v.set_offboard_setpoint(sim.t, sp)
        for _ in range(steps):
            sim.world.step(sim.t)
            sim.t = sim.world.time_s
        if until is not None and until():
            return True
    return False


def start_offboard(sim, sp):
    """Disarmed, Offboard is granted without a setpoint; arming needs one (offboard signal)."""
    v = sim.v
    if not v.status.armed:
        assert v.set_nav_state(sim.t, NavState.OFFBOARD) is CommandResult.ACCEPTED
        assert v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED
    v.set_offboard_setpoint(sim.t, sp)
    assert v.set_nav_state(sim.t, NavState.OFFBOARD) is CommandResult.ACCEPTED
    assert v.arm(sim.t) is CommandResult.ACCEPTED


def test_offboard_refused_with_stale_setpoint(sim):
    v = sim.v
    assert v.arm(sim.t) is CommandResult.ACCEPTED  # (disarmed, any mode is granted)
    v.set_offboard_setpoint(sim.t, OffboardSetpoint(position_ned_m=(0, 0, -5)))
    sim.run(1.5)  # older than COM_OF_LOSS_T = 1 s
    assert v.set_nav_state(sim.t, NavState.OFFBOARD) is CommandResult.TEMPORARILY_REJECTED
    assert v.status.nav_state is NavState.AUTO_LOITER


def test_offboard_position_takeoff_and_steps(sim):
    v = sim.v
    sp = OffboardSetpoint(position_ned_m=(0.0, 0.0, -5.0), yaw_rad=0.0)
    start_offboard(sim, sp)  # armed on the ground in offboard: the setpoint above takes off
    for target in [(0.0, 0.0, -5.0), (10.0, 0.0, -5.0), (10.0, 10.0, -8.0)]:
        sp = OffboardSetpoint(position_ned_m=target, yaw_rad=math.radians(90))
        stream(sim, sp, 10.0)
        assert np.linalg.norm(v.state.position_ned_m - np.array(target)) < 0.7, target
    assert v.status.nav_state is NavState.OFFBOARD
    assert v.status.landed_state is LandedState.IN_AIR
    assert q_yaw(tuple(v.state.attitude_q)) == pytest.approx(math.radians(90), abs=0.05)


def test_offboard_velocity_with_yaw_rate(sim):
    v = sim.v
    take_off(sim)
    sp = OffboardSetpoint(velocity_ned_mps=(0.0, 0.0, 0.0))
    start_offboard(sim, sp)
    # A body-frame "2 m/s forward" already rotated to NED by the gateway, plus a yaw rate.
    sp = OffboardSetpoint(velocity_ned_mps=(2.0, 1.0, -0.5), yaw_rate_radps=0.3)
    yaw0 = q_yaw(tuple(v.state.attitude_q))
    stream(sim, sp, 4.0)
    vel = v.state.velocity_ned_mps
    assert np.allclose(vel, (2.0, 1.0, -0.5), atol=0.3)
    yaw1 = q_yaw(tuple(v.state.attitude_q))
    assert math.remainder(yaw1 - yaw0, math.tau) == pytest.approx(1.2, abs=0.25)


def test_a_yaw_rate_from_the_ground_builds_no_yaw_error(sim):
    """MAVSDK's offboard_velocity_body: climb at 1 m/s yawing at 60 deg/s from the ground. PX4's
    PositionControl takes the present heading as the yaw setpoint and the rate as feed-forward
    (nothing is integrated, and mc_pos_control clears it until the takeoff ramp): the vehicle
    climbs and yaws at the commanded rate, not at MC_YAWRATE_MAX. (The rate controller's
    integrator, held only while landed or maybe landed, winds up a little on the ground once the
    ramp's thrust leaves the land detector's minimum: the first turn overshoots by ~25 deg/s.)"""
    v = sim.v
    sp = OffboardSetpoint(velocity_ned_mps=(0.0, 0.0, -1.0), yaw_rate_radps=math.radians(60))
    start_offboard(sim, sp)
    rates = []
    for _ in range(32):  # 8 s: spool-up, takeoff ramp, climb
        yaw0 = q_yaw(tuple(v.state.attitude_q))
        stream(sim, sp, 0.25)
        rates.append(math.remainder(q_yaw(tuple(v.state.attitude_q)) - yaw0, math.tau) / 0.25)
    assert v.state.position_ned_m[2] < -1.5  # climbing (after the spool-up and the ramp)
    assert max(abs(r) for r in rates) < math.radians(90)  # never catching up on a built-up error
    assert sum(rates[-4:]) / 4 == pytest.approx(math.radians(60), abs=math.radians(15))


def test_offboard_attitude_and_thrust(sim):
    v = sim.v
    take_off(sim)
    hover = v.airframe.hover_thrust_norm
    level = OffboardSetpoint(attitude_q=(1.0, 0.0, 0.0, 0.0), thrust=hover + 0.05)
    start_offboard(sim, level)
    z0 = v.state.position_ned_m[2]
    stream(sim, level, 2.0)
    assert v.state.position_ned_m[2] < z0 - 0.3  # more than hover thrust climbs
    pitch = math.radians(-10)  # nose down: accelerate north
    q = (math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0)
    stream(sim, OffboardSetpoint(attitude_q=q, thrust=hover / math.cos(pitch)), 2.0)
    assert v.state.euler_rad()[1] == pytest.approx(pitch, abs=0.03)
    assert v.state.velocity_ned_mps[0] > 1.5


def test_offboard_attitude_yaw_rate_is_fed_forward(sim):
    """SET_ATTITUDE_TARGET's body yaw rate with an attitude: mavlink_receiver.cpp makes it
    yaw_sp_move_rate, which AttitudeControl adds to the rate setpoint about the world z axis
    (MAVROS's yaw-rate test flies on it)."""
    v = sim.v
    take_off(sim)
    level = (1.0, 0.0, 0.0, 0.0)
    sp = OffboardSetpoint(attitude_q=level, body_rates_frd_radps=(NAN, NAN, 0.3),
                          thrust=v.airframe.hover_thrust_norm)
    start_offboard(sim, sp)
    stream(sim, sp, 3.0)
    # the feed-forward turns it until the heading error's pull back matches it (a steady
    # offset from the setpoint's heading, no steady rate); without it the heading stays 0
    assert 0.08 < v.state.euler_rad()[2] < 0.4
    assert abs(v.state.rates_frd_radps[2]) < 0.05


def test_offboard_degenerate_attitude_stops_the_motors(sim):
    """A zero quaternion normalizes to NaN in AttitudeControl; the NaN motor commands go out as
    the disarmed value (MixingOutput::output_limit_calc_single): the vehicle falls while they
    last, and flies again on the next valid setpoint."""
    v = sim.v
    take_off(sim)
    hover = v.airframe.hover_thrust_norm
    start_offboard(sim, OffboardSetpoint(attitude_q=(1.0, 0.0, 0.0, 0.0), thrust=hover))
    z0 = v.state.position_ned_m[2]
    stream(sim, OffboardSetpoint(attitude_q=(NAN, NAN, NAN, NAN), thrust=hover), 0.5)
    assert v.state.velocity_ned_mps[2] > 2.0 and v.state.position_ned_m[2] > z0 + 0.5
    assert v.status.armed and max(sim.world.rotor_speeds(0)) < 0.5 * 769
    stream(sim, OffboardSetpoint(attitude_q=(1.0, 0.0, 0.0, 0.0), thrust=hover + 0.2), 0.5)
    assert v.state.velocity_ned_mps[2] < 2.0


def test_offboard_body_rates(sim):
    v = sim.v
    take_off(sim)
    hover = v.airframe.hover_thrust_norm
    sp = OffboardSetpoint(body_rates_frd_radps=(0.0, 0.0, 0.5), thrust=hover)
    start_offboard(sim, sp)
    stream(sim, sp, 1.0)
    assert v.state.rates_frd_radps[2] == pytest.approx(0.5, abs=0.1)


def test_offboard_loss_holds_then_returns(sim):
    v = sim.v
    take_off(sim)
    sp = OffboardSetpoint(position_ned_m=(15.0, 0.0, -5.0))
    start_offboard(sim, sp)
    stream(sim, sp, 6.0)
    lost_at = sim.t
    assert sim.run(3.0, until=lambda: v.status.failsafe)
    assert v.status.nav_state is NavState.AUTO_LOITER  # COM_FAIL_ACT_T hold first
    assert sim.t - lost_at == pytest.approx(1.0, abs=0.1)  # COM_OF_LOSS_T
    assert "Failsafe activated: entering Hold for 5 seconds\t" in sim.texts()
    assert sim.run(6.0, until=lambda: v.status.nav_state is NavState.AUTO_RTL)
    assert sim.t - lost_at == pytest.approx(6.0, abs=0.2)
    assert sim.texts()[-3:].count("Failsafe activated\t") == 1
    assert sim.run(60.0, until=lambda: not v.status.armed)
    p = v.state.position_ned_m
    assert math.hypot(p[0], p[1]) < 1.5
    # disarmed: the failsafe is gone and the mode is the one asked for, Offboard (onDisarm)
    assert v.status.nav_state is NavState.OFFBOARD and not v.status.failsafe


# --- actions ---------------------------------------------------------------------------------
def test_goto_35m_at_15m(sim):
    v = sim.v
    take_off(sim)
    g = v.origin.offset_ned(25.0, -24.5, -15.0)
    assert v.goto(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m, math.radians(45)) is CommandResult.ACCEPTED
    assert v.status.nav_state is NavState.AUTO_LOITER
    sim.run(20.0)
    assert np.linalg.norm(v.state.position_ned_m - np.array((25.0, -24.5, -15.0))) < 1.5
    assert q_yaw(tuple(v.state.attitude_q)) == pytest.approx(math.radians(45), abs=0.05)
    # NaN lat/lon keeps the position, a new altitude only climbs.
    assert v.goto(sim.t, math.nan, math.nan, g.alt_amsl_m + 5.0) is CommandResult.ACCEPTED
    sim.run(8.0)
    assert np.linalg.norm(v.state.position_ned_m - np.array((25.0, -24.5, -20.0))) < 1.0


def test_goto_speed_and_change_speed(sim):
    v = sim.v
    take_off(sim)
    g = v.origin.offset_ned(60.0, 0.0, -2.5)
    assert v.change_speed(sim.t, 10.0) is CommandResult.ACCEPTED
    v.goto(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m)
    top = 0.0
    def fast():
        nonlocal top
        top = max(top, v.state.velocity_ned_mps[0])
        return False
    sim.run(6.0, until=fast)
    assert top == pytest.approx(10.0, abs=1.0)
    v.change_speed(sim.t, -1.0)  # back to MPC_XY_CRUISE 5 m/s
    g = v.origin.offset_ned(0.0, 0.0, -2.5)
    v.goto(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m, speed_mps=3.0)
    top = 0.0
    def slow():
        nonlocal top
        top = max(top, -v.state.velocity_ned_mps[0])
        return False
    sim.run(10.0, until=slow)
    assert top == pytest.approx(3.0, abs=0.5)


def test_goto_on_the_ground_takes_off_to_the_target_when_armed(sim):
    """PX4 loiter.cpp reposition(): armed is all a reposition needs; the auto flight task then
    takes off towards a target above (MAVSDK's goto example: arm, takeoff, goto 1 s later)."""
    v = sim.v
    g = v.origin.offset_ned(20.0, 0.0, -10.0)
    assert v.goto(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m) is CommandResult.ACCEPTED
    sim.run(3.0)  # disarmed: the reposition is not kept (navigator_main.cpp: only when armed)
    assert v.status.landed_state is LandedState.ON_GROUND
    v.arm(sim.t)
    sim.run(1.0)
    assert v.status.landed_state is LandedState.ON_GROUND  # Hold on the ground: idle
    assert v.goto(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m) is CommandResult.ACCEPTED
    sim.run(15.0)
    n, e, d = v.state.position_ned_m
    assert v.status.landed_state is LandedState.IN_AIR
    assert (n, e, d) == pytest.approx((20.0, 0.0, -10.0), abs=1.0)


def test_set_home_and_terminate(sim):
    v = sim.v
    here = v.global_position
    target = GeoPoint(here.lat_deg + 1e-4, here.lon_deg, here.alt_amsl_m + 3.0)
    assert v.set_home(sim.t, target) is CommandResult.ACCEPTED
    assert v.status.home.geo == target
    assert v.status.home.position_ned_m[2] == pytest.approx(-3.0, abs=1e-3)
    assert v.set_home(sim.t, GeoPoint(math.nan, 0.0, 0.0)) is CommandResult.DENIED
    assert v.set_home(sim.t, None) is CommandResult.ACCEPTED
    assert v.status.home.geo.alt_amsl_m == pytest.approx(here.alt_amsl_m, abs=0.01)
    assert v.terminate(sim.t) is CommandResult.DENIED  # disarmed
    take_off(sim)
    assert v.terminate(sim.t) is CommandResult.ACCEPTED
    assert v.status.nav_state is NavState.TERMINATION and v.status.terminated
    sim.run(2.0)
    assert v.state.position_ned_m[2] > -0.3  # fell
    assert v.arm(sim.t) is CommandResult.ACCEPTED or not v.status.prearm_ok
