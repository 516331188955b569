"""Command protocol server: COMMAND_LONG / COMMAND_INT / legacy SET_MODE → vehicle → COMMAND_ACK.

Source: PX4 v1.15.2 mavlink_receiver.cpp handle_message_command_*, Commander::handle_command,
navigator_main.cpp; the requests the MAVLink module answers itself are in command_requests.py,
who answers what in command_table.py.
Rules:
- Only target_system = own and target_component ∈ {0, 1} are handled
  (MavlinkReceiver::evaluate_target_ok); REQUEST_AUTOPILOT_CAPABILITIES /
  REQUEST_PROTOCOL_VERSION take system 0 too and ignore the component. Any other target (system
  0 too) is answered FAILED, unless that component was heard on another link of the vehicle
  (PX4 forwards it there, no ACK). Legacy SET_MODE goes to Commander, which takes system 0.
- The ACK goes to the sender's sysid/compid, from compid 1, progress 0, result_param2 0.
- COMMAND_INT x/y are degE7 (INT32_MAX = unset → NaN), z as-is (AMSL). The frame is ignored, as
  PX4 ≤ 1.16 does: QGC sends 0, MAVSDK4 3, MAVSDK 5 — all work (PX4 main would reject ≠ 5).
- Every command is answered at once (never IN_PROGRESS): unknown → UNSUPPORTED, and so is a
  contract command the vehicle object does not implement (yet). Except those PX4 leaves
  unanswered (command_table.UNANSWERED, DO_FIGURE_EIGHT on a multicopter) and those a module
  answers later, on its own (vehicles/command_journal.py): a calibration's cancel, and
  LOGGING_START / LOGGING_STOP, which the logger answers once the link has them
  (log_streaming.py).
- DO_ORBIT (multicopter): switch to Orbit and hand it the parameters; TEMPORARILY_REJECTED
  when the mode cannot run (no position estimate).
- DO_LAND_START (navigator_main.cpp): MISSION_START from the mission's DO_LAND_START marker,
  ACCEPTED whatever Commander then decides; no marker → CANCELLED (PX4 says "planned mission
  landing not available" on its console only). MAVProxy's `land` sends it.
- DO_REPOSITION: p2 must be exactly MAV_DO_REPOSITION_FLAGS_CHANGE_MODE (PX4 Commander:
  uint32(p2) != 1 → UNSUPPORTED); p1 ≤ 0/NaN = default speed; p4 yaw rad; NaN lat/lon/alt = keep
  (QGC's pause sends all of them NaN → brake and hold). z is AMSL whatever the frame (≤ 1.16).
  DO_CHANGE_ALTITUDE: Hold, and p1 the new altitude (AMSL, the frame in p2 is not read).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.command_requests import (
    MessageRequests,
    MetadataFiles,
    c_int,
    lroundf,
    roundf,
    wrap_int,
)
from gateway.mavlink.command_table import (
    DO_GO_AROUND,
    FIGURE_EIGHT,
    MAVLINK_ANSWERS,
    ROI_COMMANDS,
    STANDARD_MODE_LAND,
    STANDARD_MODE_MISSION,
    STANDARD_MODE_RETURN_HOME,
    STANDARD_MODE_TAKEOFF,
    UNANSWERED,
)
from gateway.mavlink.link import LinkContext, Say
from gateway.mavlink.modes import SetModeRefusal, decode_set_mode
from gateway.mavlink.snapshot import Snapshot
from gateway.mavlink.streams import Scheduler
from vehicles.plan_types import PlanItem, PlanType
from vehicles.types import CommandResult, GeoPoint, NavState, Severity

ACCEPTED = CommandResult.ACCEPTED
TEMPORARILY_REJECTED = CommandResult.TEMPORARILY_REJECTED
DENIED = CommandResult.DENIED
UNSUPPORTED = CommandResult.UNSUPPORTED
FAILED = CommandResult.FAILED
CANCELLED = CommandResult.CANCELLED

MAV_COMP_ID_MISSIONPLANNER = 190  # QGC, MAVSDK's default component
FORCE_MAGIC = 21196  # COMPONENT_ARM_DISARM p2: forced arm/disarm (kill)
INT32_MAX = 2**31 - 1
# (float)INT32_MAX and its float neighbours, nextafterf towards 0 and towards infinity
INT32_MAX_AS_FLOAT32 = (2147483520.0, 2147483648.0, 2147483904.0)
REPOSITION_FLAGS_CHANGE_MODE = 1  # MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, the only flag PX4 takes
SPEED_RESET = -1.0  # DO_CHANGE_SPEED: ≤ FLT_EPSILON → back to the cruise speed
FLT_EPSILON = 1.1920929e-07

# Commander's printRejectMode when the command's mode switch is refused (TEMPORARILY_REJECTED)
REJECT_SAYS_MODE: dict[int, NavState] = {
    M.MAV_CMD_NAV_TAKEOFF: NavState.AUTO_TAKEOFF, M.MAV_CMD_NAV_LAND: NavState.AUTO_LAND,
    M.MAV_CMD_NAV_RETURN_TO_LAUNCH: NavState.AUTO_RTL,
    M.MAV_CMD_DO_REPOSITION: NavState.AUTO_LOITER, M.MAV_CMD_MISSION_START: NavState.AUTO_MISSION,
    M.MAV_CMD_DO_CHANGE_ALTITUDE: NavState.AUTO_LOITER}
STANDARD_MODES = {STANDARD_MODE_RETURN_HOME: NavState.AUTO_RTL,
                  STANDARD_MODE_MISSION: NavState.AUTO_MISSION,
                  STANDARD_MODE_LAND: NavState.AUTO_LAND, STANDARD_MODE_TAKEOFF: NavState.AUTO_TAKEOFF}
ANY_COMPONENT_COMMANDS = frozenset({
    M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, M.MAV_CMD_REQUEST_PROTOCOL_VERSION,
})


@dataclass(frozen=True)
class Command:
    """A command with COMMAND_INT's integers already converted (p5/p6 degrees, p7 AMSL)."""

    command: int
    params: tuple[float, float, float, float, float, float, float]
    src_system: int
    src_component: int
    is_int: bool = False

    def p(self, n: int) -> float:
        return self.params[n - 1]


