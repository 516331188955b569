"""The region of interest in a mission (PX4 v1.15.2 navigator_main.cpp: the ROI commands replace
``_vroi``; mission_block.cpp issue_command: ROI items publish those commands; mission_base.cpp
heading_sp_update: a multicopter's mission points its heading at the ROI), flown on the World."""

import math
from dataclasses import replace
from types import SimpleNamespace

import pytest

from tests.unit.test_vehicles_flight import Sim
from tests.unit.test_vehicles_mission import item, waypoints
from vehicles.nav_core import NavSetpoint
from vehicles.nav_roi import (
    DO_SET_ROI,
    DO_SET_ROI_LOCATION,
    DO_SET_ROI_NONE,
    DO_SET_ROI_WPNEXT_OFFSET,
    NAV_ROI,
    NO_ROI,
    ROI_LOCATION,
    ROI_NONE,
    ROI_WPINDEX,
    ROI_WPNEXT,
    Roi,
    RoiHeading,
    VehicleRoi,
    command_of_item,
    heading_at,
    roi_of_command,
)
from vehicles.params import ParamStore
from vehicles.plan_types import MavCmd, MavFrame, PlanResult, PlanType
from vehicles.types import CommandResult, GeoPoint, NavState

LEGS = [(60.0, 0.0, 10.0), (60.0, 60.0, 10.0), (0.0, 60.0, 10.0)]
ROI_NE = (-40.0, -40.0)  # south-west of every leg: never the way the vehicle flies
NORTH, EAST, SOUTH = 0.0, math.pi / 2, math.pi
TOL = math.radians(4.0)


def heading(v):
    return v.state.euler_rad()[2]


def bearing_to(v, n, e):
    p = v.state.position_ned_m
    return math.atan2(e - p[1], n - p[0])


def off(a, b):
    return abs(math.remainder(a - b, math.tau))


def roi_params(v, n, e):
    g = v.origin.offset_ned(n, e, 0.0)
    return (0.0, 0.0, 0.0, 0.0, g.lat_deg, g.lon_deg, g.alt_amsl_m)


def nav(v):
    return v._autopilot.navigator


def start(sim, items):
    """The mission flown from the ground; returns once it is on its first leg, up and away."""
    v = sim.v
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(30.0, until=lambda: v.state.position_ned_m[0] > 10.0)
    return v


def worst_on_leg(sim, seq, aim, settle_s=4.0, seconds=5.0):
    """The largest heading error from ``aim(v)`` sampled every 0.2 s while item ``seq`` is flown
    (from ``settle_s`` after it starts), and the fastest horizontal speed seen meanwhile."""
    v = sim.v
    assert sim.run(60.0, until=lambda: v.mission_status.current_seq == seq)
    sim.run(settle_s)
    worst = fastest = 0.0
    for _ in range(int(seconds / 0.2)):
        sim.run(0.2)
        assert v.mission_status.current_seq == seq
        worst = max(worst, off(heading(v), aim(v)))
        fastest = max(fastest, math.hypot(*v.state.velocity_ned_mps[:2]))
    return worst, fastest


def towards_roi(v):
    return bearing_to(v, *ROI_NE)


@pytest.fixture
def sim():
    s = Sim()
    s.run(1.2)
    yield s
    s.close()


def test_without_roi_the_legs_are_flown_facing_their_waypoints(sim):
    """The reference: the auto task's own heading (MPC_YAW_MODE 0) faces each target."""
    start(sim, waypoints(sim.v, LEGS))
    for seq, aim in ((1, EAST), (2, SOUTH)):
        worst, _ = worst_on_leg(sim, seq, lambda v, aim=aim: aim)
        assert worst < TOL, (seq, math.degrees(worst))


def test_roi_location_command_points_the_heading_at_it_while_the_legs_are_flown(sim):
    v = start(sim, waypoints(sim.v, LEGS))
    assert v.set_roi(sim.t, DO_SET_ROI_LOCATION, roi_params(v, *ROI_NE)) is CommandResult.ACCEPTED
    assert nav(v).roi.current.mode == ROI_LOCATION
    for seq in (1, 2):
        worst, fastest = worst_on_leg(sim, seq, towards_roi)
        assert worst < TOL, (seq, math.degrees(worst))
        assert fastest > 3.0  # still flying the leg, sideways or backwards
    assert sim.run(30.0, until=lambda: v.mission_status.reached_seq == 2)


