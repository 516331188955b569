"""Failsafe state machine after PX4 ``commander/failsafe/failsafe.cpp`` + ``framework.cpp``.

Rules and invariants (PX4 semantics, simplified to what SITL exercises):
- ``CHECKS`` is a table: one row per failsafe condition with the function that tells whether the
  condition holds and the function that maps the parameters to an ``ActionOptions`` (action and
  clear condition). A test proves every row is exercised.
- Every tick each check reports its condition. A new failing condition adds its action; when the
  condition clears, ``WHEN_CONDITION_CLEARS`` actions go away, the others stay until a mode change
  or disarm (``ON_MODE_CHANGE_OR_DISARM``), disarm (``ON_DISARM``) or never (Terminate).
- The selected action is the most severe one. Adding an action worse than Warn starts the
  COM_FAIL_ACT_T hold delay: the vehicle holds first ("Failsafe activated: entering Hold for N
  seconds") and then takes the action ("Failsafe activated"). Terminate/Disarm skip the delay.
- The user is told when the action gets worse or a warning is added (notifyUser): an event that
  names the action and its cause (a lost link, a battery level) and the text above.
- Without a position estimate the delay's Hold cannot run: the action is taken at once.
- A user mode change while a failsafe is active is a user takeover: the action is dropped until a
  new one is added. Terminate is never cleared. Disarmed -> no action.
- Pure: time is an argument; the caller turns the action into a nav_state.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from dataclasses import dataclass, replace

from vehicles.cnum import c_int
from vehicles.custom_mode import custom_mode_of
from vehicles.events import (
    FAILSAFE_CRIT_BAT,
    FAILSAFE_EMERGENCY_BAT,
    FAILSAFE_ENTER,
    FAILSAFE_GENERIC,
    FAILSAFE_GENERIC_HOLD,
    FAILSAFE_GENERIC_WARN,
    FAILSAFE_HOLD,
    FAILSAFE_LOW_BAT,
    FAILSAFE_WARN,
    EventLog,
    Log,
)
from vehicles.params import ParamStore
from vehicles.status_log import StatusLog
from vehicles.types import NavState


class Action(enum.IntEnum):
    """failsafe.h Action, in PX4's severity order."""

    NONE = 0
    WARN = 1
    FALLBACK_POSCTRL = 2
    FALLBACK_ALTCTRL = 3
    FALLBACK_STABILIZED = 4
    HOLD = 5
    RTL = 6
    LAND = 7
    DESCEND = 8
    DISARM = 9
    TERMINATE = 10


# failsafe_action_t's descriptions (src/lib/events/enums.json), as the events name the actions
ACTION_TEXT = {Action.NONE: "", Action.WARN: "warning",
               Action.FALLBACK_POSCTRL: "Position mode",
               Action.FALLBACK_ALTCTRL: "Altitude mode",
               Action.FALLBACK_STABILIZED: "Stabilized mode", Action.HOLD: "Hold",
               Action.RTL: "RTL", Action.LAND: "Land", Action.DESCEND: "Descend",
               Action.DISARM: "disarm", Action.TERMINATE: "terminate"}


class Cause(enum.IntEnum):
    """framework.h Cause = the events' failsafe_cause_t (names as enums.json has them)."""

    GENERIC = 0
    MANUAL_CONTROL_LOSS = 1
    GCS_CONNECTION_LOSS = 2
    LOW_BATTERY_LEVEL = 3
    CRITICAL_BATTERY_LEVEL = 4
    EMERGENCY_BATTERY_LEVEL = 5
    LOW_REMAINING_FLIGHT_TIME = 6


CAUSE_TEXT = {Cause.GENERIC: "", Cause.MANUAL_CONTROL_LOSS: "Manual control loss",
              Cause.GCS_CONNECTION_LOSS: "GCS connection loss",
              Cause.LOW_BATTERY_LEVEL: "Low battery level",
              Cause.CRITICAL_BATTERY_LEVEL: "Critical battery level",
              Cause.EMERGENCY_BATTERY_LEVEL: "Emergency battery level",
              Cause.LOW_REMAINING_FLIGHT_TIME: "Remaining flight time low"}
