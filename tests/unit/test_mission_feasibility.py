"""PX4's mission feasibility check (vehicles/mission_feasibility.py).

The first tests reproduce PX4's src/modules/navigator/MissionFeasibility/FeasibilityCheckerTest.cpp
test by test, with its inputs and verdicts, for a multicopter. Not reproduced, and why:
- ``instantiation``: nothing to check in Python.
- ``max_dist_between_waypoints``: MIS_DIST_WPS, which PX4 1.15's checker no longer reads.
- ``fixed_wing_land_approach`` and ``fixed_wing_landing``: fixed-wing checks; only their last
  case (the approach checks are not run for a rotary wing) applies, and is reproduced.
``check_dist_first_waypoint`` measures from the vehicle's position, as PX4 1.15 does (the test's
older checker measured from home; both are at 0, 0 there).
"""


import pytest

from tests.unit.test_vehicles_flight import Sim
from tests.unit.test_vehicles_mission import item, waypoints
from vehicles.events import MIS_UNSUPPORTED_CMD, EventLog
from vehicles.geodesy import waypoint_from_heading_and_distance
from vehicles.mission_feasibility import LAND, TAKEOFF, WAYPOINT, FeasibilityChecker, Item
from vehicles.plan_types import MavCmd, MavFrame, PlanResult, PlanType
from vehicles.status_log import StatusLog
from vehicles.types import CommandResult, GeoPoint, NavState

WAYPOINT_ITEM = Item(WAYPOINT)


def north_of(lat_deg: float, dist_m: float) -> float:
    """The latitude ``dist_m`` north (PX4's test: waypoint_from_heading_and_distance, heading 0)."""
    return waypoint_from_heading_and_distance(lat_deg, 0.0, 0.0, dist_m)[0]


def checker(home=None, landed=True, position=None, **params):
    p = {"MIS_DIST_1WP": 10000.0, "MIS_TKO_LAND_REQ": 0, **params}
    log = StatusLog()
    log.events = EventLog(0.0)
    return FeasibilityChecker(log, 0.0, p, home, landed, position), log


def texts(log):
    return [t.text for t in log.after(0)]


def test_mission_item_validity():
    c, _ = checker()  # landed, no home
    c.process_next_item(WAYPOINT_ITEM, 0, 1)
    assert not c.some_check_failed()  # a supported item passes
    c, log = checker(home=GeoPoint(0.0, 0.0, 100.0))
    assert c.process_next_item(Item(LAND), 0, 1) is False  # landed: cannot start with a landing
    assert c.some_check_failed()
    assert texts(log) == ["Mission rejected: starts with landing\t"]
    c, log = checker()  # no home: a relative item fails at once
    assert c.process_next_item(Item(TAKEOFF, relative=True), 0, 5) is False
    assert texts(log) == ["Mission rejected: No home pos, WP 1 uses rel alt\t"]


def test_check_dist_first_waypoint():
    home = GeoPoint(0.0, 0.0, 0.0)
    c, log = checker(home, position=(0.0, 0.0), MIS_DIST_1WP=500.0)
    c.process_next_item(Item(WAYPOINT, north_of(0.0, 501)), 0, 1)
    assert c.some_check_failed()
    assert texts(log) == ["First waypoint too far away: 501m, 500 max\t"]
    c, _ = checker(home, position=(0.0, 0.0), MIS_DIST_1WP=500.0)
    c.process_next_item(Item(WAYPOINT, north_of(0.0, 499)), 0, 1)
    assert not c.some_check_failed()


def test_check_below_home():
    c, _ = checker()  # no home position
    c.process_next_item(Item(WAYPOINT, altitude_m=50, relative=True), 0, 1)
    assert c.some_check_failed()  # a relative altitude without home


def test_check_takeoff():
    home = GeoPoint(0.0, 0.0, 100.0)
    c, log = checker(home)
    c.process_next_item(Item(TAKEOFF, altitude_m=-5.0, relative=True), 0, 1)
    assert c.some_check_failed()  # below home
    assert texts(log) == ["Mission rejected: Takeoff altitude below home altitude!\t"]
    c, _ = checker(home)
    c.process_next_item(Item(TAKEOFF, altitude_m=0.1, relative=True), 0, 1)
    assert not c.some_check_failed()  # above home
    c, log = checker(home)  # the takeoff must be the first item with a position
    c.process_next_item(Item(WAYPOINT, altitude_m=0.1, relative=True), 0, 2)
    c.process_next_item(Item(TAKEOFF, altitude_m=0.1, relative=True), 1, 2)
    assert c.some_check_failed()
    assert texts(log) == ["Mission rejected: takeoff not first waypoint item\t"]


def test_fixed_wing_land_approach_checks_are_not_run_for_a_rotary_wing():
    c, _ = checker(GeoPoint(0.0, 0.0, 100.0))
    c.process_next_item(Item(WAYPOINT, altitude_m=50, relative=True), 0, 2)
    c.process_next_item(Item(LAND, north_of(0.0, 1), altitude_m=40, relative=True), 1, 2)
    assert not c.some_check_failed()