def test_roi_location_item_points_the_heading_at_it_from_that_item_on(sim):
    o = sim.v.origin
    items = [item(0, MavCmd.NAV_WAYPOINT, 60.0, 0.0, 10.0, o),
             item(1, DO_SET_ROI_LOCATION, *ROI_NE, 0.0, o),
             item(2, MavCmd.NAV_WAYPOINT, 60.0, 60.0, 10.0, o),
             item(3, MavCmd.NAV_WAYPOINT, 0.0, 60.0, 10.0, o)]
    v = start(sim, items)
    worst, _ = worst_on_leg(sim, 0, lambda v: NORTH, settle_s=0.0, seconds=3.0)
    assert worst < TOL, math.degrees(worst)
    assert nav(v).roi.current == NO_ROI
    for seq, settle_s in ((2, 6.0), (3, 4.0)):  # first a 160° turn to the ROI
        worst, _ = worst_on_leg(sim, seq, towards_roi, settle_s)
        assert worst < TOL, (seq, math.degrees(worst))
    roi = nav(v).roi.current
    g = o.offset_ned(*ROI_NE, 0.0)
    assert roi.mode == ROI_LOCATION
    assert (roi.lat_deg, roi.lon_deg) == pytest.approx((g.lat_deg, g.lon_deg), abs=1e-7)
    # issue_command: the relative altitude plus home's
    assert roi.alt_amsl_m == pytest.approx(v.status.home.geo.alt_amsl_m, abs=1e-3)


def test_roi_none_command_clears_it_and_the_next_item_faces_its_waypoint(sim):
    v = start(sim, waypoints(sim.v, LEGS))
    v.set_roi(sim.t, DO_SET_ROI_LOCATION, roi_params(v, *ROI_NE))
    worst, _ = worst_on_leg(sim, 1, towards_roi, seconds=1.0)
    assert worst < TOL
    assert v.set_roi(sim.t, DO_SET_ROI_NONE, (0.0,) * 7) is CommandResult.ACCEPTED
    assert nav(v).roi.current == NO_ROI
    # the heading written into the current item stays until the next one
    held = heading(v)
    sim.run(1.0)
    assert v.mission_status.current_seq == 1 and off(heading(v), held) < TOL
    worst, _ = worst_on_leg(sim, 2, lambda v: SOUTH)
    assert worst < TOL, math.degrees(worst)


def test_a_new_mission_upload_forgets_the_roi(sim):
    v = start(sim, waypoints(sim.v, LEGS))
    v.set_roi(sim.t, DO_SET_ROI_LOCATION, roi_params(v, *ROI_NE))
    worst, _ = worst_on_leg(sim, 1, towards_roi, seconds=1.0)
    assert worst < TOL
    # update_mission's reset_vroi: the new mission (at the same index) faces its waypoints
    new = waypoints(v, [(60.0, 0.0, 10.0), (60.0, 90.0, 10.0), (0.0, 90.0, 10.0)])
    assert v.set_plan(sim.t, PlanType.MISSION, new) is PlanResult.ACCEPTED
    assert nav(v).roi.current == NO_ROI
    worst, _ = worst_on_leg(sim, 1, lambda v: EAST)
    assert worst < TOL, math.degrees(worst)


def test_reactivating_the_mission_forgets_the_roi(sim):
    """MissionBase::on_activation → update_mission → reset_vroi: a ROI set before the mission
    (re)starts is not used."""
    v = start(sim, waypoints(sim.v, LEGS))
    v.set_roi(sim.t, DO_SET_ROI_LOCATION, roi_params(v, *ROI_NE))
    assert v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    sim.run(0.5)
    assert nav(v).roi.current.mode == ROI_LOCATION  # Loiter neither reads nor resets it
    assert v.set_nav_state(sim.t, NavState.AUTO_MISSION) is CommandResult.ACCEPTED
    sim.run(0.1)
    assert nav(v).roi.current == NO_ROI


