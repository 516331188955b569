"""Command answers re-read against PX4 v1.15.2: Commander::handle_command's cases and its list of
commands left to other modules, the navigator's ACKs (navigator_main.cpp) and its DO_REPOSITION /
DO_CHANGE_ALTITUDE handling."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as M
from test_mavlink_support import acks, make

from gateway.mavlink.command_table import UNANSWERED
from gateway.testing import Sim
from tests.unit.test_vehicles_flight import Sim as WorldSim
from tests.unit.test_vehicles_flight import take_off
from tests.unit.test_vehicles_mission import item
from vehicles.plan_types import MavCmd, PlanResult, PlanType
from vehicles.types import CommandResult, NavState

NAN = math.nan


def results(msgs):
    return [(a.command, a.result) for a in acks(msgs)]


@pytest.mark.parametrize("command", sorted(UNANSWERED))
def test_commands_commander_leaves_to_modules_sitl_does_not_run_get_no_ack(command):
    """Commander::handle_command "ignore commands that are handled by other parts of the
    system": camera, gimbal, gripper, winch, VTOL transition, RX pairing … — in default
    multicopter SITL no module answers them, so no COMMAND_ACK comes (not UNSUPPORTED);
    CONTROL_HIGH_LATENCY is answered only when a high-latency link was heard."""
    vehicle, _, client = make()
    assert results(client.command_long(command, 1, 0, 0)) == []
    assert vehicle.calls == []


@pytest.mark.parametrize("command", [M.MAV_CMD_DO_GO_AROUND, M.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET,
                                     M.MAV_CMD_DO_SET_ROI, M.MAV_CMD_DO_SET_ROI_NONE])
def test_the_navigator_accepts_go_around_and_every_roi_command(command):
    """navigator_main.cpp: DO_GO_AROUND and the five ROI commands (WPNEXT_OFFSET too) are
    ACCEPTED at once."""
    _, _, client = make()
    assert results(client.command_long(command, 0, 0, 0, 0, 1, 2, 3)) == [(command, 0)]


def test_roi_commands_reach_the_navigator_with_their_params():
    """navigator_main.cpp replaces its _vroi from the command: COMMAND_LONG as sent, COMMAND_INT
    with x/y in degrees (vehicles/nav_roi.py reads them)."""
    vehicle, _, client = make()
    loc = M.MAV_CMD_DO_SET_ROI_LOCATION
    assert results(client.command_long(loc, 0, 0, 0, 0, 47.4, 8.5, 500.0)) == [(loc, 0)]
    assert vehicle.calls[-1] == ("set_roi", loc, pytest.approx((0, 0, 0, 0, 47.4, 8.5, 500.0)))
    got = client.send(M.MAVLink_command_int_message(1, 1, 0, loc, 0, 0, 0, 0, 0, 0,
                                                    473977420, 85455940, 490.0))
    assert results(got) == [(loc, 0)]
    assert vehicle.calls[-1] == ("set_roi", loc,
                                 pytest.approx((0, 0, 0, 0, 47.397742, 8.545594, 490.0)))
    assert results(client.command_long(M.MAV_CMD_DO_SET_ROI_NONE)) == [
        (M.MAV_CMD_DO_SET_ROI_NONE, 0)]
    assert vehicle.calls[-1][:2] == ("set_roi", M.MAV_CMD_DO_SET_ROI_NONE)


@pytest.mark.parametrize("command", [M.MAV_CMD_IMAGE_START_CAPTURE, M.MAV_CMD_DO_MOTOR_TEST,
                                     M.MAV_CMD_DO_SET_SERVO, 31000])
def test_commands_commander_does_not_know_are_unsupported(command):
    """The default case of Commander::handle_command answers UNSUPPORTED."""
    _, _, client = make()
    assert results(client.command_long(command, 1)) == [(command, 3)]


@pytest.mark.parametrize("p1, nav", [(5, NavState.AUTO_RTL), (7, NavState.AUTO_MISSION),
                                     (8, NavState.AUTO_LAND), (9, NavState.AUTO_TAKEOFF),
                                     (7.4, NavState.AUTO_MISSION), (261, NavState.AUTO_RTL)])
def test_set_standard_mode_switches_to_the_modes_px4_maps(p1, nav):
    """DO_SET_STANDARD_MODE: (StandardMode)roundf(param1), an 8-bit enum, through
    getNavStateFromStandardMode: return home, mission, land, takeoff."""
    vehicle, _, client = make()
    assert results(client.command_long(M.MAV_CMD_DO_SET_STANDARD_MODE, p1)) == [(262, 0)]
    assert vehicle.calls[-1][2] is nav


@pytest.mark.parametrize("p1", [0, 1, 2, 3, 4, 6, 10, NAN])
def test_set_standard_mode_without_a_px4_mode_fails(p1):
    vehicle, _, client = make()
    assert results(client.command_long(M.MAV_CMD_DO_SET_STANDARD_MODE, p1)) == [(262, 4)]
    assert vehicle.calls == []


def test_change_altitude_holds_at_the_new_altitude():
    """DO_CHANGE_ALTITUDE: Commander switches to Hold and ACCEPTs; the navigator takes p1 as
    the new AMSL altitude (the frame in p2 is not read)."""
    with Sim(params={"MIS_TAKEOFF_ALT": 5.0}) as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        assert api.arm() == 0 and api.takeoff() == 0
        assert sim.run_until(lambda: sim.state(0).position_ned_m[2] < -4.5, timeout_s=30)
        home_alt = sim.status(0).home.geo.alt_amsl_m
        assert api.command_long(M.MAV_CMD_DO_CHANGE_ALTITUDE, home_alt + 12.0, 3) == 0
        assert sim.status(0).nav_state is NavState.AUTO_LOITER
        assert sim.run_until(lambda: sim.state(0).position_ned_m[2] < -11.5, timeout_s=30)
        sim.advance(3.0)
        assert sim.state(0).position_ned_m[2] == pytest.approx(-12.0, abs=0.3)


def test_figure_eight_on_a_multicopter_is_said_and_not_answered():
    """Commander (CONFIG_FIGURE_OF_EIGHT in SITL): a multicopter gets a critical text and, as
    the case leaves the result UNSUPPORTED without sending it, no ACK."""
    with Sim() as sim:
        api = sim.api(0)
        api.start_heartbeat()
        sim.advance(1.0)
        since = len(api.frames)
        assert api.command_long(M.MAV_CMD_DO_FIGURE_EIGHT, 50, 20, retries=0) is None
        said = "".join(m.text for m in api.messages("STATUSTEXT", since))  # two chunks
        assert "Figure 8 command only available for fixed wing and vtol vehicles." in said


# --- DO_REPOSITION: Commander answers, the navigator acts (navigator_main.cpp) ---------------
@pytest.fixture
def world():
    s = WorldSim()
    s.run(1.2)
    yield s
    s.close()


def fence_circle(v, radius_m=20.0):
    return [item(0, MavCmd.NAV_FENCE_CIRCLE_INCLUSION, 0.0, 0.0, 0.0, v.origin, p1=radius_m,
                 mission_type=PlanType.FENCE)]


def test_reposition_outside_the_fence_with_gf_action_warn_is_flown(world):
    """Navigator::geofence_allows_position checks only when GF_ACTION is neither None (0) nor
    Warning (1)."""
    v = world.v
    v.params.set("GF_ACTION", 1)
    assert v.set_plan(world.t, PlanType.FENCE, fence_circle(v)) is PlanResult.ACCEPTED
    take_off(world)
    outside = v.origin.offset_ned(30.0, 0.0, -2.5)
    assert v.goto(world.t, outside.lat_deg, outside.lon_deg, outside.alt_amsl_m) \
        is CommandResult.ACCEPTED
    assert "Reposition is outside geofence\t" not in world.texts()
    assert world.run(20.0, until=lambda: v.state.position_ned_m[0] > 25.0)


def test_change_altitude_outside_the_fence_says_so_and_holds(world):
    v = world.v
    v.params.set("GF_MAX_VER_DIST", 10.0)
    take_off(world)
    z = v.state.position_ned_m[2]
    assert v.goto(world.t, NAN, NAN, v.origin.alt_amsl_m + 30.0, what="Altitude change") \
        is CommandResult.ACCEPTED
    assert world.texts()[-1] == "Altitude change is outside geofence\t"
    world.run(3.0)
    assert v.state.position_ned_m[2] == pytest.approx(z, abs=0.5)


def test_reposition_disarmed_switches_to_hold_and_takes_no_target(world):
    """The navigator takes a reposition only while armed: disarmed, Commander's switch to Hold
    is all (no geofence text either)."""
    v = world.v
    assert v.set_plan(world.t, PlanType.FENCE, fence_circle(v)) is PlanResult.ACCEPTED
    outside = v.origin.offset_ned(40.0, 0.0, -2.5)
    assert v.goto(world.t, outside.lat_deg, outside.lon_deg, outside.alt_amsl_m) \
        is CommandResult.ACCEPTED
    assert "Reposition is outside geofence\t" not in world.texts()
    assert v.arm(world.t) is CommandResult.ACCEPTED
    world.run(3.0)
    assert v.state.position_ned_m[2] > -0.3  # stays on the ground: no target taken


def test_reposition_speed_is_the_setpoints_own(world):
    """navigator_main.cpp puts DO_REPOSITION's p1 in the reposition setpoint
    (rep->current.cruising_speed), not in the navigator's cruising speed: the one
    DO_CHANGE_SPEED set stays for the modes after."""
    v = world.v
    take_off(world)
    nav = v._autopilot.navigator
    assert v.change_speed(world.t, 3.0) is CommandResult.ACCEPTED
    target = v.origin.offset_ned(30.0, 0.0, -2.5)
    assert v.goto(world.t, target.lat_deg, target.lon_deg, target.alt_amsl_m,
                  speed_mps=8.0) is CommandResult.ACCEPTED
    assert nav.cruise_mps == 3.0
    world.run(1.0)
    assert nav.hold.speed_mps == 8.0
    assert world.run(10.0, until=lambda: math.hypot(*v.state.velocity_ned_mps[:2]) > 5.0)


@pytest.mark.parametrize("p4, yaw", [(90.0, math.pi / 2), (-90.0, 1.5 * math.pi), (NAN, NAN)])
def test_set_home_takes_its_yaw_from_param4(p4, yaw):
    """Commander: DO_SET_HOME with a position hands HomePosition::setManually
    wrap_2pi(radians(param4)), NaN when that is not finite (QGC sends NaN); HOME_POSITION's q
    is that yaw's."""
    with Sim() as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        assert api.command_long(M.MAV_CMD_DO_SET_HOME, 0, 0, 0, p4, 47.3979, 8.5461, 490.0) == 0
        assert sim.status(0).home.yaw_rad == pytest.approx(yaw, nan_ok=True)
        since = len(api.frames)
        assert api.command_long(M.MAV_CMD_REQUEST_MESSAGE, 242) == 0
        (home,) = api.messages("HOME_POSITION", since)
        assert home.q[3] == pytest.approx(math.sin(yaw / 2), abs=1e-6, nan_ok=True)


