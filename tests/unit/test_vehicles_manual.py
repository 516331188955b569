"""Stick-driven flight (MANUAL_CONTROL → vehicles/manual_control.py): physics + autopilot on
simulated time, sticks fed as a joystick would at 20 Hz."""

import math
import struct

import numpy as np
import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from vehicles.airframe import X500
from vehicles.commander import ARMING_DENIED_TEXT
from vehicles.events import event_id
from vehicles.manual_attitude import throttle_to_thrust
from vehicles.manual_control import (
    ManualAltitude,
    Sticks,
    deadzone,
    expo,
    superexpo,
)
from vehicles.params import ParamStore
from vehicles.types import CommandResult, NavState

CENTRED = Sticks()


def fly(sim, seconds, sticks, until=None):
    """Run ``seconds`` sending ``sticks`` every 50 ms (a joystick through QGC)."""
    end = sim.t + seconds
    while sim.t < end - 1e-9:
        sim.v.manual_control(sim.t, sticks)
        if sim.run(0.05, until=until):
            return True
    return False


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def test_stick_math_is_px4s():
    assert deadzone(0.05, 0.1) == 0.0 and deadzone(1.0, 0.1) == 1.0
    assert deadzone(0.55, 0.1) == pytest.approx(0.5)
    assert expo(0.5, 0.6) == pytest.approx(0.4 * 0.5 + 0.6 * 0.125)
    assert superexpo(1.0, 0.69, 0.7) == pytest.approx(1.0)
    p = ParamStore()
    assert throttle_to_thrust(0.0, p, 0.4) == pytest.approx(0.4)  # centred = hover
    assert throttle_to_thrust(-1.0, p, 0.4) == pytest.approx(float(p["MPC_MANTHR_MIN"]))
    assert throttle_to_thrust(1.0, p, 0.4) == pytest.approx(float(p["MPC_THR_MAX"]))


