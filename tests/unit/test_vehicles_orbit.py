"""Orbit (DO_ORBIT → vehicles/orbit.py): physics + autopilot on simulated time."""

import math

import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from vehicles.events import ORBIT_RADIUS_EXCEEDED, Log
from vehicles.manual_control import Sticks
from vehicles.orbit import sanitize
from vehicles.types import CommandResult, NavState


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def test_sanitize_lowers_the_speed_before_the_radius():
    assert sanitize(5.0, 10.0, 1000.0) == (5.0, pytest.approx(math.sqrt(10.0)))  # v²/r < 2 m/s²
    assert sanitize(0.2, -1.0, 1000.0) == (1.0, -1.0)
    assert sanitize(500.0, 20.0, 1000.0) == (500.0, 10.0)
    assert sanitize(2000.0, -20.0, 1000.0) == (1000.0, -10.0)  # MC_ORBIT_RAD_MAX


@pytest.mark.parametrize("radius", [10.0, -10.0])
def test_orbit_flies_the_circle_nose_to_the_centre(sim, radius):
    take_off(sim)
    v = sim.v
    origin = v.origin
    center = origin.offset_ned(20.0, 0.0, 0.0)
    alt = origin.alt_amsl_m + 6.0
    assert v.orbit(sim.t, radius, 2.0, math.nan, center.lat_deg, center.lon_deg, alt) \
        is CommandResult.ACCEPTED
    assert v.status.nav_state is NavState.ORBIT
    sim.run(25.0)  # approach (~8 m) and settle
    angles = []
    for _ in range(40):
        sim.run(0.25)
        n, e, d = v.state.position_ned_m
        assert math.hypot(n - 20.0, e) == pytest.approx(10.0, abs=0.8)
        # the approach ends within NAV_MC_ALT_RAD (0.8 m) of the altitude, and the altitude
        # task holds where its smoothing stops
        assert -d == pytest.approx(6.0, abs=0.8)
        assert math.hypot(*v.state.velocity_ned_mps[:2]) == pytest.approx(2.0, abs=0.4)
        to_center = math.atan2(-e, 20.0 - n)
        assert abs(math.remainder(v.state.euler_rad()[2] - to_center, math.tau)) < math.radians(10)
        angles.append(math.atan2(e, n - 20.0))
    turned = sum(math.remainder(b - a, math.tau) for a, b in zip(angles, angles[1:]))
    assert turned == pytest.approx(math.copysign(2.0 * 10.0 / 10.0, radius), abs=0.3)  # ω t
    st = v.orbit_status
    assert st.radius_m == radius and st.center_ne_m == pytest.approx((20.0, 0.0), abs=1e-6)


def test_orbit_is_refused_for_arming_and_left_by_a_mode_change(sim):
    take_off(sim)
    assert sim.v.orbit(sim.t, 5.0) is CommandResult.ACCEPTED
    sim.run(5.0)
    assert sim.v.status.armed and sim.v.status.nav_state is NavState.ORBIT
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    sim.run(0.1)
    assert sim.v.orbit_status is None
    assert sim.v.land(sim.t) is CommandResult.ACCEPTED
    assert sim.run(30.0, until=lambda: not sim.v.status.armed)
    assert sim.v.orbit(sim.t, 5.0) is CommandResult.ACCEPTED  # the mode, on the ground
    assert sim.v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED  # PX4: no arming in Orbit


def test_sticks_trim_the_orbit_radius_and_speed(sim):
    take_off(sim)
    assert sim.v.orbit(sim.t, 10.0, 2.0) is CommandResult.ACCEPTED
    sim.run(0.1)
    task = sim.v._autopilot.orbit_task
    end = sim.t + 1.0
    while sim.t < end:  # pitch back (−) widens the circle by MPC_XY_CRUISE (5 m/s) a second
        sim.v.manual_control(sim.t, Sticks(pitch=-1.0))
        sim.run(0.05)
    assert task.radius == pytest.approx(10.0 + 5.0, abs=0.3)
    assert task.velocity == pytest.approx(2.0)
    end = sim.t + 0.5
    while sim.t < end:  # roll left (−) speeds it up by MPC_ACC_HOR (3 m/s²)
        sim.v.manual_control(sim.t, Sticks(roll=-1.0))
        sim.run(0.05)
    assert task.velocity == pytest.approx(2.0 + 1.5, abs=0.2)


