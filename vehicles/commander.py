"""Commander: arming, pre-arm checks, auto-disarm, landed bookkeeping and mode switching.

After PX4 ``src/modules/commander/Commander.cpp`` (arm/disarm, handle_command, auto-disarm with
COM_DISARM_LAND / COM_DISARM_PRFLT) and ``ModeUtil/mode_requirements.cpp``.

Rules and invariants:
- ``MODE_TABLE`` has one row per NavState (a test proves it): how a request to switch to it is
  answered, whether it needs a position estimate, whether arming is allowed in it, and which mode
  the vehicle falls back to after a disarm (Land/RTL -> Hold, PX4_COMPAT.md §11).
- Boot in AUTO_LOITER (Hold). ``position_valid`` becomes true POSITION_VALID_DELAY_S after boot
  (stands in for EKF2 + GPS convergence); the autopilot sets home then and on every arming.
- Arming always runs the pre-arm checks (also when forced, like PX4 for external commands).
  Already armed -> ACCEPTED. Disarm in the air only when forced (kill).
- Status texts are PX4's strings (without the trailing tab).
- Time is an argument; nothing here knows physics or MAVLink.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from vehicles.status_log import StatusLog
from vehicles.types import CommandResult, NavState

# EKF2/GPS "ready" this long after boot (PX4 SITL needs a few seconds; EKF2_REQ_GPS_H is 0.5 s).
POSITION_VALID_DELAY_S = 1.0

ARMING_DENIED_TEXT = "Arming denied: Resolve system health failures first"


class SwitchRule(enum.Enum):
    ALLOWED = "allowed"  # ACCEPTED (TEMPORARILY_REJECTED without position if it needs one)
    NEEDS_MANUAL_CONTROL = "needs_manual_control"  # no RC/joystick in SITL -> rejected
    NOT_YET = "not_yet"  # implemented in a later task (Mission, Offboard, ...) -> rejected
    FAILSAFE_ONLY = "failsafe_only"  # entered by the vehicle itself, never by request


class ArmEvent(enum.Enum):
    """Commander events other than mode requests (the coverage test crosses them with modes)."""

    ARM = "arm"
    DISARM = "disarm"
    KILL = "kill"
    AUTO_DISARM = "auto_disarm"


@dataclass(frozen=True)
class ModeSpec:
    name: str
    switch: SwitchRule
    needs_position: bool
    arming_allowed: bool
    after_disarm: NavState | None  # fallback once disarmed; None = stay


_L = NavState.AUTO_LOITER
MODE_TABLE: dict[NavState, ModeSpec] = {
    NavState.MANUAL: ModeSpec("Manual", SwitchRule.NEEDS_MANUAL_CONTROL, False, True, None),
    NavState.ALTCTL: ModeSpec("Altitude", SwitchRule.NEEDS_MANUAL_CONTROL, False, True, None),
    NavState.POSCTL: ModeSpec("Position", SwitchRule.NEEDS_MANUAL_CONTROL, True, True, None),
    NavState.AUTO_MISSION: ModeSpec("Mission", SwitchRule.NOT_YET, True, True, None),
    NavState.AUTO_LOITER: ModeSpec("Hold", SwitchRule.ALLOWED, True, True, None),
    NavState.AUTO_RTL: ModeSpec("Return", SwitchRule.ALLOWED, True, False, _L),
    NavState.POSITION_SLOW: ModeSpec("Position Slow", SwitchRule.NEEDS_MANUAL_CONTROL, True, True,
                                     None),
    NavState.ACRO: ModeSpec("Acro", SwitchRule.NEEDS_MANUAL_CONTROL, False, True, None),
    NavState.DESCEND: ModeSpec("Descend", SwitchRule.FAILSAFE_ONLY, False, False, _L),
    NavState.TERMINATION: ModeSpec("Termination", SwitchRule.FAILSAFE_ONLY, False, False, None),
    NavState.OFFBOARD: ModeSpec("Offboard", SwitchRule.NOT_YET, True, True, None),
    NavState.STAB: ModeSpec("Stabilized", SwitchRule.NEEDS_MANUAL_CONTROL, False, True, None),
    NavState.AUTO_TAKEOFF: ModeSpec("Takeoff", SwitchRule.ALLOWED, True, True, None),
    NavState.AUTO_LAND: ModeSpec("Land", SwitchRule.ALLOWED, True, False, _L),
    NavState.AUTO_FOLLOW_TARGET: ModeSpec("Follow Me", SwitchRule.NOT_YET, True, False, _L),
    NavState.AUTO_PRECLAND: ModeSpec("Precision Land", SwitchRule.NOT_YET, True, False, _L),
    NavState.ORBIT: ModeSpec("Orbit", SwitchRule.NOT_YET, True, False, _L),
}


class Commander:
    def __init__(self, params, status_log: StatusLog, boot_time_s: float = 0.0) -> None:
        self._params = params
        self._log = status_log
        self._boot_time_s = boot_time_s
        self.armed = False
        self.nav_state = NavState.AUTO_LOITER
        self.position_valid = False
        self.terminated = False
        self.landed = True
        self.have_taken_off_since_arming = False
        self._armed_at_s = 0.0
        self._landed_since_s: float | None = None

    # --- queries ------------------------------------------------------------------------------
    def prearm_ok(self) -> bool:
        return (self.position_valid and int(self._params["COM_ARMABLE"]) == 1
                and not self.terminated and MODE_TABLE[self.nav_state].arming_allowed)

    def mode_request_result(self, target: NavState) -> CommandResult:
        """How a request to switch to ``target`` would be answered right now (pure query)."""
        spec = MODE_TABLE[target]
        if self.terminated:
            return CommandResult.TEMPORARILY_REJECTED
        if spec.switch is not SwitchRule.ALLOWED:
            return CommandResult.TEMPORARILY_REJECTED
        if spec.needs_position and not self.position_valid:
            return CommandResult.TEMPORARILY_REJECTED
        return CommandResult.ACCEPTED

    # --- requests -----------------------------------------------------------------------------
    def request_nav_state(self, now_s: float, target: NavState) -> CommandResult:
        result = self.mode_request_result(target)
        if result is CommandResult.ACCEPTED:
            self.nav_state = target
        return result

    def arm(self, now_s: float, forced: bool = False) -> CommandResult:
        if self.armed:
            return CommandResult.ACCEPTED
        if not self.prearm_ok():
            # PX4 runs the checks for external commands even when forced.
            self._log.critical(now_s, ARMING_DENIED_TEXT)
            return CommandResult.TEMPORARILY_REJECTED
        self.armed = True
        self._armed_at_s = now_s
        self.have_taken_off_since_arming = False
        self._landed_since_s = None
        self._log.info(now_s, "Armed by external command")
        return CommandResult.ACCEPTED

    def disarm(self, now_s: float, forced: bool = False) -> CommandResult:
        if not self.armed:
            return CommandResult.ACCEPTED
        if not self.landed and not forced:
            self._log.critical(now_s, "Disarming denied: not landed")
            return CommandResult.TEMPORARILY_REJECTED
        self._disarm(now_s, "Disarmed by external command")
        return CommandResult.ACCEPTED

    def _disarm(self, now_s: float, text: str) -> None:
        self.armed = False
        self._log.info(now_s, text)
        fallback = MODE_TABLE[self.nav_state].after_disarm
        if fallback is not None:
            self.nav_state = fallback

    # --- periodic -----------------------------------------------------------------------------
    def update(self, now_s: float, landed: bool) -> bool:
        """Advance timers; returns True when the position estimate has just become valid."""
        became_valid = False
        if not self.position_valid and now_s - self._boot_time_s >= POSITION_VALID_DELAY_S - 1e-9:
            self.position_valid = became_valid = True
        if self.armed and landed != self.landed:
            if landed:
                self._log.info(now_s, "Landing detected")
            else:
                self._log.info(now_s, "Takeoff detected")
                self.have_taken_off_since_arming = True
        self.landed = landed
        if not self.armed:
            return became_valid
        # Auto-disarm (Commander::checkForAutoDisarm-like; one hysteresis, two delays).
        if self.have_taken_off_since_arming:
            delay = float(self._params["COM_DISARM_LAND"])
            if landed:
                if self._landed_since_s is None:
                    self._landed_since_s = now_s
                if delay > 0.0 and now_s - self._landed_since_s >= delay - 1e-9:
                    self._disarm(now_s, "Disarmed by landing")
            else:
                self._landed_since_s = None
        else:
            delay = float(self._params["COM_DISARM_PRFLT"])
            if delay > 0.0 and now_s - self._armed_at_s >= delay - 1e-9:
                self._disarm(now_s, "Disarmed by auto preflight disarming")
        return became_valid

    def switch_by_vehicle(self, target: NavState) -> None:
        """A switch the vehicle makes itself (takeoff done -> Hold): no request rules apply."""
        self.nav_state = target