# Warnings with a cause of their own event (notifyUser), by cause: (event, external level)
_CAUSE_WARNINGS = {Cause.LOW_BATTERY_LEVEL: (FAILSAFE_LOW_BAT, Log.WARNING),
                   Cause.CRITICAL_BATTERY_LEVEL: (FAILSAFE_CRIT_BAT, Log.CRITICAL),
                   Cause.EMERGENCY_BATTERY_LEVEL: (FAILSAFE_EMERGENCY_BAT, Log.EMERGENCY)}

# What ``Failsafe.update`` reads at every 50 Hz tick, by module names: in Python 3.11 a member
# read off its class (``Action.TERMINATE``) goes through EnumType.__getattr__ (~0.2 us).
_TERMINATE = Action.TERMINATE
_NO_ACTION = (Action.NONE, Action.NONE, Cause.GENERIC)  # (selected, delayed, cause)


class Clear(enum.Enum):
    WHEN_CONDITION_CLEARS = "when_condition_clears"
    ON_MODE_CHANGE_OR_DISARM = "on_mode_change_or_disarm"
    ON_DISARM = "on_disarm"
    NEVER = "never"


@dataclass(frozen=True)
class ActionOptions:
    action: Action
    clear: Clear = Clear.WHEN_CONDITION_CLEARS
    failing: bool = True  # the condition currently holds (PX4 state_failure)
    cause: Cause = Cause.GENERIC  # what the user is told (ActionOptions::causedBy)


@dataclass(frozen=True)
class FailsafeFlags:
    """Inputs of one tick (PX4 failsafe_flags + state)."""

    armed: bool
    user_nav_state: NavState
    gcs_lost: bool = False
    offboard_lost: bool = False
    battery_warning: int = 0  # 0 none, 1 low, 2 critical, 3 emergency
    geofence_breached: bool = False
    # No stick input within COM_RC_LOSS_T (true until a joystick or MANUAL_CONTROL sender shows up).
    manual_control_lost: bool = True
    # Filled in by Failsafe.update: the input was already missing when the vehicle armed (and has
    # not come back since), so its loss is not a failsafe (PX4 _manual_control_lost_at_arming).
    manual_control_lost_at_arming: bool = True
    # Filled in by Failsafe.update: the battery warning when the vehicle armed (COM_ARM_BAT_MIN
    # may let it arm low): only a worse level takes COM_LOW_BAT_ACT's action, this one warns.
    battery_warning_at_arming: int = 0
    # The position estimate was valid and is lost (no aiding for EKF2_NOAID_TOUT: GPS off).
    position_invalid: bool = False
    # failure_detector.py: roll or pitch beyond its limit (fd_critical_failure), and whether the
    # vehicle armed less than COM_SPOOLUP_TIME + 3 s ago (PX4's early takeoff phase)
    fd_critical_failure: bool = False
    early_takeoff: bool = False
    # mission_result.failure: the mission cannot be completed (a forced heading timed out)
    mission_failure: bool = False
    # mission_result.finished: the mission flew its last item
    mission_finished: bool = False


# NAV_DLL_ACT / NAV_RCL_ACT values: 0 disabled, 1 Hold, 2 Return, 3 Land, 5 Terminate, 6 Disarm.
def from_nav_dll_or_rcl_act(value: int) -> ActionOptions:
    table = {1: ActionOptions(Action.HOLD),
             2: ActionOptions(Action.RTL, Clear.ON_MODE_CHANGE_OR_DISARM),
             3: ActionOptions(Action.LAND, Clear.ON_MODE_CHANGE_OR_DISARM),
             5: ActionOptions(Action.TERMINATE, Clear.NEVER),
             6: ActionOptions(Action.DISARM)}
    return table.get(value, ActionOptions(Action.NONE))


def from_offboard_loss_act(params, manual_control_lost: bool = True) -> ActionOptions:
    """COM_OBL_RC_ACT; the manual fallbacks (0 Position, 1 Altitude, 2 Stabilized) need stick
    input, without it NAV_RCL_ACT applies (failsafe.cpp checkModeFallback)."""
    value = int(params["COM_OBL_RC_ACT"])
    table = {3: ActionOptions(Action.RTL, Clear.ON_MODE_CHANGE_OR_DISARM),
             4: ActionOptions(Action.LAND, Clear.ON_MODE_CHANGE_OR_DISARM),
             5: ActionOptions(Action.HOLD),
             6: ActionOptions(Action.TERMINATE, Clear.NEVER),
             7: ActionOptions(Action.DISARM)}
    if value in table:
        return table[value]
    if not manual_control_lost:
        fallback = {1: Action.FALLBACK_ALTCTRL, 2: Action.FALLBACK_STABILIZED}
        return ActionOptions(fallback.get(value, Action.FALLBACK_POSCTRL))
    return from_nav_dll_or_rcl_act(int(params["NAV_RCL_ACT"]))