def test_a_radius_beyond_the_old_100_m_cap_is_flown(sim):
    """MC_ORBIT_RAD_MAX (1000 m by default) bounds the radius, not a constant."""
    take_off(sim)
    assert sim.v.orbit(sim.t, -150.0, 3.0) is CommandResult.ACCEPTED
    sim.run(0.1)
    st = sim.v.orbit_status
    assert st.radius_m == -150.0
    assert sim.v._autopilot.orbit_task.velocity == -3.0


@pytest.mark.parametrize("radius", [0.5, -1500.0])
def test_a_radius_out_of_range_is_refused_and_the_vehicle_holds(sim, radius):
    """FlightTaskOrbit::applyCommandParameters fails (the mode switch was accepted), and
    FlightModeManager flies FlightTaskFailsafe's setpoint: hold here; a new DO_ORBIT orbits."""
    v = sim.v
    take_off(sim)
    mark = v.events.latest
    here = v.state.position_ned_m
    assert v.orbit(sim.t, radius, 2.0) is CommandResult.ACCEPTED
    sim.run(0.1)
    assert "Orbit radius limit exceeded\t" in sim.texts()
    assert [(e.id, e.log_levels & 0xF) for e in v.events.after(mark)] == \
        [(ORBIT_RADIUS_EXCEEDED.id, Log.ALERT)]
    sim.run(5.0)
    assert v.status.nav_state is NavState.ORBIT and v.orbit_status is None
    assert math.dist(v.state.position_ned_m, here) < 0.3
    assert v.orbit(sim.t, 5.0, 2.0) is CommandResult.ACCEPTED
    sim.run(0.1)
    assert v.orbit_status.radius_m == 5.0


def test_off_the_circle_by_the_altitude_stick_it_circles_on_until_a_new_command(sim):
    """Only activation and a DO_ORBIT start the approach: the throttle stick moves the altitude
    (and the reported one) but not the centre's, and a later DO_ORBIT flies back to it."""
    v = sim.v
    take_off(sim)
    alt = v.origin.alt_amsl_m + 6.0
    center = v.origin.offset_ned(10.0, 0.0, 0.0)
    assert v.orbit(sim.t, 10.0, 2.0, math.nan, center.lat_deg, center.lon_deg, alt) \
        is CommandResult.ACCEPTED
    task = v._autopilot.orbit_task
    assert sim.run(0.1, until=lambda: task.approaching)  # the next autopilot tick starts it
    assert sim.run(20.0, until=lambda: not task.approaching)
    end = sim.t + 1.0
    while sim.t < end:  # climb at the stick's MPC_Z_VEL_MAX_UP
        v.manual_control(sim.t, Sticks(throttle=1.0))
        sim.run(0.05)
    while sim.t < end + 4.0:  # centred: the altitude locks where it stops
        v.manual_control(sim.t, Sticks())
        sim.run(0.05)
    assert -v.state.position_ned_m[2] > 7.0 and not task.approaching
    assert -v.orbit_status.down_m == pytest.approx(-v.state.position_ned_m[2], abs=0.3)
    assert task.center[2] == pytest.approx(-6.0)
    assert v.orbit(sim.t, 10.0) is CommandResult.ACCEPTED
    sim.run(0.1)
    assert task.approaching
    end = sim.t + 15.0
    while task.approaching and sim.t < end:  # the sticks stay (no RC loss failsafe)
        v.manual_control(sim.t, Sticks())
        sim.run(0.05)
    assert not task.approaching and v.status.nav_state is NavState.ORBIT
    assert -v.state.position_ned_m[2] == pytest.approx(6.0, abs=0.8)


def test_an_uncontrolled_heading_stays_uncontrolled_in_that_orbit(sim):
    """SlewRateYaw keeps the NaN of ORBIT_YAW_BEHAVIOUR_UNCONTROLLED, whatever comes next."""
    take_off(sim)
    task = sim.v._autopilot.orbit_task
    assert sim.v.orbit(sim.t, 3.0, 1.0, 2.0) is CommandResult.ACCEPTED
    assert sim.run(0.1, until=lambda: task.approaching)  # the next autopilot tick starts it
    assert sim.run(10.0, until=lambda: not task.approaching)
    sim.run(0.1)
    assert math.isnan(task.yaw_setpoint)
    assert sim.v.orbit(sim.t, 3.0, 1.0, 0.0) is CommandResult.ACCEPTED
    sim.run(1.0)
    assert task.yaw_behaviour == 0 and math.isnan(task.yaw_setpoint)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    sim.run(0.1)
    assert sim.v.orbit(sim.t, 3.0, 1.0) is CommandResult.ACCEPTED  # a new task
    sim.run(0.1)
    assert math.isfinite(task.yaw_setpoint)
