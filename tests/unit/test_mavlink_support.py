"""Shared helpers for the MAVLink session tests: a fake vehicle and an in-memory client.

FakeVehicle implements the vehicles/README.md contract with a real ParamStore, so the session is
tested against the API the real autopilot will expose. Client is a pymavlink codec playing
MAVSDK/QGC, paired with a Session in memory (h11 ConnectionPair style): no sockets, no clock.
"""

from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from gateway.mavlink.session import LinkKind, Session
from vehicles.params import ParamStore
from vehicles.types import (
    PX4_SITL_HOME,
    BatteryState,
    CommandResult,
    HomePosition,
    LandedState,
    NavState,
    Severity,
    StatusText,
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

    # --- contract -------------------------------------------------------------------------
    @property
    def status(self) -> VehicleStatus:
        return VehicleStatus(
            time_s=self.state.time_s, armed=self.armed, nav_state=self.nav_state,
            landed_state=self.landed_state, position_valid=self.position_valid,
            prearm_ok=self.prearm_ok, failsafe=self.failsafe, terminated=self.terminated,
            battery=BatteryState(16.2, 0.5, 0.9, 12.0, 4), home=self.home)

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

    def arm(self, now_s: float, forced: bool = False) -> CommandResult:
        self.calls.append(("arm", now_s, forced))
        if not self.prearm_ok and not forced:
            return CommandResult.TEMPORARILY_REJECTED
        self.armed = True
        self.say(now_s, "Armed by external command")
        return CommandResult.ACCEPTED

    def disarm(self, now_s: float, forced: bool = False) -> CommandResult:
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

    def move_to(self, north_m: float, east_m: float, down_m: float) -> None:
        z = np.zeros(3)
        self.state = VehicleState(self.state.time_s, np.array([north_m, east_m, down_m]), z.copy(),
                                  z.copy(), np.array([1.0, 0, 0, 0]), z.copy())


class Client:
    """A MAVLink peer (default: mavsdk_server's 245/190) talking to one Session in memory."""

    def __init__(self, session: Session, sysid: int = 245, compid: int = 190) -> None:
        self.session = session
        self.mav = M.MAVLink(None, sysid, compid)
        self.mav.robust_parsing = True
        self.rx = M.MAVLink(None, 0, 0)
        self.received: list[M.MAVLink_message] = []
        self.datagrams: list[bytes] = []
        self.now_s = 0.0

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
        assert not any(isinstance(m, M.MAVLink_bad_data) for m in got), got
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


def make(kind: LinkKind = LinkKind.API, sysid: int = 1) -> tuple[FakeVehicle, Session, Client]:
    vehicle = FakeVehicle(sysid)
    session = Session(vehicle, kind, now_s=0.0)
    return vehicle, session, Client(session)