class CommandService:
    """Uses the vehicle, the encoder, send, sysid, other_target; ``say`` (STATUSTEXT on this
    link), ``snapshot(now_s)`` (what telemetry builders read, for REQUEST_MESSAGE), the
    link's stream ``scheduler`` (SET/GET_MESSAGE_INTERVAL) and ``seen_elsewhere(system,
    component)``: whether another link of the vehicle heard that component (a command for it
    is forwarded there, not refused)."""

    def __init__(self, ctx: LinkContext, say: Say, snapshot: Callable[[float], Snapshot],
                 scheduler: Scheduler, *,
                 logging_command: Callable[[int, tuple[int, int], float], int | None]
                 | None = None,
                 seen_elsewhere: Callable[[int, int], bool] | None = None) -> None:
        self.vehicle = ctx.vehicle
        self.seen_elsewhere = seen_elsewhere
        self.encoder = ctx.encoder
        self.send = ctx.send
        self.sysid = ctx.sysid
        self.other_target = ctx.other_target
        self.say = say
        # The requests MAVLink answers itself (command_requests.py)
        self.requests = req = MessageRequests(ctx, snapshot, scheduler)
        # LOGGING_START / LOGGING_STOP: the link's log stream (log_streaming.py), then the logger
        self.logging_command = logging_command
        self._handlers: dict[int, Callable[[Command, float], int | None]] = {
            M.MAV_CMD_COMPONENT_ARM_DISARM: self._arm_disarm,
            M.MAV_CMD_NAV_TAKEOFF: self._takeoff,
            M.MAV_CMD_NAV_LAND: lambda c, t: self.vehicle.land(t),
            M.MAV_CMD_NAV_RETURN_TO_LAUNCH: lambda c, t: self.vehicle.return_to_launch(t),
            M.MAV_CMD_DO_SET_MODE: self._set_mode,
            M.MAV_CMD_REQUEST_MESSAGE: lambda c, t: req.request_message(c.params, t),
            M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: lambda c, t: req.autopilot_capabilities(),
            M.MAV_CMD_REQUEST_PROTOCOL_VERSION: lambda c, t: req.protocol_version(),
            M.MAV_CMD_GET_HOME_POSITION: lambda c, t: req.home_position(t),
            M.MAV_CMD_REQUEST_FLIGHT_INFORMATION: lambda c, t: req.request_flight_information(t),
            M.MAV_CMD_REQUEST_STORAGE_INFORMATION: lambda c, t: req.storage_information(0.0, t),
            M.MAV_CMD_SET_MESSAGE_INTERVAL: lambda c, t: req.set_message_interval(c.params, t),
            M.MAV_CMD_GET_MESSAGE_INTERVAL: lambda c, t: req.get_message_interval(c.params),
            M.MAV_CMD_PREFLIGHT_CALIBRATION: self._calibration,
            M.MAV_CMD_PREFLIGHT_STORAGE: self._storage,
            # MAV_CMD_DO_MOTOR_TEST has no handler: PX4 1.14 removed Commander's
            # handle_command_motor_test (and test_motor) for MAV_CMD_ACTUATOR_TEST, so 1.15's
            # handle_command answers it UNSUPPORTED in its default case, armed or not.
            M.MAV_CMD_ACTUATOR_TEST: self._actuator_test,
            # Commander: (int)param1 0 does nothing (ACCEPTED); a reboot or shutdown is refused
            M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN:
                lambda c, t: ACCEPTED if c_int(c.p(1)) == 0 else DENIED,
            M.MAV_CMD_RUN_PREARM_CHECKS: self._run_prearm_checks,
            # Commander.cpp ACCEPTs it unchecked; the mixer's FunctionActuatorSet drives the
            # outputs mapped to "Peripheral via Actuator Set N", which a quadrotor has none of.
            M.MAV_CMD_DO_SET_ACTUATOR: lambda c, t: ACCEPTED,
            M.MAV_CMD_DO_REPOSITION: self._reposition,
            M.MAV_CMD_DO_ORBIT: self._orbit,
            M.MAV_CMD_DO_CHANGE_SPEED: self._change_speed,
            M.MAV_CMD_DO_SET_HOME: self._set_home,
            M.MAV_CMD_MISSION_START: self._mission_start,
            M.MAV_CMD_DO_LAND_START: self._land_start,
            M.MAV_CMD_DO_FLIGHTTERMINATION: self._terminate,
            M.MAV_CMD_INJECT_FAILURE: self._inject_failure,
            M.MAV_CMD_LOGGING_START: self._logging,
            M.MAV_CMD_LOGGING_STOP: self._logging,
            M.MAV_CMD_DO_CHANGE_ALTITUDE: self._change_altitude,
            M.MAV_CMD_DO_SET_STANDARD_MODE: self._set_standard_mode,
            FIGURE_EIGHT: self._figure_eight,
            # navigator_main.cpp: ACCEPTED at once (the position controller flies a go-around
            # of a fixed-wing landing; a multicopter has none)
            DO_GO_AROUND: lambda c, t: ACCEPTED,
        }
        for cmd in ROI_COMMANDS:  # the navigator publishes the ROI and ACCEPTs
            self._handlers[cmd] = self._set_roi
        for cmd in UNANSWERED:
            self._handlers[cmd] = lambda c, t: None

    @property
    def component_metadata(self) -> MetadataFiles | None:
        """Attached with the vehicle's FTP files; without them the request is DENIED."""
        return self.requests.component_metadata

    @component_metadata.setter
    def component_metadata(self, files: MetadataFiles | None) -> None:
        self.requests.component_metadata = files

    # --- inbound ------------------------------------------------------------------------------
    def on_command_long(self, msg: M.MAVLink_command_long_message, now_s: float) -> None:
        cmd = Command(msg.command, (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5,
                                    msg.param6, msg.param7), msg.get_srcSystem(),
                      msg.get_srcComponent())
        # handle_message_command_long, before the target is looked at: param5 and param6 both
        # within one float step of INT32_MAX look like a COMMAND_INT sent as COMMAND_LONG.
        if _near_int32_max(msg.param5) and _near_int32_max(msg.param6):
            self.ack(cmd, DENIED)
            return
        if self._for_us(msg, cmd.command):
            self.dispatch(cmd, now_s)

    def on_command_int(self, msg: M.MAVLink_command_int_message, now_s: float) -> None:
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if msg.x == 0x7FF80000 and msg.y == 0x7FF80000:  # a NaN sent as int, whatever the target
            self.ack(Command(msg.command, (math.nan,) * 7, *src, True), DENIED)
            return
        if not self._for_us(msg, msg.command):
            return
        # handle_message_command_int: x and y both INT32_MAX leave the position unset (NaN);
        # otherwise both are degE7, INT32_MAX included.
        unset = msg.x == INT32_MAX and msg.y == INT32_MAX
        lat = math.nan if unset else msg.x * 1e-7
        lon = math.nan if unset else msg.y * 1e-7
        cmd = Command(msg.command, (msg.param1, msg.param2, msg.param3, msg.param4, lat, lon,
                                    msg.z), *src, True)
        self.dispatch(cmd, now_s)

    def on_set_mode(self, msg: M.MAVLink_set_mode_message, now_s: float) -> None:
        """Legacy SET_MODE (11): PX4 converts it to DO_SET_MODE and ACKs it as 176."""
        if msg.target_system not in (0, self.sysid):
            self.other_target()
            return
        main, sub = (msg.custom_mode >> 16) & 0xFF, (msg.custom_mode >> 24) & 0xFF
        cmd = Command(M.MAV_CMD_DO_SET_MODE, (float(msg.base_mode), float(main), float(sub), 0.0,
                                              0.0, 0.0, 0.0), msg.get_srcSystem(),
                      msg.get_srcComponent())
        self.dispatch(cmd, now_s, legacy=True)

    def _for_us(self, msg: M.MAVLink_message, command: int) -> bool:
        """MavlinkReceiver::evaluate_target_ok: this system (not 0) and this component or 0;
        the capability requests take system 0 too and any component. Another target is
        answered FAILED unless it was heard on another link (forwarded: no ACK)."""
        if command in ANY_COMPONENT_COMMANDS:
            if msg.target_system in (0, self.sysid):
                return True
        elif msg.target_system == self.sysid and msg.target_component in (0, 1):
            return True
        self.other_target()
        seen = self.seen_elsewhere
        if seen is None or not seen(msg.target_system, msg.target_component):
            self.send(self.encoder.pack(M.MAVLink_command_ack_message, command, int(FAILED), 0,
                                        0, msg.get_srcSystem(), msg.get_srcComponent()))
        return False

    def dispatch(self, cmd: Command, now_s: float, legacy: bool = False) -> None:
        """``legacy``: a SET_MODE, which handle_message_set_mode passes on from anyone."""
        if (not legacy and cmd.command not in MAVLINK_ANSWERS and cmd.src_system == self.sysid
                and cmd.src_component == self.encoder.compid):
            return  # handle_message_command_both: "ignoring CMD with same SYS/COMP ID"
        handler = self._handlers.get(cmd.command)
        result = UNSUPPORTED if handler is None else handler(cmd, now_s)
        mode = REJECT_SAYS_MODE.get(cmd.command)
        if mode is not None and result == TEMPORARILY_REJECTED:
            commander = getattr(self.vehicle, "commander", None)
            if commander is not None:
                commander.reject_mode(now_s, mode)
        if result is not None:
            self.ack(cmd, int(result))
        record = getattr(self.vehicle, "record_command", None)
        if record is not None:  # the logger's vehicle_command and vehicle_command_ack
            record(now_s, cmd.command, cmd.params, (cmd.src_system, cmd.src_component),
                   None if result is None else int(result))

    def ack(self, cmd: Command, result: int) -> None:
        self.send(self.encoder.pack(M.MAVLink_command_ack_message, cmd.command, result, 0, 0,
                                    cmd.src_system, cmd.src_component))

    # --- handlers: return a MAV_RESULT, or None for "no ACK" -------------------------------
    def _arm_disarm(self, cmd: Command, now_s: float) -> int | None:
        """Commander::handle_command: the action is static_cast<int8_t>(lroundf(param1)), forced
        when static_cast<int>(lroundf(param2)) is 21196; another action gets a critical text and
        its event, and no ACK."""
        action = wrap_int(lroundf(cmd.p(1)), 8)
        forced = wrap_int(lroundf(cmd.p(2)), 32) == FORCE_MAGIC
        if action == 1:
            return self.vehicle.arm(now_s, forced=forced)
        if action == 0:
            return self.vehicle.disarm(now_s, forced=forced)
        commander = getattr(self.vehicle, "commander", None)
        if commander is not None:
            commander.unsupported_arm_disarm(now_s, cmd.p(1))
        else:
            self.say(now_s, Severity.CRITICAL, f"Unsupported ARM_DISARM param: {cmd.p(1):.3f}")
        return None

    def _takeoff(self, cmd: Command, now_s: float) -> int:
        # PX4's navigator takes param7 only when finite: inf asks for the default altitude.
        return self.vehicle.takeoff(now_s, alt_amsl_m=_finite_or_nan(cmd.p(7)))

    def _set_mode(self, cmd: Command, now_s: float) -> int:
        """Commander reads p1..p3 as (uint8_t) casts; no mode asked for is ACCEPTED, changing
        nothing; a refused switch is said (printRejectMode) only to QGC (component 190)."""
        base, main, sub = (c_int(cmd.p(n)) & 0xFF for n in (1, 2, 3))
        nav = decode_set_mode(base, main, sub)
        if nav is None:
            return ACCEPTED
        commander = getattr(self.vehicle, "commander", None)
        if nav is SetModeRefusal.UNSUPPORTED_AUTO:
            if commander is not None:
                commander.unsupported_auto_mode(now_s)
            else:
                self.say(now_s, Severity.CRITICAL, "Unsupported auto mode")
            return TEMPORARILY_REJECTED
        if nav is SetModeRefusal.NOT_AVAILABLE:
            return TEMPORARILY_REJECTED
        result = self.vehicle.set_nav_state(now_s, nav)
        if (result == TEMPORARILY_REJECTED and cmd.src_component == MAV_COMP_ID_MISSIONPLANNER
                and commander is not None):
            commander.reject_mode(now_s, nav)
        return result

    def _vehicle(self, name: str) -> Callable[..., int] | None:
        return getattr(self.vehicle, name, None)

    def _reposition(self, cmd: Command, now_s: float) -> int:
        goto = self._vehicle("goto")
        p2 = cmd.p(2)
        flags = int(p2) if math.isfinite(p2) and p2 >= 0 else 0  # PX4: uint32_t(param2)
        if goto is None or flags != REPOSITION_FLAGS_CHANGE_MODE:
            return UNSUPPORTED
        speed = cmd.p(1) if math.isfinite(cmd.p(1)) and cmd.p(1) > 0 else math.nan
        lat, lon, alt, yaw = (_finite_or_nan(cmd.p(n)) for n in (5, 6, 7, 4))
        return goto(now_s, lat, lon, alt, yaw_rad=yaw, speed_mps=speed)

    def _orbit(self, cmd: Command, now_s: float) -> int:
        """DO_ORBIT: p1 radius (sign: direction), p2 speed, p3 yaw behaviour, lat/lon centre,
        z AMSL; NaN keeps the present value (vehicles/orbit.py)."""
        orbit = self._vehicle("orbit")
        if orbit is None:
            return UNSUPPORTED
        radius, speed, yaw_behaviour, lat, lon, alt = (_finite_or_nan(cmd.p(n))
                                                        for n in (1, 2, 3, 5, 6, 7))
        result = orbit(now_s, radius, speed, yaw_behaviour, lat, lon, alt)
        commander = getattr(self.vehicle, "commander", None)
        if result == TEMPORARILY_REJECTED and commander is not None:
            commander.orbit_rejected(now_s)  # Commander's text (no printRejectMode)
        return result

    def _change_speed(self, cmd: Command, now_s: float) -> int:
        change_speed = self._vehicle("change_speed")
        if change_speed is None:
            return UNSUPPORTED
        # navigator_main.cpp: param2 > FLT_EPSILON is the cruising speed (+inf too: the speed
        # limit then), anything else (NaN, 0, tiny) resets it; the speed type is not read.
        speed = cmd.p(2) if cmd.p(2) > FLT_EPSILON else SPEED_RESET
        return change_speed(now_s, speed)

    def _set_roi(self, cmd: Command, now_s: float) -> int:
        """navigator_main.cpp: the ROI commands replace the navigator's ROI and are ACCEPTED,
        whatever their parameters (a vehicle without a navigator ACCEPTs them too)."""
        set_roi = self._vehicle("set_roi")
        if set_roi is not None:
            set_roi(now_s, cmd.command, cmd.params)
        return ACCEPTED

    def _set_home(self, cmd: Command, now_s: float) -> int:
        set_home = self._vehicle("set_home")
        if set_home is None:
            return UNSUPPORTED
        if not int(self.vehicle.params.get("COM_HOME_EN", 1) or 0):
            return DENIED  # Commander: home disabled, whatever the parameters
        if cmd.p(1) > 0.5:  # use the current position
            return set_home(now_s, None)
        lat, lon, alt = cmd.p(5), cmd.p(6), cmd.p(7)
        if not all(math.isfinite(v) for v in (lat, lon, alt)):
            return DENIED
        # Commander: yaw = wrap_2pi(radians(param4)), NaN when that is not finite
        yaw = math.radians(cmd.p(4)) % (2.0 * math.pi) if math.isfinite(cmd.p(4)) else math.nan
        return set_home(now_s, GeoPoint(lat, lon, alt), yaw_rad=yaw)

    def _change_altitude(self, cmd: Command, now_s: float) -> int:
        """DO_CHANGE_ALTITUDE: Commander switches to Hold; the navigator, armed, holds at p1
        (AMSL; NaN keeps the altitude; the frame in p2 is not read) where the vehicle brakes,
        or says "Altitude change is outside geofence"."""
        goto = self._vehicle("goto")
        if goto is None:
            return UNSUPPORTED
        return goto(now_s, math.nan, math.nan, _finite_or_nan(cmd.p(1)), what="Altitude change")

    def _set_standard_mode(self, cmd: Command, now_s: float) -> int:
        """Commander: (mode_util::StandardMode)roundf(param1), an 8-bit enum, through
        getNavStateFromStandardMode: return home, mission, land and takeoff; another is FAILED.
        A refused switch is TEMPORARILY_REJECTED, without printRejectMode's text."""
        nav = STANDARD_MODES.get(c_int(roundf(cmd.p(1))) & 0xFF)
        if nav is None:
            return FAILED
        return self.vehicle.set_nav_state(now_s, nav)

    def _figure_eight(self, cmd: Command, now_s: float) -> None:
        """Commander, on a multicopter: a critical text and no ACK at all."""
        commander = getattr(self.vehicle, "commander", None)
        if commander is not None:
            commander.figure_eight_rejected(now_s)
        return None

    def _mission_start(self, cmd: Command, now_s: float) -> int:
        start = self._vehicle("start_mission")
        if start is None:
            return UNSUPPORTED
        return start(now_s, cmd.p(1))  # the vehicle checks it as Commander.cpp does

    def _land_start(self, cmd: Command, now_s: float) -> int:
        plan = getattr(self.vehicle, "plan", None)
        start = self._vehicle("start_mission")
        if plan is None or start is None:
            return UNSUPPORTED
        items: tuple[PlanItem, ...] = plan(PlanType.MISSION)
        for item in items:
            if item.command == M.MAV_CMD_DO_LAND_START:
                # The navigator ACKs before Commander decides on its MISSION_START.
                if start(now_s, float(item.seq)) == TEMPORARILY_REJECTED:
                    commander = getattr(self.vehicle, "commander", None)
                    if commander is not None:
                        commander.reject_mode(now_s, NavState.AUTO_MISSION)
                return ACCEPTED
        return CANCELLED

    def _terminate(self, cmd: Command, now_s: float) -> int:
        terminate = self._vehicle("terminate")
        if terminate is None:
            return UNSUPPORTED
        return terminate(now_s) if cmd.p(1) > 0.5 else DENIED

    def _calibration(self, cmd: Command, now_s: float) -> int | None:
        """PX4 Commander's PREFLIGHT_CALIBRATION, in its order of parameters: gyro (param1 1),
        magnetometer (param2 1), barometer (param3 1), radio (param4 1), accelerometer
        (param5 1), level horizon (param5 2), quick accelerometer (param5 4), ESCs (param7 1);
        param4 0 otherwise ends a radio calibration or cancels a running one (QGC's and MAVSDK's
        cancel: every parameter 0). Temperature (3 in param1, 5 or 7) Commander leaves to the
        temperature_compensation module, which SITL does not start: no ACK (disarmed and idle).
        Not served: radio trim, airspeed (TEMPORARILY_REJECTED)."""
        calibrate = self._vehicle("calibrate")
        if calibrate is None:
            return UNSUPPORTED
        p = [c_int(cmd.p(i)) for i in range(1, 8)]
        # In Commander's order; None: one PX4 starts that is not served here.
        for asked, kind in ((p[0] == 1, "gyro"), (3 in (p[0], p[4], p[6]), "temperature"),
                             (p[1] == 1, "mag"), (p[2] == 1, "baro"), (p[3] == 1, "radio"),
                             (p[3] == 2, None), (p[4] == 1, "accel"), (p[4] == 2, "level"),
                             (p[4] == 4, "accel_quick"), (p[5] in (1, 2), None), (p[6] == 1, "esc"),
                             (p[3] == 0, "cancel")):
            if asked:
                if kind is None:
                    return TEMPORARILY_REJECTED
                if kind == "cancel":  # a running one answers later (vehicles/calibration.py)
                    return calibrate(now_s, kind, (cmd.src_system, cmd.src_component))
                return calibrate(now_s, kind)
        return UNSUPPORTED

    def _run_prearm_checks(self, cmd: Command, now_s: float) -> int:
        """Commander: the health and arming report at once (its events), then ACCEPTED."""
        run = self._vehicle("run_prearm_checks")
        return ACCEPTED if run is None else run(now_s)

    def _actuator_test(self, cmd: Command, now_s: float) -> int:
        test = self._vehicle("actuator_test")
        if test is None:
            return UNSUPPORTED
        value = cmd.p(1)
        return test(now_s, c_int(cmd.p(5) + 0.5), value if math.isfinite(value) else math.nan,
                    cmd.p(2))

    def _storage(self, cmd: Command, now_s: float) -> int | None:
        storage = self._vehicle("param_storage")
        if storage is None:
            return UNSUPPORTED
        return storage(now_s, c_int(cmd.p(1)))

    def _inject_failure(self, cmd: Command, now_s: float) -> int | None:
        """handle_message_command_both: DENIED without SYS_FAILURE_EN; else passed on, and the
        module that takes the unit ACKs it later to every link (vehicles/failure_injection.py),
        none if no module does. The modules read static_cast<int>(param + 0.5f): NaN is
        INT_MIN, a unit nobody takes."""
        inject = self._vehicle("inject_failure")
        if inject is None:
            return UNSUPPORTED
        if int(self.vehicle.params.get("SYS_FAILURE_EN", 0) or 0) != 1:
            return DENIED
        unit, kind, instance = (c_int(cmd.p(i) + 0.5) for i in (1, 2, 3))
        inject(now_s, unit, kind, instance)
        return None

    def _logging(self, cmd: Command, now_s: float) -> int | None:
        if self.logging_command is None:
            return UNSUPPORTED
        return self.logging_command(cmd.command, (cmd.src_system, cmd.src_component), now_s)


def _near_int32_max(value: float) -> bool:
    return INT32_MAX_AS_FLOAT32[0] <= value <= INT32_MAX_AS_FLOAT32[-1]


def _finite_or_nan(value: float) -> float:
    return value if math.isfinite(value) else math.nan
