"""Commander tables and rules, without physics."""

import pytest

from vehicles.commander import ARMING_DENIED_TEXT, POSITION_VALID_DELAY_S, Commander
from vehicles.events import ARM_DENIED_THROTTLE_CENTER, ARM_DENIED_THROTTLE_HIGH, ArmReason, EventLog
from vehicles.mode_table import MODE_TABLE, ArmEvent, SwitchRule
from vehicles.params import ParamStore
from vehicles.status_log import StatusLog
from vehicles.types import CommandResult, NavState

REQUESTABLE = {NavState.AUTO_LOITER, NavState.AUTO_TAKEOFF, NavState.AUTO_LAND, NavState.AUTO_RTL,
               NavState.AUTO_MISSION, NavState.OFFBOARD, NavState.ORBIT,
               NavState.AUTO_FOLLOW_TARGET, NavState.AUTO_PRECLAND}
# ... and with stick input (MANUAL_CONTROL) within COM_RC_LOSS_T:
STICK_MODES = {NavState.MANUAL, NavState.ALTCTL, NavState.POSCTL, NavState.POSITION_SLOW,
               NavState.STAB, NavState.ACRO}


def make(nav_state=NavState.AUTO_LOITER, position_valid=True, armed=False, landed=True,
         mission_valid=True, offboard_available=True, manual_control_available=False):
    log = StatusLog()
    c = Commander(ParamStore(), log)
    c.manual_control_available = manual_control_available
    c.throttle_low = True  # the sticks' throttle down, where a pilot arms from
    c.position_valid = c.home_valid = position_valid  # (home is set where the position is)
    c.mission_valid = mission_valid
    c.offboard_available = offboard_available
    c._intend(nav_state)  # as a granted request leaves it
    c.armed = armed
    c.landed = landed
    return c, log


def test_mode_table_covers_every_nav_state():
    assert set(MODE_TABLE) == set(NavState)


def test_boot_state_is_hold_disarmed_without_position():
    c = Commander(ParamStore(), StatusLog())
    assert (c.nav_state, c.armed, c.position_valid) == (NavState.AUTO_LOITER, False, False)
    assert not c.update(POSITION_VALID_DELAY_S / 2, landed=True)
    assert c.update(POSITION_VALID_DELAY_S, landed=True)
    assert c.position_valid


@pytest.mark.parametrize("sticks", [False, True])
@pytest.mark.parametrize("current", list(NavState))
@pytest.mark.parametrize("target", list(NavState))
def test_every_mode_request_from_every_mode_has_a_defined_answer(current, target, sticks):
    """Armed (UserModeIntention::change checks canRun): as the table says."""
    c, _ = make(current, armed=True, landed=False, manual_control_available=sticks)
    result = c.request_nav_state(0.0, target)
    if target in REQUESTABLE or (sticks and target in STICK_MODES):
        assert result is CommandResult.ACCEPTED
        assert c.nav_state is target
    else:
        assert MODE_TABLE[target].switch is not SwitchRule.ALLOWED
        assert result is CommandResult.TEMPORARILY_REJECTED
        assert c.nav_state is current


@pytest.mark.parametrize("current", list(NavState))
@pytest.mark.parametrize("target", list(NavState))
def test_disarmed_every_requestable_mode_is_granted(current, target):
    """UserModeIntention::change: always_allow while disarmed (a command can name every mode
    but Descend and Termination); arming then says what the mode lacks."""
    c, _ = make(current, position_valid=False, mission_valid=False, offboard_available=False)
    result = c.request_nav_state(0.0, target)
    if MODE_TABLE[target].switch is SwitchRule.FAILSAFE_ONLY:
        assert result is CommandResult.TEMPORARILY_REJECTED and c.nav_state is current
    else:
        assert result is CommandResult.ACCEPTED and c.nav_state is target


