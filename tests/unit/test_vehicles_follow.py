"""Follow Me (FOLLOW_TARGET → vehicles/follow_target.py): physics + autopilot on simulated time."""

import math

import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from vehicles.types import CommandResult, NavState


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def report(sim, n, e, vn=0.0, ve=0.0):
    g = sim.v.origin.offset_ned(n, e, 0.0)
    sim.v.set_follow_target(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m, (vn, ve, 0.0))


def test_follow_me_follows_a_walking_target_from_behind(sim):
    take_off(sim)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_FOLLOW_TARGET) is CommandResult.ACCEPTED
    # A target walking east at 2 m/s, reported once a second (as MAVSDK's follow_me sends).
    n0, e0 = 10.0, 0.0
    for k in range(40):
        report(sim, n0, e0 + 2.0 * k, 0.0, 2.0)
        sim.run(1.0)
    tn, te = n0, e0 + 2.0 * 40
    pn, pe, pd = sim.v.state.position_ned_m
    assert -pd == pytest.approx(8.0, abs=0.5)  # FLW_TGT_HT above home
    assert math.hypot(pn - tn, pe - te) == pytest.approx(8.0, abs=1.5)  # FLW_TGT_DST
    assert pe < te - 6.0 and abs(pn - tn) < 2.0  # behind (FLW_TGT_FA 180): west of it
    assert sim.v.state.velocity_ned_mps[1] == pytest.approx(2.0, abs=0.4)
    heading = sim.v.state.euler_rad()[2]
    assert abs(math.remainder(heading - math.pi / 2, math.tau)) < math.radians(15)  # at the target


def test_follow_me_without_target_holds_and_cannot_arm(sim):
    take_off(sim)
    start = sim.v.state.position_ned_m.copy()
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_FOLLOW_TARGET) is CommandResult.ACCEPTED
    sim.run(5.0)  # no target yet: the velocity setpoint is zero where it is
    assert math.dist(start, sim.v.state.position_ned_m) < 0.5
    sim.v.land(sim.t)
    assert sim.run(40.0, until=lambda: not sim.v.status.armed)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_FOLLOW_TARGET) is CommandResult.ACCEPTED
    assert sim.v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED


def test_a_lost_target_is_followed_where_it_was_last_seen(sim):
    """TargetEstimator: after 3 s without a report the estimate stops moving but stays valid,
    so the vehicle takes its place FLW_TGT_DST behind the last position; the course starts
    north, so behind (FLW_TGT_FA 180) is south of it."""
    take_off(sim)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_FOLLOW_TARGET) is CommandResult.ACCEPTED
    report(sim, 20.0, 0.0)
    sim.run(30.0)
    pn, pe, pd = sim.v.state.position_ned_m
    assert (pn, pe) == pytest.approx((12.0, 0.0), abs=0.5)
    assert -pd == pytest.approx(8.0, abs=0.3)  # FLW_TGT_HT above home
    assert abs(math.remainder(sim.v.state.euler_rad()[2], math.tau)) < math.radians(5)  # at it
    assert sim.v.status.nav_state is NavState.AUTO_FOLLOW_TARGET


def test_the_orbit_angle_starts_north_of_the_target(sim):
    """The orbit angle trajectory starts at 0 (north) at activation and turns to the follow
    angle (180: -pi after wrap_pi, so through the west) at FLW_TGT_MAX_VEL."""
    take_off(sim)
    report(sim, 10.0, 0.0)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_FOLLOW_TARGET) is CommandResult.ACCEPTED
    west = 0.0
    for _ in range(150):
        sim.run(0.1)
        west = min(west, sim.v.state.position_ned_m[1])
    assert west < -4.0
    pn, pe, _ = sim.v.state.position_ned_m
    assert (pn, pe) == pytest.approx((2.0, 0.0), abs=0.6)


def test_a_report_without_velocity_is_still_followed(sim):
    """FOLLOW_TARGET with NaN velocities (a GCS without a velocity estimate): the position
    is fused, the velocity is not."""
    take_off(sim)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_FOLLOW_TARGET) is CommandResult.ACCEPTED
    g = sim.v.origin.offset_ned(-15.0, 0.0, 0.0)
    for _ in range(25):
        sim.v.set_follow_target(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m, (math.nan,) * 3)
        sim.run(1.0)
    pn, pe, _ = sim.v.state.position_ned_m
    assert math.hypot(pn + 15.0, pe) == pytest.approx(8.0, abs=0.5)


def test_the_throttle_stick_raises_the_follow_height():
    """The throttle trims the follow height at 1.5 m/s. The sticks do not take Follow Me over
    (COM_RC_OVERRIDE's default 1 is for the auto modes; control_mode.cpp clears Follow Target's
    auto flag: "Follow Target supports RC adjustment")."""
    from vehicles.manual_control import Sticks

    sim = Sim()
    take_off(sim)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_FOLLOW_TARGET) is CommandResult.ACCEPTED
    report(sim, 5.0, 0.0)
    for _ in range(200):  # 20 s with centred sticks (stick input present)
        sim.v.manual_control(sim.t, Sticks())
        sim.run(0.1)
    follow = sim.v._autopilot.follow_target
    assert follow.height == pytest.approx(8.0)
    for _ in range(20):
        sim.v.manual_control(sim.t, Sticks(throttle=1.0))
        sim.run(0.1)
    assert follow.height > 9.5
    for _ in range(60):
        sim.v.manual_control(sim.t, Sticks())
        sim.run(0.1)
    assert -sim.v.state.position_ned_m[2] == pytest.approx(follow.height, abs=0.3)
    assert sim.v.status.nav_state is NavState.AUTO_FOLLOW_TARGET
    sim.close()


def test_target_estimator_gains_and_stale_reports():
    from vehicles.follow_target import TargetEstimator
    from vehicles.params import ParamStore

    est = TargetEstimator(ParamStore({"FLW_TGT_RS": 0.1}))
    assert not est.update(0.0, None)  # the first run stamps the time
    assert est.update(0.5, (0.5, (1.0, 2.0, -3.0), (1.0, 0.0, 0.0)))
    assert est.valid and est.pos == (1.0, 2.0, -3.0) and est.vel == (1.0, 0.0, 0.0)
    beta = 0.1 ** (1.0 / 3.0)
    assert est._gains[0] == pytest.approx(1.0 - beta ** 3)
    est.update(1.0, None)
    assert est.pos[0] == pytest.approx(1.5)  # predicted with the velocity
    est.update(3.6, None)  # 3.1 s after the report: stale, no longer moving
    assert est.valid and est.vel == (0.0, 0.0, 0.0)
    x = est.pos[0]
    est.update(5.0, None)
    assert est.pos[0] == x
