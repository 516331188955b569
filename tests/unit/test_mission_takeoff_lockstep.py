"""A mission's takeoff through the wire in lockstep (gateway.testing.Sim), as PX4 1.15.2 flies
it: mission_base.cpp checkClimbRequired decides on activation whether the next position item is
more than NAV_MC_ALT_RAD above; on the ground mission.cpp handleTakeoff then inserts a
NAV_CMD_TAKEOFF work item (a SETPOINT_TYPE_TAKEOFF setpoint FlightTaskAuto climbs to at
MPC_TKO_SPEED with the MPC_TKO_RAMP_T ramp below MPC_LAND_ALT1), accepted by mission_block.cpp's
multicopter takeoff test and never reported as reached."""

import math

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.testing import mission_item
from tests.unit import lockstep_support
from tests.unit.lockstep_support import geo, height, texts
from vehicles.plan_types import MavCmd, PlanResult
from vehicles.types import PX4_SITL_HOME, LandedState

sim = lockstep_support.sim  # the fixture: one vehicle, its position estimate valid

CLIMB_TEXT = "Climb to"


def reached_seqs(api, mark=0):
    return [m.seq for m in api.messages("MISSION_ITEM_REACHED", since=mark)]


@pytest.mark.parametrize("explicit", [False, True])
def test_mission_takeoff_climbs_as_a_takeoff_setpoint_and_is_not_reported(sim, explicit):
    """Plain waypoints (as MAVSDK uploads them) or a NAV_TAKEOFF first: the climb in place to
    15 m is a takeoff setpoint, so FlightTaskAuto::_updateTrajConstraints climbs at most at
    MPC_TKO_SPEED (1.5 m/s), accelerating at MPC_TKO_SPEED / MPC_TKO_RAMP_T, below
    MPC_LAND_ALT1 (10 m) and at MPC_Z_V_AUTO_UP (3 m/s) above it. The climb is a work item:
    MISSION_CURRENT stays 0 and nothing is reported reached until item 0's own position."""
    api = sim.api(0)
    first = MavCmd.NAV_TAKEOFF if explicit else MavCmd.NAV_WAYPOINT
    items = [mission_item(first, *geo(30, 0), 15.0),
             mission_item(MavCmd.NAV_WAYPOINT, *geo(30, 20), 15.0)]
    assert api.upload_mission(items) == PlanResult.ACCEPTED
    assert api.arm() == 0 and api.start_mission() == 0
    samples = []  # (t, height, climb rate, landed state, MISSION_CURRENT seq)

    def record():
        s = sim.state(0)
        cur = api.last("MISSION_CURRENT")
        samples.append((sim.now, -s.position_ned_m[2], -s.velocity_ned_mps[2],
                        sim.status(0).landed_state, cur.seq if cur else -1))
        return s.position_ned_m[0] > 1.0  # the climb is over: off towards item 0

    assert sim.run_until(record, timeout_s=60)
    assert "Climb to 15.0 meters above home\t" in texts(api)
    low = [(t, vz) for t, h, vz, _, _ in samples if h < 9.0]
    assert max(vz for _, vz in low) < 1.5 + 0.1
    t_slow = next(t for t, vz in low if vz >= 0.3)
    t_fast = next(t for t, vz in low if vz >= 1.3)
    assert t_fast - t_slow > 1.0 / 0.6  # about MPC_TKO_SPEED / MPC_TKO_RAMP_T
    assert max(vz for _, h, vz, _, _ in samples if h > 10.0) > 1.8  # MPC_Z_V_AUTO_UP
    in_air = [ls for _, h, _, ls, _ in samples if 0.5 < h < 14.0]
    assert set(in_air) == {LandedState.TAKEOFF}  # EXTENDED_SYS_STATE: a takeoff setpoint
    assert {seq for *_, seq in samples} <= {-1, 0} and reached_seqs(api) == []
    assert sim.run_until(lambda: 0 in reached_seqs(api), timeout_s=40)
    n, e, d = sim.state(0).position_ned_m
    assert math.hypot(n - 30, e) < 2.5 and abs(-d - 15) < 0.8


def test_takeoff_work_item_is_accepted_by_the_multicopter_takeoff_test(sim):
    """mission_block.cpp is_mission_item_reached_or_completed, multicopter NAV_CMD_TAKEOFF:
    reached above the takeoff altitude less the altitude acceptance radius, which is half the
    takeoff altitude above home when that is below NAV_MC_ALT_RAD (0.8 m). With home 1 m above
    the vehicle and a takeoff item 0.6 m above home, the climb (1.6 m, more than NAV_MC_ALT_RAD:
    checkClimbRequired) ends 0.3 m below it, 1.3 m above the ground, not 0.8 m below."""
    api = sim.api(0)
    assert api.arm() == 0
    home = sim.vehicles[0].origin.alt_amsl_m - sim.state(0).position_ned_m[2] + 1.0
    assert api.command_long(M.MAV_CMD_DO_SET_HOME, 0, 0, 0, math.nan,
                            *geo(0, 0), home) == 0
    items = [mission_item(MavCmd.NAV_TAKEOFF, *geo(0, 0), 0.6),
             mission_item(MavCmd.NAV_WAYPOINT, *geo(20, 0), 0.6)]
    assert api.upload_mission(items) == PlanResult.ACCEPTED
    ground = height(sim)
    assert api.start_mission() == 0
    assert sim.run_until(lambda: sim.status(0).landed_state is LandedState.TAKEOFF,
                         timeout_s=10)
    assert sim.run_until(lambda: sim.status(0).landed_state is not LandedState.TAKEOFF,
                         timeout_s=20)
    assert height(sim) - ground == pytest.approx(1.3, abs=0.1)
    assert "Climb to 0.6 meters above home\t" in texts(api)