def test_a_disarm_comes_back_to_the_last_mode_asked_that_can_arm():
    """UserModeIntention::onDisarm: Mission, then Return (which prevents arming), landed and
    disarmed: Mission again; a failsafe's Return leaves the asked mode alone too."""
    c, _ = make(NavState.AUTO_MISSION, armed=True, landed=False)
    assert c.request_nav_state(0.0, NavState.AUTO_RTL) is CommandResult.ACCEPTED
    c.landed = True
    assert c.disarm(1.0) is CommandResult.ACCEPTED
    assert c.nav_state is c.user_nav_state is NavState.AUTO_MISSION


@pytest.mark.parametrize("mission_valid", [False, True])
@pytest.mark.parametrize("offboard_available", [False, True])
@pytest.mark.parametrize("target", list(NavState))
def test_mission_and_offboard_requirements(target, mission_valid, offboard_available):
    c, _ = make(mission_valid=mission_valid, offboard_available=offboard_available, armed=True,
                landed=False)
    spec = MODE_TABLE[target]
    result = c.request_nav_state(0.0, target)
    blocked = (spec.needs_mission and not mission_valid) or (
        spec.needs_offboard and not offboard_available)
    if target in REQUESTABLE and not blocked:
        assert result is CommandResult.ACCEPTED
    else:
        assert result is CommandResult.TEMPORARILY_REJECTED
        assert c.nav_state is NavState.AUTO_LOITER
    assert spec.needs_mission is (target is NavState.AUTO_MISSION)
    assert spec.needs_offboard is (target is NavState.OFFBOARD)


@pytest.mark.parametrize("current", list(NavState))
@pytest.mark.parametrize("armed", [False, True])
def test_termination_from_every_mode(current, armed):
    c, _ = make(current, armed=armed, landed=not armed)
    result = c.terminate(0.0)
    if not armed:
        assert result is CommandResult.DENIED and not c.terminated
        return
    assert result is CommandResult.ACCEPTED
    assert c.terminated and c.nav_state is NavState.TERMINATION
    assert not c.prearm_ok()
    # Final: no mode request is honoured any more.
    assert c.request_nav_state(0.0, NavState.AUTO_LOITER) is CommandResult.TEMPORARILY_REJECTED


@pytest.mark.parametrize("target", sorted(REQUESTABLE | STICK_MODES))
def test_mode_requests_need_a_position_estimate(target):
    c, _ = make(position_valid=False, manual_control_available=True, armed=True, landed=False)
    expected = (CommandResult.TEMPORARILY_REJECTED if MODE_TABLE[target].needs_position
                else CommandResult.ACCEPTED)
    assert c.request_nav_state(0.0, target) is expected
    assert MODE_TABLE[target].needs_position is (
        target not in STICK_MODES - {NavState.POSCTL, NavState.POSITION_SLOW})


@pytest.mark.parametrize("mode", sorted(STICK_MODES))
def test_arming_in_a_stick_mode_needs_stick_input(mode):
    c, log = make(mode)
    assert c.arm(0.0) is CommandResult.TEMPORARILY_REJECTED
    # v1.15's modeCheck.cpp reports it as an event only: no text but the denial
    assert [t.text for t in log.after(0)] == [ARMING_DENIED_TEXT]
    c.manual_control_available = True
    assert c.arm(0.0) is CommandResult.ACCEPTED


@pytest.mark.parametrize("mode", sorted(STICK_MODES))
def test_arming_with_the_throttle_up_is_denied_as_commander_arm_says(mode):
    """Commander::arm: with stick input, above centre (> 0.2) in Altitude and Position, not low
    (>= -0.8) where the stick sets the thrust (Manual, Stabilized, Acro); text and event."""
    c, log = make(mode, manual_control_available=True)
    events = EventLog()
    c.events = events
    thrust = MODE_TABLE[mode].stick_thrust
    c.throttle_low = False  # centred: the thrust modes refuse, the climb-rate modes arm
    if thrust:
        assert c.arm(0.0) is CommandResult.TEMPORARILY_REJECTED
        assert [t.text for t in log.after(0)] == ["Arming denied: high throttle\t"]
        assert events.get(events.latest).id == ARM_DENIED_THROTTLE_HIGH.id
        c.throttle_low = True
        assert c.arm(0.0) is CommandResult.ACCEPTED
        return
    c.throttle_above_center = True
    assert c.arm(0.0) is CommandResult.TEMPORARILY_REJECTED
    assert [t.text for t in log.after(0)] == ["Arming denied: throttle above center\t"]
    assert events.get(events.latest).id == ARM_DENIED_THROTTLE_CENTER.id
    c.manual_control_available = False  # lost: no throttle check (then the mode's own)
    c.nav_state = NavState.AUTO_LOITER
    assert c.arm(0.0) is CommandResult.ACCEPTED