@pytest.mark.parametrize("params", [(3, 0, 0, 0, 0, 0, 0), (0, 0, 0, 0, 3, 0, 0),
                                    (0, 0, 0, 0, 0, 0, 3)])
def test_temperature_calibration_is_left_unanswered(params):
    """Commander::handle_command, PREFLIGHT_CALIBRATION: temperature (3 in param1, param5 or
    param7) breaks out without an ACK for the temperature_compensation module, which SITL does
    not start; armed it is TEMPORARILY_REJECTED first."""
    with Sim() as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        cal = M.MAV_CMD_PREFLIGHT_CALIBRATION
        assert api.command_long(cal, *params, retries=0) is None
        assert api.arm() == 0
        assert api.command_long(cal, *params, retries=0) == 1


def test_reposition_of_the_altitude_alone_keeps_the_setpoints_position(world):
    """navigator_main.cpp: DO_REPOSITION with only p7 (QGC's "change altitude") keeps the
    current setpoint's lat/lon ("Position is not changing, thus we keep the setpoint"): a
    vehicle on its way to a reposition target goes on there, at the new altitude."""
    v = world.v
    take_off(world)
    target = v.origin.offset_ned(30.0, 0.0, -2.5)
    assert v.goto(world.t, target.lat_deg, target.lon_deg, target.alt_amsl_m) \
        is CommandResult.ACCEPTED
    world.run(2.0)
    assert 1.0 < v.state.position_ned_m[0] < 20.0  # on its way
    assert v.goto(world.t, NAN, NAN, v.origin.alt_amsl_m + 6.0) is CommandResult.ACCEPTED
    world.run(20.0)
    assert v.state.position_ned_m[0] == pytest.approx(30.0, abs=0.5)
    assert v.state.position_ned_m[2] == pytest.approx(-6.0, abs=0.3)
