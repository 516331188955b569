"""Plans (validation, ids) and Mission mode flown on the physics World."""

import math

import pytest

from tests.unit.test_vehicles_flight import Sim
from vehicles.plan_types import MavCmd, MavFrame, MissionState, PlanItem, PlanResult, PlanType
from vehicles.plans import plan_crc32, validate_plan
from vehicles.types import CommandResult, NavState

REL = MavFrame.GLOBAL_RELATIVE_ALT_INT
NAN = math.nan


def item(seq, cmd, n=0.0, e=0.0, alt=0.0, origin=None, frame=REL, p1=0.0, p2=0.0, p4=NAN,
         current=0, mission_type=PlanType.MISSION):
    if origin is not None:
        g = origin.offset_ned(n, e, 0.0)
        x, y = round(g.lat_deg * 1e7), round(g.lon_deg * 1e7)
    else:
        x = y = 0
    return PlanItem(seq, frame, cmd, current, 1, p1, p2, 0.0, p4, x, y, alt, mission_type)


def waypoints(v, points, rtl=False):
    items = [item(i, MavCmd.NAV_WAYPOINT, n, e, alt, v.origin) for i, (n, e, alt) in enumerate(points)]
    if rtl:
        items.append(item(len(items), MavCmd.NAV_RETURN_TO_LAUNCH, frame=MavFrame.MISSION))
    return items


SQUARE = [(20.0, 0.0, 12.0), (20.0, 20.0, 15.0), (0.0, 20.0, 12.0), (0.0, 0.0, 15.0)]


@pytest.fixture
def sim():
    s = Sim()
    s.run(1.2)
    yield s
    s.close()


# --- plans -----------------------------------------------------------------------------------
def test_plan_store_accepts_replaces_and_clears(sim):
    v = sim.v
    assert v.plan_id(PlanType.MISSION) == 0
    assert v.mission_status.state is MissionState.NO_MISSION
    items = waypoints(v, SQUARE)
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.plan(PlanType.MISSION) == tuple(items)
    assert v.plan_id(PlanType.MISSION) == plan_crc32(items) != 0
    st = v.mission_status
    assert (st.count, st.state, st.current_seq, st.mission_id) == (
        4, MissionState.NOT_STARTED, 0, v.plan_id(PlanType.MISSION))
    bad = items[:2] + [item(2, 9999, frame=MavFrame.MISSION)]
    assert v.set_plan(sim.t, PlanType.MISSION, bad) is PlanResult.UNSUPPORTED
    assert v.plan(PlanType.MISSION) == tuple(items)  # atomic: old plan kept
    assert v.clear_plan(sim.t, PlanType.MISSION) is PlanResult.ACCEPTED
    assert v.plan(PlanType.MISSION) == () and v.plan_id(PlanType.MISSION) == 0


def test_item_with_current_flag_sets_start_index(sim):
    items = waypoints(sim.v, SQUARE)
    items[2] = item(2, MavCmd.NAV_WAYPOINT, 0, 20, 12, sim.v.origin, current=1)
    sim.v.set_plan(sim.t, PlanType.MISSION, items)
    assert sim.v.mission_status.current_seq == 2


