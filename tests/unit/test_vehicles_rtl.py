"""Return mode (RTL_TYPE 0) against PX4 v1.15 navigator rtl.cpp / rtl_direct.cpp /
mission_block.cpp, flown on the physics World."""

import math
import re
from types import SimpleNamespace

import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from tests.unit.test_vehicles_mission import item
from vehicles.nav_rtl import RtlPhase, rtl_destination
from vehicles.plan_types import MavCmd, MavFrame, PlanType
from vehicles.plans import PlanStore
from vehicles.status_log import StatusLog
from vehicles.types import CommandResult, GeoPoint, HomePosition, NavState

ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)


def _ctx(position_ned_m, home=True):
    home_pos = HomePosition(ORIGIN, (0.0, 0.0, 0.0), 0.0) if home else None
    return SimpleNamespace(home=home_pos, origin=ORIGIN, position_ned_m=position_ned_m,
                           home_alt_amsl_m=ORIGIN.alt_amsl_m, log=StatusLog(), now_s=0.0)


def _rally(*points_ne, frames=None):
    """Rally points in MAV_FRAME_GLOBAL_RELATIVE_ALT (QGC's), or the given frames."""
    frames = frames or [MavFrame.GLOBAL_RELATIVE_ALT] * len(points_ne)
    plans = PlanStore()
    plans.set(PlanType.RALLY, [item(i, MavCmd.NAV_RALLY_POINT, n, e, 0.0, ORIGIN, frame=f,
                                    mission_type=PlanType.RALLY)
                               for i, ((n, e), f) in enumerate(zip(points_ne, frames))])
    return plans


@pytest.mark.parametrize("rally_ne, at_ned, expected_ne", [
    # findRtlDestination: a rally point within 10 m of home is ignored
    # (MAX_DIST_FROM_HOME_FOR_LAND_APPROACHES), however close to the vehicle.
    ((8.0, 0.0), (8.0, 0.0, -5.0), (0.0, 0.0)),
    ((12.0, 0.0), (12.0, 0.0, -5.0), (12.0, 0.0)),
    # ... and it has to be more than MIN_DIST_THRESHOLD (2 m) closer than home.
    ((30.0, 0.0), (15.5, 0.0, -5.0), (0.0, 0.0)),  # 14.5 m vs 15.5 m from home
    ((30.0, 0.0), (16.5, 0.0, -5.0), (30.0, 0.0)),  # 13.5 m vs 16.5 m
])
def test_rally_point_choice_follows_find_rtl_destination(rally_ne, at_ned, expected_ne):
    dest = rtl_destination(_ctx(at_ned), _rally(rally_ne))
    assert dest[:2] == pytest.approx(expected_ne, abs=0.05)


UNSUPPORTED = "RTL: unsupported MAV_FRAME\t"
G, REL, G_INT, REL_INT = (MavFrame.GLOBAL, MavFrame.GLOBAL_RELATIVE_ALT, MavFrame.GLOBAL_INT,
                          MavFrame.GLOBAL_RELATIVE_ALT_INT)


@pytest.mark.parametrize("points, frames, expected_ne, texts", [
    # setSafepointAsDestination knows frames 0 and 3 only
    ([(30.0, 0.0)], [G], (30.0, 0.0), 0),
    ([(30.0, 0.0)], [REL_INT], (0.0, 0.0), 1),
    ([(30.0, 0.0)], [G_INT], (0.0, 0.0), 1),
    # a point of another frame still wins on distance: the usable one behind it cannot beat it
    ([(30.0, 0.0), (28.0, 0.0)], [REL_INT, REL], (0.0, 0.0), 1),
    ([(28.0, 0.0), (30.0, 0.0)], [REL, REL_INT], (28.0, 0.0), 1),
    # every counted point is warned about, chosen or not; one within 10 m of home is not counted
    ([(30.0, 0.0), (-40.0, 0.0), (5.0, 0.0)], [REL, G_INT, REL_INT], (30.0, 0.0), 1),
    ([(30.0, 0.0), (-40.0, 0.0)], [REL_INT, G_INT], (0.0, 0.0), 2),
])
def test_rally_points_in_frames_rtl_cannot_use(points, frames, expected_ne, texts):
    """rtl.cpp findRtlDestination / setSafepointAsDestination (v1.15): a rally point stored in
    MAV_FRAME_GLOBAL_INT / GLOBAL_RELATIVE_ALT_INT (a MISSION_ITEM_INT client's frames) gets
    "RTL: unsupported MAV_FRAME" each time the destination is chosen, and gives no position."""
    ctx = _ctx((30.0, 0.0, -10.0))
    dest = rtl_destination(ctx, _rally(*points, frames=frames))
    assert dest[:2] == pytest.approx(expected_ne, abs=0.05)
    assert [t.text for t in ctx.log.after(0)] == [UNSUPPORTED] * texts
    ctx = _ctx((30.0, 0.0, -10.0))
    rtl_destination(ctx, _rally(*points, frames=frames), warn=False)
    assert ctx.log.after(0) == []
    ctx = _ctx((30.0, 0.0, -10.0), home=False)  # PX4's home at 0°/0°: every point counts
    rtl_destination(ctx, _rally(*points, frames=frames))
    assert len(ctx.log.after(0)) == sum(f not in (G, REL) for f in frames)