def test_altitude_mode_limits_the_stick_before_filtering_the_tilt():
    """StickTiltXY::generateAccelerationSetpoints: limitStickUnitLengthXY comes before the
    MC_MAN_TILT_TAU filter, so a full diagonal stick starts from a filtered unit vector, not a
    filtered (1, 1) that is only limited once it has grown past unit length."""
    task = ManualAltitude(ParamStore({"MC_MAN_TILT_TAU": 1.0, "MPC_MAN_TILT_MAX": 45.0}))
    task.activate((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0)
    sp = task.update(1.0, Sticks(pitch=1.0, roll=1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0,
                     (0.0, 0.0, 0.0))
    half_of_unit = 0.5 / math.sqrt(2.0) * 9.80665  # alpha = dt / (tau + dt) = 0.5
    assert sp.acceleration_ned_mps2[0] == pytest.approx(half_of_unit)
    assert sp.acceleration_ned_mps2[1] == pytest.approx(half_of_unit)


def test_position_mode_needs_sticks_and_then_flies_them(sim):
    take_off(sim)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.TEMPORARILY_REJECTED
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    start = sim.v.state.position_ned_m.copy()
    fly(sim, 3.0, CENTRED)  # centred sticks: position and altitude hold
    assert np.linalg.norm(sim.v.state.position_ned_m - start) < 0.3
    fly(sim, 4.0, Sticks(pitch=1.0))  # full forward: accelerate north towards MPC_VEL_MANUAL
    vn = sim.v.state.velocity_ned_mps[0]
    assert vn > 5.0
    fly(sim, 6.0, CENTRED)  # release: brake and lock the position
    s = sim.v.state
    assert np.linalg.norm(s.velocity_ned_mps) < 0.2
    held = s.position_ned_m.copy()
    fly(sim, 2.0, CENTRED)
    assert np.linalg.norm(sim.v.state.position_ned_m - held) < 0.2
    z0 = held[2]
    # Full up: below MPC_LAND_ALT2 (5 m) at MPC_TKO_SPEED, above MPC_LAND_ALT1 (10 m) at
    # MPC_Z_VEL_MAX_UP (3 m/s).
    fly(sim, 1.0, Sticks(throttle=1.0))
    assert sim.v.state.velocity_ned_mps[2] == pytest.approx(-1.5, abs=0.2)
    assert fly(sim, 10.0, Sticks(throttle=1.0), until=lambda: sim.v.state.position_ned_m[2] < -12.0)
    fly(sim, 0.5, Sticks(throttle=1.0))
    assert sim.v.state.velocity_ned_mps[2] == pytest.approx(-3.0, abs=0.3)
    fly(sim, 3.0, CENTRED)
    assert sim.v.state.position_ned_m[2] < z0 - 9.0
    assert abs(sim.v.state.velocity_ned_mps[2]) < 0.2
    yaw0 = sim.v.state.euler_rad()[2]
    fly(sim, 1.0, Sticks(yaw=0.5))  # yaw right at ~35 deg/s (expo), the rate fed forward
    assert math.remainder(sim.v.state.euler_rad()[2] - yaw0, math.tau) > 0.38
    assert sim.v.status.nav_state is NavState.POSCTL


def test_position_mode_lands_and_disarms_with_the_stick_down(sim):
    take_off(sim)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    assert fly(sim, 30.0, Sticks(throttle=-1.0), until=lambda: not sim.v.status.armed)
    assert "Disarmed by landing\t" in sim.texts()
    assert abs(sim.v.state.position_ned_m[2]) < 0.1


def test_position_mode_takes_off_from_the_ground_with_the_stick_up(sim):
    sim.run(1.2)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    assert sim.v.arm(sim.t) is CommandResult.ACCEPTED
    fly(sim, 1.0, CENTRED)
    assert abs(sim.v.state.position_ned_m[2]) < 0.05  # centred on the ground: stays there
    # PX4's takeoff: COM_SPOOLUP_TIME, then the MPC_TKO_RAMP_T ramp, then the climb.
    assert fly(sim, 8.0, Sticks(throttle=0.8), until=lambda: sim.v.state.position_ned_m[2] < -2.0)
    fly(sim, 2.0, CENTRED)
    assert not sim.v.status.landed_state.name == "ON_GROUND"


def test_position_mode_stick_tilt_is_limited_by_the_takeoff_tilt_limit(sim):
    """StickAccelerationXY::applyTiltLimit reads takeoff_status.tilt_limit: MPC_TILTMAX_LND
    (12 deg) until the takeoff reaches its flight state, then slewed up at 0.2 rad/s towards
    MPC_TILTMAX_AIR (45 deg), not MPC_TILTMAX_AIR at once."""
    sim.run(1.2)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    assert sim.v.arm(sim.t) is CommandResult.ACCEPTED
    fly(sim, 1.0, CENTRED)
    stage = sim.v._autopilot.stage
    assert fly(sim, 8.0, Sticks(throttle=0.8), until=lambda: sim.v.state.position_ned_m[2] < -0.5)
    seen = []
    for _ in range(20):  # full pitch forward right after lifting off
        fly(sim, 0.05, Sticks(pitch=1.0, throttle=0.3))
        acc = stage.task_setpoint.acceleration_ned_mps2
        seen.append((math.hypot(acc[0], acc[1]), stage.tilt_limit_rad))
    first_acc, first_limit = seen[0]
    assert first_limit < math.radians(20.0)
    for acc, limit in seen:
        assert acc <= math.tan(limit) * 9.80665 + 1e-6
    assert seen[-1][1] > first_limit  # slewing up


def test_an_invalid_mpc_pos_mode_is_reset_to_4_in_position_mode(sim):
    """FlightModeManager: MPC_POS_MODE other than 0, 3 and 4 is set back to 4 (and committed)
    as soon as Position mode runs; the valid ones stay."""
    sim.run(1.2)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    for value, kept in ((3, 3), (2, 4), (0, 0), (1, 4)):
        assert sim.v.params.set("MPC_POS_MODE", value)
        fly(sim, 0.1, CENTRED)
        assert sim.v.params["MPC_POS_MODE"] == kept


@pytest.mark.parametrize("mode", [NavState.STAB, NavState.ALTCTL, NavState.ACRO])
def test_attitude_modes_tilt_with_the_roll_stick(sim, mode):
    take_off(sim)
    # Stabilized and Altitude: a centred throttle is the hover thrust (mc_att_control's throttle
    # curve, mc_pos_control). Acro passes the stick on: centred is 0.5, and the gz X500 needs
    # ~0.73 to hover, so the pilot holds the stick there.
    hold = Sticks(throttle=2.0 * X500.hover_thrust_norm - 1.0) if mode is NavState.ACRO else CENTRED
    sim.v.manual_control(sim.t, hold)
    assert sim.v.set_nav_state(sim.t, mode) is CommandResult.ACCEPTED
    fly(sim, 1.0, hold)
    roll = Sticks(roll=0.5) if mode is not NavState.ACRO else Sticks(roll=0.3, throttle=hold.throttle)
    fly(sim, 0.6, roll)
    assert sim.v.state.euler_rad()[0] > math.radians(8.0)  # rolled right
    assert sim.v.state.velocity_ned_mps[1] > 0.3  # and drifting east
    if mode is NavState.STAB:  # the roll stick's angle: MPC_MAN_TILT_MAX / 2
        assert math.degrees(sim.v.state.euler_rad()[0]) == pytest.approx(17.5, abs=2.0)


def test_stick_loss_in_position_mode_returns(sim):
    take_off(sim)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    fly(sim, 1.0, CENTRED)
    sim.run(7.0)  # no input: COM_RC_LOSS_T, then Hold for COM_FAIL_ACT_T, then NAV_RCL_ACT
    assert sim.v.status.nav_state is NavState.AUTO_RTL
    # rcAndDataLinkCheck.cpp: events, no texts; regained after the whole gap since the last input
    events = sim.v.events
    lost = [e for e in events.after(events.latest - len(events))
            if e.id == event_id("commander_rc_lost")]
    assert lost and "Manual control lost" not in sim.texts()
    fly(sim, 0.2, CENTRED)
    regained = next(e for e in reversed(events.after(events.latest - len(events)))
                    if e.id == event_id("commander_rc_regained"))
    assert struct.unpack("<f", regained.arguments)[0] == pytest.approx(7.0, abs=0.1)


def test_moving_the_sticks_takes_over_a_mission_hold(sim):
    take_off(sim)
    fly(sim, 1.0, CENTRED)  # a joystick appears, centred: no takeover
    assert sim.v.status.nav_state is NavState.AUTO_LOITER
    fly(sim, 0.5, Sticks(pitch=0.8))
    assert sim.v.status.nav_state is NavState.POSCTL
    assert "Pilot took over using sticks\t" in sim.texts()
    assert sim.v.events.after(sim.v.events.latest - 1)[0].id == event_id("commander_rc_override")


def test_moving_the_sticks_during_a_failsafe_is_the_failsafes_takeover(sim):
    """Commander passes the override to the failsafe while one acts: Position, the framework's
    "Pilot took over using sticks" event (failsafe_rc_override), no text."""
    take_off(sim)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    fly(sim, 1.0, CENTRED)
    sim.run(7.0)  # sticks lost: Hold, then Return
    assert sim.v.status.nav_state is NavState.AUTO_RTL
    fly(sim, 0.5, CENTRED)  # the joystick is back: the Return goes on (cleared by a mode change)
    assert sim.v.status.nav_state is NavState.AUTO_RTL and sim.v.status.failsafe
    fly(sim, 0.5, Sticks(pitch=0.8))
    assert sim.v.status.nav_state is NavState.POSCTL and not sim.v.status.failsafe
    ids = [e.id for e in sim.v.events.after(sim.v.events.latest - len(sim.v.events))]
    assert event_id("failsafe_rc_override") in ids and event_id("commander_rc_override") not in ids
    assert "Pilot took over using sticks\t" not in sim.texts()


def test_no_takeover_with_com_rc_override_zero():
    s = Sim(COM_RC_OVERRIDE=0)
    try:
        take_off(s)
        fly(s, 1.0, CENTRED)
        fly(s, 0.5, Sticks(pitch=0.8))
        assert s.v.status.nav_state is NavState.AUTO_LOITER
    finally:
        s.close()


def test_arming_in_position_mode_without_sticks_is_denied(sim):
    sim.run(1.2)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    sim.run(1.0)  # the input is gone
    assert sim.v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED
    assert ARMING_DENIED_TEXT in sim.texts()
    assert not any("manual control" in text for text in sim.texts())  # an event, no text


ARM_GESTURE = Sticks(throttle=-1.0, yaw=1.0)  # left stick lower right, right stick centred
DISARM_GESTURE = Sticks(throttle=-1.0, yaw=-1.0)  # lower left


def test_the_stick_gestures_arm_and_disarm_after_com_rc_arm_hyst(sim):
    """ManualControl::processStickArming: held COM_RC_ARM_HYST (1 s) the gesture asks once;
    Commander::arm refuses it outside a manual mode, and the sticks disarm once landed."""
    sim.run(1.2)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    fly(sim, 1.5, ARM_GESTURE)  # Hold, asked for: not a manual mode
    assert not sim.v.status.armed
    assert sim.texts()[-1] == "Arming denied: switch to manual mode first\t"
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    fly(sim, 0.2, CENTRED)  # released: the next hold starts again
    fly(sim, 0.9, ARM_GESTURE)  # samples 0.0 .. 0.85 s into the hold
    assert not sim.v.status.armed
    fly(sim, 0.2, ARM_GESTURE)
    assert sim.v.status.armed
    assert sim.texts()[-1] == "Armed by RC\t"
    fly(sim, 1.2, DISARM_GESTURE)  # landed: the sticks disarm
    assert not sim.v.status.armed
    assert sim.texts()[-1] == "Disarmed by RC\t"


def test_man_arm_gesture_zero_ignores_the_gesture():
    s = Sim(MAN_ARM_GESTURE=0)
    try:
        s.run(1.2)
        s.v.manual_control(s.t, CENTRED)
        assert s.v.set_nav_state(s.t, NavState.POSCTL) is CommandResult.ACCEPTED
        fly(s, 3.0, ARM_GESTURE)
        assert not s.v.status.armed
    finally:
        s.close()


def test_the_throttle_stick_up_denies_arming_in_position_mode(sim):
    """Commander::arm: "throttle above center" (> 0.2) while a climb-rate mode has sticks."""
    sim.run(1.2)
    sim.v.manual_control(sim.t, Sticks(throttle=0.5))
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    assert sim.v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED
    assert sim.texts()[-1] == "Arming denied: throttle above center\t"
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.arm(sim.t) is CommandResult.ACCEPTED


def test_sys_status_reports_the_joystick(sim):
    """SYS_STATUS RC_RECEIVER (MAVSDK's rc_status, QGC's RC indicator): present and healthy
    with sticks; without them, never there or lost, absent (rcAndDataLinkCheck sets it present
    only while valid) and unhealthy, so enabled ("No manual control input", modeCheck)."""
    from gateway.mavlink.heartbeat import SENSOR_RC_RECEIVER, sensor_bits

    sim.run(1.2)
    present, enabled, health = sensor_bits(sim.v.status)
    assert not present & SENSOR_RC_RECEIVER and not health & SENSOR_RC_RECEIVER
    assert enabled & SENSOR_RC_RECEIVER
    fly(sim, 0.5, CENTRED)
    present, enabled, health = sensor_bits(sim.v.status)
    assert present & enabled & health & SENSOR_RC_RECEIVER
    sim.run(1.0)
    present, enabled, health = sensor_bits(sim.v.status)
    assert not present & SENSOR_RC_RECEIVER and not health & SENSOR_RC_RECEIVER
    assert enabled & SENSOR_RC_RECEIVER


def test_a_second_stick_source_is_ignored_while_the_first_is_fresh(sim):
    take_off(sim)
    sim.v.manual_control(sim.t, CENTRED, source="qgc")
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    end = sim.t + 3.0
    while sim.t < end:  # QGC centred, another app pushing full forward: QGC keeps control
        sim.v.manual_control(sim.t, CENTRED, source="qgc")
        sim.v.manual_control(sim.t, Sticks(pitch=1.0), source="app")
        sim.run(0.05)
    assert abs(sim.v.state.velocity_ned_mps[0]) < 0.3
    assert sim.v._autopilot.manual.source == "qgc"


def test_once_the_takeoff_ramp_starts_it_runs_whatever_the_sticks_ask(sim):
    """PX4's TakeoffHandling stays in rampup until the ramp ends and mc_pos_control keeps
    controlling meanwhile: one tick of climb input starts the takeoff; centred sticks after it
    do not idle the motors again (they did: the ramp only advanced on ticks asking to climb)."""
    sim.run(1.2)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    assert sim.v.arm(sim.t) is CommandResult.ACCEPTED
    fly(sim, 1.5, CENTRED)  # spooled up, ready for takeoff
    stage = sim.v.autopilot.stage
    fly(sim, 0.05, Sticks(throttle=1.0))
    assert stage.taking_off
    idle, end = [], sim.t + 2.0
    while sim.t < end:  # 2 s of centred sticks within the 3 s ramp
        fly(sim, 0.05, CENTRED)
        idle.append(stage.idle)
    assert not any(idle) and stage.taking_off


@pytest.mark.parametrize("mode", [0, 4])
def test_com_rc_in_mode_rc_only_or_disabled_ignores_mavlink_sticks(mode):
    """ManualControlSelector::isInputValid: 0 takes RC only (there is none), 4 no input."""
    s = Sim(COM_RC_IN_MODE=mode)
    try:
        s.run(1.2)
        s.v.manual_control(s.t, CENTRED, source="gcs")
        assert s.v._autopilot.manual.sticks is None
        assert s.v.status.nav_state is NavState.AUTO_LOITER  # no input: no Position either
    finally:
        s.close()


def test_stick_input_before_any_mode_change_makes_the_mode_position(sim):
    """Commander::manualControlCheck: disarmed, valid MAVLink sticks and no mode change since
    boot force Position (once); after a mode change they do not."""
    sim.run(1.2)
    fly(sim, 0.2, CENTRED)
    assert sim.v.status.nav_state is NavState.POSCTL
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    fly(sim, 0.2, CENTRED)
    assert sim.v.status.nav_state is NavState.AUTO_LOITER


def test_com_rc_in_mode_3_keeps_the_first_source_until_reboot():
    """COM_RC_IN_MODE 3 (PX4's default; SITL sets 1): the first source is the only one, even
    once its input is lost, where 1 falls back to another."""
    for mode, other_takes_over in ((3, False), (1, True)):
        s = Sim(COM_RC_IN_MODE=mode)
        try:
            s.run(1.2)
            s.v.manual_control(s.t, CENTRED, source="gcs")
            s.run(1.0)  # lost (COM_RC_LOSS_T 0.5 s)
            s.v.manual_control(s.t, CENTRED, source="api")
            assert (s.v._autopilot.manual.source == "api") is other_takes_over
        finally:
            s.close()
