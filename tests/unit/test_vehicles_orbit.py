"""Orbit (DO_ORBIT → vehicles/orbit.py): physics + autopilot on simulated time."""

import math

import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from vehicles.orbit import sanitize
from vehicles.types import CommandResult, NavState


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def test_sanitize_lowers_the_speed_before_the_radius():
    assert sanitize(5.0, 10.0) == (5.0, pytest.approx(math.sqrt(10.0)))  # v²/r ≤ 2 m/s²
    assert sanitize(0.2, -1.0) == (1.0, -1.0)
    assert sanitize(500.0, 20.0) == (100.0, 10.0)


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
        assert -d == pytest.approx(6.0, abs=0.5)
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
    from vehicles.manual_control import Sticks

    take_off(sim)
    assert sim.v.orbit(sim.t, 10.0, 2.0) is CommandResult.ACCEPTED
    sim.run(0.1)
    task = sim.v._autopilot.orbit_task
    end = sim.t + 1.0
    while sim.t < end:  # pitch back (−) widens the circle: + RADIUS_MAX / 8 per second
        sim.v.manual_control(sim.t, Sticks(pitch=-1.0))
        sim.run(0.05)
    assert task.radius == pytest.approx(10.0 + 100.0 / 8.0, abs=1.0)
    assert task.velocity == pytest.approx(2.0)