def from_battery_act(params, level: int, worse_than_at_arming: bool = True) -> ActionOptions:
    """COM_LOW_BAT_ACT: 0 warn, 2 Land, 3 Return at critical / Land at emergency; the cause is
    the warning's level (fromBatteryWarningActParam). A level no worse than the one the vehicle
    armed with only warns (failsafe.cpp, warning_worse_than_at_arming)."""
    act = int(params["COM_LOW_BAT_ACT"]) if worse_than_at_arming else 0
    cause = Cause(Cause.LOW_BATTERY_LEVEL + min(max(level, 1), 3) - 1)
    if level <= 1 or act == 0:
        return ActionOptions(Action.WARN, cause=cause)
    if level == 2 and act == 3:
        return ActionOptions(Action.RTL, Clear.ON_MODE_CHANGE_OR_DISARM, cause=cause)
    return ActionOptions(Action.LAND, Clear.ON_DISARM, cause=cause)


def from_gf_act(params) -> ActionOptions:
    """GF_ACTION: 0 none, 1 warn, 2 Hold, 3 Return, 4 Terminate, 5 Land."""
    table = {1: ActionOptions(Action.WARN),
             2: ActionOptions(Action.HOLD, Clear.ON_MODE_CHANGE_OR_DISARM),
             3: ActionOptions(Action.RTL, Clear.ON_MODE_CHANGE_OR_DISARM),
             4: ActionOptions(Action.TERMINATE, Clear.NEVER),
             5: ActionOptions(Action.LAND, Clear.ON_MODE_CHANGE_OR_DISARM)}
    return table.get(int(params["GF_ACTION"]), ActionOptions(Action.NONE))


# COM_RCL_EXCEPT bits (v1.15 failsafe.cpp checkStateAndMode's rc_loss_ignored_*): which user
# modes ignore a manual-control loss (Hold covers the takeoff too).
_LINK_LOSS_EXCEPT_MODES = {
    1: {NavState.AUTO_MISSION},
    2: {NavState.AUTO_LOITER, NavState.AUTO_TAKEOFF},
    4: {NavState.OFFBOARD},
}


def _ignored(mode: NavState, bits: int) -> bool:
    return any(bits & bit and mode in modes for bit, modes in _LINK_LOSS_EXCEPT_MODES.items())


def _dll_condition(f: FailsafeFlags, params) -> bool:
    """GCS connection lost, ignored only in Land and Precision land (v1.15 has no
    COM_DLL_EXCEPT: gcs_connection_loss_ignored)."""
    return f.gcs_lost and f.user_nav_state not in (NavState.AUTO_LAND, NavState.AUTO_PRECLAND)


def _rcl_condition(f: FailsafeFlags, params) -> bool:
    """Manual control lost, unless it was already missing at arming (SITL without a joystick)
    or the mode is excepted by COM_RCL_EXCEPT."""
    if not f.manual_control_lost or f.manual_control_lost_at_arming:
        return False
    return not _ignored(f.user_nav_state, int(params["COM_RCL_EXCEPT"]))


RC_IN_MODE_STICK_INPUT_DISABLED = 4  # COM_RC_IN_MODE


def _mission_control_lost(f: FailsafeFlags, params) -> bool:
    """checkStateAndMode's last resort in Mission: with no manual-control failsafe (sticks
    disabled, or their loss ignored in Mission) and no data-link one (NAV_DLL_ACT 0), a finished
    mission whose GCS link is lost returns, rather than hover until the battery runs out."""
    return (f.user_nav_state is NavState.AUTO_MISSION and f.mission_finished and f.gcs_lost
            and int(params["NAV_DLL_ACT"]) == 0
            and (int(params["COM_RC_IN_MODE"]) == RC_IN_MODE_STICK_INPUT_DISABLED
                 or int(params["COM_RCL_EXCEPT"]) & 1 != 0))


