"""Sans-IO MAVLink session: one per (vehicle, link). Bytes + ``now`` in, datagrams out.

The asyncio shell drives it exactly like aioquic's QuicConnection:

    s = Session(vehicle, LinkKind.API, now_s=0.0)
    s.receive_datagram(data, now_s, peer)  # a datagram arrived from ``peer`` (never raises)
    s.handle_timer(now_s)                  # at s.get_timer(): emit due telemetry, paced params …
    for d in s.datagrams_to_send(now_s):   # then drain: one datagram per frame, as PX4 sends
        link.send(d, s.peer)

Rules and invariants:
- Time is simulated seconds since boot (time_boot_ms = now_s·1000); no wall clock, no I/O here.
- Identity: sysid = vehicle.params['MAV_SYS_ID'], compid 1; MAVLink 2 out, one seq per link.
- Inbound frames addressed to another system are dropped and counted (``rx_other_target``),
  but for commands, which PX4 answers FAILED (commands.py); messages nobody handles are counted
  (``rx_unhandled``). Every frame's sender is noted in ``seen`` (command_table.SeenComponents),
  shared by the sessions of one vehicle's links.
- ``peer`` is the client this link answers (PX4 replies to the address it last heard from,
  mavlink_main.cpp in UDP mode): the opaque address passed with the last datagram that held a
  valid frame for this vehicle, so garbage and traffic for other systems or components (dropped
  here or by a service, ``other_target()``) never move it, and a restarted client is followed.
  With signing on only a frame with a valid signature moves it: an unsigned HEARTBEAT, which is
  accepted (signing.py), must not redirect the vehicle's replies. None until then.
- A GCS heartbeat (type 6) marks the link "GCS present" (STATUSTEXT gating) and is forwarded
  to ``vehicle.on_gcs_heartbeat(now_s)`` when the vehicle has it (data-link-loss failsafe).
- Services live one per module; this file only routes. Each service gets a ``LinkContext``
  (link.py) and the few callables it needs from its neighbours, never the Session: nothing in
  gateway/mavlink imports this module.
- Signing (``signing=SigningConfig(...)``, rules in signing.py): every outgoing frame is signed
  with link_id 0 on the GCS link and 1 on the API link (PX4 SITL starts its GCS instance first,
  then the onboard one, and signs with the instance number); inbound frames the Verifier rejects
  never reach a service and are counted (rx_unsigned, rx_bad_signature, rx_replayed).
  SETUP_SIGNING is refused and counted (``rx_setup_signing_refused``). ``signing=None`` (the
  default, and PX4 ≤ 1.16): nothing is signed or checked.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.codec import Decoder, Encoder
from gateway.mavlink.command_table import SeenComponents
from gateway.mavlink.commands import CommandService
from gateway.mavlink.event_messages import REQUEST_EVENT
from gateway.mavlink.events import EventsService
from gateway.mavlink.ftp import FtpService
from gateway.mavlink.link import LinkContext, LinkKind, SessionStats
from gateway.mavlink.link_status import TelemetryStatus
from gateway.mavlink.log_handler import LogHandlerService
from gateway.mavlink.log_streaming import LogStreamingService
from gateway.mavlink.manual import ManualControlService
from gateway.mavlink.mission import MissionService, UploadLock
from gateway.mavlink.offboard import OffboardService
from gateway.mavlink.params import ParamService
from gateway.mavlink.ping import PingService
from gateway.mavlink.serial_control import SerialControlService
from gateway.mavlink.signing import Signer, SigningClock, SigningConfig, Verifier
from gateway.mavlink.snapshot import LinkTelemetry, SampleCache, Snapshot
from gateway.mavlink.statustext import GCS_PRESENT_S, StatusTextService
from gateway.mavlink.statustext_in import StatustextInService
from gateway.mavlink.streams import Scheduler
from gateway.mavlink.timesync import Timesync
from gateway.mavlink.vehicle_port import VehiclePort
from gateway.mavlink.wip_dialect import SET_VELOCITY_LIMITS
from vehicles.types import Changes

__all__ = ["LinkKind", "Session", "SessionStats", "SigningConfig"]

log = logging.getLogger(__name__)

COMPONENT_ID = 1
ERROR_LOG_INTERVAL_S = 10.0  # a failing service logs at most once per this (simulated) time
MAV_TYPE_GCS = 6
MAV_TYPE_ONBOARD_CONTROLLER = 18
SIGNING_LINK_ID = {LinkKind.GCS: 0, LinkKind.API: 1}
# Handled whatever their target_system: PX4 answers a command for another target FAILED, and
# its SET_VELOCITY_LIMITS handler reads no target field.
_ANY_TARGET = frozenset({M.MAVLINK_MSG_ID_COMMAND_LONG, M.MAVLINK_MSG_ID_COMMAND_INT,
                         SET_VELOCITY_LIMITS.id})


class Session:
    def __init__(self, vehicle: VehiclePort, kind: LinkKind, now_s: float = 0.0, *,
                 boot_unix_s: float | None = None, signing: SigningConfig | None = None,
                 uploads: UploadLock | None = None, signing_link_id: int | None = None,
                 seen: SeenComponents | None = None) -> None:
        """``uploads``: the vehicle's plan-upload lock, shared by the sessions of its links (a
        session of its own when None); ``seen`` likewise, the components its links heard.
        ``signing_link_id``: the link id this link signs with (default: by kind, as below; a
        vehicle's extra MAVLink instances number on from 2)."""
        self.vehicle = vehicle
        self.kind = kind
        self.sysid = int(vehicle.params["MAV_SYS_ID"])
        self.compid = COMPONENT_ID
        self.boot_unix_s = boot_unix_s  # no Unix time when None: no SYSTEM_TIME
        self.stats = SessionStats()
        self.signing = signing
        signer = verifier = None
        if signing is not None:
            # One per link, shared by both directions; the replay state is the key's.
            clock = SigningClock(signing.epoch_unix_s, signing.state)
            link_id = SIGNING_LINK_ID[kind] if signing_link_id is None else signing_link_id
            signer = Signer(signing.key, link_id, clock)
            verifier = Verifier(signing.key, clock, signing.accept_unsigned, stats=self.stats)
        self.encoder = Encoder(self.sysid, self.compid, signer)
        self.encoder.now_s = now_s
        self._decoder = Decoder(self.stats, verifier)
        self._verifier = verifier
        self.peer: object = None  # module docstring
        self._addressed = False  # the frame being routed is for us (cleared by other_target)
        self._out: list[bytes] = []
        self.last_gcs_heartbeat_s = -math.inf
        self.last_onboard_heartbeat_s = -math.inf  # MAV_TYPE_ONBOARD_CONTROLLER
        self._next_error_log_s = -math.inf
        self.scheduler = Scheduler(kind, now_s)
        # What telemetry derives from one kinematics sample; the shell may give the sessions of
        # one vehicle the same cache (they sample it at the same instants).
        self.samples = SampleCache()
        self.tstatus = TelemetryStatus(self.stats)
        self.link_telemetry = LinkTelemetry(self.tstatus)
        self.link_telemetry.scheduler = self.scheduler
        ctx = LinkContext(vehicle, kind, self.sysid, self.encoder, self.stats, self.send,
                          self._other_target)
        scheduler = self.scheduler
        self.statustext = StatusTextService(
            ctx, self._text_listener_present,
            lambda: scheduler.period_s(M.MAVLINK_MSG_ID_STATUSTEXT))
        self.events = EventsService(ctx)
        say = self.statustext.local
        self.log_streaming = LogStreamingService(ctx, say)  # its ``topic`` too
        self.seen = seen if seen is not None else SeenComponents()
        self.commands = CommandService(
            ctx, say, self.snapshot, self.scheduler, logging_command=self.log_streaming.on_command,
            seen_elsewhere=lambda system, component: self.seen.seen_elsewhere(self, system,
                                                                              component))
        self.params = ParamService(ctx)
        # the client's clock as this link estimates it (PX4's per-instance MavlinkTimesync)
        self.timesync = Timesync(f"sysid {self.sysid} {kind.value} link:")
        self.ping = PingService(ctx, self.timesync)
        self.mission = MissionService(ctx, say, uploads if uploads is not None else UploadLock())
        self.offboard = OffboardService(ctx, say)
        self.manual = ManualControlService(ctx, self.timesync)
        self.logs = LogHandlerService(ctx)  # its ``store`` is attached by the shell
        self.serial = SerialControlService(ctx)  # its ``terminal_factory`` too
        self.ftp = FtpService(ctx)  # and its ``root``
        self.statustext_in = StatustextInService(ctx)
        self._routes: dict[int, Callable[[Any, float], None]] = {
            M.MAVLINK_MSG_ID_HEARTBEAT: self._on_heartbeat,
            M.MAVLINK_MSG_ID_COMMAND_LONG: self.commands.on_command_long,
            M.MAVLINK_MSG_ID_COMMAND_INT: self.commands.on_command_int,
            M.MAVLINK_MSG_ID_SET_MODE: self.commands.on_set_mode,
            M.MAVLINK_MSG_ID_PARAM_REQUEST_LIST: self.params.on_request_list,
            M.MAVLINK_MSG_ID_PARAM_REQUEST_READ: self.params.on_request_read,
            M.MAVLINK_MSG_ID_PARAM_SET: self.params.on_set,
            M.MAVLINK_MSG_ID_PING: self.ping.on_ping,
            M.MAVLINK_MSG_ID_TIMESYNC: self.ping.on_timesync,
            M.MAVLINK_MSG_ID_MISSION_COUNT: self.mission.on_count,
            M.MAVLINK_MSG_ID_MISSION_ITEM_INT: self.mission.on_item_int,
            M.MAVLINK_MSG_ID_MISSION_ITEM: self.mission.on_item,
            M.MAVLINK_MSG_ID_MISSION_REQUEST_LIST: self.mission.on_request_list,
            M.MAVLINK_MSG_ID_MISSION_REQUEST_INT: self.mission.on_request_int,
            M.MAVLINK_MSG_ID_MISSION_REQUEST: self.mission.on_request,
            M.MAVLINK_MSG_ID_MISSION_ACK: self.mission.on_ack,
            M.MAVLINK_MSG_ID_MISSION_CLEAR_ALL: self.mission.on_clear_all,
            M.MAVLINK_MSG_ID_MISSION_SET_CURRENT: self.mission.on_set_current,
            M.MAVLINK_MSG_ID_SET_POSITION_TARGET_LOCAL_NED: self.offboard.on_local_ned,
            M.MAVLINK_MSG_ID_SET_POSITION_TARGET_GLOBAL_INT: self.offboard.on_global_int,
            M.MAVLINK_MSG_ID_SET_ATTITUDE_TARGET: self.offboard.on_attitude_target,
            M.MAVLINK_MSG_ID_MANUAL_CONTROL: self.manual.on_manual_control,
            M.MAVLINK_MSG_ID_FOLLOW_TARGET: self.manual.on_follow_target,
            SET_VELOCITY_LIMITS.id: self.manual.on_set_velocity_limits,
            M.MAVLINK_MSG_ID_LANDING_TARGET: self.manual.on_landing_target,
            M.MAVLINK_MSG_ID_LOG_REQUEST_LIST: self.logs.on_request_list,
            M.MAVLINK_MSG_ID_LOG_REQUEST_DATA: self.logs.on_request_data,
            M.MAVLINK_MSG_ID_LOG_REQUEST_END: self.logs.on_request_end,
            M.MAVLINK_MSG_ID_LOG_ERASE: self.logs.on_erase,
            M.MAVLINK_MSG_ID_LOGGING_ACK: self.log_streaming.on_logging_ack,
            M.MAVLINK_MSG_ID_SERIAL_CONTROL: self.serial.on_serial_control,
            M.MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL: self.ftp.on_file_transfer_protocol,
            REQUEST_EVENT.id: self.events.on_request_event,
            M.MAVLINK_MSG_ID_STATUSTEXT: self.statustext_in.on_statustext,
        }
        if signing is not None:
            self._routes[M.MAVLINK_MSG_ID_SETUP_SIGNING] = self._on_setup_signing
        # After the telemetry, a wake-up polls the mission progress, the status texts and the
        # events (``handle_timer``: those that can have anything to do), then the paced services
        # (bursts of PARAM_VALUE, LOG_DATA, FTP data), in this order. A paced service has nothing
        # to do before its ``due_s`` (inf while idle), so it is only called from then on.
        self._paced: tuple[tuple[str, ParamService | LogHandlerService | FtpService
                                 | LogStreamingService | SerialControlService], ...] = (
            ("the parameter timer", self.params),
            ("the log download", self.logs),
            ("the FTP burst", self.ftp),
            ("the log stream", self.log_streaming),
            ("the shell", self.serial))
        self._paced_services = (self.params, self.logs, self.ftp, self.log_streaming,
                                self.serial)
        # COMMAND_ACKs the vehicle's modules give later, on their own (vehicles/command_journal.py)
        self._journal = getattr(vehicle, "commands", None)
        self._changes: Changes | None = getattr(vehicle, "changes", None)
        self._ack_seq = self._journal.ack_seq if self._journal is not None else 0

    # --- the sans-IO contract -----------------------------------------------------------------
    def receive_datagram(self, data: bytes, now_s: float, peer: object = None) -> None:
        """``peer``: the sender's address, opaque here; it becomes ``self.peer`` if the datagram
        held a frame for this vehicle (module docstring)."""
        self.encoder.now_s = now_s  # the time replies are signed with
        authenticate = self._verifier is not None
        heard = False
        try:
            for msg in self._decoder.feed(data, now_s):
                self.seen.heard(self, msg.get_srcSystem(), msg.get_srcComponent())
                target = getattr(msg, "target_system", 0)
                if target not in (0, self.sysid) and msg.get_msgId() not in _ANY_TARGET:
                    self.stats.rx_other_target += 1
                    continue
                self._addressed = True
                try:
                    route = self._routes.get(msg.get_msgId())
                    if route is None:
                        self.stats.rx_unhandled += 1
                    else:
                        route(msg, now_s)
                except Exception:  # a bug must not cost the datagram's other frames
                    self._failed(now_s, f"handling {msg.get_type()}")
                finally:  # a service that fails on a frame for us has still heard its sender
                    if self._addressed and (not authenticate or msg.get_signed()):
                        heard = True
        finally:
            if heard and peer is not None:
                self.peer = peer

    def datagrams_to_send(self, now_s: float) -> list[bytes]:
        """Every frame queued since the last call, each in a datagram of its own, in order: PX4
        sends each message as it is finalised (mavlink_main.cpp ``send_finish``: one
        ``sendto`` per message), so a network loses, delays and queues messages one by one."""
        out = self._out
        if not out:
            return out
        self._out = []
        self.stats.tx_datagrams += len(out)
        self.stats.tx_bytes += sum(map(len, out))
        return out

    def set_epoch(self, boot_unix_s: float) -> None:
        """The Unix time of simulated t = 0, once the shell knows it (time starts after the
        vehicles are built and their ports bound): SYSTEM_TIME's clock and the signing clock."""
        if self.boot_unix_s is not None:
            self.boot_unix_s = boot_unix_s
        signer = self.encoder.signer
        if signer is not None:
            signer.clock.rebase(boot_unix_s)  # the verifier's clock too: one per link

    def get_timer(self) -> float | None:
        t = min(self.scheduler.next_s, self.params.due_s, self.mission.due_s,
                self.logs.due_s, self.ftp.due_s, self.log_streaming.due_s, self.events.due_s,
                self.statustext.due_s, self.serial.due_s)
        return None if t == math.inf else t

    def handle_timer(self, now_s: float) -> None:
        enc = self.encoder
        enc.now_s = now_s
        tstatus = self.tstatus
        if now_s > tstatus.due_s:
            tstatus.update(now_s)
        due = self.scheduler.due(now_s)
        if due:
            snap = Snapshot(self.vehicle, now_s, self.boot_unix_s, self.samples,
                            self.link_telemetry)
            out = self._out
            sent = len(out)
            enc.frame_streams(due, snap, out, self._build_failed)  # ``send`` inlined
            self.stats.tx_frames += len(out) - sent
        # The change-driven services, each called only when it has something to look at: its
        # generation of the vehicle's Changes moved, its own timer came, or (STATUSTEXT) texts
        # wait and a heartbeat came since (a listener may be back). A vehicle without Changes
        # has them polled at every wake-up.
        changes = self._changes
        mission = self.mission
        if changes is None or changes.mission_progress != mission.seen_progress \
                or now_s >= mission.due_s:
            try:
                mission.handle_timer(now_s)
            except Exception:
                self._failed(now_s, "the mission timer")
        # before the texts: an ACK and the text it explains go out in that order
        journal = self._journal
        if journal is not None and journal.ack_seq != self._ack_seq:
            for ack in journal.acks_after(self._ack_seq):
                self.send(enc.pack(M.MAVLink_command_ack_message, ack.command, ack.result, 0, 0,
                                   ack.target_system, ack.target_component))
                self.log_streaming.on_logger_ack(ack.command, ack.result, now_s)
            self._ack_seq = journal.ack_seq
        statustext = self.statustext
        if changes is None or changes.status_texts != statustext.seen_texts \
                or (statustext.pending and (statustext.recheck
                                            or now_s >= statustext.due_s - 1e-9)):
            try:
                statustext.poll(now_s)
            except Exception:
                self._failed(now_s, "STATUSTEXT")
        events = self.events
        log = events.log
        if log is not None and (log.latest != events.sent or now_s >= events.due_s):
            try:
                events.poll(now_s)
            except Exception:
                self._failed(now_s, "the events")
        params, logs, ftp, stream, serial = self._paced_services
        if params.due_s <= now_s or logs.due_s <= now_s or ftp.due_s <= now_s \
                or stream.due_s <= now_s or serial.due_s <= now_s:
            for name, service in self._paced:
                if service.due_s <= now_s:
                    try:
                        service.handle_timer(now_s)
                    except Exception:
                        self._failed(now_s, name)

    def _build_failed(self, msg_id: int) -> None:
        self._failed(self.encoder.now_s, f"building message {msg_id}")

    def _failed(self, now_s: float, what: str) -> None:
        """A service raised: counted (``handler_errors``), logged with its traceback the first
        time and then at most once per ERROR_LOG_INTERVAL_S of simulated time."""
        self.stats.handler_errors += 1
        if now_s >= self._next_error_log_s:
            self._next_error_log_s = now_s + ERROR_LOG_INTERVAL_S
            log.error("vehicle %d %s link: error while %s (%d so far)", self.sysid,
                      self.kind.value, what, self.stats.handler_errors,
                      exc_info=self.stats.handler_errors == 1)

    # --- for the services ---------------------------------------------------------------------
    def send(self, frame: bytes) -> None:
        self._out.append(frame)
        self.stats.tx_frames += 1

    def snapshot(self, now_s: float) -> Snapshot:
        """What a REQUEST_MESSAGE builds its answer from."""
        return Snapshot(self.vehicle, now_s, self.boot_unix_s, self.samples,
                        self.link_telemetry, requested=True)

    def _other_target(self) -> None:
        self.stats.rx_other_target += 1
        self._addressed = False

    def gcs_present(self, now_s: float) -> bool:
        return now_s - self.last_gcs_heartbeat_s <= GCS_PRESENT_S

    def _text_listener_present(self, now_s: float) -> bool:
        """PX4 sends STATUSTEXT while ``is_gcs_connected() || is_onboard_controller_connected()``."""
        return (now_s - self.last_gcs_heartbeat_s <= GCS_PRESENT_S
                or now_s - self.last_onboard_heartbeat_s <= GCS_PRESENT_S)

    def _on_heartbeat(self, msg: M.MAVLink_heartbeat_message, now_s: float) -> None:
        self.statustext.recheck = True  # waiting texts may have a listener now
        if msg.type != MAV_TYPE_GCS:
            if msg.type == MAV_TYPE_ONBOARD_CONTROLLER:
                self.last_onboard_heartbeat_s = now_s
            return
        self.last_gcs_heartbeat_s = now_s
        hook = getattr(self.vehicle, "on_gcs_heartbeat", None)
        if hook is not None:
            hook(now_s)

    def _on_setup_signing(self, msg: M.MAVLink_setup_signing_message, now_s: float) -> None:
        # Refused: the key is the operator's and shared by every link (signing.py docstring).
        self.stats.rx_setup_signing_refused += 1
        if self.stats.rx_setup_signing_refused == 1:
            log.warning("%s link of system %d: SETUP_SIGNING from %d/%d refused; the signing key "
                        "is fixed at start-up", self.kind.value, self.sysid, msg.get_srcSystem(),
                        msg.get_srcComponent())