@pytest.mark.parametrize("plan_type,items,expected", [
    (PlanType.MISSION, [item(0, MavCmd.NAV_WAYPOINT, frame=1)], PlanResult.UNSUPPORTED_FRAME),
    (PlanType.MISSION, [item(0, MavCmd.DO_CHANGE_SPEED, frame=1)], PlanResult.UNSUPPORTED_FRAME),
    # parse_mavlink_mission_item (mavlink_mission.cpp): the frame picks the branch, and each
    # branch refuses the other branch's commands with UNSUPPORTED.
    (PlanType.MISSION, [item(0, MavCmd.NAV_WAYPOINT, frame=MavFrame.MISSION)],
     PlanResult.UNSUPPORTED),
    (PlanType.MISSION, [item(0, MavCmd.DO_CHANGE_SPEED, p2=3.0)], PlanResult.UNSUPPORTED),
    (PlanType.MISSION, [item(0, MavCmd.NAV_RETURN_TO_LAUNCH, frame=MavFrame.GLOBAL_RELATIVE_ALT)],
     PlanResult.UNSUPPORTED),
    # Commands PX4 1.15's parser does not know, in either branch: COMPONENT_ARM_DISARM,
    # DO_AUTOTUNE_ENABLE, SET_CAMERA_SOURCE, SET_CAMERA_ZOOM.
    (PlanType.MISSION, [item(0, 400, p1=1.0)], PlanResult.UNSUPPORTED),
    (PlanType.MISSION, [item(0, 400, p1=1.0, frame=MavFrame.MISSION)], PlanResult.UNSUPPORTED),
    (PlanType.MISSION, [item(0, 212, p1=1.0)], PlanResult.UNSUPPORTED),
    (PlanType.MISSION, [item(0, 212, p1=1.0, frame=MavFrame.MISSION)], PlanResult.UNSUPPORTED),
    (PlanType.MISSION, [item(0, 534, frame=MavFrame.MISSION)], PlanResult.UNSUPPORTED),
    (PlanType.MISSION, [item(0, 531, frame=MavFrame.MISSION)], PlanResult.UNSUPPORTED),
    (PlanType.MISSION, [item(0, 532, frame=MavFrame.MISSION)], PlanResult.ACCEPTED),
    # a fence return point parses and a mission stores it (the feasibility check refuses it)
    (PlanType.MISSION, [item(0, MavCmd.NAV_FENCE_RETURN_POINT)], PlanResult.ACCEPTED),
    (PlanType.MISSION, [item(0, MavCmd.NAV_RALLY_POINT)], PlanResult.ERROR),
    (PlanType.MISSION, [item(0, 201, p1=1.0, frame=MavFrame.MISSION)], PlanResult.ACCEPTED),
    (PlanType.MISSION, [item(0, 201, p1=3.0, frame=MavFrame.MISSION)], PlanResult.INVALID_PARAM1),
    (PlanType.MISSION, [item(0, 201, p1=1.0)], PlanResult.INVALID_PARAM1),
    (PlanType.MISSION, [item(0, MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, p1=3)],
     PlanResult.ERROR),
    (PlanType.MISSION, [item(0, 12345)], PlanResult.UNSUPPORTED),
    (PlanType.MISSION, [item(1, MavCmd.NAV_WAYPOINT)], PlanResult.INVALID_SEQUENCE),
    (PlanType.MISSION, [item(0, MavCmd.DO_CHANGE_SPEED, frame=MavFrame.MISSION, p2=3.0),
                        item(1, 2000, frame=MavFrame.MISSION), item(2, 205, frame=MavFrame.MISSION),
                        item(3, MavCmd.NAV_WAYPOINT)], PlanResult.ACCEPTED),
    (PlanType.FENCE, [item(i, MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, p1=3) for i in range(3)],
     PlanResult.ACCEPTED),
    # handle_mission_item_both checks only each vertex's own count, (uint16_t)(param1 + 0.5f)
    # >= 3 (else MAV_MISSION_ERROR): a polygon cut short, vertices of mixed kinds or counts
    # are stored and only make sense (or not) when the fence loads (geofence.cpp).
    (PlanType.FENCE, [item(i, MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, p1=3) for i in range(2)],
     PlanResult.ACCEPTED),
    (PlanType.FENCE, [item(i, MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, p1=2) for i in range(2)],
     PlanResult.ERROR),
    (PlanType.FENCE, [item(0, MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, p1=2.5)],
     PlanResult.ACCEPTED),  # rounds to 3
    (PlanType.FENCE, [item(0, MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, p1=2.4)],
     PlanResult.ERROR),
    (PlanType.FENCE, [item(0, MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION, p1=NAN)],
     PlanResult.ERROR),  # NaN converts to 0
    (PlanType.FENCE, [item(0, MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION, p1=65539.0)],
     PlanResult.ACCEPTED),  # uint16: 3
    (PlanType.FENCE, [item(0, MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, p1=3),
                      item(1, MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION, p1=3),
                      item(2, MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, p1=4)],
     PlanResult.ACCEPTED),
    # PX4 takes any circle radius at upload (MAVSDK's geofence example sends a zero circle);
    # one that does not contain home is dropped when the fence loads.
    (PlanType.FENCE, [item(0, MavCmd.NAV_FENCE_CIRCLE_INCLUSION, p1=0.0)], PlanResult.ACCEPTED),
    (PlanType.FENCE, [item(0, MavCmd.NAV_FENCE_CIRCLE_INCLUSION, p1=NAN)], PlanResult.ACCEPTED),
    (PlanType.FENCE, [item(0, MavCmd.NAV_FENCE_CIRCLE_EXCLUSION, p1=-30.0)], PlanResult.ACCEPTED),
    (PlanType.FENCE, [item(0, MavCmd.NAV_FENCE_CIRCLE_EXCLUSION, p1=30.0)], PlanResult.ACCEPTED),
    # A fence or rally plan stores whatever the parser takes, mission commands included ...
    (PlanType.FENCE, [item(0, MavCmd.NAV_WAYPOINT)], PlanResult.ACCEPTED),
    (PlanType.FENCE, [item(0, MavCmd.DO_CHANGE_SPEED, frame=MavFrame.MISSION)],
     PlanResult.ACCEPTED),
    (PlanType.RALLY, [item(0, MavCmd.NAV_LOITER_TO_ALT)], PlanResult.ACCEPTED),
    (PlanType.RALLY, [item(0, MavCmd.NAV_FENCE_CIRCLE_INCLUSION, p1=5.0)], PlanResult.ACCEPTED),
    (PlanType.RALLY, [item(0, MavCmd.DO_JUMP, frame=MavFrame.MISSION)], PlanResult.ACCEPTED),
    # ... and refuses what it refuses, as in a mission
    (PlanType.FENCE, [item(0, MavCmd.DO_CHANGE_SPEED)], PlanResult.UNSUPPORTED),
    (PlanType.RALLY, [item(0, 201, p1=1.0)], PlanResult.INVALID_PARAM1),
    (PlanType.RALLY, [item(0, 12345)], PlanResult.UNSUPPORTED),
    (PlanType.RALLY, [item(0, MavCmd.NAV_RALLY_POINT)], PlanResult.ACCEPTED),
    # the parser's frame test first: not a MAV_FRAME_MISSION command, then an unknown frame
    (PlanType.RALLY, [item(0, MavCmd.NAV_RALLY_POINT, frame=MavFrame.MISSION)],
     PlanResult.UNSUPPORTED),
    (PlanType.FENCE, [item(0, MavCmd.NAV_WAYPOINT, frame=1)], PlanResult.UNSUPPORTED_FRAME),
    (PlanType.RALLY, [item(i, MavCmd.NAV_RALLY_POINT) for i in range(33)], PlanResult.NO_SPACE),
])
def test_plan_validation(plan_type, items, expected):
    assert validate_plan(plan_type, items) is expected