# The user modes that need a position estimate (PX4 mode_requirements: global or local position).
NEEDS_POSITION = frozenset({NavState.AUTO_MISSION, NavState.AUTO_LOITER, NavState.AUTO_RTL,
                            NavState.AUTO_TAKEOFF, NavState.AUTO_LAND, NavState.AUTO_PRECLAND,
                            NavState.AUTO_FOLLOW_TARGET, NavState.ORBIT, NavState.POSCTL,
                            NavState.POSITION_SLOW, NavState.OFFBOARD})


def from_position_loss(f: FailsafeFlags) -> ActionOptions:
    """failsafe.cpp checkModeFallback: Position falls back to Altitude with stick input; any other
    mode that cannot run tries Return, Land, then Descend — without a position estimate only
    Descend can run."""
    if f.user_nav_state is NavState.POSCTL and not f.manual_control_lost:
        return ActionOptions(Action.FALLBACK_ALTCTRL)
    return ActionOptions(Action.DESCEND)


CBRK_FLIGHTTERM_KEY = 121212  # circuit_breaker.h: CBRK_FLIGHTTERM at this value disables it


def from_fd_critical_failure(f: FailsafeFlags, params) -> ActionOptions:
    """failsafe.cpp: in the early takeoff phase Disarm; later Terminate unless the flight
    termination circuit breaker is set (CBRK_FLIGHTTERM 121212, PX4's default), then Warn."""
    if f.early_takeoff:
        return ActionOptions(Action.DISARM)
    if int(params["CBRK_FLIGHTTERM"]) != CBRK_FLIGHTTERM_KEY:
        return ActionOptions(Action.TERMINATE, Clear.NEVER)
    return ActionOptions(Action.WARN)


@dataclass(frozen=True)
class Check:
    name: str
    condition: Callable[[FailsafeFlags, ParamStore], bool]
    options: Callable[[FailsafeFlags, ParamStore], ActionOptions]


CHECKS: tuple[Check, ...] = (
    Check("gcs_connection_lost", _dll_condition,
          lambda f, p: replace(from_nav_dll_or_rcl_act(int(p["NAV_DLL_ACT"])),
                               cause=Cause.GCS_CONNECTION_LOSS)),
    Check("manual_control_signal_lost", _rcl_condition,
          lambda f, p: replace(from_nav_dll_or_rcl_act(int(p["NAV_RCL_ACT"])),
                               cause=Cause.MANUAL_CONTROL_LOSS)),
    Check("offboard_signal_lost",
          lambda f, p: f.offboard_lost and f.user_nav_state is NavState.OFFBOARD,
          lambda f, p: from_offboard_loss_act(p, f.manual_control_lost)),
    Check("battery_warning", lambda f, p: f.battery_warning > 0,
          lambda f, p: from_battery_act(p, f.battery_warning,
                                        f.battery_warning > f.battery_warning_at_arming)),
    Check("geofence_breached", lambda f, p: f.geofence_breached, lambda f, p: from_gf_act(p)),
    Check("fd_critical_failure", lambda f, p: f.fd_critical_failure, from_fd_critical_failure),
    Check("position_lost", lambda f, p: f.position_invalid and f.user_nav_state in NEEDS_POSITION,
          lambda f, p: from_position_loss(f)),
    Check("mission_failure",
          lambda f, p: f.mission_failure and f.user_nav_state is NavState.AUTO_MISSION,
          lambda f, p: ActionOptions(Action.RTL)),
    Check("mission_control_lost", _mission_control_lost, lambda f, p: ActionOptions(Action.RTL)),
)


