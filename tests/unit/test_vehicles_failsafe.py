"""Failsafes (data link, offboard, battery, geofence) and Return to rally points."""

import math
import struct

import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from tests.unit.test_vehicles_mission import item
from vehicles.events import DEFINITIONS, EventLog, Log
from vehicles.failsafe import (
    CHECKS,
    Action,
    ActionOptions,
    Cause,
    Check,
    Clear,
    Failsafe,
    FailsafeFlags,
)
from vehicles.params import ParamStore
from vehicles.plan_types import MavCmd, MavFrame, PlanItem, PlanResult, PlanType
from vehicles.status_log import StatusLog
from vehicles.types import CommandResult, NavState


def event_name(event_id: int) -> str:
    return next(d.name for d in DEFINITIONS if d.id == event_id)


def make_sim(**overrides):
    s = Sim(**overrides)
    s.run(1.2)
    return s


@pytest.fixture
def sim():
    s = make_sim()
    yield s
    s.close()


# --- the pure state machine ------------------------------------------------------------------
FLAG_FOR_CHECK = {
    "gcs_connection_lost": dict(gcs_lost=True),
    "offboard_signal_lost": dict(offboard_lost=True, user_nav_state=NavState.OFFBOARD),
    "battery_warning": dict(battery_warning=3),
    "geofence_breached": dict(geofence_breached=True),
    "manual_control_signal_lost": dict(manual_control_lost=True),
    "position_lost": dict(position_invalid=True),
    "fd_critical_failure": dict(fd_critical_failure=True),
    "mission_failure": dict(mission_failure=True, user_nav_state=NavState.AUTO_MISSION),
    # only with NAV_DLL_ACT 0 (test_a_finished_mission_returns_when_every_command_link_is_lost)
    "mission_control_lost": dict(gcs_lost=True, mission_finished=True,
                                 user_nav_state=NavState.AUTO_MISSION),
}


def test_every_check_has_a_trigger_in_this_test():
    assert {c.name for c in CHECKS} == set(FLAG_FOR_CHECK)


@pytest.mark.parametrize("check", [c.name for c in CHECKS
                                   if c.name not in ("position_lost", "fd_critical_failure",
                                                     "mission_control_lost")])
def test_each_check_holds_then_acts_and_clears_on_disarm(check):
    params = ParamStore({"NAV_DLL_ACT": 2, "GF_ACTION": 3, "COM_LOW_BAT_ACT": 3})
    log = StatusLog()
    fs = Failsafe(params, log)
    base = dict(armed=True, user_nav_state=NavState.AUTO_LOITER)
    if check == "manual_control_signal_lost":
        base["manual_control_lost"] = False  # sticks present when it armed
    assert fs.update(0.0, FailsafeFlags(**base)) is Action.NONE
    flags = FailsafeFlags(**{**base, **FLAG_FOR_CHECK[check]})
    assert fs.update(1.0, flags) is Action.HOLD  # COM_FAIL_ACT_T = 5 s hold first
    assert log.after(0)[-1].text == "Failsafe activated: entering Hold for 5 seconds\t"
    expected = Action.LAND if check == "battery_warning" else Action.RTL
    assert fs.update(6.1, flags) is expected
    assert log.after(0)[-1].text == "Failsafe activated\t"
    assert fs.in_failsafe
    assert fs.update(7.0, FailsafeFlags(**{**flags.__dict__, "armed": False})) is Action.NONE


def _told(events: EventLog) -> list[tuple[str, int, int, tuple]]:
    """(name, external level, internal level, arguments) of every event sent."""
    names = {d.id: d for d in DEFINITIONS}
    out = []
    for e in events.after(events.latest - len(events)):
        d = names[e.id]
        fmt = "<" + "".join({"uint32_t": "I", "uint16_t": "H"}.get(t, "B") for t, _ in d.arguments)
        out.append((d.name, e.log_levels & 0xF, e.log_levels >> 4,
                    struct.unpack(fmt, e.arguments)))
    return out