@pytest.mark.parametrize("req, fails, text", [
    (0, False, None),
    (1, True, "Mission rejected: Takeoff waypoint required.\t"),
    (2, True, "Mission rejected: Landing waypoint/pattern required.\t"),
    (3, True, "Mission rejected: Takeoff or Landing item missing.\t"),
    (4, False, None),  # neither takeoff nor landing: allowed
])
def test_check_takeoff_land_requirements(req, fails, text):
    c, log = checker(GeoPoint(0.0, 0.0, 0.0), MIS_TKO_LAND_REQ=req)
    c.process_next_item(WAYPOINT_ITEM, 0, 1)
    assert c.some_check_failed() is fails
    assert texts(log) == ([text] if text else [])


def test_takeoff_land_requirement_4_wants_both_or_neither():
    home = GeoPoint(0.0, 0.0, 0.0)
    c, log = checker(home, MIS_TKO_LAND_REQ=4)
    c.process_next_item(Item(TAKEOFF, altitude_m=10, relative=True), 0, 2)
    c.process_next_item(Item(WAYPOINT, altitude_m=10, relative=True), 1, 2)
    assert c.some_check_failed()
    assert texts(log) == ["Mission rejected: Add Landing item or remove Takeoff.\t"]
    c, _ = checker(home, MIS_TKO_LAND_REQ=4)
    c.process_next_item(Item(TAKEOFF, altitude_m=10, relative=True), 0, 2)
    c.process_next_item(Item(LAND, altitude_m=0, relative=True), 1, 2)
    assert not c.some_check_failed()


def test_unsupported_and_vtol_items_are_rejected_with_their_events():
    c, log = checker(GeoPoint(0.0, 0.0, 0.0))
    c.process_next_item(WAYPOINT_ITEM, 0, 2)
    assert c.process_next_item(Item(112), 1, 2) is False  # CONDITION_DELAY: not flown by PX4
    assert texts(log) == ["Mission rejected: item 2: unsupported cmd: 112\t"]
    event = log.events.get(log.events.latest)  # navigator_mis_unsup_cmd: item 2, command 112
    assert event.arguments == bytes([2, 0, 112, 0]) and event.id == MIS_UNSUPPORTED_CMD.id
    c, log = checker(GeoPoint(0.0, 0.0, 0.0))
    c.process_next_item(Item(84, altitude_m=10, relative=True), 0, 1)  # VTOL takeoff
    assert c.some_check_failed()
    assert texts(log) == ["Mission rejected: Mission contains VTOL items but vehicle is not a VTOL\t"]


# --- on the vehicle: the verdict decides whether Mission mode may start ------------------------
@pytest.fixture
def sim():
    s = Sim()
    s.run(1.2)
    yield s
    s.close()


def test_an_infeasible_mission_is_uploaded_but_cannot_start_and_says_why(sim):
    v = sim.v
    items = waypoints(v, [(10.0, 0.0, 10.0)])
    items.append(item(1, 112, frame=MavFrame.MISSION, p1=2.0))  # CONDITION_DELAY
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED  # as PX4's upload
    assert v.start_mission(sim.t) is CommandResult.DENIED
    said = [t.text for t in v.status_texts(0)]
    assert "Mission rejected: item 2: unsupported cmd: 112\t" in said
    assert "Mission start denied! No valid mission\t" in said
    assert v.set_nav_state(sim.t, NavState.AUTO_MISSION) is CommandResult.ACCEPTED  # disarmed
    assert v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED  # missionCheck: no mode arms
    assert v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    # the same mission without it flies
    assert v.set_plan(sim.t, PlanType.MISSION, items[:1]) is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED


def test_first_waypoint_beyond_mis_dist_1wp_and_a_waypoint_outside_the_fence(sim):
    v = sim.v
    v.params.set("MIS_DIST_1WP", 100.0)
    assert v.set_plan(sim.t, PlanType.MISSION, waypoints(v, [(150.0, 0.0, 10.0)])) \
        is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.DENIED
    assert "First waypoint too far away: 150m, 100 max\t" in [t.text for t in v.status_texts(0)]
    v.params.set("MIS_DIST_1WP", 10000.0)
    v.params.set("GF_MAX_HOR_DIST", 120.0)  # the fence: 120 m around home
    # (a parameter change alone does not check the mission again, as in PX4: a new upload does)
    assert v.set_plan(sim.t, PlanType.MISSION, waypoints(v, [(50.0, 0.0, 10.0), (150.0, 0.0, 10.0)])) \
        is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.DENIED
    assert "Geofence violation for waypoint 2\t" in [t.text for t in v.status_texts(0)]


def test_takeoff_item_at_home_altitude_is_rejected(sim):
    v = sim.v
    items = [item(0, MavCmd.NAV_TAKEOFF, alt=0.0, origin=v.origin)] + [
        item(1, MavCmd.NAV_WAYPOINT, 10.0, 0.0, 10.0, v.origin)]
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.DENIED
    said = [t.text for t in v.status_texts(0)]
    assert "Mission rejected: Takeoff altitude below home altitude!\t" in said