def test_mis_mnt_yaw_ctl_leaves_the_heading_to_the_mount():
    """MIS_MNT_YAW_CTL 1: the mount, not the vehicle, points at the ROI."""
    s = Sim(MIS_MNT_YAW_CTL=1)
    try:
        s.run(1.2)
        v = start(s, waypoints(s.v, LEGS))
        v.set_roi(s.t, DO_SET_ROI_LOCATION, roi_params(v, *ROI_NE))
        worst, _ = worst_on_leg(s, 1, lambda v: EAST)
        assert worst < TOL, math.degrees(worst)
    finally:
        s.close()


def test_roi_wpnext_offset_faces_the_current_waypoint_turned_by_the_offset(sim):
    v = start(sim, waypoints(sim.v, LEGS))
    v.set_roi(sim.t, DO_SET_ROI_WPNEXT_OFFSET, (0.0, 0.0, 0.0, 0.0, 5.0, 0.0, 90.0))
    assert nav(v).roi.current.yaw_offset_rad == pytest.approx(math.pi / 2)
    worst, _ = worst_on_leg(sim, 1, lambda v: bearing_to(v, 60.0, 60.0) + math.pi / 2)
    assert worst < TOL, math.degrees(worst)


def test_within_the_acceptance_radius_of_the_roi_the_heading_is_held(sim):
    """heading_sp_update turns no further closer than NAV_ACC_RAD (2 m) to the ROI: holding a
    waypoint 1 m west of it keeps the heading the vehicle came with, not east at the ROI."""
    o = sim.v.origin
    items = [item(0, MavCmd.NAV_WAYPOINT, 20.0, 0.0, 10.0, o),
             item(1, DO_SET_ROI_LOCATION, 40.0, 21.0, 0.0, o),
             item(2, MavCmd.NAV_WAYPOINT, 40.0, 20.0, 10.0, o, p1=8.0)]
    v = sim.v
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(60.0, until=lambda: v.mission_status.reached_seq == 2)
    sim.run(2.0)
    # the bearing 2 m short of the ROI on the track from the first waypoint (~67°)
    held = heading(v)
    assert math.radians(50.0) < held < math.radians(80.0), math.degrees(held)
    for _ in range(20):  # the rest of the hold, on the waypoint
        sim.run(0.2)
        p = v.state.position_ned_m
        assert math.hypot(p[0] - 40.0, p[1] - 20.0) < 0.5
        assert off(heading(v), held) < math.radians(1.0)
        assert off(heading(v), towards_roi(v)) > math.radians(15.0)  # east, 1 m away


# --- the pieces --------------------------------------------------------------------------------
ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)


def test_heading_at_is_none_within_the_acceptance_radius():
    roi = VehicleRoi(ROI_LOCATION, *(ORIGIN.offset_ned(0.0, 1.5, 0.0).lat_deg,
                                     ORIGIN.offset_ned(0.0, 1.5, 0.0).lon_deg), 488.0)
    assert math.isnan(heading_at(roi, ORIGIN, (0.0, 0.0, -5.0), (9.0, 9.0, -5.0), 2.0))
    assert heading_at(roi, ORIGIN, (0.0, 0.0, -5.0), (9.0, 9.0, -5.0), 1.0) == pytest.approx(
        EAST, abs=1e-6)
    assert heading_at(roi, ORIGIN, (0.0, 3.0, -5.0), (9.0, 9.0, -5.0), 1.0) == pytest.approx(
        -EAST, abs=1e-6)
    for mode in (ROI_NONE, ROI_WPINDEX, 4):
        assert math.isnan(heading_at(roi._replace(mode=mode), ORIGIN, (0.0, 0.0, 0.0),
                                     (9.0, 9.0, 0.0), 0.0))