def test_the_user_is_told_what_the_failsafe_does_and_why():
    """framework.cpp notifyUser: a lost data link in Mission holds first ("GCS connection loss:
    switching to RTL in 5 seconds"), then returns ("GCS connection loss: switching to RTL"), as
    v1.15 words them; each event names the user's mode by its PX4 custom mode, the action and the cause, and
    comes with the text "Failsafe activated…\t". A geofence breach (no cause) and a low battery
    (a warning with an event of its own) say it their way."""
    log, events = StatusLog(), EventLog()
    fs = Failsafe(ParamStore({"NAV_DLL_ACT": 2}), log)
    fs.events = events
    mission = 0x04040000  # AUTO.MISSION
    base = dict(armed=True, user_nav_state=NavState.AUTO_MISSION, manual_control_lost=False)
    fs.update(0.0, FailsafeFlags(**base))
    lost = FailsafeFlags(**base, gcs_lost=True)
    assert fs.update(1.0, lost) is Action.HOLD
    assert fs.update(6.1, lost) is Action.RTL
    assert _told(events) == [
        ("commander_failsafe_enter_hold", Log.CRITICAL, Log.WARNING,
         (mission, int(Action.RTL), 5, int(Cause.GCS_CONNECTION_LOSS))),
        ("commander_failsafe_enter", Log.CRITICAL, Log.WARNING,
         (mission, int(Action.RTL), int(Cause.GCS_CONNECTION_LOSS)))]
    assert [t.text for t in log.after(0)] == [
        "Failsafe activated: entering Hold for 5 seconds\t", "Failsafe activated\t"]
    # As a ground station shows them: libevents (pyulog's copy) with the vehicle's metadata.
    import json

    from pyulog.libevents_parse.parser import Parser

    from gateway.onboard.metadata import events_json

    parser = Parser()
    parser.load_definitions(json.loads(events_json()))
    parser.set_profile("dev")
    assert [parser.parse(e.id, e.arguments.ljust(25, b"\0")).message()
            for e in events.after(events.latest - len(events))] == [
        "GCS connection loss: switching to RTL in 5 seconds",
        "GCS connection loss: switching to RTL"]

    events = EventLog()
    fs = Failsafe(ParamStore({"GF_ACTION": 3, "COM_FAIL_ACT_T": 0.0}), StatusLog())
    fs.events = events
    fs.update(0.0, FailsafeFlags(**base, geofence_breached=True))
    assert _told(events) == [("commander_failsafe_enter_generic", Log.CRITICAL, Log.WARNING,
                              (mission, int(Action.RTL)))]

    events = EventLog()
    fs = Failsafe(ParamStore(), StatusLog())
    fs.events = events
    assert fs.update(0.0, FailsafeFlags(**base, battery_warning=1)) is Action.WARN
    assert _told(events) == [("commander_failsafe_enter_low_bat", Log.WARNING, Log.INFO, ())]


def test_an_attitude_failure_disarms_on_takeoff_and_then_warns_or_terminates():
    """failsafe.cpp fd_critical_failure: Disarm in the early takeoff phase; later Warn with the
    flight termination circuit breaker set (CBRK_FLIGHTTERM 121212, PX4's default), Terminate
    without it."""
    base = dict(armed=True, user_nav_state=NavState.AUTO_LOITER, manual_control_lost=False)
    cases = ((121212, True, Action.DISARM), (121212, False, Action.WARN),
             (0, False, Action.TERMINATE), (0, True, Action.DISARM))
    for breaker, early, action in cases:
        fs = Failsafe(ParamStore({"CBRK_FLIGHTTERM": breaker}), StatusLog())
        fs.update(0.0, FailsafeFlags(**base, early_takeoff=early))
        assert fs.update(0.1, FailsafeFlags(**base, early_takeoff=early,
                                            fd_critical_failure=True)) is action, (breaker, early)


def test_a_battery_level_the_vehicle_armed_with_only_warns():
    """failsafe.cpp: armed at the critical level (COM_ARM_BAT_MIN let it), the critical level
    warns instead of taking COM_LOW_BAT_ACT's Return; the emergency level, worse than at arming,
    lands."""
    fs = Failsafe(ParamStore({"COM_LOW_BAT_ACT": 3, "COM_FAIL_ACT_T": 0.0}), StatusLog())
    base = dict(user_nav_state=NavState.AUTO_MISSION, manual_control_lost=False)
    fs.update(0.0, FailsafeFlags(armed=False, battery_warning=2, **base))
    assert fs.update(0.1, FailsafeFlags(armed=True, battery_warning=2, **base)) is Action.WARN
    assert fs.update(0.2, FailsafeFlags(armed=True, battery_warning=3, **base)) is Action.LAND
    fresh = Failsafe(ParamStore({"COM_LOW_BAT_ACT": 3, "COM_FAIL_ACT_T": 0.0}), StatusLog())
    fresh.update(0.0, FailsafeFlags(armed=True, **base))
    assert fresh.update(0.1, FailsafeFlags(armed=True, battery_warning=2, **base)) is Action.RTL