def test_no_takeoff_towards_a_first_waypoint_just_above_the_ground(sim):
    """checkClimbRequired: an item no more than NAV_MC_ALT_RAD above the vehicle needs no
    climb, so the mission flies it as a waypoint straight from the ground (no "Climb to"). PX4
    v1.15.2 then never takes off towards a waypoint 0.6 m up and 10 m away: FlightTaskAuto
    only wants a takeoff when its unsmoothed velocity setpoint climbs faster than 0.3 m/s
    (_want_takeoff), and PositionSmoothing's one straight 3-D direction, its horizontal part
    held to the xy speed (at most the 5 m/s cruise), climbs at 4.62 x 0.5 / 10 = 0.23 m/s (the
    height estimate wanders by some centimetres on the ground, more just after the GNSS
    fusion's start resets the vertical velocity: 0.6 m up is too near the edge). The vehicle
    idles on the ground until Commander disarms it after COM_DISARM_PRFLT (10 s)."""
    api = sim.api(0)
    items = [mission_item(MavCmd.NAV_WAYPOINT, *geo(10, 0), 0.5),
             mission_item(MavCmd.NAV_WAYPOINT, *geo(10, 10), 0.5)]
    assert api.upload_mission(items) == PlanResult.ACCEPTED
    assert api.arm() == 0 and api.start_mission() == 0
    start, highest = sim.now, 0.0

    def disarmed():
        nonlocal highest  # the true height: the estimate wanders by cm with the GPS height
        highest = max(highest, -float(sim.simulation.world.inner.measured[0][2]))
        return not sim.status(0).armed

    assert sim.run_until(disarmed, timeout_s=15)
    assert sim.now - start == pytest.approx(10.0, abs=0.5)
    assert highest < 0.05 and sim.status(0).landed_state is LandedState.ON_GROUND
    assert "Disarmed by auto preflight disarming\t" in texts(api)
    assert not reached_seqs(api)
    assert not [t for t in texts(api) if t.startswith(CLIMB_TEXT)]


def test_a_delay_first_waits_on_the_ground_then_climbs(sim):
    """handleTakeoff runs for position items only: a NAV_DELAY before the first waypoint is
    waited out on the ground, the climb to the waypoint's altitude comes after it."""
    api = sim.api(0)
    items = [mission_item(MavCmd.NAV_DELAY, params=(4.0, -1.0, -1.0, -1.0)),
             mission_item(MavCmd.NAV_WAYPOINT, *geo(10, 0), 8.0)]
    assert api.upload_mission(items) == PlanResult.ACCEPTED
    assert api.arm() == 0 and api.start_mission() == 0
    start = sim.now
    assert sim.run_until(lambda: 0 in reached_seqs(api), timeout_s=10)
    assert sim.now - start == pytest.approx(4.0, abs=0.3)
    assert height(sim) < 0.2  # still on the ground
    assert sim.run_until(lambda: 1 in reached_seqs(api), timeout_s=40)
    assert "Climb to 8.0 meters above home\t" in texts(api)


def test_heading_is_held_within_the_acceptance_radius_of_a_waypoint_without_yaw(sim):
    """FlightTaskAuto::_set_heading_from_mode (MPC_YAW_MODE 0) for a setpoint without a yaw
    (a waypoint whose param4 is NaN, a takeoff item flown as a waypoint): the heading turns
    towards the target only while it is farther than the setpoint's acceptance radius
    (NAV_ACC_RAD, 2 m), otherwise it is held. Descending to a waypoint 1.5 m to the side the
    vehicle keeps its heading."""
    api = sim.api(0)
    origin_amsl = sim.vehicles[0].origin.alt_amsl_m
    assert api.arm() == 0 and api.takeoff(origin_amsl + 8.0) == 0
    assert sim.run_until(lambda: height(sim) > 7.5, timeout_s=30)
    sim.advance(2.0)
    n, e, _ = sim.state(0).position_ned_m
    g = PX4_SITL_HOME.offset_ned(n, e + 1.5, 0.0)
    items = [mission_item(MavCmd.NAV_WAYPOINT, g.lat_deg, g.lon_deg, 2.0)]
    assert api.upload_mission(items) == PlanResult.ACCEPTED
    start_yaw = yaw_of(sim)
    assert api.start_mission() == 0
    turned = 0.0

    def reached():
        nonlocal turned
        turned = max(turned, abs(math.remainder(yaw_of(sim) - start_yaw, math.tau)))
        return 0 in reached_seqs(api)

    assert sim.run_until(reached, timeout_s=30)
    assert height(sim) < 3.0
    assert turned < math.radians(5.0)


def yaw_of(sim) -> float:
    w, x, y, z = sim.state(0).attitude_q
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
