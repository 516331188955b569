"""Shared helpers for the MAVLink session tests: a fake vehicle and an in-memory client.

FakeVehicle implements the vehicles/README.md contract with a real ParamStore, so the session is
tested against the API the real autopilot will expose. Client is a pymavlink codec playing
MAVSDK/QGC, paired with a Session in memory (h11 ConnectionPair style): no sockets, no clock.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20 import development

from gateway.mavlink.session import LinkKind, Session
from gateway.mavlink.signing import SigningConfig
from vehicles.manual_control import Sticks
from vehicles.nav_rtl import RtlTimeEstimate
from vehicles.orbit import OrbitStatus
from vehicles.params import ParamStore
from vehicles.plan_types import (
    MissionState,
    MissionStatus,
    OffboardSetpoint,
    PlanItem,
    PlanResult,
    PlanType,
)
from vehicles.types import (
    PX4_SITL_HOME,
    BatteryState,
    CommandResult,
    GeoPoint,
    HomePosition,
    Kinematics,
    LandedState,
    Measurement,
    NavState,
    Severity,
    StatusText,
    Targets,
    VehicleState,
    VehicleStatus,
)

M = mavlink2


class FakeVehicle:
    def __init__(self, sysid: int = 1) -> None:
        self.params = ParamStore({"MAV_SYS_ID": sysid})
        self.origin = PX4_SITL_HOME
        self.state = VehicleState.at_rest()
        self.armed = False
        self.nav_state = NavState.AUTO_LOITER
        self.landed_state = LandedState.ON_GROUND
        self.position_valid = False
        self.prearm_ok = False
        self.failsafe = False
        self.terminated = False
        self.home: HomePosition | None = None
        self.texts: list[StatusText] = []
        self.calls: list[tuple] = []
        self.gcs_heartbeats: list[float] = []
        # missions / offboard (README "Missions, offboard, actions and failsafes")
        self.plans: dict[PlanType, tuple[PlanItem, ...]] = {t: () for t in PlanType}
        self.plan_result: PlanResult | None = None  # force set_plan's answer in a test
        self.current_seq = 0
        self.reached_seq = -1
        self.reached_count = 0
        self.reached_resets = 0
        self.mission_finished = False
        self.setpoints: list[tuple[float, OffboardSetpoint]] = []
        self.orbit_status: OrbitStatus | None = None
        self.rotor_speeds_radps: tuple[float, ...] = (0.0,) * 4
        self.motor_outputs: tuple[float, ...] = (0.0,) * 4  # commanded rotor speeds (rad/s)
        # What ``targets`` reports of the controllers (None: the real vehicle's defaults below).
        self.position_setpoint_ned_m: tuple[float, float, float] | None = None
        self.global_target_ned_m: tuple[float, float, float] | None = None

    # --- contract -------------------------------------------------------------------------
    @property
    def status(self) -> VehicleStatus:
        return VehicleStatus(
            time_s=self.state.time_s, armed=self.armed, nav_state=self.nav_state,
            landed_state=self.landed_state, position_valid=self.position_valid,
            prearm_ok=self.prearm_ok, failsafe=self.failsafe, terminated=self.terminated,
            battery=BatteryState(16.2, 0.5, 0.9, 12.0, 4), home=self.home,
            extra={"rotor_speed_radps": self.rotor_speeds_radps})

    @property
    def kinematics(self) -> Kinematics:
        return Kinematics.of(self.state)

    @property
    def targets(self) -> Targets:
        """Level attitude at hover thrust; a position setpoint when one is set."""
        pos = self.position_setpoint_ned_m or (math.nan,) * 3
        vel = (0.0, 0.0, 0.0) if self.position_setpoint_ned_m else (math.nan,) * 3
        return Targets(self.state.time_s, (1.0, 0.0, 0.0, 0.0), 0.5, (0.01, -0.02, 0.03),
                       self.nav_state not in (NavState.MANUAL, NavState.STAB, NavState.ACRO),
                       pos, vel, vel, 0.25, 0.0, self.global_target_ned_m, self.motor_outputs)

    @property
    def sensors(self) -> list[float]:
        """Exact sensors at the present state, GPS and barometer included (estimation.S_*)."""
        from vehicles import estimation as est
        s = [0.0] * est.S_SIZE
        from gateway.mavlink.telemetry import to_body
        q = self.kinematics.attitude_q
        s[est.S_ACC:est.S_ACC + 3] = to_body(q, (0.0, 0.0, -9.80665))
        s[est.S_MAG:est.S_MAG + 3] = to_body(q, est.MAG_NED_GAUSS)
        pos = [float(v) for v in self.state.position_ned_m]
        s[est.S_GPS_POS:est.S_GPS_POS + 3] = pos
        s[est.S_GPS_VEL:est.S_GPS_VEL + 3] = [float(v) for v in self.state.velocity_ned_mps]
        s[est.S_BARO_DOWN] = pos[2]
        return s

    @property
    def estimator(self) -> list[float]:
        """A converged estimator (estimation.E_*): small test ratios and accuracies."""
        from vehicles import estimation as est
        e = [0.0] * est.E_SIZE
        e[est.E_Q] = 1.0
        e[est.E_RATIOS:est.E_RATIOS + 4] = [0.05, 0.04, 0.01, 0.2]
        e[est.E_ACCURACY:est.E_ACCURACY + 2] = [0.02, 0.01]
        return e

    @property
    def truth(self) -> Measurement:
        """The simulator's ground truth: here the state itself."""
        st = self.state
        return Measurement(*(tuple(float(x) for x in v) for v in (
            st.position_ned_m, st.velocity_ned_mps, st.attitude_q, st.rates_frd_radps,
            st.acceleration_ned_mps2)))

    @property
    def acceleration_ned_mps2(self) -> tuple[float, float, float]:
        a = self.state.acceleration_ned_mps2
        return (float(a[0]), float(a[1]), float(a[2]))

    @property
    def global_position(self):
        n, e, d = (float(v) for v in self.state.position_ned_m)
        return self.origin.offset_ned(n, e, d)

    def status_texts(self, after_seq: int) -> list[StatusText]:
        return [t for t in self.texts if t.seq > after_seq]

    def say(self, now_s: float, text: str, severity: Severity = Severity.INFO) -> None:
        self.texts.append(StatusText(len(self.texts), now_s, severity, text))

    def become_ready(self) -> None:
        self.position_valid = True
        self.prearm_ok = True
        self.home = HomePosition(self.origin, (0.0, 0.0, 0.0), 0.0)
        # RTL has published one estimate (navigator.py): TIME_ESTIMATE_TO_TARGET sends it once
        self.rtl_time_estimate = (1, RtlTimeEstimate(True, 12.5, 113.75))
        # a client's stick sample, published (MANUAL_CONTROL echoes it once asked)
        self.manual_control_setpoint = lambda now_s: (2, Sticks(0.25, -0.5, 0.0, 1.0))

    def arm(self, now_s: float, forced: bool = False, internal: bool = False) -> CommandResult:
        self.calls.append(("arm", now_s, forced))
        if not self.prearm_ok and not forced:
            return CommandResult.TEMPORARILY_REJECTED
        self.armed = True
        self.say(now_s, "Armed by external command")
        return CommandResult.ACCEPTED

    def disarm(self, now_s: float, forced: bool = False, internal: bool = False
               ) -> CommandResult:
        self.calls.append(("disarm", now_s, forced))
        if self.landed_state is not LandedState.ON_GROUND and not forced:
            return CommandResult.TEMPORARILY_REJECTED
        self.armed = False
        return CommandResult.ACCEPTED

    def takeoff(self, now_s: float, alt_amsl_m: float = math.nan) -> CommandResult:
        self.calls.append(("takeoff", now_s, alt_amsl_m))
        if not self.position_valid:
            return CommandResult.TEMPORARILY_REJECTED
        self.nav_state = NavState.AUTO_TAKEOFF
        return CommandResult.ACCEPTED

    def land(self, now_s: float) -> CommandResult:
        self.calls.append(("land", now_s))
        self.nav_state = NavState.AUTO_LAND
        return CommandResult.ACCEPTED

    def return_to_launch(self, now_s: float) -> CommandResult:
        self.calls.append(("rtl", now_s))
        self.nav_state = NavState.AUTO_RTL
        return CommandResult.ACCEPTED

    def set_nav_state(self, now_s: float, nav: NavState) -> CommandResult:
        self.calls.append(("set_nav_state", now_s, nav))
        self.nav_state = nav
        return CommandResult.ACCEPTED

    def on_gcs_heartbeat(self, now_s: float) -> None:
        self.gcs_heartbeats.append(now_s)

    # --- plans ------------------------------------------------------------------------------
    def plan(self, plan_type: PlanType) -> tuple[PlanItem, ...]:
        return self.plans[plan_type]

    def set_plan(self, now_s: float, plan_type: PlanType, items) -> PlanResult:
        items = tuple(items)
        self.calls.append(("set_plan", now_s, plan_type, items))
        if self.plan_result is not None:
            return self.plan_result
        if [i.seq for i in items] != list(range(len(items))) or any(
                i.mission_type != plan_type for i in items):
            return PlanResult.INVALID_SEQUENCE
        self.plans[plan_type] = items
        if plan_type is PlanType.MISSION:  # as the navigator takes a new mission (nav_mission)
            flagged = [i.seq for i in items if i.current]
            self.current_seq = flagged[-1] if flagged else max(0, min(self.current_seq,
                                                                      len(items) - 1))
            self.reached_seq, self.mission_finished = -1, False
            self.reached_resets += 1
        return PlanResult.ACCEPTED

    def clear_plan(self, now_s: float, plan_type: PlanType) -> PlanResult:
        self.calls.append(("clear_plan", now_s, plan_type))
        self.plans[plan_type] = ()
        if plan_type is PlanType.MISSION:
            self.current_seq = 0
            self.reached_resets += 1
        return PlanResult.ACCEPTED

    def plan_id(self, plan_type: PlanType) -> int:
        items = self.plans[plan_type]
        return zlib.crc32(repr(items).encode()) if items else 0

    def set_current_mission_item(self, now_s: float, seq: int) -> bool:
        self.calls.append(("set_current", now_s, seq))
        if not 0 <= seq < len(self.plans[PlanType.MISSION]):
            return False
        self.current_seq = seq
        return True

    @property
    def mission_status(self) -> MissionStatus:
        count = len(self.plans[PlanType.MISSION])
        in_mission = self.nav_state is NavState.AUTO_MISSION
        if count == 0:
            state = MissionState.NO_MISSION
        elif self.mission_finished:
            state = MissionState.COMPLETE
        elif in_mission:
            state = MissionState.ACTIVE
        else:
            state = MissionState.PAUSED if self.reached_seq >= 0 else MissionState.NOT_STARTED
        return MissionStatus(self.current_seq, count, state, in_mission, self.reached_seq,
                             self.reached_count, self.plan_id(PlanType.MISSION),
                             self.plan_id(PlanType.FENCE), self.plan_id(PlanType.RALLY),
                             reached_resets=self.reached_resets)

    def reach(self, seq: int) -> None:
        """Test helper: the navigator reached item ``seq`` and moved on."""
        self.reached_seq, self.reached_count = seq, self.reached_count + 1
        self.current_seq = min(seq + 1, len(self.plans[PlanType.MISSION]) - 1)

    def start_mission(self, now_s: float, first_seq: int = -1) -> CommandResult:
        self.calls.append(("start_mission", now_s, first_seq))
        if not self.plans[PlanType.MISSION]:
            return CommandResult.DENIED
        self.nav_state, self.armed = NavState.AUTO_MISSION, True
        return CommandResult.ACCEPTED

    # --- offboard and actions ---------------------------------------------------------------
    def set_offboard_setpoint(self, now_s: float, sp: OffboardSetpoint) -> None:
        self.setpoints.append((now_s, sp))

    def goto(self, now_s: float, lat_deg: float, lon_deg: float, alt_amsl_m: float,
             yaw_rad: float = math.nan, speed_mps: float = math.nan,
             what: str = "Reposition") -> CommandResult:
        self.calls.append(("goto", now_s, lat_deg, lon_deg, alt_amsl_m, yaw_rad, speed_mps))
        self.nav_state = NavState.AUTO_LOITER
        return CommandResult.ACCEPTED

    def orbit(self, now_s: float, radius_m: float, speed_mps: float, yaw_behaviour: float,
              lat_deg: float, lon_deg: float, alt_amsl_m: float) -> CommandResult:
        self.calls.append(("orbit", now_s, radius_m, speed_mps, yaw_behaviour, lat_deg, lon_deg,
                           alt_amsl_m))
        self.nav_state = NavState.ORBIT
        return CommandResult.ACCEPTED

    def change_speed(self, now_s: float, speed_mps: float) -> CommandResult:
        self.calls.append(("change_speed", now_s, speed_mps))
        return CommandResult.ACCEPTED

    def set_roi(self, now_s: float, command: int, params: tuple[float, ...]) -> CommandResult:
        self.calls.append(("set_roi", command, params))
        return CommandResult.ACCEPTED

    def set_home(self, now_s: float, geo: GeoPoint | None, yaw_rad: float = math.nan
                 ) -> CommandResult:
        self.calls.append(("set_home", now_s, geo))
        geo = self.global_position if geo is None else geo
        self.home = HomePosition(geo, self.origin.ned_of(geo), 0.0)
        return CommandResult.ACCEPTED

    def terminate(self, now_s: float) -> CommandResult:
        self.calls.append(("terminate", now_s))
        if not self.armed:
            return CommandResult.DENIED
        self.terminated, self.nav_state = True, NavState.TERMINATION
        return CommandResult.ACCEPTED

    def move_to(self, north_m: float, east_m: float, down_m: float, yaw_rad: float = 0.0) -> None:
        z = np.zeros(3)
        q = np.array([math.cos(yaw_rad / 2), 0.0, 0.0, math.sin(yaw_rad / 2)])
        self.state = VehicleState(self.state.time_s, np.array([north_m, east_m, down_m]), z.copy(),
                                  z.copy(), q, z.copy())