def test_px4s_framework_test_general():
    """PX4's own FailsafeTest.general (failsafe_test.cpp), its checks (FailsafeTester: manual
    control lost -> RTL cleared on a mode change, data link lost -> Descend) and steps: RC lost
    holds, then returns; the data link lost on top descends at once (already in a failsafe: no
    second hold, clearDelayIfNeeded); back -> RTL; RC back -> RTL stays; a mode change clears."""
    tester = (
        Check("manual_control_signal_lost", lambda f, p: f.manual_control_lost,
              lambda f, p: ActionOptions(Action.RTL, Clear.ON_MODE_CHANGE_OR_DISARM)),
        Check("gcs_connection_lost", lambda f, p: f.gcs_lost,
              lambda f, p: ActionOptions(Action.DESCEND)))
    fs = Failsafe(ParamStore({"COM_FAIL_ACT_T": 5.0}), StatusLog(), tester)
    ok = dict(armed=True, user_nav_state=NavState.POSCTL, manual_control_lost=False,
              manual_control_lost_at_arming=False)
    rc_lost = dict(ok, manual_control_lost=True)
    t = 5.0
    steps = ((0.0, ok, Action.NONE), (0.01, rc_lost, Action.HOLD), (6.0, rc_lost, Action.RTL),
             (0.01, dict(rc_lost, gcs_lost=True), Action.DESCEND), (0.01, rc_lost, Action.RTL),
             (0.01, ok, Action.RTL))
    for dt, flags, action in steps:
        t += dt
        assert fs.update(t, FailsafeFlags(**flags)) is action, (t, flags)
    fs.user_mode_changed()
    assert fs.update(t + 0.01, FailsafeFlags(**dict(ok, user_nav_state=NavState.ALTCTL))) \
        is Action.NONE


def test_already_landing_a_return_only_warns():
    """getSelectedAction's UX rule: in Land a Return failsafe only warns."""
    fs = Failsafe(ParamStore({"GF_ACTION": 3}), StatusLog())
    flags = FailsafeFlags(armed=True, user_nav_state=NavState.AUTO_LAND, geofence_breached=True,
                          manual_control_lost=False)
    assert fs.update(0.0, flags) is Action.WARN


def test_the_same_flags_are_checked_again_after_a_parameter_change():
    """A data-link loss with NAV_DLL_ACT 0 does nothing; the very same flags act once it is
    set. PX4 v1.15 has no COM_DLL_EXCEPT (it came later): no mode but Land and Precision land
    ignores the loss, and the name does not exist."""
    params = ParamStore({"NAV_DLL_ACT": 0, "COM_FAIL_ACT_T": 0.0})
    assert params.get("COM_DLL_EXCEPT") is None and not params.set("COM_DLL_EXCEPT", 1)
    fs = Failsafe(params, StatusLog())
    flags = FailsafeFlags(armed=True, user_nav_state=NavState.AUTO_MISSION, gcs_lost=True,
                          manual_control_lost=False, manual_control_lost_at_arming=False)
    assert fs.update(0.0, flags) is Action.NONE
    assert fs.update(0.1, flags) is Action.NONE
    params.set("NAV_DLL_ACT", 2)
    assert fs.update(0.2, flags) is Action.RTL


def test_position_loss_descends_at_once_and_clears_with_the_position():
    """checkModeFallback: Hold/Return/Land need a position, so Descend, with no Hold delay (Hold
    cannot run); Position mode with sticks falls back to Altitude; modes that need no position
    (Altitude, Stabilized) fly on."""
    fs = Failsafe(ParamStore(), StatusLog())
    lost = FailsafeFlags(armed=True, user_nav_state=NavState.AUTO_MISSION, position_invalid=True)
    assert fs.update(0.0, lost) is Action.DESCEND
    assert fs.update(1.0, FailsafeFlags(armed=True, user_nav_state=NavState.AUTO_MISSION)) \
        is Action.NONE
    sticks = dict(armed=True, position_invalid=True, manual_control_lost=False)
    assert Failsafe(ParamStore(), StatusLog()).update(
        0.0, FailsafeFlags(user_nav_state=NavState.POSCTL, **sticks)) is Action.FALLBACK_ALTCTRL
    assert Failsafe(ParamStore(), StatusLog()).update(
        0.0, FailsafeFlags(user_nav_state=NavState.ALTCTL, **sticks)) is Action.NONE