def test_roi_heading_keeps_the_heading_it_wrote_or_the_items_own_within_the_radius():
    roi = Roi()
    here = ORIGIN.offset_ned(0.0, 1.0, 0.0)
    roi.command(DO_SET_ROI_LOCATION, (0.0, 0.0, 0.0, 0.0, here.lat_deg, here.lon_deg, 0.0), 0.0)
    ctx = SimpleNamespace(params=ParamStore({}), origin=ORIGIN, position_ned_m=(0.0, 0.0, -5.0))
    sp = NavSetpoint((10.0, 0.0, -5.0), math.nan, None)
    h = RoiHeading(roi)
    assert math.isnan(h.apply(ctx, sp, True).yaw_rad)  # within NAV_ACC_RAD, nothing written
    assert h.apply(ctx, sp._replace(yaw_rad=0.3), True).yaw_rad == 0.3  # the item's own
    ctx.position_ned_m = (0.0, -5.0, -5.0)
    assert h.apply(ctx, sp, True).yaw_rad == pytest.approx(EAST, abs=1e-6)
    ctx.position_ned_m = (0.0, 0.5, -5.0)
    assert h.apply(ctx, sp._replace(yaw_rad=0.3), True).yaw_rad == pytest.approx(EAST, abs=1e-6)
    assert h.apply(ctx, sp._replace(idle=True), True).idle  # no setpoint to turn
    assert math.isnan(h.apply(ctx, sp, False).yaw_rad)  # a takeoff or a landing
    h.new_item()
    assert math.isnan(h.apply(ctx, sp, True).yaw_rad)


def test_roi_commands_replace_the_whole_roi():
    """navigator_main.cpp: ``_vroi = {}`` and then the command's own fields."""
    loc = roi_of_command(DO_SET_ROI_LOCATION, (0, 0, 0, 0, 47.4, 8.5, 500.0))
    assert loc == VehicleRoi(ROI_LOCATION, 47.4, 8.5, 500.0)
    # DO_SET_ROI / NAV_ROI take only the mode: a location given with them is not read
    assert roi_of_command(DO_SET_ROI, (3, 0, 0, 0, 47.4, 8.5, 500.0)) == VehicleRoi(ROI_LOCATION)
    assert roi_of_command(NAV_ROI, (1.7, 0, 0, 0, 0, 0, 0)) == VehicleRoi(ROI_WPNEXT)
    assert roi_of_command(DO_SET_ROI, (math.nan,) * 7) == NO_ROI
    wp = roi_of_command(DO_SET_ROI_WPNEXT_OFFSET, (0, 0, 0, 0, 10.0, -20.0, 45.0))
    assert (wp.mode, wp.lat_deg) == (ROI_WPNEXT, 0.0)
    assert (wp.pitch_offset_rad, wp.roll_offset_rad, wp.yaw_offset_rad) == pytest.approx(
        (math.radians(10.0), math.radians(-20.0), math.radians(45.0)))
    assert roi_of_command(DO_SET_ROI_NONE, (3, 0, 0, 0, 47.4, 8.5, 500.0)) == NO_ROI


def test_roi_items_become_the_commands_issue_command_publishes():
    g = ORIGIN.offset_ned(10.0, 20.0, 0.0)
    x, y = round(g.lat_deg * 1e7), round(g.lon_deg * 1e7)
    rel = MavFrame.GLOBAL_RELATIVE_ALT_INT
    loc = replace(item(0, DO_SET_ROI_LOCATION, frame=rel, alt=15.0), x=x, y=y)
    cmd, params = command_of_item(loc, 488.0)
    assert cmd == DO_SET_ROI_LOCATION
    assert params[4:] == pytest.approx((x * 1e-7, y * 1e-7, 503.0))  # plus home's altitude
    absolute = replace(loc, frame=MavFrame.GLOBAL_INT)
    assert command_of_item(absolute, 488.0)[1][6] == 15.0
    # NAV_ROI is stored as DO_SET_ROI; in a global frame its position is not kept
    nav_roi = replace(item(0, NAV_ROI, frame=rel, p1=3.0, alt=15.0), x=x, y=y)
    assert command_of_item(nav_roi, 488.0) == (DO_SET_ROI, (3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 15.0))
    assert roi_of_command(*command_of_item(nav_roi, 488.0)) == VehicleRoi(ROI_LOCATION)
    offset = replace(item(0, DO_SET_ROI_WPNEXT_OFFSET, frame=MavFrame.MISSION, alt=30.0),
                     x=5, y=-2)
    roi = roi_of_command(*command_of_item(offset, 488.0))
    assert (roi.pitch_offset_rad, roi.roll_offset_rad, roi.yaw_offset_rad) == pytest.approx(
        (math.radians(5.0), math.radians(-2.0), math.radians(30.0)))