class Failsafe:
    def __init__(self, params, log: StatusLog, checks: tuple[Check, ...] = CHECKS) -> None:
        """``checks``: the conditions and their actions (failsafe.cpp checkStateAndMode); PX4's
        own framework tests run theirs."""
        self._checks = checks
        self._params = params
        self._log = log
        self.actions: dict[str, ActionOptions] = {}
        self.selected = Action.NONE
        self._delay_until = -math.inf
        self._user_takeover = False
        self._last_armed = False
        self._manual_control_lost_at_arming = False
        self._battery_warning_at_arming = 0
        self._quiet_flags: FailsafeFlags | None = None  # see ``update``
        self._quiet_version = -1
        self._notification_required = False  # a warning was added (checkFailsafe)
        self.events: EventLog | None = None  # events::send (notifyUser), where there are events
        self.flags: FailsafeFlags | None = None  # the last update's (PX4's failsafe_flags topic)
        self._calm: tuple[FailsafeFlags, int] | None = None  # see ``update``

    @property
    def in_failsafe(self) -> bool:
        """vehicle_status.failsafe: an action other than None/Warn is being taken."""
        return self.selected > Action.WARN

    @property
    def user_takeover_active(self) -> bool:
        """vehicle_status.failsafe_and_user_took_over (FailsafeBase::userTakeoverActive)."""
        return self._user_takeover

    def user_mode_changed(self) -> None:
        """The user asked for a mode: a takeover while in failsafe, clears mode-change actions."""
        self._remove(Clear.ON_MODE_CHANGE_OR_DISARM)
        if self.in_failsafe and self.selected is not Action.TERMINATE:
            self._user_takeover = True

    def _remove(self, clear: Clear) -> None:
        for name in [n for n, a in self.actions.items() if not a.failing and a.clear is clear]:
            del self.actions[name]

    def update(self, now_s: float, flags: FailsafeFlags) -> Action:
        # The same flags object as the last pass's (the autopilot hands the same frozen one
        # while its inputs stay), the same parameters, and that pass left no action and none
        # selected: this pass would find the same nothing (with no action no timer counts).
        calm = self._calm
        if calm is not None and calm[0] is flags and calm[1] == self._params.version:
            return self.selected
        self._calm = None
        given = flags
        # updateArmingState, then: input that comes back makes its later loss count again.
        if flags.armed and not self._last_armed or not flags.armed:
            self._manual_control_lost_at_arming = flags.manual_control_lost
        if not flags.manual_control_lost:
            self._manual_control_lost_at_arming = False
        if flags.manual_control_lost_at_arming != self._manual_control_lost_at_arming:
            flags = replace(flags, manual_control_lost_at_arming=self._manual_control_lost_at_arming)
        if flags.armed and not self._last_armed:
            self._battery_warning_at_arming = flags.battery_warning
        if self._battery_warning_at_arming != flags.battery_warning_at_arming:
            flags = replace(flags, battery_warning_at_arming=self._battery_warning_at_arming)
        self.flags = flags
        if flags.armed != self._last_armed:
            self._remove(Clear.ON_DISARM)
            self._remove(Clear.ON_MODE_CHANGE_OR_DISARM)
            self._user_takeover = False
            self._last_armed = flags.armed
        p, actions = self._params, self.actions
        # The conditions are functions of the flags and the parameters alone: when the last
        # pass found none true on these very flags (the autopilot hands the same frozen object
        # while its inputs stay) and the parameters have not changed, this pass would change
        # nothing (its clearing is done).
        if flags is self._quiet_flags and p.version == self._quiet_version:
            checks: tuple[Check, ...] = ()
        else:
            checks = self._checks
            self._quiet_flags, self._quiet_version = flags, p.version
        for check in checks:
            if check.condition(flags, p):
                self._quiet_flags = None
                current = actions.get(check.name)
                opts = check.options(flags, p)
                if opts.action is Action.NONE:
                    continue
                if current is None or opts.action > current.action or not current.failing:
                    # New, worse, or back after its condition had cleared (a second data-link
                    # loss after the link came back): a fresh failsafe event, which a user
                    # takeover of the earlier one does not cover.
                    self._add(now_s, check.name, opts)
                elif opts.action != current.action:
                    # checkFailsafe: the caller's action follows its options, the rest is kept
                    # (a lesser one too: a battery level the vehicle armed with only warns)
                    actions[check.name] = replace(current, failing=True, action=opts.action)
            elif actions:  # (nothing to clear without actions: the common case)
                current = actions.get(check.name)
                if current is not None and current.failing:
                    if current.clear is Clear.WHEN_CONDITION_CLEARS:
                        del actions[check.name]
                    else:
                        actions[check.name] = replace(current, failing=False)
        if (not actions or not any(a.action >= Action.HOLD for a in actions.values())
                or self.selected > Action.HOLD or self._user_takeover):
            # clearDelayIfNeeded: no Hold first when already in a failsafe or taken over
            self._delay_until = -math.inf
        action, delayed, cause = self._select(now_s, flags)
        # The action is worse than before, or a warning was added (framework.cpp update)
        if action > self.selected or (self._notification_required and action is not Action.NONE):
            self._notify_user(now_s, flags.user_nav_state, action, delayed, cause)
        self._notification_required = False
        self.selected = action
        if action is Action.NONE and not actions:
            self._calm = (given, p.version)
        return action

    def _notify_user(self, now_s: float, mode: NavState, action: Action, delayed: Action,
                     cause: Cause) -> None:
        """framework.cpp notifyUser: one event (which says what the action is and why) and a
        text (which only says that a failsafe began)."""
        events, custom_mode = self.events, custom_mode_of(mode)
        if action is Action.HOLD and delayed is not Action.NONE:
            left_s = self._delay_until - now_s + 0.5
            secs = int(left_s) if math.isfinite(left_s) else c_int(left_s)  # inf: saturated
            wire_secs = secs & 0xFFFF  # the event's (uint16_t)delay_s: COM_FAIL_ACT_T is as given
            if events is None:
                pass
            elif cause is Cause.GENERIC:
                events.send(now_s, FAILSAFE_GENERIC_HOLD, Log.CRITICAL, Log.WARNING, "IBH",
                            custom_mode, int(delayed), wire_secs)
            else:
                events.send(now_s, FAILSAFE_HOLD, Log.CRITICAL, Log.WARNING, "IBHB", custom_mode,
                            int(delayed), wire_secs, int(cause))
            self._log.critical(now_s, f"Failsafe activated: entering Hold for {secs} seconds\t")
            return
        if events is None:
            pass
        elif cause is Cause.GENERIC and action is Action.WARN:
            events.send(now_s, FAILSAFE_GENERIC_WARN, Log.WARNING, Log.WARNING, "I", custom_mode)
        elif cause is Cause.GENERIC:
            events.send(now_s, FAILSAFE_GENERIC, Log.CRITICAL, Log.WARNING, "IB", custom_mode,
                        int(action))
        elif action is Action.WARN and cause in _CAUSE_WARNINGS:
            event, level = _CAUSE_WARNINGS[cause]
            events.send(now_s, event, level, Log.INFO)
        elif action is Action.WARN:
            events.send(now_s, FAILSAFE_WARN, Log.WARNING, Log.WARNING, "IB", custom_mode,
                        int(cause))
        else:
            events.send(now_s, FAILSAFE_ENTER, Log.CRITICAL, Log.WARNING, "IBB", custom_mode,
                        int(action), int(cause))
        self._log.critical(now_s, "Failsafe activated\t")

    def _add(self, now_s: float, name: str, opts: ActionOptions) -> None:
        self.actions[name] = opts
        delay = float(self._params["COM_FAIL_ACT_T"])
        if (opts.action > Action.WARN and delay > 0.1 and now_s >= self._delay_until
                and opts.clear is not Clear.NEVER):
            self._delay_until = now_s + delay
        if opts.action is Action.WARN:
            self._notification_required = True
        if opts.action >= Action.HOLD:
            self._user_takeover = False

    def _select(self, now_s: float, flags: FailsafeFlags) -> tuple[Action, Action, Cause]:
        """getSelectedAction: (action, the action a Hold delays, the cause of the worst)."""
        if self.selected is _TERMINATE:
            return Action.TERMINATE, Action.NONE, Cause.GENERIC
        if not flags.armed or not self.actions:  # (no actions: the common case)
            return _NO_ACTION
        worst, cause = Action.NONE, Cause.GENERIC
        for a in self.actions.values():  # the first of the worst, as PX4 walks its slots
            if a.action > worst:
                worst, cause = a.action, a.cause
        if self._user_takeover and worst is not Action.TERMINATE:
            return Action.NONE, Action.NONE, cause
        delayed = Action.NONE
        if (now_s < self._delay_until and worst > Action.WARN and not flags.position_invalid
                and worst not in (Action.DISARM, Action.TERMINATE)):  # Hold needs a position
            worst, delayed = Action.HOLD, worst
        # getSelectedAction's UX rule: already landing, a Return (or, precision landing, a Land)
        # only warns
        mode = flags.user_nav_state
        if mode is NavState.AUTO_LAND and Action.RTL in (worst, delayed) or (
                mode is NavState.AUTO_PRECLAND
                and (Action.RTL in (worst, delayed) or Action.LAND in (worst, delayed))):
            return Action.WARN, Action.NONE, cause
        return worst, delayed, cause