def test_terminate_has_no_delay_and_never_clears():
    fs = Failsafe(ParamStore({"GF_ACTION": 4}), StatusLog())
    flags = FailsafeFlags(armed=True, user_nav_state=NavState.AUTO_LOITER, geofence_breached=True)
    assert fs.update(0.0, flags) is Action.TERMINATE
    assert fs.update(1.0, FailsafeFlags(armed=False, user_nav_state=NavState.AUTO_LOITER)) \
        is Action.TERMINATE


def test_user_mode_change_takes_over():
    fs = Failsafe(ParamStore({"GF_ACTION": 2}), StatusLog())
    flags = FailsafeFlags(armed=True, user_nav_state=NavState.AUTO_MISSION, geofence_breached=True)
    assert fs.update(0.0, flags) is Action.HOLD
    fs.user_mode_changed()
    assert fs.update(0.1, flags) is Action.NONE


def test_manual_control_missing_at_arming_is_no_failsafe_until_it_came_and_went():
    fs = Failsafe(ParamStore(), StatusLog())
    none = dict(user_nav_state=NavState.AUTO_LOITER, manual_control_lost=True)
    assert fs.update(0.0, FailsafeFlags(armed=False, **none)) is Action.NONE
    assert fs.update(0.1, FailsafeFlags(armed=True, **none)) is Action.NONE  # SITL, no joystick
    assert fs.update(5.0, FailsafeFlags(armed=True, **none)) is Action.NONE
    back = dict(none, manual_control_lost=False)
    assert fs.update(6.0, FailsafeFlags(armed=True, **back)) is Action.NONE
    assert fs.update(7.0, FailsafeFlags(armed=True, **none)) is Action.HOLD  # then NAV_RCL_ACT
    assert fs.update(12.1, FailsafeFlags(armed=True, **none)) is Action.RTL


@pytest.mark.parametrize("bits, mode, ignored", [
    (1, NavState.AUTO_MISSION, True), (1, NavState.AUTO_LOITER, False),
    (2, NavState.AUTO_LOITER, True), (2, NavState.AUTO_TAKEOFF, True), (2, NavState.POSCTL, False),
    (2, NavState.AUTO_RTL, False), (2, NavState.ORBIT, False),  # v1.15's Hold bit: Hold, takeoff
    (4, NavState.OFFBOARD, True), (0, NavState.AUTO_MISSION, False)])
def test_com_rcl_except(bits, mode, ignored):
    fs = Failsafe(ParamStore({"COM_RCL_EXCEPT": bits}), StatusLog())
    assert fs.update(0.0, FailsafeFlags(armed=True, user_nav_state=mode,
                                        manual_control_lost=False)) is Action.NONE
    lost = FailsafeFlags(armed=True, user_nav_state=mode, manual_control_lost=True)
    assert (fs.update(1.0, lost) is Action.NONE) is ignored


@pytest.mark.parametrize("act, expected", [(0, Action.FALLBACK_POSCTRL), (1, Action.FALLBACK_ALTCTRL),
                                           (2, Action.FALLBACK_STABILIZED)])
def test_offboard_loss_falls_back_to_the_sticks_when_there_are_some(act, expected):
    fs = Failsafe(ParamStore({"COM_OBL_RC_ACT": act}), StatusLog())
    flags = FailsafeFlags(armed=True, user_nav_state=NavState.OFFBOARD, offboard_lost=True,
                          manual_control_lost=False)
    assert fs.update(0.0, flags) is expected