# --- mission mode ----------------------------------------------------------------------------
def test_mission_mode_rejected_without_mission(sim):
    """Armed, Mission needs a valid mission (canRun); disarmed it is granted, arming refused."""
    v = sim.v
    assert v.start_mission(sim.t) is CommandResult.DENIED
    assert v.set_nav_state(sim.t, NavState.AUTO_MISSION) is CommandResult.ACCEPTED
    assert v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED
    assert v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    assert v.arm(sim.t) is CommandResult.ACCEPTED
    assert v.set_nav_state(sim.t, NavState.AUTO_MISSION) is CommandResult.TEMPORARILY_REJECTED
    assert v.disarm(sim.t) is CommandResult.ACCEPTED
    assert "Mission start denied! No valid mission\t" in sim.texts()
    assert not v.status.armed


def fly_mission(sim, items, timeout_s=120.0, visit=None, rtl=False):
    """Until the mission is complete and the vehicle disarmed (``rtl``: disarmed, a mission
    that hands over to Return on its last item is never complete)."""
    v = sim.v
    reached, closest = [], {}
    last = 0
    def watch():
        nonlocal last
        st = v.mission_status
        if st.reached_count != last:
            new = st.reached_history[len(st.reached_history) - (st.reached_count - last):]
            reached.extend(new)
            last = st.reached_count
            p = v.state.position_ned_m
            for i in new:
                if visit and i < len(visit):  # where the vehicle was when the item was reached
                    closest[i] = (math.hypot(p[0] - visit[i][0], p[1] - visit[i][1]), -p[2])
        return (rtl or st.state is MissionState.COMPLETE) and not v.status.armed
    done = sim.run(timeout_s, until=watch)
    return done, reached, closest


