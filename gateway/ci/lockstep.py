"""In-process lockstep flights: vehicles, MAVLink clients and the network on one simulated clock.

    from gateway.testing import Sim, mission_item
    with Sim(vehicles=1, network=NetworkConfig.from_flags(50, 10, 0.1, seed=3)) as sim:
        api = sim.api(0)                              # an in-memory MAVSDK-like client
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
        api.upload_mission([mission_item(22, lat, lon, 10), ...])
        api.arm(); api.start_mission()
        sim.run_until(lambda: not sim.status(0).armed, timeout_s=120)

No sockets, no asyncio, no wall clock, no threads: every client action is a datagram injected
into the same ``Simulation`` the daemon runs (uplink link model → session → vehicle), and every
reply comes back through the downlink model. Waiting (command retries, mission transfer) runs the
kernel event by event, so same seed + same calls → the same bytes.

Clients keep received frames raw and decode lazily (by message id), because decoding every
telemetry frame with pymavlink would cost more than the simulation itself. Like MAVSDK and QGC,
a client answers the vehicle's PING requests at once, and, while it streams the vehicle's ULog
(``start_log_stream``), acknowledges each LOGGING_DATA_ACKED at once.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20 import development

from gateway.ci.frame_store import FrameStore
from gateway.ci.ulog_receiver import UlogReceiver
from gateway.mavlink.modes import custom_mode_of
from gateway.mavlink.session import LinkKind
from gateway.onboard.files import attach_ftp
from gateway.onboard.logs import Logs
from gateway.onboard.shell import attach_shells
from gateway.sim import scenario as scenario_mod
from gateway.sim.flightlog import DOWN, MAGIC_V2, UP, FlightLog, split_frames
from gateway.sim.radios import LinkTag
from gateway.sim.scenario import NetworkConfig
from gateway.sim.simulation import PHYSICS_DT_S, Simulation, default_params
from netsim.kernel import Ticker
from vehicles.plan_types import PlanItem, PlanType
from vehicles.plans import NON_POSITIONAL_COMMANDS
from vehicles.types import PX4_SITL_HOME, GeoPoint, NavState, VehicleState, VehicleStatus

__all__ = ["Client", "Sim", "mission_item", "LinkKind", "NetworkConfig", "PlanType", "NavState"]

M = mavlink2

# MAVSDK defaults (MavlinkCommandSender, MavlinkMissionTransferClient).
COMMAND_TIMEOUT_S = 0.5
COMMAND_RETRIES = 3
MISSION_TIMEOUT_S = 1.0  # per step of the transfer, before the last message is repeated
MISSION_RETRIES = 5
CLIENT_SYSID = 245  # MAVSDK's default system id / MAV_COMP_ID_MISSIONPLANNER
CLIENT_COMPID = 190
HEARTBEAT_PERIOD_S = 1.0
POLL_S = 0.02  # run_until checks its predicate at the position-control rate
# Fixed boot epoch of lockstep logs (2026-01-01T00:00:00Z): logs stay byte-identical run to run.
LOCKSTEP_EPOCH_UNIX_S = 1_767_225_600.0
GLOBAL_RELATIVE_ALT_INT = 6
MAV_FRAME_MISSION = 2

_ID_COMMAND_ACK = M.MAVLINK_MSG_ID_COMMAND_ACK
_ID_PING = M.MAVLINK_MSG_ID_PING
_ID_LOGGING_DATA = M.MAVLINK_MSG_ID_LOGGING_DATA
_ID_LOGGING_DATA_ACKED = M.MAVLINK_MSG_ID_LOGGING_DATA_ACKED
_MISSION_REPLY_IDS = (M.MAVLINK_MSG_ID_MISSION_REQUEST_INT, M.MAVLINK_MSG_ID_MISSION_REQUEST,
                      M.MAVLINK_MSG_ID_MISSION_ACK)
_NAME_TO_ID = {cls.msgname: msgid for msgid, cls in development.mavlink_map.items()}


def mission_item(command: int, lat_deg: float = 0.0, lon_deg: float = 0.0, alt_m: float = 0.0, *,
                 params: Sequence[float] = (0.0, 0.0, 0.0, math.nan),
                 frame: int | None = None,
                 mission_type: PlanType = PlanType.MISSION) -> PlanItem:
    """One plan item as MISSION_ITEM_INT carries it (seq is set at upload). ``frame`` defaults
    to QGC's choice: MAV_FRAME_MISSION for a command without a position (RTL, DO_JUMP,
    DO_CHANGE_SPEED, ...: PX4 refuses those in a global frame), else GLOBAL_RELATIVE_ALT_INT."""
    if frame is None:
        frame = MAV_FRAME_MISSION if command in NON_POSITIONAL_COMMANDS else GLOBAL_RELATIVE_ALT_INT
    p = list(params) + [0.0] * (4 - len(params))
    return PlanItem(seq=0, frame=frame, command=command, current=0, autocontinue=1,
                    param1=p[0], param2=p[1], param3=p[2], param4=p[3],
                    x=int(round(lat_deg * 1e7)), y=int(round(lon_deg * 1e7)), z=alt_m,
                    mission_type=int(mission_type))


class Client:
    """A pymavlink codec on one vehicle link, playing a GCS / MAVSDK inside the simulation."""

    def __init__(self, sim: Sim, index: int, kind: LinkKind, sysid: int = CLIENT_SYSID,
                 compid: int = CLIENT_COMPID) -> None:
        self.sim, self.index, self.kind = sim, index, kind
        self.target = int(sim.vehicles[index].params["MAV_SYS_ID"])
        # PX4 SITL's dialect (development: common and CURRENT_MODE)
        self.mav = development.MAVLink(None, srcSystem=sysid, srcComponent=compid)
        self.mav.robust_parsing = True
        self.peer = ("lockstep", index, kind.name.lower())
        # Raw frames as they arrive: (time, msgid, frame). Decoded on demand, cached.
        self.frames = FrameStore(sim.history_s)
        self._decoded: dict[int, Any] = {}
        self._decoded_floor = 0  # frames.first when the cache last dropped forgotten frames
        self._heartbeat: Ticker | None = None
        self.log_stream: UlogReceiver | None = None  # while streaming the ULog
        self._kernel = sim.simulation.kernel
        flightlog = sim.flightlog
        self._record_up = None if flightlog is None else flightlog.recorder(UP, index, kind)
        self._record_down = None if flightlog is None else flightlog.recorder(DOWN, index, kind)
        sim.simulation.links[(index, kind)].on_downlink = self._on_downlink

    # --- receiving ----------------------------------------------------------------------------
    def _on_downlink(self, data: bytes, peer: object) -> None:
        """A datagram the link's downlink delivered (its ``VehicleLink.on_downlink``): into the
        flight log, then its frames into the store, answered at once where MAVSDK answers."""
        now = self._kernel.now
        n = len(data)
        if n > 2 and data[0] == MAGIC_V2 and n == 12 + data[1] + (13 if data[2] & 1 else 0):
            split: Sequence[bytes] = (data,)  # split_frames' case of PX4's datagrams, inlined
        else:
            split = split_frames(data)
        record = self._record_down
        if record is not None:
            record(split, now)
        frames = self.frames
        for frame in split:
            # frame_msgid inlined
            msgid = frame[7] | frame[8] << 8 | frame[9] << 16 if frame[0] == MAGIC_V2 else frame[5]
            i = frames.append(now, msgid, frame)
            if msgid == _ID_PING:
                self._answer_ping(i)
            elif (msgid == _ID_LOGGING_DATA or msgid == _ID_LOGGING_DATA_ACKED) \
                    and self.log_stream is not None:
                self._on_logging_data(i, msgid == _ID_LOGGING_DATA_ACKED)
        decoded = self._decoded
        if decoded and frames.first > self._decoded_floor:  # forgotten frames: decoded too
            self._decoded = {i: m for i, m in decoded.items() if i >= frames.first}
            self._decoded_floor = frames.first

    def _on_logging_data(self, i: int, acked: bool) -> None:
        msg = self._decode(i)
        if not msg or msg.target_system != self.mav.srcSystem \
                or msg.target_component != self.mav.srcComponent:
            return
        if acked:  # MAVSDK acknowledges first, then takes the data
            self.send(self.mav.logging_ack_encode(msg.get_srcSystem(), msg.get_srcComponent(),
                                                  msg.sequence))
        assert self.log_stream is not None
        self.log_stream.feed(msg.sequence, msg.length, msg.first_message_offset, bytes(msg.data))

    def _answer_ping(self, i: int) -> None:
        """A PING to all (PX4's PING stream) is a request: MAVSDK and QGC answer it at once,
        addressed to its sender, with its time and sequence."""
        ping = self._decode(i)
        if ping and ping.target_system == 0 and ping.target_component == 0:
            self.send(self.mav.ping_encode(ping.time_usec, ping.seq, ping.get_srcSystem(),
                                           ping.get_srcComponent()))

    def _decode(self, i: int) -> Any:
        msg = self._decoded.get(i)
        if msg is None:
            self.mav.buf, self.mav.buf_index = bytearray(), 0
            msgs = self.mav.parse_buffer(self.frames.frame(i)) or []
            msg = msgs[0] if msgs else False
            self._decoded[i] = msg
        return msg

    def messages(self, name: str | None = None, since: int = 0) -> list[Any]:
        """Decoded messages received (of one type, e.g. ``"COMMAND_ACK"``), oldest first."""
        return [m for _, m in self.timed_messages(name, since)]

    def timed_messages(self, name: str | None = None, since: int = 0) -> list[tuple[float, Any]]:
        frames = self.frames
        indices = range(max(since, frames.first), len(frames)) if name is None \
            else frames.find(frozenset((_NAME_TO_ID[name],)), since)
        out = []
        for i in indices:
            msg = self._decode(i)
            if msg and msg.get_type() != "BAD_DATA":
                out.append((frames.time_s(i), msg))
        return out

    def last(self, name: str) -> Any | None:
        for i in self.frames.last(_NAME_TO_ID[name]):
            msg = self._decode(i)
            if msg:
                return msg
        return None

    def _wait_message(self, msgids: Iterable[int], match: Callable[[Any], bool],
                      cursor: list[int], timeout_s: float) -> Any | None:
        """The first new message (from ``cursor[0]`` on) with one of ``msgids`` that ``match``es,
        running the kernel event by event for at most ``timeout_s``; advances the cursor."""
        ids = frozenset(msgids)
        found: list[Any] = []

        def check() -> bool:
            frames = self.frames
            for i in frames.find(ids, cursor[0]):
                cursor[0] = i + 1
                msg = self._decode(i)
                if msg and match(msg):
                    found.append(msg)
                    return True
            cursor[0] = len(frames)
            return False

        self.sim._run_events_until(check, self.sim.now + timeout_s)
        return found[0] if found else None

    # --- sending ------------------------------------------------------------------------------
    def send(self, msg: Any) -> None:
        """Send a pymavlink message (e.g. ``client.mav.heartbeat_encode(...)``) now, with the
        client's next sequence number (as pymavlink's ``send`` counts them)."""
        mav = self.mav
        self.send_bytes(msg.pack(mav))
        mav.seq = (mav.seq + 1) % 256

    def send_bytes(self, datagram: bytes) -> None:
        if self._record_up is not None:
            self._record_up(split_frames(datagram), self._kernel.now)
        self.sim.simulation.inject(self.index, self.kind, datagram, self.peer)

    def heartbeat(self) -> None:
        self.send(self.mav.heartbeat_encode(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0,
                                            M.MAV_STATE_ACTIVE))

    def start_heartbeat(self, period_s: float = HEARTBEAT_PERIOD_S) -> None:
        """A GCS heartbeat every ``period_s`` of simulated time (as MAVSDK and QGC send)."""
        if self._heartbeat is None:
            self._heartbeat = self.sim.simulation.every(period_s, lambda now: self.heartbeat())

    def stop_heartbeat(self) -> None:
        if self._heartbeat is not None:
            self._heartbeat.cancel()
            self._heartbeat = None

    # --- commands (MAVSDK MavlinkCommandSender) -----------------------------------------------
    def command_long(self, command: int, *params: float, timeout_s: float = COMMAND_TIMEOUT_S,
                     retries: int = COMMAND_RETRIES) -> int | None:
        """Send COMMAND_LONG, resend (confirmation + 1) after ``timeout_s`` without an ACK, up to
        ``retries`` times. Returns the MAV_RESULT of the final ACK, None if none came.
        IN_PROGRESS ACKs extend the wait, as in MAVSDK."""
        p = [float(x) for x in params] + [0.0] * (7 - len(params))
        cursor = [len(self.frames)]
        for confirmation in range(retries + 1):
            self.send(self.mav.command_long_encode(self.target, 1, command, min(confirmation, 255),
                                                   *p))
            while True:
                ack = self._wait_message((_ID_COMMAND_ACK,), lambda m: m.command == command,
                                         cursor, timeout_s)
                if ack is None:
                    break
                if ack.result != M.MAV_RESULT_IN_PROGRESS:
                    return int(ack.result)
        return None

    def arm(self) -> int | None:
        return self.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)

    # --- ULog streaming (MAVSDK log_streaming, PX4 Tools/mavlink_ulog_streaming.py) -----------
    def start_log_stream(self) -> int | None:
        """MAV_CMD_LOGGING_START: the vehicle's logger streams its ULog to this client."""
        self.log_stream = UlogReceiver()
        return self.command_long(M.MAV_CMD_LOGGING_START, 0)

    def stop_log_stream(self) -> tuple[int | None, bytes]:
        """MAV_CMD_LOGGING_STOP; the result and the ULog file the stream made."""
        result = self.command_long(M.MAV_CMD_LOGGING_STOP)
        stream, self.log_stream = self.log_stream, None
        return result, stream.ulog() if stream is not None else b""

    def disarm(self) -> int | None:
        return self.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 0)

    def takeoff(self, alt_amsl_m: float = math.nan) -> int | None:
        nan = math.nan
        return self.command_long(M.MAV_CMD_NAV_TAKEOFF, nan, nan, nan, nan, nan, nan, alt_amsl_m)

    def land(self) -> int | None:
        return self.command_long(M.MAV_CMD_NAV_LAND, *([math.nan] * 7))

    def return_to_launch(self) -> int | None:
        return self.command_long(M.MAV_CMD_NAV_RETURN_TO_LAUNCH)

    def set_mode(self, nav_state: NavState) -> int | None:
        """DO_SET_MODE with PX4 custom main/sub mode (what MAVSDK's flight-mode calls send)."""
        custom = custom_mode_of(nav_state)
        return self.command_long(M.MAV_CMD_DO_SET_MODE, 1, (custom >> 16) & 0xFF,
                                 (custom >> 24) & 0xFF)

    def start_mission(self) -> int | None:
        """MAVSDK ``mission.start_mission``: switch to Mission mode."""
        return self.set_mode(NavState.AUTO_MISSION)

    # --- mission protocol client (MAVSDK MavlinkMissionTransferClient, upload) ----------------
    def upload_mission(self, items: Sequence[PlanItem],
                       mission_type: PlanType = PlanType.MISSION,
                       timeout_s: float = MISSION_TIMEOUT_S,
                       retries: int = MISSION_RETRIES) -> int | None:
        """Upload ``items`` (seq renumbered) through the vehicle's mission protocol server:
        MISSION_COUNT → answers each MISSION_REQUEST(_INT) → MISSION_ACK. Whatever the link
        loses is repeated (COUNT, the last item) after ``timeout_s``, at most ``retries`` times
        in a row. Returns the MAV_MISSION_RESULT of the ACK, None if the transfer timed out."""
        mtype = int(mission_type)
        count = len(items)
        tgt = self.target
        last = self.mav.mission_count_encode(tgt, 1, count, mtype)
        self.send(last)
        cursor = [len(self.frames)]
        misses = 0

        def ours(m: Any) -> bool:
            return m.mission_type == mtype and m.target_system == self.mav.srcSystem

        while misses <= retries:
            reply = self._wait_message(_MISSION_REPLY_IDS, ours, cursor, timeout_s)
            if reply is None:
                misses += 1
                self.send(last)
                continue
            misses = 0
            if reply.get_type() == "MISSION_ACK":
                return int(reply.type)
            seq = reply.seq
            if not 0 <= seq < count:
                continue
            it = items[seq]
            common = (tgt, 1, seq, it.frame, it.command, int(seq == 0), it.autocontinue,
                      it.param1, it.param2, it.param3, it.param4)
            if reply.get_type() == "MISSION_REQUEST_INT":
                last = self.mav.mission_item_int_encode(*common, it.x, it.y, it.z, mtype)
            else:
                scale = 1e-7 if it.frame in (0, 3, 5, 6, 10, 11) else 1.0
                last = self.mav.mission_item_encode(*common, it.x * scale, it.y * scale, it.z,
                                                    mtype)
            self.send(last)
        return None

    def upload_fence(self, items: Sequence[PlanItem]) -> int | None:
        return self.upload_mission(items, PlanType.FENCE)

    def upload_rally(self, items: Sequence[PlanItem]) -> int | None:
        return self.upload_mission(items, PlanType.RALLY)