# --- in flight -------------------------------------------------------------------------------
def test_data_link_loss_default_does_nothing(sim):
    v = sim.v
    take_off(sim)
    v.on_gcs_heartbeat(sim.t)
    sim.run(16.0)
    assert "Connection to ground station lost\t" in sim.texts()
    assert v.status.nav_state is NavState.AUTO_LOITER and not v.status.failsafe
    v.on_gcs_heartbeat(sim.t)
    assert sim.texts()[-1] == "GCS connection regained\t"
    told = [event_name(e.id) for e in v.events.after(v.events.latest - len(v.events))]
    assert told[-2:] == ["commander_gcs_lost", "commander_dl_regained"]


def test_data_link_loss_returns_with_nav_dll_act_2():
    sim = make_sim(NAV_DLL_ACT=2)
    try:
        v = sim.v
        take_off(sim)
        sim.run(20.0)  # no GCS heartbeat ever: no data-link failsafe
        assert not v.status.failsafe
        v.on_gcs_heartbeat(sim.t)
        t0 = sim.t
        assert sim.run(12.0, until=lambda: v.status.failsafe)
        assert sim.t - t0 == pytest.approx(10.0, abs=0.1)  # COM_DL_LOSS_T
        assert v.status.nav_state is NavState.AUTO_LOITER
        assert sim.run(6.0, until=lambda: v.status.nav_state is NavState.AUTO_RTL)
        assert sim.t - t0 == pytest.approx(15.0, abs=0.2)  # + COM_FAIL_ACT_T
        v.on_gcs_heartbeat(sim.t)  # regained: PX4 keeps returning
        sim.run(1.0)
        assert v.status.nav_state is NavState.AUTO_RTL
        assert sim.run(60.0, until=lambda: not v.status.armed)
    finally:
        sim.close()


def test_geofence_circle_violation_holds(sim):
    v = sim.v
    fence = [item(0, MavCmd.NAV_FENCE_CIRCLE_INCLUSION, 0.0, 0.0, 0.0, v.origin, p1=20.0,
                  mission_type=PlanType.FENCE)]
    assert v.set_plan(sim.t, PlanType.FENCE, fence) is PlanResult.ACCEPTED
    take_off(sim)
    # PX4 v1.15 Commander ACCEPTs the switch to Hold; the navigator drops the target outside
    # the fence with its text, and the vehicle holds where it is.
    here = v.state.position_ned_m.copy()
    outside = v.origin.offset_ned(40.0, 0.0, -2.5)
    assert v.goto(sim.t, outside.lat_deg, outside.lon_deg, outside.alt_amsl_m) \
        is CommandResult.ACCEPTED
    assert sim.texts()[-1] == "Reposition is outside geofence\t"
    sim.run(3.0)
    assert v.status.nav_state is NavState.AUTO_LOITER
    assert math.hypot(*(v.state.position_ned_m[:2] - here[:2])) < 1.0
    # Fly out in offboard (not checked against the fence) and get caught.
    from vehicles.plan_types import OffboardSetpoint
    sp = OffboardSetpoint(velocity_ned_mps=(4.0, 0.0, 0.0))
    v.set_offboard_setpoint(sim.t, sp)
    assert v.set_nav_state(sim.t, NavState.OFFBOARD) is CommandResult.ACCEPTED
    def out():
        v.set_offboard_setpoint(sim.t, sp)
        return v.status.failsafe
    assert sim.run(10.0, until=out)
    assert "Geofence violation: approaching or outside geofence" in sim.texts()  # geofenceCheck
    assert v.status.nav_state is NavState.AUTO_LOITER
    sim.run(3.0, until=lambda: v.set_offboard_setpoint(sim.t, sp))  # stream on: no offboard loss
    assert v.status.nav_state is NavState.AUTO_LOITER
    assert math.hypot(*v.state.position_ned_m[:2]) < 26.0
    assert math.hypot(*v.state.velocity_ned_mps[:2]) < 0.3


def test_rtl_lands_at_closer_rally_point(sim):
    v = sim.v
    rally = [item(0, MavCmd.NAV_RALLY_POINT, 30.0, 10.0, 0.0, v.origin,
                  frame=MavFrame.GLOBAL_RELATIVE_ALT, mission_type=PlanType.RALLY)]
    assert v.set_plan(sim.t, PlanType.RALLY, rally) is PlanResult.ACCEPTED
    take_off(sim)
    g = v.origin.offset_ned(35.0, 10.0, -5.0)
    v.goto(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m)
    sim.run(12.0)
    assert v.return_to_launch(sim.t) is CommandResult.ACCEPTED
    assert sim.run(90.0, until=lambda: not v.status.armed)
    p = v.state.position_ned_m
    assert math.hypot(p[0] - 30.0, p[1] - 10.0) < 1.5
    assert "RTL: land at destination\t" in sim.texts()