def test_square_mission_from_the_ground_with_rtl(sim):
    v = sim.v
    assert v.set_plan(sim.t, PlanType.MISSION, waypoints(v, SQUARE, rtl=True)) is PlanResult.ACCEPTED
    assert v.set_nav_state(sim.t, NavState.AUTO_MISSION) is CommandResult.ACCEPTED  # MAVSDK way
    assert v.mission_status.state is MissionState.ACTIVE
    assert v.arm(sim.t) is CommandResult.ACCEPTED
    t0 = sim.t
    done, reached, closest = fly_mission(sim, None, visit=SQUARE, rtl=True)
    assert done, (v.status, v.mission_status, sim.texts()[-5:])
    assert sim.t - t0 < 110
    assert reached == [0, 1, 2, 3]  # the RTL item hands over to Return: never reached
    for i, (_n, _e, alt) in enumerate(SQUARE):
        d, h = closest[i]
        assert d < 2.0, (i, d)  # NAV_ACC_RAD
        assert h == pytest.approx(alt, abs=1.0), (i, h)
    texts = sim.texts()
    assert "Executing Mission\t" in texts
    assert "Climb to 12.0 meters above home\t" in texts
    assert "Returning to launch\t" in texts and "Disarmed by landing\t" in texts
    p = v.state.position_ned_m
    assert math.hypot(p[0], p[1]) < 2.0
    # disarmed, the mode asked for before Return (UserModeIntention::onDisarm), the mission
    # still on its RTL item
    assert v.status.nav_state is NavState.AUTO_MISSION
    assert v.mission_status.current_seq == 4 and v.mission_status.state is MissionState.ACTIVE


def test_mission_start_arms_takeoff_item_speed_change_and_loiter_at_end(sim):
    v = sim.v
    o = v.origin
    items = [item(0, MavCmd.NAV_TAKEOFF, alt=5.0, origin=o),
             item(1, MavCmd.DO_CHANGE_SPEED, frame=MavFrame.MISSION, p1=1, p2=8.0),
             item(2, 2000, frame=MavFrame.MISSION),  # IMAGE_START_CAPTURE: accepted, skipped
             item(3, MavCmd.NAV_WAYPOINT, 30.0, 0.0, 8.0, o, p1=2.0)]
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert v.status.armed and "Armed by mission start\t" in sim.texts()
    top_speed = 0.0
    def done():
        nonlocal top_speed
        top_speed = max(top_speed, math.hypot(*v.state.velocity_ned_mps[:2]))
        return v.mission_status.state is MissionState.COMPLETE
    assert sim.run(40.0, until=done)
    assert v.mission_status.reached_seq == 3
    assert top_speed > 6.5  # DO_CHANGE_SPEED 8 m/s, not the 5 m/s cruise
    assert "Mission finished, loitering\t" in sim.texts()
    sim.run(3.0)
    p = v.state.position_ned_m
    assert v.status.nav_state is NavState.AUTO_MISSION and v.status.armed
    assert math.hypot(p[0] - 30.0, p[1]) < 1.5 and -p[2] == pytest.approx(8.0, abs=0.8)