def test_the_sticks_arm_only_in_a_manual_mode():
    c, log = make(NavState.AUTO_LOITER, manual_control_available=True)
    assert c.arm(0.0, reason=ArmReason.RC_STICK) is CommandResult.TEMPORARILY_REJECTED
    assert [t.text for t in log.after(0)] == ["Arming denied: switch to manual mode first\t"]
    assert c.arm(0.0) is CommandResult.ACCEPTED  # a command may
    c, log = make(NavState.POSCTL, manual_control_available=True)
    assert c.arm(0.0, reason=ArmReason.RC_STICK) is CommandResult.ACCEPTED
    assert log.after(0)[-1].text == "Armed by RC\t"


@pytest.mark.parametrize("mode", [NavState.POSCTL, NavState.STAB])
def test_the_sticks_disarm_in_the_air_only_where_they_set_the_thrust(mode):
    """Commander::disarm: not landed, the sticks' request passes in Stabilized/Acro/Manual with
    COM_DISARM_MAN 1, and is refused silently elsewhere; a command's refusal says why."""
    c, log = make(mode, armed=True, landed=False, manual_control_available=True)
    if mode is NavState.STAB:
        c2, _ = make(mode, armed=True, landed=False, manual_control_available=True)
        c2._params.set("COM_DISARM_MAN", 0)
        assert c2.disarm(0.0, reason=ArmReason.RC_STICK) is CommandResult.TEMPORARILY_REJECTED
        assert c.disarm(0.0, reason=ArmReason.RC_STICK) is CommandResult.ACCEPTED
        assert log.after(0)[-1].text == "Disarmed by RC\t"
        return
    assert c.disarm(0.0, reason=ArmReason.RC_STICK) is CommandResult.TEMPORARILY_REJECTED
    assert c.armed and log.after(0) == []


@pytest.mark.parametrize("current", list(NavState))
@pytest.mark.parametrize("event", list(ArmEvent))
def test_every_mode_times_every_arming_event(current, event):
    armed = event is not ArmEvent.ARM
    c, log = make(current, armed=armed, landed=True, manual_control_available=True)
    if event is ArmEvent.ARM:
        result = c.arm(0.0)
        expected = MODE_TABLE[current].arming_allowed
        assert c.armed is expected
        assert result is (CommandResult.ACCEPTED if expected else CommandResult.TEMPORARILY_REJECTED)
        if not expected:
            assert log.after(0)[-1].text == ARMING_DENIED_TEXT
        return
    if event is ArmEvent.DISARM:
        assert c.disarm(0.0) is CommandResult.ACCEPTED
    elif event is ArmEvent.KILL:
        c.landed = False
        assert c.disarm(0.0, forced=True) is CommandResult.ACCEPTED
    else:  # AUTO_DISARM: preflight timeout
        c.update(100.0, landed=True)
    assert not c.armed
    # onDisarm: the last mode asked for that does not prevent arming (make's: Hold before)
    assert c.nav_state is (current if MODE_TABLE[current].arming_allowed
                           else NavState.AUTO_LOITER)


def test_arming_denied_before_position_valid():
    c, log = make(position_valid=False)
    assert c.arm(0.0) is CommandResult.TEMPORARILY_REJECTED
    assert c.arm(0.0, forced=True) is CommandResult.TEMPORARILY_REJECTED
    assert [t.text for t in log.after(0)] == [ARMING_DENIED_TEXT] * 2