def test_a_motor_lost_in_flight_is_an_attitude_failure_that_denies_arming():
    """A motor off in flight (failure injection): the vehicle rolls past FD_FAIL_R for
    FD_FAIL_R_TTRI, the failure detector's roll failure; the failsafe warns (CBRK_FLIGHTTERM
    set), and where it lies tilted, arming is denied ("Attitude failure detected"). How the
    tumble from 2.5 m ends depends on the motor and on the mixer's saturation handling: with
    PX4's sequential desaturation, losing motor 2 or 4 leaves the X500 upside down, 1 or 3
    upright."""
    sim = make_sim(SYS_FAILURE_EN=1)
    try:
        v = sim.v
        take_off(sim)
        sim.run(3.0)
        assert v.inject_failure(sim.t, 101, 1, 2) is CommandResult.ACCEPTED  # motor 2 off
        fd = v._autopilot.failure_detector
        assert sim.run(6.0, until=lambda: fd.roll or fd.pitch)
        sim.run(0.2)
        told = [event_name(e.id) for e in v.events.after(v.events.latest - len(v.events))]
        assert "commander_failsafe_enter_generic_warn" in told
        assert "Failsafe activated\t" in sim.texts()
        sim.run(6.0)
        assert fd.critical  # it lies tilted where it fell
        v.disarm(sim.t, forced=True)
        assert v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED
        assert sim.texts()[-1] == "Arming denied: Resolve system health failures first\t"
        assert v.run_prearm_checks(sim.t) is CommandResult.ACCEPTED
        told = [event_name(e.id) for e in v.events.after(v.events.latest - len(v.events))]
        assert {"check_failure_detector_roll", "check_failure_detector_pitch"} & set(told)
    finally:
        sim.close()


def test_battery_emergency_lands():
    sim = make_sim(SIM_BAT_MIN_PCT=0.0, SIM_BAT_DRAIN=40.0)
    try:
        v = sim.v
        take_off(sim)  # ~3 s of the 40 s battery
        v.goto(sim.t, *_above(v, 10.0))
        assert sim.run(40.0, until=lambda: v.status.nav_state is NavState.AUTO_LAND)
        texts = sim.texts()  # batteryCheck.cpp's texts; the failsafe's events say the rest
        assert "Low battery\t" in texts and "Emergency battery level\t" in texts
        told = [event_name(e.id) for e in v.events.after(v.events.latest - len(v.events))]
        assert "commander_failsafe_enter_low_bat" in told
        assert v.status.battery.remaining <= 0.05 + 1e-3
        assert sim.run(40.0, until=lambda: not v.status.armed)
    finally:
        sim.close()


def _above(v, alt):
    g = v.global_position
    return g.lat_deg, g.lon_deg, v.origin.alt_amsl_m + alt


def test_a_second_link_loss_after_a_takeover_triggers_again():
    from vehicles.failsafe import Action, Failsafe, FailsafeFlags
    from vehicles.params import ParamStore
    from vehicles.status_log import StatusLog
    from vehicles.types import NavState

    fs = Failsafe(ParamStore({"NAV_DLL_ACT": 2, "COM_FAIL_ACT_T": 0.0}), StatusLog())
    hold = NavState.AUTO_LOITER
    assert fs.update(1.0, FailsafeFlags(True, hold, gcs_lost=True)) is Action.RTL
    assert not fs.user_takeover_active and fs.flags.gcs_lost  # failsafe_flags, as logged
    fs.user_mode_changed()  # the user takes over while the link is still down
    # vehicle_status.failsafe_and_user_took_over (userTakeoverActive)
    assert fs.user_takeover_active
    assert fs.update(1.1, FailsafeFlags(True, hold, gcs_lost=True)) is Action.NONE
    assert fs.update(2.0, FailsafeFlags(True, hold)) is Action.NONE  # link back
    assert fs.update(9.0, FailsafeFlags(True, hold, gcs_lost=True)) is Action.RTL  # lost again