def test_pause_with_hold_resume_and_set_current(sim):
    v = sim.v
    pts = [(40.0, 0.0, 10.0), (40.0, 40.0, 10.0), (0.0, 40.0, 10.0)]
    v.set_plan(sim.t, PlanType.MISSION, waypoints(v, pts))
    assert v.set_current_mission_item(sim.t, 5) is False
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: v.mission_status.reached_seq == 0)
    sim.run(2.0)
    assert v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED  # pause
    sim.run(0.1)
    hold = v._autopilot.tasks.auto.setpoint.target_ned_m  # Navigator::calculate_breaking_stop
    # Paused while still speeding up it passes Hold's stopping point, and FlightTaskAuto then
    # flies to it from where it passed (_getCurrentState target_behind, that point the previous
    # waypoint). The vehicle passes within a few decimetres of it, so that line's direction is
    # chance: along it PositionSmoothing's L1 point lies past the target without bound and, the
    # trajectory turning, the speed is held at the last one planned inside the acceptance
    # radius (~1.2 m/s): the vehicle can fly away down that line until it leaves target_behind,
    # then back (offtrack), as PX4 v1.15.2 does (tests/unit/test_vehicles_trajectory.py).
    def settled():
        p, vel = v.state.position_ned_m, v.state.velocity_ned_mps
        return math.hypot(p[0] - hold[0], p[1] - hold[1]) < 0.3 and math.hypot(*vel) < 0.05
    assert sim.run(45.0, until=settled)
    st = v.mission_status
    assert st.state is MissionState.PAUSED and st.current_seq == 1 and not st.in_mission_mode
    held = v.state.position_ned_m.copy()
    sim.run(3.0)
    assert math.dist(held, v.state.position_ned_m) < 0.5
    # Jump ahead while paused, then resume: item 1 is skipped.
    assert v.set_current_mission_item(sim.t, 2) is True
    assert v.mission_status.current_seq == 2
    assert v.set_nav_state(sim.t, NavState.AUTO_MISSION) is CommandResult.ACCEPTED
    assert sim.run(60.0, until=lambda: v.mission_status.state is MissionState.COMPLETE)
    assert v.mission_status.reached_seq == 2
    p = v.state.position_ned_m
    assert math.hypot(p[0] - 0.0, p[1] - 40.0) < 2.0


def test_land_item_lands_at_its_position_and_disarms(sim):
    v = sim.v
    o = v.origin
    items = [item(0, MavCmd.NAV_WAYPOINT, 10.0, 5.0, 6.0, o),
             item(1, MavCmd.NAV_LAND, 15.0, 10.0, 0.0, o)]
    v.set_plan(sim.t, PlanType.MISSION, items)
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(60.0, until=lambda: not v.status.armed)
    texts = sim.texts()
    assert "Mission finished, landed\t" in texts
    assert v.mission_status.state is MissionState.COMPLETE
    p = v.state.position_ned_m
    assert math.hypot(p[0] - 15.0, p[1] - 10.0) < 1.0


def test_changes_move_with_every_change_of_mission_progress_and_status_texts(sim):
    """The links skip their polls while ``v.changes`` stands still: it must move with every
    change of what they poll (a move without a change is allowed)."""
    v = sim.v
    seen = (v.mission_progress, v.status_texts(0)[-1:], v.changes.mission_progress,
            v.changes.status_texts)
    changed = {"progress": 0, "texts": 0}

    def watch():
        nonlocal seen
        now = (v.mission_progress, v.status_texts(0)[-1:], v.changes.mission_progress,
               v.changes.status_texts)
        if now[0] != seen[0]:
            assert now[2] != seen[2], (seen, now)
            changed["progress"] += 1
        if now[1] != seen[1]:
            assert now[3] != seen[3], (seen, now)
            changed["texts"] += 1
        seen = now
        return False

    assert v.set_plan(sim.t, PlanType.MISSION, waypoints(v, SQUARE)) is PlanResult.ACCEPTED
    watch()
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    sim.run(25.0, until=watch)
    assert v.set_current_mission_item(sim.t, 0)
    watch()
    assert v.set_plan(sim.t, PlanType.MISSION, waypoints(v, SQUARE[:2])) is PlanResult.ACCEPTED
    watch()
    sim.run(5.0, until=watch)
    assert changed["progress"] >= 4 and changed["texts"] >= 2, changed


