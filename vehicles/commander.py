"""Commander: arming, pre-arm checks, auto-disarm, landed bookkeeping and mode switching.

After PX4 ``src/modules/commander/Commander.cpp`` (arm/disarm, handle_command, auto-disarm with
COM_DISARM_LAND / COM_DISARM_PRFLT) and ``ModeUtil/mode_requirements.cpp``.

Rules and invariants:
- The modes' rules are mode_table.py's ``MODE_TABLE``: how a request to switch is answered, what
  a mode needs, whether it arms, where a disarm leaves it (Land/RTL -> Hold).
- Boot in AUTO_LOITER (Hold). ``position_valid`` becomes true POSITION_VALID_DELAY_S after boot
  (stands in for EKF2 + GPS convergence) while the estimator is aided (``position_aided``: a GPS
  fix within EKF2_NOAID_TOUT); the autopilot sets home the first time and on every arming.
  Losing it later (GPS off) is ``position_lost``, the failsafes' input.
- Arming always runs the pre-arm checks (also when forced, like PX4 for external commands):
  first, with stick input, the throttle's (Commander::arm: above centre in Altitude/Position, not
  low in the modes where it sets the thrust), or, asked by the sticks in a mode without them,
  "switch to manual mode first"; then the health checks. Already armed -> ACCEPTED.
- Disarm in the air only when forced (kill), or asked by the sticks in a mode where the throttle
  sets the thrust (COM_DISARM_MAN); the sticks' refusal says nothing (Commander::disarm).
- Mission and Offboard have extra requirements (``needs_mission`` / ``needs_offboard``, PX4
  mode_req_mission / mode_req_offboard_signal): the autopilot keeps ``mission_valid`` and
  ``offboard_available`` current.
- ``user_nav_state`` is the mode the user (or the vehicle itself) asked for; ``nav_state`` is what
  runs: the failsafe state machine (failsafe.py) may override it while a failsafe is active.
- Mode requests follow UserModeIntention: while disarmed any mode a command names is granted
  (arming then says what it lacks), armed it must be able to run. A disarm goes back to the
  last mode asked for that does not prevent arming (after Return or Land: the Mission, Hold, …
  before them). Stick input while disarmed, before any mode change since boot, makes the mode
  Position (manualControlCheck).
- Stick input (MANUAL_CONTROL, manual_control.py): the stick modes (``NEEDS_MANUAL_CONTROL``)
  are entered and armed in only while it is fresh (``manual_control_available``); once seen, its
  loss and return are announced as events ("Manual control lost" / "... regained after N.N s").
- Data-link loss (Commander::dataLinkCheck): the timer starts at the first GCS heartbeat; no
  heartbeat for COM_DL_LOSS_T -> "Connection to ground station lost"; a new one -> "GCS connection
  regained". The mode is not restored automatically.
- Termination (DO_FLIGHTTERMINATION or a failsafe) is final: motors off, mode TERMINATION.
- Status texts are PX4's strings (without the trailing tab).
- Time is an argument; nothing here knows physics or MAVLink.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

from vehicles.custom_mode import custom_mode_of
from vehicles.events import (
    ARM_DENIED,
    ARM_DENIED_CALIBRATING,
    ARM_DENIED_NOT_MANUAL,
    ARM_DENIED_THROTTLE_CENTER,
    ARM_DENIED_THROTTLE_HIGH,
    ARM_REASON_TEXT,
    ARMED_BY,
    CHECK_MISSION_FAILURE,
    COMMANDER_LAND,
    COMMANDER_RTL,
    DISARM_DENIED_NOT_LANDED,
    DISARMED_BY,
    FAILSAFE_RC_OVERRIDE,
    GCS_LOST,
    GCS_REGAINED,
    LANDING_DETECTED,
    MODE_NOT_AVAILABLE,
    NAVIGATION_MODE,
    NAVIGATION_MODE_UNKNOWN,
    RC_LOST,
    RC_OVERRIDE,
    RC_REGAINED,
    TAKEOFF_DETECTED,
    UNSUPPORTED_ARM_PARAM,
    UNSUPPORTED_AUTO_MODE,
    ArmReason,
    EventLog,
    Log,
)
from vehicles.failsafe import Action, Failsafe, FailsafeFlags
from vehicles.mode_table import ACTION_NAV_STATE, MODE_TABLE, SwitchRule
from vehicles.status_log import StatusLog
from vehicles.types import CommandResult, NavState

if TYPE_CHECKING:
    from vehicles.health_checks import Results

# EKF2/GPS "ready" this long after boot (PX4 SITL needs a few seconds; EKF2_REQ_GPS_H is 0.5 s).
POSITION_VALID_DELAY_S = 1.0

# printRejectMode says it at most once in this long (Commander.cpp: elapsed > 1_s)
REJECT_MODE_QUIET_S = 1.0

# Why the sticks arm or disarm (manual_control.py's gestures; PX4's switches and buttons too)
RC_REASONS = frozenset({ArmReason.RC_STICK, ArmReason.RC_SWITCH, ArmReason.RC_BUTTON})

# PX4 ends a mavlink_log text that it also sends as an event with a tab (QGC then shows the event).
ARMING_DENIED_TEXT = ARM_DENIED.message + "\t"  # "Arming denied: Resolve system health failures first"


# Read at every 50 Hz tick (``_update_failsafe``), by module names: in Python 3.11 a member read
# off its class (``Action.TERMINATE``) goes through EnumType.__getattr__ (~0.2 us).
_TERMINATE, _DISARM, _WARN = Action.TERMINATE, Action.DISARM, Action.WARN


class Commander:
    def __init__(self, params, status_log: StatusLog, boot_time_s: float = 0.0) -> None:
        self._params = params
        self._log = status_log
        self._boot_time_s = boot_time_s
        self.armed = False
        self.nav_state = NavState.AUTO_LOITER
        self.user_nav_state = NavState.AUTO_LOITER
        self._after_disarm = NavState.AUTO_LOITER  # UserModeIntention's _nav_state_after_disarming
        self._ever_changed = False  # everHadModeChange
        self.mission_valid = False
        self.offboard_available = False
        self.manual_control_available = False
        self._sticks_seen = False
        self._sticks_lost_s: float | None = None
        self.home_valid = False
        self.failsafe = Failsafe(params, status_log)
        self.gcs_lost = False
        self._gcs_seen_s: float | None = None
        self.position_valid = False
        self.position_aided = True  # the estimator's say (Autopilot.set_position_aided)
        self._ever_valid = False
        self.terminated = False
        self.landed = True
        self.have_taken_off_since_arming = False
        self._armed_at_s = 0.0
        self.takeoff_at_s: float | None = None  # vehicle_status.takeoff_time, while armed
        self._landed_since_s: float | None = None
        self._params_version = -1  # the timeouts below are read at the first update
        self._disarm_land_s = self._disarm_preflight_s = self._dl_loss_t_s = 0.0
        self.events: EventLog | None = None  # PX4's events::send, where it sends as well as says
        # The health checks' failures that deny arming in every mode, as an arming request's
        # "Preflight Fail: …" texts (health_checks.py, told at each evaluation).
        self.health_failures: tuple[str, ...] = ()
        # failure_detector.py's verdict: failureDetectorCheck.cpp denies arming in every mode
        self.attitude_failure = False
        self.mission_failure = False  # missionCheck.cpp: no mode can arm
        self._reject_said_s = -math.inf  # printRejectMode's last text
        # manualControlCheck: the last valid stick sample's throttle (-1 down .. 1 up)
        self.throttle_above_center = False  # > 0.2
        self.throttle_low = False  # < -0.8

    def _update_params(self) -> None:
        p = self._params
        self._params_version = p.version
        self._disarm_land_s = float(p["COM_DISARM_LAND"])
        self._disarm_preflight_s = float(p["COM_DISARM_PRFLT"])
        self._dl_loss_t_s = float(p["COM_DL_LOSS_T"])

    def set_health(self, results: Results) -> None:
        """health_checks.HealthChecks' ``on_results``."""
        self.health_failures = results.preflight_texts
        self.mission_failure = any(check[0] is CHECK_MISSION_FAILURE for check in results.checks)

    # --- queries ------------------------------------------------------------------------------
    def prearm_ok(self) -> bool:
        """Arming possible in the current mode (HealthAndArmingChecks canArm(nav_state)): the
        mode allows arming and what it requires is there (mode_requirements.cpp): a position
        estimate for the modes that fly one (Stabilized, Acro, Manual and Altitude arm without
        it), a mission, an offboard signal, stick input; no failed mission (missionCheck)."""
        spec = MODE_TABLE[self.nav_state]
        return (int(self._params["COM_ARMABLE"]) == 1 and not self.terminated
                and spec.arming_allowed and not self.health_failures and not self.attitude_failure
                and not self.mission_failure
                and (self.position_valid or not spec.needs_position)
                and (self.mission_valid or not spec.needs_mission)
                and (self.offboard_available or not spec.needs_offboard)
                and not self._needs_sticks_now())

    def _needs_sticks_now(self) -> bool:
        """The mode flies from the sticks and there are none (rcAndDataLinkCheck)."""
        return (MODE_TABLE[self.nav_state].switch is SwitchRule.NEEDS_MANUAL_CONTROL
                and not self.manual_control_available)

    @property
    def manual_control_state(self) -> str | None:
        """Stick input: None (never seen), "present", or "lost" (seen, then gone)."""
        if self.manual_control_available:
            return "present"
        return "lost" if self._sticks_seen else None

    @property
    def failsafe_active(self) -> bool:
        """vehicle_status.failsafe (PX4 selects no action while disarmed)."""
        return self.armed and self.failsafe.in_failsafe

    def mode_request_result(self, target: NavState) -> CommandResult:
        """How a request to switch to ``target`` would be answered right now (pure query):
        UserModeIntention::change allows any mode a command names while disarmed (arming then
        says what is missing); armed, the mode must be able to run (canRun)."""
        spec = MODE_TABLE[target]
        if self.terminated or spec.switch is SwitchRule.FAILSAFE_ONLY:
            return CommandResult.TEMPORARILY_REJECTED
        if not self.armed:
            return CommandResult.ACCEPTED
        if spec.needs_home and not self.home_valid:
            return CommandResult.TEMPORARILY_REJECTED
        if spec.switch is SwitchRule.NEEDS_MANUAL_CONTROL:
            if not self.manual_control_available:
                return CommandResult.TEMPORARILY_REJECTED
        elif spec.switch is not SwitchRule.ALLOWED:
            return CommandResult.TEMPORARILY_REJECTED
        if spec.needs_position and not self.position_valid:
            return CommandResult.TEMPORARILY_REJECTED
        if (spec.needs_mission and not self.mission_valid) or (
                spec.needs_offboard and not self.offboard_available):
            return CommandResult.TEMPORARILY_REJECTED
        return CommandResult.ACCEPTED

    # --- requests -----------------------------------------------------------------------------
    def request_nav_state(self, now_s: float, target: NavState) -> CommandResult:
        self._ever_changed = True  # UserModeIntention: any request counts, granted or not
        result = self.mode_request_result(target)
        if result is CommandResult.ACCEPTED:
            self._intend(target)
            self.failsafe.user_mode_changed()
        return result

    def _intend(self, target: NavState) -> None:
        """UserModeIntention::change, granted: the mode flown (unless a failsafe acts), and the
        one a disarm comes back to unless it prevents arming (Return, Land, ...: onDisarm)."""
        self.nav_state = self.user_nav_state = target
        if MODE_TABLE[target].arming_allowed:
            self._after_disarm = target

    def sticks_seen_disarmed(self) -> None:
        """manualControlCheck, disarmed, with valid MAVLink stick input: a vehicle whose mode
        nobody has changed since boot takes Position (forced)."""
        if not self.armed and not self._ever_changed and not self.terminated:
            self._ever_changed = True
            self._intend(NavState.POSCTL)

    def command_mode(self, now_s: float, target: NavState) -> CommandResult:
        """NAV_RETURN_TO_LAUNCH / NAV_LAND: the mode, and Commander's answer when it is taken
        ("Returning to launch", "Landing at current position": a text and its event)."""
        result = self.request_nav_state(now_s, target)
        if result is CommandResult.ACCEPTED:
            event = COMMANDER_RTL if target is NavState.AUTO_RTL else COMMANDER_LAND
            self._log.info(now_s, event.message + "\t")
            self._log.event(now_s, event)
        return result

    def reject_mode(self, now_s: float, target: NavState) -> None:
        """Commander::printRejectMode, for a command whose mode switch was refused: "Switching
        to <mode> is currently not available" (mode_util::nav_state_names) and its event (the
        mode's custom mode and navigation_mode_t), at most once a second."""
        if now_s - self._reject_said_s <= REJECT_MODE_QUIET_S:
            return
        self._reject_said_s = now_s
        mode, _, name = NAVIGATION_MODE.get(target, (NAVIGATION_MODE_UNKNOWN, "", "Unknown"))
        self._log.critical(now_s, f"Switching to {name} is currently not available\t")
        if self.events is not None:
            self.events.send(now_s, MODE_NOT_AVAILABLE, Log.CRITICAL, Log.INFO, "IB",
                             custom_mode_of(target), mode)

    def unsupported_auto_mode(self, now_s: float) -> None:
        """DO_SET_MODE with an AUTO sub mode Commander does not know."""
        self._log.critical(now_s, UNSUPPORTED_AUTO_MODE.message + "\t")
        if self.events is not None:
            self.events.send(now_s, UNSUPPORTED_AUTO_MODE, Log.ERROR)

    def unsupported_arm_disarm(self, now_s: float, param1: float) -> None:
        """COMPONENT_ARM_DISARM whose param1 rounds to neither arm nor disarm (no ACK)."""
        self._log.critical(now_s, f"Unsupported ARM_DISARM param: {param1:.3f}\t")
        if self.events is not None:
            self.events.send(now_s, UNSUPPORTED_ARM_PARAM, Log.ERROR, None, "f", param1)

    def orbit_rejected(self, now_s: float) -> None:
        """DO_ORBIT whose switch to Orbit was refused (a text without an event)."""
        self._log.critical(now_s, "Orbit command rejected")

    def figure_eight_rejected(self, now_s: float) -> None:
        """DO_FIGUREEIGHT on a multicopter: a text without an event (and no ACK)."""
        self._log.critical(now_s, "Figure 8 command only available for fixed wing and vtol vehicles.")

    def terminate(self, now_s: float) -> CommandResult:
        """DO_FLIGHTTERMINATION: only when armed; final until reboot."""
        if not self.armed:
            return CommandResult.DENIED
        if not self.terminated:
            self._log.critical(now_s, "Flight termination active")
        self.terminated = True
        self.nav_state = NavState.TERMINATION
        return CommandResult.ACCEPTED

    def on_gcs_heartbeat(self, now_s: float) -> None:
        if self.gcs_lost:
            self._log.info(now_s, "GCS connection regained\t")
            if self.events is not None:
                self.events.send(now_s, GCS_REGAINED, Log.INFO)
        self.gcs_lost = False
        self._gcs_seen_s = now_s

    def deny_arming_calibrating(self, now_s: float) -> None:
        """Commander::arm while a calibration runs: its text (with PX4's tab) and event."""
        self._log.critical(now_s, ARM_DENIED_CALIBRATING.message + "\t")
        if self.events is not None:
            self.events.send(now_s, ARM_DENIED_CALIBRATING, Log.CRITICAL, Log.INFO)

    def arm(self, now_s: float, forced: bool = False,
            reason: ArmReason = ArmReason.COMMAND_EXTERNAL) -> CommandResult:
        if self.armed:
            return CommandResult.ACCEPTED
        spec = MODE_TABLE[self.nav_state]
        sticks = self.manual_control_available  # !manual_control_signal_lost
        refused = (ARM_DENIED_THROTTLE_CENTER if spec.manual and not spec.stick_thrust and sticks
                   and self.throttle_above_center
                   else ARM_DENIED_THROTTLE_HIGH if spec.stick_thrust and sticks
                   and not self.throttle_low
                   else ARM_DENIED_NOT_MANUAL if not spec.manual and reason in RC_REASONS
                   else None)
        if refused is not None:
            self._log.critical(now_s, refused.message + "\t")
            if self.events is not None:
                self.events.send(now_s, refused, Log.CRITICAL, Log.INFO)
            return CommandResult.TEMPORARILY_REJECTED
        if not self.prearm_ok():
            # PX4 runs the checks for external commands even when forced.
            # The checks that print a text of their own (mavlink_log_*); modeCheck.cpp's "No
            # manual control input" is an event only (check_modes_manual_control).
            for text in self.health_failures:
                self._log.critical(now_s, text)
            self._log.critical(now_s, ARMING_DENIED_TEXT)
            if self.events is not None:
                self.events.send(now_s, ARM_DENIED, Log.CRITICAL, Log.INFO)
            return CommandResult.TEMPORARILY_REJECTED
        self.armed = True
        self._armed_at_s = now_s
        self.have_taken_off_since_arming = False
        self._landed_since_s = None
        self._log.info(now_s, f"Armed by {ARM_REASON_TEXT[reason]}\t")
        if self.events is not None:
            self.events.send(now_s, ARMED_BY, Log.INFO, None, "B", int(reason))
        return CommandResult.ACCEPTED

    @property
    def armed_at_s(self) -> float | None:
        """vehicle_status.armed_time: when the vehicle armed, while armed."""
        return self._armed_at_s if self.armed else None

    def disarm(self, now_s: float, forced: bool = False,
               reason: ArmReason = ArmReason.COMMAND_EXTERNAL) -> CommandResult:
        if not self.armed:
            return CommandResult.ACCEPTED
        if not self.landed and not forced and not (
                MODE_TABLE[self.nav_state].stick_thrust and reason in RC_REASONS
                and int(self._params["COM_DISARM_MAN"])):
            if reason is not ArmReason.RC_STICK:
                self._log.critical(now_s, DISARM_DENIED_NOT_LANDED.message + "\t")
                if self.events is not None:
                    self.events.send(now_s, DISARM_DENIED_NOT_LANDED, Log.CRITICAL, Log.INFO)
            return CommandResult.TEMPORARILY_REJECTED
        self._disarm(now_s, reason)
        return CommandResult.ACCEPTED

    def _disarm(self, now_s: float, reason: ArmReason) -> None:
        self.armed = False
        self.takeoff_at_s = None
        self._log.info(now_s, f"Disarmed by {ARM_REASON_TEXT[reason]}\t")
        if self.events is not None:
            self.events.send(now_s, DISARMED_BY, Log.INFO, None, "B", int(reason))
        # PX4 counts flights in COM_FLIGHT_UUID at every disarm (an int32: it wraps).
        uuid = int(self._params.get("COM_FLIGHT_UUID", 0) or 0)
        self._params.set("COM_FLIGHT_UUID", (uuid + 1 + 2**31) % 2**32 - 2**31, notify=False)
        self.user_nav_state = self._after_disarm  # UserModeIntention::onDisarm
        if not self.terminated:
            self.nav_state = self.user_nav_state

    # --- periodic -----------------------------------------------------------------------------
    def update(self, now_s: float, landed: bool, flags: FailsafeFlags | None = None) -> bool:
        """Advance timers; returns True when the position estimate has just become valid.

        ``flags`` (battery, geofence, offboard inputs from the autopilot) run the failsafes."""
        if self._params.version != self._params_version:
            self._update_params()
        self._update_data_link(now_s)
        if flags is not None:
            self._update_manual_control(now_s, not flags.manual_control_lost)
            if (flags.armed is not self.armed or flags.gcs_lost is not self.gcs_lost
                    or flags.user_nav_state is not self.user_nav_state):
                flags = replace(flags, armed=self.armed, gcs_lost=self.gcs_lost,
                                user_nav_state=self.user_nav_state)
            self._update_failsafe(now_s, flags)
        became_valid = False
        valid = self.position_aided and now_s - self._boot_time_s >= POSITION_VALID_DELAY_S - 1e-9
        if valid and not self.position_valid and not self._ever_valid:
            became_valid = self._ever_valid = True
        self.position_valid = valid
        if self.armed and landed != self.landed:
            if landed:
                self._log.info(now_s, LANDING_DETECTED.message + "\t")
                if self.events is not None:
                    self.events.send(now_s, LANDING_DETECTED, Log.INFO)
            else:
                self._log.info(now_s, TAKEOFF_DETECTED.message + "\t")
                if self.events is not None:
                    self.events.send(now_s, TAKEOFF_DETECTED, Log.INFO)
                self.have_taken_off_since_arming = True
                self.takeoff_at_s = now_s
        self.landed = landed
        if not self.armed:
            return became_valid
        # Auto-disarm (Commander::checkForAutoDisarm-like; one hysteresis, two delays).
        if self.have_taken_off_since_arming:
            delay = self._disarm_land_s
            if landed:
                if self._landed_since_s is None:
                    self._landed_since_s = now_s
                if delay > 0.0 and now_s - self._landed_since_s >= delay - 1e-9:
                    self._disarm(now_s, ArmReason.AUTO_DISARM_LAND)
            else:
                self._landed_since_s = None
        else:
            delay = self._disarm_preflight_s
            if delay > 0.0 and now_s - self._armed_at_s >= delay - 1e-9:
                self._disarm(now_s, ArmReason.AUTO_DISARM_PREFLIGHT)
        return became_valid

    @property
    def position_lost(self) -> bool:
        """The position estimate was valid and is not now."""
        return self._ever_valid and not self.position_valid

    def _update_manual_control(self, now_s: float, available: bool) -> None:
        """rcAndDataLinkCheck.cpp's events (no texts), once stick input has been seen; the
        time regained counts from the last input (the loss shows COM_RC_LOSS_T after it)."""
        events = self.events
        if available and self._sticks_lost_s is not None:
            if events is not None:
                since_s = self._sticks_lost_s - float(self._params["COM_RC_LOSS_T"])
                events.send(now_s, RC_REGAINED, Log.INFO, None, "f", now_s - since_s)
            self._sticks_lost_s = None
        elif not available and self._sticks_seen and self._sticks_lost_s is None:
            if events is not None:
                events.send(now_s, RC_LOST, Log.INFO, Log.INFO)
            self._sticks_lost_s = now_s
        self._sticks_seen = self._sticks_seen or available

    def _update_data_link(self, now_s: float) -> None:
        if self._gcs_seen_s is None or self.gcs_lost:
            return
        if now_s - self._gcs_seen_s > self._dl_loss_t_s:
            self.gcs_lost = True
            self._log.info(now_s, "Connection to ground station lost\t")
            if self.events is not None:
                self.events.send(now_s, GCS_LOST, Log.WARNING, Log.INFO)

    def _update_failsafe(self, now_s: float, flags: FailsafeFlags) -> None:
        before = self.failsafe.selected
        action = self.failsafe.update(now_s, flags)
        if before <= _WARN < action and self.user_nav_state is NavState.ORBIT:
            # modifyUserIntendedMode: a failsafe that engages during an orbit leaves Hold, not
            # the orbit, to come back to once it clears.
            self.user_nav_state = self._after_disarm = NavState.AUTO_LOITER
        if self.terminated:
            return
        if action is _TERMINATE:
            self.terminate(now_s)
        elif action is _DISARM and self.armed:
            self._disarm(now_s, ArmReason.FAILSAFE)
        elif action in ACTION_NAV_STATE:
            target = ACTION_NAV_STATE[action]
            if target is NavState.AUTO_RTL and not self.home_valid:
                target = NavState.AUTO_LAND
            self.nav_state = target
        elif self.armed:
            self.nav_state = self.user_nav_state

    def stick_override(self, now_s: float) -> None:
        """Sticks moved in an auto mode or Offboard (COM_RC_OVERRIDE): Position. Without a
        failsafe acting it is a mode change ("Pilot took over using sticks", text and event);
        with one it is the failsafe's user takeover (its event only)."""
        in_failsafe = self.failsafe.selected > _WARN
        if self.request_nav_state(now_s, NavState.POSCTL) is not CommandResult.ACCEPTED:
            return
        if in_failsafe:
            if self.events is not None:
                self.events.send(now_s, FAILSAFE_RC_OVERRIDE, Log.INFO)
            return
        self._log.info(now_s, "Pilot took over using sticks\t")
        if self.events is not None:
            self.events.send(now_s, RC_OVERRIDE, Log.INFO)

    def switch_by_vehicle(self, target: NavState) -> None:
        """A switch the vehicle makes itself (takeoff done -> Hold): no request rules apply."""
        self._ever_changed = True
        self._intend(target)