class Sim:
    """N vehicles and their clients in one process, advanced explicitly on simulated time."""

    def __init__(self, vehicles: int | None = None, network: NetworkConfig | None = None, *,
                 scenario: str | Path | scenario_mod.Scenario | None = None,
                 params: dict[str, float] | None = None, home: GeoPoint | None = None,
                 log_dir: str | Path | None = None, boot_unix_s: float = LOCKSTEP_EPOCH_UNIX_S,
                 state_period_s: float = 0.1, heartbeat: bool = True,
                 physics_dt_s: float = PHYSICS_DT_S, extra_meta: dict | None = None,
                 links: Iterable[LinkKind] = (LinkKind.API,), history_s: float = math.inf) -> None:
        """Vehicles, network, home and parameters come from ``scenario`` (a path or a parsed
        Scenario) when given, then from the arguments. ``log_dir``: record flight logs there
        (gateway/sim/flightlog.py). ``heartbeat``: each vehicle's API client sends a GCS heartbeat
        every simulated second, as MAVSDK does. ``links``: the MAVLink links each vehicle runs.
        The default is the API link (PX4's onboard link on 14540+i, MAVSDK's); add
        ``LinkKind.GCS`` for QGC's link. A link nobody reads would cost as much time as the
        physics, so lockstep runs leave it out unless asked. ``history_s``: each client forgets the
        frames it received more than that many simulated seconds ago, so a long or crowded run
        keeps a bounded window (otherwise an API client keeps ~130 MB per vehicle-hour)."""
        if isinstance(scenario, (str, Path)):
            scenario = scenario_mod.load(scenario)
        sc = scenario or scenario_mod.Scenario(source="lockstep")
        n = vehicles if vehicles is not None else sc.vehicles
        self.home = home or (sc.home if scenario is not None else PX4_SITL_HOME)
        overrides = {**sc.params, **(params or {})}
        self.flightlog: FlightLog | None = None
        self.log_dir = None if log_dir is None else Path(log_dir)
        self._closed = False
        self.history_s = history_s
        tracer = None
        if log_dir is not None:
            self.flightlog = FlightLog(log_dir, boot_unix_s=boot_unix_s,
                                       state_period_s=state_period_s)
            tracer = self.flightlog.tracer
        self.simulation = Simulation(
            n, network if network is not None else sc.network,
            params_for=lambda i: default_params(i, overrides), tracer=tracer, home=self.home,
            physics_dt_s=physics_dt_s, link_kinds=tuple(links), wind=sc.wind,
            sensors=sc.sensors, faults=sc.faults, spawn_ned_m=sc.spawn_ned_m,
            extra_radios=False, boot_unix_s=boot_unix_s)
        # PX4's logger: <log_dir>/vehicle-<sysid>/log/…; without a log dir it only streams.
        run = self.flightlog.dir if self.flightlog is not None else None
        if self.flightlog is not None:
            self.flightlog.attach(self.simulation, extra_meta)
        self.logs = Logs(self.simulation,
                         lambda sysid: [run / f"vehicle-{sysid}"] if run is not None else [],
                         boot_unix_s, storage=run is not None)
        attach_shells(self.simulation, self.logs.loggers.get)
        # MAVLink FTP: the vehicle's root when there is a log dir, PX4's etc/extras always.
        run_dir = self.flightlog.dir if self.flightlog is not None else None
        attach_ftp(self.simulation,
                   lambda sysid: [run_dir / f"vehicle-{sysid}"] if run_dir is not None else [])
        self.clients: dict[tuple[int, LinkTag], Client] = {
            (i, kind): Client(self, i, kind) for i in range(n)
            for kind in self.simulation.link_kinds}  # each takes its link's datagrams
        if heartbeat:
            for i in range(n):
                kind = LinkKind.API if LinkKind.API in self.simulation.link_kinds else LinkKind.GCS
                self.client(i, kind).start_heartbeat()

    # --- plumbing -----------------------------------------------------------------------------
    def _run_events_until(self, done: Callable[[], bool], deadline: float) -> bool:
        """Process events one by one until ``done()`` or the next event is past ``deadline``
        (then time stops at ``deadline``)."""
        step_until = self.simulation.kernel.step_until
        while not done():
            if not step_until(deadline):  # the next event is past it
                self.simulation.kernel.run(until=deadline)
                return done()
        return True

    # --- the API ------------------------------------------------------------------------------
    @property
    def now(self) -> float:
        return self.simulation.kernel.now

    @property
    def vehicles(self) -> list:
        return self.simulation.vehicles

    def client(self, index: int = 0, kind: LinkKind = LinkKind.API) -> Client:
        client = self.clients.get((index, kind))
        if client is None:
            if not 0 <= index < len(self.vehicles):
                raise IndexError(f"no vehicle {index} (the Sim has {len(self.vehicles)})")
            raise KeyError(f"this Sim has no {kind.name} link: create it with "
                           f"links=(LinkKind.API, LinkKind.GCS)")
        return client

    def api(self, index: int = 0) -> Client:
        return self.client(index, LinkKind.API)

    def gcs(self, index: int = 0) -> Client:
        return self.client(index, LinkKind.GCS)

    def state(self, index: int = 0) -> VehicleState:
        return self.simulation.vehicles[index].state

    def status(self, index: int = 0) -> VehicleStatus:
        return self.simulation.vehicles[index].status

    def advance(self, seconds: float) -> None:
        """Run ``seconds`` of simulated time."""
        self.simulation.run(until=self.now + seconds)

    def run_until(self, predicate: Callable[[], bool], timeout_s: float,
                  poll_s: float = POLL_S) -> bool:
        """Advance until ``predicate()`` is true (checked every ``poll_s`` of simulated time),
        at most ``timeout_s``. Returns whether it became true."""
        deadline = self.now + timeout_s
        while not predicate():
            if self.now >= deadline:
                return False
            self.simulation.run(until=min(self.now + poll_s, deadline))
        return True

    def every(self, period_s: float, callback: Callable[[float], None]):
        """An observer on the simulated clock (``callback(now)``), e.g. to sample positions."""
        return self.simulation.every(period_s, callback)

    def link_stats(self) -> dict[str, dict]:
        return self.simulation.link_stats()

    def close(self) -> None:
        """Stop the clients, flush the logs, free the physics; a second call does nothing."""
        if self._closed:
            return
        self._closed = True
        for c in self.clients.values():
            c.stop_heartbeat()
        if self.logs is not None:
            self.logs.close()
        if self.flightlog is not None:
            self.flightlog.close()
        self.simulation.close()

    def __enter__(self) -> Sim:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