def test_finished_mission_does_not_start_over_in_air(sim):
    """PX4 mission_base.cpp: advance_mission past the last item leaves no valid current item;
    on_activation's checkMissionRestart rewinds only when the vehicle was disarmed while the
    mission was inactive, so Hold -> Mission in the air keeps loitering and update_mission says
    "No valid mission available, loitering" (seen with MAVSDK-Python issue #683 on PX4 1.15)."""
    v = sim.v
    v.set_plan(sim.t, PlanType.MISSION, waypoints(v, [(10.0, 0.0, 5.0), (10.0, 10.0, 5.0)]))
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(60.0, until=lambda: v.mission_status.state is MissionState.COMPLETE)
    sim.run(3.0)
    assert v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    sim.run(2.0)
    held = v.state.position_ned_m.copy()
    assert v.set_nav_state(sim.t, NavState.AUTO_MISSION) is CommandResult.ACCEPTED
    sim.run(5.0)
    st = v.mission_status
    assert st.state is MissionState.COMPLETE and st.current_seq == 1
    assert math.dist(held, v.state.position_ned_m) < 1.0
    assert sim.texts()[-1] == "No valid mission available, loitering\t"
    # Setting an item (MISSION_SET_CURRENT) makes it valid again: the mission flies from there
    # and update_mission, finding no mission running, says so.
    assert v.set_current_mission_item(sim.t, 0)
    assert sim.run(30.0, until=lambda: v.mission_status.reached_seq == 0
                   and v.mission_status.state is MissionState.ACTIVE)
    assert "Executing Mission\t" in sim.texts()[-3:]


def test_arming_in_mission_mode_after_a_landed_mission_starts_it_over(sim):
    """PX4 navigator_main.cpp runs no mode while disarmed, so arming in Mission mode activates
    the mission; MissionBase::checkMissionRestart then rewinds a mission left at its last item
    after a disarm (PX4's "Missions reset once the vehicle is disarmed")."""
    v = sim.v
    o = v.origin
    v.set_plan(sim.t, PlanType.MISSION, [item(0, MavCmd.NAV_WAYPOINT, 5.0, 0.0, 5.0, o),
                                         item(1, MavCmd.NAV_LAND, 5.0, 5.0, 0.0, o)])
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(60.0, until=lambda: not v.status.armed)
    assert v.status.nav_state is NavState.AUTO_MISSION
    sim.run(1.0)
    assert v.arm(sim.t) is CommandResult.ACCEPTED
    assert sim.run(20.0, until=lambda: v.mission_status.reached_seq == 0
                   and v.mission_status.state is MissionState.ACTIVE)
    assert sim.texts().count("Executing Mission\t") == 2


def test_mission_current_mode_is_active_in_takeoff_and_land_and_infeasible_is_no_mission(sim):
    """PX4 mavlink_mission.cpp update_mission_state: mission_mode ACTIVE in Mission, Takeoff and
    Land (mission_state ACTIVE then), and NO_MISSION while mission_result.valid is false."""
    v = sim.v
    v.set_plan(sim.t, PlanType.MISSION, waypoints(v, [(10.0, 0.0, 5.0)]))
    sim.run(0.1)
    assert v.mission_status.state is MissionState.NOT_STARTED
    assert v.arm(sim.t) is CommandResult.ACCEPTED
    assert v.takeoff(sim.t) is CommandResult.ACCEPTED
    sim.run(0.1)
    st = v.mission_status
    assert v.status.nav_state is NavState.AUTO_TAKEOFF
    assert st.in_mission_mode and st.state is MissionState.ACTIVE
    assert sim.run(20.0, until=lambda: v.status.nav_state is NavState.AUTO_LOITER)
    st = v.mission_status
    assert not st.in_mission_mode and st.state is MissionState.NOT_STARTED
    # A takeoff item not above home: FeasibilityChecker rejects the mission.
    v.set_plan(sim.t, PlanType.MISSION, [item(0, MavCmd.NAV_TAKEOFF, alt=0.0, origin=v.origin)])
    sim.run(0.1)
    assert v.mission_status.state is MissionState.NO_MISSION