def test_fence_areas_that_exclude_home_are_dropped_at_load(sim):
    """MAVSDK's geofence example: a polygon round home plus a zero circle at (0, 0). PX4 takes the
    upload and drops the circle, which does not contain home, with a critical text."""
    v = sim.v
    sim.run(0.5)  # home is set with the position estimate
    poly = [item(i, MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, n, e, 0.0, v.origin, p1=4,
                 mission_type=PlanType.FENCE)
            for i, (n, e) in enumerate([(-11, -8), (11, -8), (11, 8), (-11, 8)])]
    zero = PlanItem(4, 6, MavCmd.NAV_FENCE_CIRCLE_INCLUSION, 0, 1, 0.0, 0.0, 0.0, math.nan, 0, 0,
                    0.0, PlanType.FENCE)
    assert v.set_plan(sim.t, PlanType.FENCE, poly + [zero]) is PlanResult.ACCEPTED
    assert sim.texts()[-1] == "Geofence invalid, doesn't contain Home position\t"
    assert len(v.autopilot.geofence.areas) == 1 and v.autopilot.geofence.areas[0].polygon


@pytest.mark.parametrize("distance, cone, expected", [
    (50.0, 45.0, 30.0),  # beyond RTL_MIN_DIST: RTL_RETURN_ALT
    (8.0, 45.0, 8.0),  # inside RTL_MIN_DIST: into the 45° cone
    (8.0, 80.0, 4.0),  # a wide cone: at least 2 × NAV_ACC_RAD
    (1.5, 45.0, 3.0),  # within NAV_ACC_RAD: twice the distance
    (8.0, 0.0, 30.0),  # no cone: RTL_RETURN_ALT everywhere
])
def test_rtl_return_altitude_follows_px4s_cone(distance, cone, expected):
    """rtl.cpp calculate_return_alt_from_cone_half_angle with PX4's defaults (RTL_RETURN_ALT
    30, RTL_MIN_DIST 10, NAV_ACC_RAD 2)."""
    from vehicles.nav_rtl import return_height_m
    assert return_height_m(distance, 30.0, cone, 10.0, 2.0) == pytest.approx(expected, abs=1e-3)


@pytest.mark.parametrize("delay_s", [70_000.0, 3e38])
def test_a_hold_delay_beyond_the_events_field_is_cast_as_px4_casts_it(delay_s):
    """PX4 stores COM_FAIL_ACT_T as given (no range check in param_set); notifyUser sends the
    delay as (uint16_t)delay_s, so a huge one wraps in the event and the text says it whole."""
    log, events = StatusLog(), EventLog()
    fs = Failsafe(ParamStore({"NAV_DLL_ACT": 2}), log)
    fs.events = events
    fs._params.set("COM_FAIL_ACT_T", delay_s)
    base = dict(armed=True, user_nav_state=NavState.AUTO_MISSION, manual_control_lost=False)
    fs.update(0.0, FailsafeFlags(**base))
    assert fs.update(1.0, FailsafeFlags(**base, gcs_lost=True)) is Action.HOLD
    secs = int(float(fs._params["COM_FAIL_ACT_T"]) + 0.5)
    assert _told(events)[0][3][2] == secs & 0xFFFF
    assert log.after(0)[-1].text == f"Failsafe activated: entering Hold for {secs} seconds\t"


@pytest.mark.parametrize("params, finished, expected", [
    ({"COM_RCL_EXCEPT": 1}, True, Action.RTL),  # sticks' loss ignored in Mission
    ({"COM_RC_IN_MODE": 4}, True, Action.RTL),  # sticks disabled
    ({"COM_RCL_EXCEPT": 1}, False, Action.NONE),  # the mission still flying
    ({}, True, Action.NONE),  # COM_RC_IN_MODE 1, no exception: the sticks' failsafe would act
])
def test_a_finished_mission_returns_when_every_command_link_is_lost(params, finished, expected):
    """failsafe.cpp's last resort in Mission (v1.15): with no manual-control failsafe and
    NAV_DLL_ACT 0, a finished mission whose GCS link is lost takes Return."""
    fs = Failsafe(ParamStore({"COM_FAIL_ACT_T": 0.0, **params}), StatusLog())
    flags = FailsafeFlags(armed=True, user_nav_state=NavState.AUTO_MISSION, gcs_lost=True,
                          mission_finished=finished)
    assert fs.update(0.0, flags) is expected