@pytest.mark.parametrize("mode", sorted(STICK_MODES))
def test_arming_without_position_only_in_modes_that_do_not_fly_one(mode):
    """HealthAndArmingChecks canArm(nav_state): a missing position estimate (GPS failed) denies
    arming in the modes that require one (mode_requirements.cpp), not in Stabilized, Acro,
    Manual or Altitude."""
    c, log = make(mode, position_valid=False, manual_control_available=True)
    needs = MODE_TABLE[mode].needs_position
    assert c.prearm_ok() is not needs
    assert c.arm(0.0) is (CommandResult.TEMPORARILY_REJECTED if needs else CommandResult.ACCEPTED)
    assert c.armed is not needs


def test_arming_needs_the_missions_and_offboard_signal_of_its_mode():
    c, _ = make(NavState.AUTO_MISSION, mission_valid=False)
    assert c.arm(0.0) is CommandResult.TEMPORARILY_REJECTED
    c, _ = make(NavState.OFFBOARD, offboard_available=False)
    assert c.arm(0.0) is CommandResult.TEMPORARILY_REJECTED
    c.offboard_available = True
    assert c.arm(0.0) is CommandResult.ACCEPTED


def test_already_armed_is_accepted_and_com_armable_zero_denies():
    c, _ = make(armed=True)
    assert c.arm(0.0) is CommandResult.ACCEPTED
    c2 = Commander(ParamStore({"COM_ARMABLE": 0}), StatusLog())
    c2.position_valid = True
    assert c2.arm(0.0) is CommandResult.TEMPORARILY_REJECTED


def test_disarm_denied_in_air_unless_forced():
    c, log = make(armed=True, landed=False)
    assert c.disarm(0.0) is CommandResult.TEMPORARILY_REJECTED
    assert c.armed
    assert log.after(0)[-1].text == "Disarming denied: not landed\t"
    assert c.disarm(0.0, forced=True) is CommandResult.ACCEPTED
    assert not c.armed
    assert log.after(0)[-1].text == "Disarmed by external command\t"


def test_status_log_sequence_and_bound():
    log = StatusLog(capacity=3)
    for i in range(5):
        log.info(float(i), f"t{i}")
    assert [t.seq for t in log.after(0)] == [3, 4, 5]
    assert [t.text for t in log.after(4)] == ["t4"]
    assert log.after(5) == []


def test_a_failsafe_during_an_orbit_comes_back_to_hold():
    """failsafe.cpp modifyUserIntendedMode: when a failsafe engages while the user's mode is
    Orbit, the user's mode becomes Hold, so the vehicle holds once the failsafe clears."""
    from vehicles.failsafe import FailsafeFlags

    c, _ = make(nav_state=NavState.ORBIT, armed=True, landed=False)
    c._params.set("GF_ACTION", 2)  # geofence breach: Hold until a mode change
    c._params.set("COM_FAIL_ACT_T", 0.0)
    flags = FailsafeFlags(armed=True, user_nav_state=NavState.ORBIT, manual_control_lost=False)
    c.update(0.0, False, flags)
    assert c.nav_state is NavState.ORBIT
    c.update(0.1, False, FailsafeFlags(**{**flags.__dict__, "geofence_breached": True}))
    assert c.nav_state is NavState.AUTO_LOITER and c.user_nav_state is NavState.AUTO_LOITER


def test_armed_return_needs_a_home():
    """mode_req_home_position: armed without home, Return cannot run."""
    c, _ = make(NavState.AUTO_LOITER, armed=True, landed=False)
    c.home_valid = False
    assert c.request_nav_state(0.0, NavState.AUTO_RTL) is CommandResult.TEMPORARILY_REJECTED
    c.home_valid = True
    assert c.request_nav_state(0.0, NavState.AUTO_RTL) is CommandResult.ACCEPTED