def test_uploading_the_same_mission_again_changes_nothing(sim):
    """PX4 mavlink_mission.cpp handle_mission_item_both: after the last item the mission is
    published (update_active_mission) only if its CRC32 differs from the stored one's, and
    crc32_for_mission_item leaves out seq and ``current``; so the same mission sent again
    (MAVSDK flags item 0 current) keeps the mission flying where it is (PX4 PR #28775 describes
    this as PX4's behaviour up to 2026)."""
    v = sim.v
    items = waypoints(v, [(20.0, 0.0, 5.0), (20.0, 20.0, 5.0), (0.0, 20.0, 5.0)])
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    mission_id = v.plan_id(PlanType.MISSION)
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: v.mission_status.reached_seq == 0)
    sim.run(1.0)
    again = [it if it.seq else item(0, MavCmd.NAV_WAYPOINT, 20.0, 0.0, 5.0, v.origin, current=1)
             for it in items]
    assert v.set_plan(sim.t, PlanType.MISSION, again) is PlanResult.ACCEPTED
    assert v.plan_id(PlanType.MISSION) == mission_id
    st = v.mission_status
    assert st.current_seq == 1 and st.state is MissionState.ACTIVE and st.reached_seq == 0
    assert sim.run(30.0, until=lambda: v.mission_status.reached_seq == 1)
    assert 0 not in v.mission_status.reached_history[1:]  # item 0 was not flown again


def test_loiter_unlimited_is_never_reached(sim):
    """PX4 mission_block.cpp is_mission_item_reached_or_completed returns false for
    NAV_CMD_LOITER_UNLIMITED: the vehicle holds there, no MISSION_ITEM_REACHED is sent for it and
    the mission does not go on until another item is set current."""
    v = sim.v
    o = v.origin
    v.set_plan(sim.t, PlanType.MISSION, [item(0, MavCmd.NAV_WAYPOINT, 10.0, 0.0, 5.0, o),
                                         item(1, MavCmd.NAV_LOITER_UNLIM, 10.0, 10.0, 5.0, o),
                                         item(2, MavCmd.NAV_WAYPOINT, 0.0, 10.0, 5.0, o)])
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: v.mission_status.reached_seq == 0)
    sim.run(25.0)
    p = v.state.position_ned_m
    st = v.mission_status
    assert math.hypot(p[0] - 10.0, p[1] - 10.0) < 1.0
    assert st.current_seq == 1 and st.reached_history == (0,) and st.state is MissionState.ACTIVE
    assert v.set_current_mission_item(sim.t, 2)
    assert sim.run(20.0, until=lambda: v.mission_status.reached_seq == 2)


def test_upload_without_a_current_item_keeps_the_index_clamped(sim):
    """mavlink_mission.cpp (1.15.2): an upload's current item is the last one flagged current
    (_transfer_current_seq), else -1; MissionBase::updateMavlinkMission then keeps the previous
    index, constrained to [0, count - 1]. A clear publishes index 0."""
    v = sim.v
    line = [(10.0 * k, 0.0, 10.0) for k in range(1, 7)]
    v.set_plan(sim.t, PlanType.MISSION, waypoints(v, line))
    assert v.set_current_mission_item(sim.t, 4)
    v.set_plan(sim.t, PlanType.MISSION, waypoints(v, [(n, 5.0, a) for n, _, a in line]))
    assert v.mission_status.current_seq == 4
    v.set_plan(sim.t, PlanType.MISSION, waypoints(v, SQUARE[:3]))
    assert v.mission_status.current_seq == 2
    flagged = [item(i, MavCmd.NAV_WAYPOINT, n, e, alt, v.origin, current=int(i in (0, 1)))
               for i, (n, e, alt) in enumerate(SQUARE)]
    v.set_plan(sim.t, PlanType.MISSION, flagged)
    assert v.mission_status.current_seq == 1
    v.clear_plan(sim.t, PlanType.MISSION)
    v.set_plan(sim.t, PlanType.MISSION, waypoints(v, line))
    assert v.mission_status.current_seq == 0