class Client:
    """A MAVLink peer (default: mavsdk_server's 245/190) talking to one Session in memory."""

    def __init__(self, session: Session, sysid: int = 245, compid: int = 190) -> None:
        self.session = session
        self.mav = M.MAVLink(None, sysid, compid)
        self.mav.robust_parsing = True
        self.rx = development.MAVLink(None, 0, 0)  # PX4 SITL's dialect: CURRENT_MODE too
        self.received: list[M.MAVLink_message] = []
        self.datagrams: list[bytes] = []
        self.now_s = 0.0

    def sign_with(self, key: bytes, timestamp: int, link_id: int = 0) -> None:
        """Sign what we send (pymavlink's own signing, from ``timestamp`` on) and accept only
        frames signed with ``key`` (no accept-unsigned callback)."""
        self.mav.signing.secret_key = key
        self.mav.signing.sign_outgoing = True
        self.mav.signing.link_id = link_id
        self.mav.signing.timestamp = timestamp
        self.rx.signing.secret_key = key

    def encode(self, msg: M.MAVLink_message) -> bytes:
        data = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) & 0xFF
        return data

    def send(self, msg: M.MAVLink_message) -> list[M.MAVLink_message]:
        """Deliver one message to the session and collect what it answers right away."""
        self.session.receive_datagram(self.encode(msg), self.now_s)
        return self.drain()

    def drain(self) -> list[M.MAVLink_message]:
        got: list[M.MAVLink_message] = []
        for d in self.session.datagrams_to_send(self.now_s):
            assert len(d) <= 1400
            self.datagrams.append(d)
            got.extend(self.rx.parse_buffer(d) or [])
        assert not any(isinstance(m, development.MAVLink_bad_data) for m in got), got
        self.received.extend(got)
        return got

    def run_until(self, t_end_s: float) -> list[M.MAVLink_message]:
        """Drive the session's timer like the shell does, up to t_end_s (exclusive)."""
        got: list[M.MAVLink_message] = []
        while True:
            t = self.session.get_timer()
            if t is None or t >= t_end_s:
                break
            self.now_s = max(self.now_s, t)
            self.session.handle_timer(self.now_s)
            got.extend(self.drain())
        self.now_s = t_end_s
        return got

    def command_long(self, command: int, *params: float, target_system: int = 1,
                     target_component: int = 1) -> list[M.MAVLink_message]:
        p = list(params) + [0.0] * (7 - len(params))
        return self.send(M.MAVLink_command_long_message(target_system, target_component, command,
                                                        0, *p))

    def heartbeat(self, mav_type: int = M.MAV_TYPE_GCS) -> list[M.MAVLink_message]:
        return self.send(M.MAVLink_heartbeat_message(mav_type, M.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))


def acks(msgs: list[M.MAVLink_message]) -> list[M.MAVLink_command_ack_message]:
    return [m for m in msgs if m.get_type() == "COMMAND_ACK"]


def of_type(msgs: list[M.MAVLink_message], name: str) -> list[M.MAVLink_message]:
    return [m for m in msgs if m.get_type() == name]


def make(kind: LinkKind = LinkKind.API, sysid: int = 1, signing: SigningConfig | None = None,
         boot_unix_s: float | None = None) -> tuple[FakeVehicle, Session, Client]:
    vehicle = FakeVehicle(sysid)
    session = Session(vehicle, kind, now_s=0.0, signing=signing, boot_unix_s=boot_unix_s)
    return vehicle, session, Client(session)