def test_unsupported_rally_frame_text_every_two_seconds_and_return_home():
    """On the vehicle: RTL picks its destination every 2 s while not returning (on_inactive,
    disarmed included) and on activation, each time with the text; the return goes home."""
    sim = Sim()
    try:
        v = sim.v
        sim.run(1.2)
        rally = [item(0, MavCmd.NAV_RALLY_POINT, 25.0, 0.0, 0.0, v.origin, frame=REL_INT,
                      mission_type=PlanType.RALLY)]
        assert v.set_plan(sim.t, PlanType.RALLY, rally) == 0
        t0 = sim.t
        sim.run(6.0)
        assert sim.texts().count(UNSUPPORTED) == 3  # ~2.05 s apart
        take_off(sim)
        v.reposition(sim.t, (22.0, 0.0, -5.0))
        sim.run(10.0)
        before = sim.texts().count(UNSUPPORTED)
        assert before >= 3 + int((sim.t - t0 - 6.0) / 2.1)
        assert v.return_to_launch(sim.t) is CommandResult.ACCEPTED
        sim.run(0.1)
        assert sim.texts().count(UNSUPPORTED) == before + 1  # on_activation
        assert sim.run(90.0, until=lambda: not v.status.armed)
        assert math.hypot(*v.state.position_ned_m[:2]) < 1.5  # home, not the rally point
    finally:
        sim.close()


def test_return_on_the_ground_stays_idle_but_says_where_it_would_return():
    """rtl_direct.cpp: armed and landed, getActivationLandState is IDLE (no climb, no landing),
    but on_activation still sends "RTL: start return at ..." (the cone over home: nothing above it)."""
    sim = Sim()
    try:
        v = sim.v
        sim.run(1.2)
        assert v.arm(sim.t) is CommandResult.ACCEPTED
        sim.run(0.5)
        assert v.return_to_launch(sim.t) is CommandResult.ACCEPTED
        sim.run(2.0)
        assert v.status.nav_state is NavState.AUTO_RTL
        assert v._autopilot.navigator.rtl.phase is RtlPhase.IDLE
        assert -v.state.position_ned_m[2] < 0.05  # never left the ground
        rtl = [t for t in sim.texts() if t.startswith("RTL")]
        # (home's altitude, rounded up: millimetres above it make 1 m)
        assert len(rtl) == 1 and re.fullmatch(
            r"RTL: start return at 48[89] m \([01] m above destination\)\t", rtl[0])
    finally:
        sim.close()


def test_return_lands_facing_home_yaw():
    """rtl_direct.cpp: from the descent (LOITER_DOWN) on, the items carry the destination's
    heading, home's yaw (WV_EN 0), and the descent is reached only within MIS_YAW_ERR of it."""
    sim = Sim(RTL_RETURN_ALT=8.0, RTL_DESCEND_ALT=4.0)
    try:
        v = sim.v
        take_off(sim)
        home_yaw = v.status.home.yaw_rad
        v.reposition(sim.t, (0.0, 25.0, -5.0))  # east: the way home faces west
        sim.run(15.0)
        assert v.return_to_launch(sim.t) is CommandResult.ACCEPTED
        rtl = v._autopilot.navigator.rtl
        assert sim.run(60.0, until=lambda: rtl.phase is RtlPhase.RETURN)
        assert sim.run(60.0, until=lambda: abs(v.state.euler_rad()[2] + math.pi / 2) < 0.1)
        assert sim.run(60.0, until=lambda: rtl.phase is RtlPhase.LAND)
        err = (v.state.euler_rad()[2] - home_yaw + math.pi) % (2 * math.pi) - math.pi
        assert abs(err) < math.radians(12.0)  # MIS_YAW_ERR
        assert sim.run(60.0, until=lambda: not v.status.armed)
        err = (v.state.euler_rad()[2] - home_yaw + math.pi) % (2 * math.pi) - math.pi
        assert abs(err) < math.radians(3.0)
    finally:
        sim.close()


def test_descent_starts_within_nav_acc_rad():
    """mission_block.cpp: the return waypoint is reached within NAV_ACC_RAD horizontally (and
    NAV_MC_ALT_RAD vertically), so the descent over the destination starts there."""
    sim = Sim(RTL_RETURN_ALT=10.0, RTL_DESCEND_ALT=5.0, RTL_CONE_ANG=0, NAV_ACC_RAD=8.0)
    try:
        v = sim.v
        take_off(sim)
        v.reposition(sim.t, (40.0, 0.0, -10.0))
        sim.run(20.0)
        assert v.return_to_launch(sim.t) is CommandResult.ACCEPTED
        rtl = v._autopilot.navigator.rtl
        assert sim.run(60.0, until=lambda: rtl.phase is RtlPhase.DESCEND)
        assert 4.0 < math.hypot(*v.state.position_ned_m[:2]) <= 8.0
    finally:
        sim.close()


def test_land_delay_minus_one_loiters_for_ever():
    """RTL_LAND_DELAY -1: setLoiterHoldMissionItem makes a LOITER_UNLIMITED item, "RTL:
    completed, loitering" once the descent is reached."""
    sim = Sim(RTL_RETURN_ALT=8.0, RTL_DESCEND_ALT=4.0, RTL_LAND_DELAY=-1.0)
    try:
        v = sim.v
        take_off(sim)
        v.reposition(sim.t, (20.0, 0.0, -5.0))
        sim.run(12.0)
        assert v.return_to_launch(sim.t) is CommandResult.ACCEPTED
        sim.run(60.0)
        assert v.status.armed and v.status.nav_state is NavState.AUTO_RTL
        assert -v.state.position_ned_m[2] == pytest.approx(4.0, abs=0.5)
        texts = [t for t in sim.texts() if t.startswith("RTL")]
        assert texts[-1] == "RTL: completed, loitering\t"
        assert "RTL: land at destination\t" not in texts
    finally:
        sim.close()