def test_mission_start_or_set_current_at_the_current_item_changes_nothing(sim):
    """Mission::set_current_mission_index returns at once when the index is the current one
    (MISSION_START's param1, navigator_main.cpp), and a MISSION_SET_CURRENT of it is no
    mission data change (checkMissionDataChanged): the item is not restarted, a finished
    mission stays finished."""
    v = sim.v
    v.set_plan(sim.t, PlanType.MISSION, waypoints(v, [(10.0, 0.0, 5.0), (10.0, 10.0, 5.0)]))
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: v.mission_status.reached_seq == 0)
    resets = v.mission_status.reached_resets
    assert v.start_mission(sim.t, 1) is CommandResult.ACCEPTED
    assert v.set_current_mission_item(sim.t, 1)
    assert v.mission_status.reached_resets == resets  # update_mission did not run again
    assert sim.run(40.0, until=lambda: v.mission_status.state is MissionState.COMPLETE)
    st = v.mission_status
    executing = sim.texts().count("Executing Mission\t")
    assert v.start_mission(sim.t, 1) is CommandResult.ACCEPTED
    assert v.set_current_mission_item(sim.t, 1)
    sim.run(5.0)
    assert v.mission_status.state is MissionState.COMPLETE
    assert v.mission_status.reached_count == st.reached_count
    assert sim.texts().count("Executing Mission\t") == executing
    assert v.start_mission(sim.t, 0) is CommandResult.ACCEPTED  # another item: flown again
    assert sim.run(30.0, until=lambda: v.mission_status.reached_count > st.reached_count)


def test_a_fence_change_runs_the_check_again_and_resets_the_reached_item(sim):
    """MissionBase::updateMavlinkMission: a new geofence id → _mission_checked = false →
    check_mission_valid, which puts mission_result.seq_reached back to -1."""
    v = sim.v
    o = v.origin
    v.set_plan(sim.t, PlanType.MISSION, waypoints(v, [(10.0, 0.0, 5.0), (40.0, 0.0, 5.0)]))
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: v.mission_status.reached_seq == 0)
    resets = v.mission_status.reached_resets
    fence = [item(0, MavCmd.NAV_FENCE_CIRCLE_INCLUSION, origin=o, p1=500.0,
                  mission_type=PlanType.FENCE)]
    assert v.set_plan(sim.t, PlanType.FENCE, fence) is PlanResult.ACCEPTED
    sim.run(0.1)
    assert v.mission_status.reached_resets > resets
    assert v.mission_status.state is MissionState.ACTIVE  # still feasible, still flying


def test_a_new_home_alone_does_not_run_the_check_but_activation_does(sim):
    """check_mission_valid runs on a new mission or geofence (MissionBase) and, forced, on each
    Mission::on_activation; a new home or a parameter change alone does not run it (1.15.2)."""
    v = sim.v
    v.set_plan(sim.t, PlanType.MISSION, waypoints(v, [(30.0, 0.0, 5.0), (30.0, 30.0, 5.0)]))
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: v.mission_status.reached_seq == 0)
    resets = v.mission_status.reached_resets
    assert v.set_home(sim.t) is CommandResult.ACCEPTED
    sim.run(0.5)
    assert v.mission_status.reached_resets == resets
    assert sim.run(20.0, until=lambda: v.state.position_ned_m[1] > 20.0)
    assert v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    v.params.set("MIS_DIST_1WP", 10.0)  # the first waypoint is more than 20 m away now
    sim.run(0.5)
    assert "First waypoint too far away" not in "".join(sim.texts())
    v.set_nav_state(sim.t, NavState.AUTO_MISSION)
    sim.run(0.5)
    assert any(t.startswith("First waypoint too far away") for t in sim.texts())
    assert v.status.nav_state is not NavState.AUTO_MISSION


def test_com_takeoff_act_1_flies_the_mission_after_the_takeoff(sim):
    """Commander: the takeoff done, COM_TAKEOFF_ACT 1 switches to Mission when a valid one is
    stored (0, the default: Hold; test_vehicles_flight)."""
    v = sim.v
    v.params.set("COM_TAKEOFF_ACT", 1)
    assert v.set_plan(sim.t, PlanType.MISSION, waypoints(v, [(15.0, 0.0, 10.0)])) \
        is PlanResult.ACCEPTED
    assert v.arm(sim.t) is CommandResult.ACCEPTED
    assert v.takeoff(sim.t) is CommandResult.ACCEPTED
    assert sim.run(30.0, until=lambda: v.status.nav_state is not NavState.AUTO_TAKEOFF)
    assert v.status.nav_state is NavState.AUTO_MISSION
    assert sim.run(30.0, until=lambda: v.mission_status.reached_count >= 1)
