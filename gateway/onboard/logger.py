"""PX4's logger for one vehicle, sans-IO: ULog bytes of its topics, messages and parameters.

Source: PX4 src/modules/logger (logger.cpp: SDLOG_MODE, the file names, what the definitions
section holds; logged_topics.cpp: the default profile's topics and intervals).
Rules:
- ``tick(now)`` (the shell calls it at 50 Hz of simulated time) starts and stops logs as
  SDLOG_MODE says (-1 never; 0 from arming to disarming; 1 from boot to disarming, then as 0;
  2 from boot on; 4 from the first arming on; 3, AUX1, as 0) and samples each topic when its
  interval has passed (0: every tick; topics marked on-change: looked at once per interval
  and written when their values changed, as PX4's logger writes a topic updated since).
- The topics, with PX4's names, field names and intervals: logged_topics.py. ``links``: the
  vehicle's MAVLink sessions, PX4's mavlink instances in order, whose telemetry_status the
  logger writes (logged_status.py; the shell sets them, as the links live in the gateway).
- vehicle_command and vehicle_command_ack are written for every command the vehicle's journal
  (vehicles/command_journal.py) recorded since the last tick, at the time it came.
- A log holds the info fields (ver_sw, ver_sw_release, ver_hw, sys_name, sys_uuid unless
  SDLOG_UUID is 0, ver_data_format, time_ref_utc = SDLOG_UTC_OFFSET in s), every parameter
  and the defaults of those that differ from them (PX4's 'Q' messages: the system's and the
  airframe's) at its start, every parameter change ('P' in the data section), and every status
  text ('L'); a sync message ('S') whenever 500 ms passed since the last (Logger::run), so
  that a reader can find the next message after damage.
- ``drain()`` hands the shell what to append to which file: (relative path, bytes, closed).
  Paths follow PX4: ``log/<YYYY-MM-DD>/<HH_MM_SS>.ulg`` (UTC) when the boot epoch is known,
  else ``log/sess<NNN>/log<NNN>.ulg``. Without storage (``file_backend=False``, a PX4 without
  its SD card) no file is written and only a stream samples.
- The MAVLink backend (logger.cpp handle_vehicle_command_update, start_log_mavlink): the
  LOGGING_START a link passed on (vehicles/command_journal.py, unanswered) is UNSUPPORTED unless
  param1 rounds to 0 (ULog), TEMPORARILY_REJECTED while a stream runs, else ACCEPTED and the
  stream starts: a header and definitions of its own, sent reliably, then the same samples the
  file gets. LOGGING_STOP: IN_PROGRESS and the stream ends, if one runs; then ACCEPTED. The
  answers go out on every link (``onboard_ack``). The packets: ulog_stream.py. While a reliable
  packet waits for its ack the logger does nothing at all (PX4's logger thread blocks).
- A log or stream that starts while the other runs shares its sampling state: it gets topics
  from their next update on (PX4's one set of subscriptions).
"""

from __future__ import annotations

import hashlib
import logging
import math
import time
from collections.abc import Sequence
from typing import Any

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.telemetry_version import FLIGHT_SW_VERSION
from gateway.mavlink.vehicle_port import VehiclePort
from gateway.onboard import metadata, ulog
from gateway.onboard.logged_topics import (
    EVENT_TOPICS,
    NESTED_FORMATS,
    TOPICS,
    Topic,
    command_ack_values,
    command_values,
    event_values,
    onboard_ack_values,
)
from gateway.onboard.topic import records_of
from gateway.onboard.ulog_stream import MavlinkLogWriter, UlogStreamTopic
from vehicles.params import VOLATILE, ParamType
from vehicles.types import CommandResult, Severity

VER_SW = "CORNET"
VER_SW_RELEASE = FLIGHT_SW_VERSION  # px4_firmware_version(), as AUTOPILOT_VERSION has it
VER_HW = "PX4_SITL"  # px4_board_name() of the SITL build
VER_DATA_FORMAT = 2  # logger.cpp write_version, uint32
SDLOG_OFF, SDLOG_ARMED, SDLOG_BOOT_TO_DISARM, SDLOG_BOOT_TO_SHUTDOWN, SDLOG_AUX1, \
    SDLOG_FIRST_ARM = -1, 0, 1, 2, 3, 4
log = logging.getLogger(__name__)
LEVELS = {s: ord(str(int(s))) for s in Severity}  # syslog digit per MAV_SEVERITY
SYNC = ulog.sync()
SYNC_PERIOD_S = 0.5


def _parameter_defaults(params: Any) -> list[bytes]:
    """logger.cpp write_parameter_defaults: for each parameter that differs from a default, the
    system default (PX4's) and the current setup's (the airframe's and the launch's
    ``param set-default``), as one message when they are equal; volatile ones left out."""
    out = []
    for info, value in params.items():
        if info.name in VOLATILE:
            continue
        is_int = info.type is ParamType.INT32
        system, setup = info.default, params.default_of(info.name)
        if system == setup:
            if value != setup:
                out.append(ulog.parameter_default(
                    info.name, setup, is_int, ulog.DEFAULT_SYSTEM | ulog.DEFAULT_CURRENT_SETUP))
            continue
        if value != setup:
            out.append(ulog.parameter_default(info.name, setup, is_int,
                                              ulog.DEFAULT_CURRENT_SETUP))
        if value != system:
            out.append(ulog.parameter_default(info.name, system, is_int, ulog.DEFAULT_SYSTEM))
    return out


def _int_param(params: Any, name: str, default: int) -> int:
    value = params.get(name, default)
    return default if value is None else int(value)


class _Sample:
    """The vehicle as one sampling instant sees it: each property read once (``status``,
    ``estimator``, ``sensors`` build new objects on every read), shared by the topics."""

    def __init__(self, logger: VehicleLogger) -> None:
        self._vehicle = logger.vehicle
        self.mavlink_links = logger.links  # the MAVLink instances' sessions (module rules)
        self.memo = logger.memo  # what a topic keeps of its last sample (mission_result)

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._vehicle, name)
        setattr(self, name, value)
        return value


class VehicleLogger:
    """One vehicle's logs (module rules)."""

    def __init__(self, vehicle: VehiclePort, boot_unix_s: float | None,
                 topics: Sequence[Topic] = TOPICS, *, file_backend: bool = True) -> None:
        self.vehicle = vehicle
        self.file_backend = file_backend
        self.stream = UlogStreamTopic()  # the link that streams reads it (log_streaming.py)
        self._mavlink = MavlinkLogWriter(self.stream)
        self._scratch = bytearray()  # a sample for the stream alone
        self.boot_unix_s = boot_unix_s
        self.topics = tuple(topics)
        self.links: Sequence[Any] = ()  # the vehicle's MAVLink sessions (module rules)
        self.memo: dict[str, Any] = {}
        # the topics' records, then those of vehicle_command and vehicle_command_ack (every
        # record of the vehicle's command journal) and the events: made once per process
        layout = records_of(self.topics, NESTED_FORMATS, tuple(f for _, f in EVENT_TOPICS))
        self._structs, self._prefixes, packers = layout.structs, layout.prefixes, layout.packers
        self._event_structs, self._event_prefixes = layout.extra_structs, layout.extra_prefixes
        self._command_seq = self._ack_seq = self._log_seq = 0
        self._events = getattr(vehicle, "events", None)  # its EventLog: the `event` topic
        self._event_seq = self._events.latest if self._events is not None else 0
        self._path: str | None = None
        self._buf = bytearray()
        self._out: list[tuple[str, bytes, bool]] = []
        self._due = [0.0] * len(self.topics)
        self._last: list[Sequence[Any] | None] = [None] * len(self.topics)
        self._written_s = [-math.inf] * len(self.topics)  # when each was last written
        self._stepped = [i for i, t in enumerate(self.topics) if t.step is not None]
        self._step_s: list[float | None] = [None] * len(self.topics)  # last step logged
        # what a sample looks up of each topic, with the packer of its data messages: every
        # topic; all but the stepped (when _sample_steps writes those); the stepped
        reads = [(i, t, t.read, packers[i], t.every_s, t.on_change, t.republish_s,
                  bool(t.period_s)) for i, t in enumerate(self.topics)]
        self._reads = tuple(reads)
        self._unstepped_reads = tuple(r for r in reads if r[1].step is None)
        self._steps = tuple((i, t, t.step, packers[i], t.interval_s)
                            for i, t in enumerate(self.topics) if t.step is not None)
        self._params: dict[str, float] = {}
        self._text_seq = 0
        self._sessions = 0
        self._was_armed = False
        self._armed_once = False
        self._booted = False
        self._param_changes: list[tuple[str, float]] = []
        vehicle.params.on_change(self._on_param)
        self.files: list[str] = []  # every log started, oldest first
        self.errors = 0  # samples a topic's reader failed (logged once)
        self.override = False  # ``logger on``: log whatever the arming state
        self._file_bytes = 0  # of the log being written, handed out so far
        self._started_s = 0.0
        self._last_sync_s = 0.0
        self._journal = getattr(vehicle, "commands", None)
        self._handled_seq = self._journal.seq if self._journal is not None else 0

    @property
    def logging(self) -> bool:
        return self._path is not None

    @property
    def current(self) -> str | None:
        """The path of the log being written (relative to the vehicle's root), or None."""
        return self._path

    @property
    def streaming(self) -> bool:
        return self._mavlink.started

    def _on_param(self, name: str, value: float) -> None:
        if self._path is not None or self._mavlink.started:
            self._param_changes.append((name, value))

    def _name(self, now_s: float) -> str:
        if self.boot_unix_s is None:
            self._sessions += 1
            return f"log/sess{self._sessions:03d}/log001.ulg"
        t = time.gmtime(self.boot_unix_s + now_s)
        return f"log/{time.strftime('%Y-%m-%d', t)}/{time.strftime('%H_%M_%S', t)}.ulg"

    def _definitions(self, now_s: float) -> tuple[bytes, bytes]:
        """The file header, and the definitions section with the subscriptions."""
        v = self.vehicle
        sysid = v.params.get("MAV_SYS_ID", 1)
        parts = [ulog.flag_bits(ulog.COMPAT_DEFAULT_PARAMETERS)]
        parts += [ulog.format_message(name, fields) for name, fields in NESTED_FORMATS.items()]
        formats = {t.name: t.fields for t in self.topics}  # one per topic, its instances share it
        parts += [ulog.format_message(name, (("uint64_t", "timestamp"), *fields))
                  for name, fields in formats.items()]
        parts += [ulog.format_message(name, (("uint64_t", "timestamp"), *fields))
                  for name, fields in EVENT_TOPICS]
        parts += [ulog.info("ver_sw", VER_SW), ulog.info("ver_sw_release", VER_SW_RELEASE, unsigned=True),
                  ulog.info("ver_hw", VER_HW), ulog.info("sys_name", "PX4"),
                  ulog.info("sys_mcu", "SITL"), ulog.info("sys_os_name", "Linux"),
                  # Logger::write_version: 2 since lat/lon/alt are doubles (sensor_gps's
                  # latitude_deg…); Flight Review reads vehicle_gps_position by it
                  ulog.info("ver_data_format", VER_DATA_FORMAT, unsigned=True)]
        if _int_param(v.params, "SDLOG_UUID", 1) == 1:
            parts.append(ulog.info("sys_uuid", f"CORNET{int(sysid or 1):04d}"))
        # the local time's offset from UTC in seconds, written whatever the clock
        parts.append(ulog.info("time_ref_utc", _int_param(v.params, "SDLOG_UTC_OFFSET", 0) * 60))
        # Logger::write_events_file: the events metadata, so that Flight Review names the events.
        events_xz = metadata.shared().files["all_events.json.xz"]
        parts += ulog.info_multiple("metadata_events", events_xz)
        parts.append(ulog.info("metadata_events_sha256", hashlib.sha256(events_xz).hexdigest()))
        for param, value in v.params.items():
            parts.append(ulog.parameter(param.name, value, param.type is ParamType.INT32))
        parts += _parameter_defaults(v.params)
        parts += [ulog.add_logged(i, t.name, t.multi_id) for i, t in enumerate(self.topics)]
        parts += [ulog.add_logged(len(self.topics) + k, name)
                  for k, (name, _) in enumerate(EVENT_TOPICS)]
        parts.append(ulog.sync())
        return ulog.header(int(now_s * 1e6)), b"".join(parts)

    def _start(self, now_s: float) -> None:
        self._path = self._name(now_s)
        self.files.append(self._path)
        self._file_bytes = 0
        self._started_s = now_s
        header, definitions = self._definitions(now_s)
        self._buf += header
        self._buf += definitions
        if not self._mavlink.started:
            self._reset_sampling(now_s)

    def _reset_sampling(self, now_s: float) -> None:
        """Nothing was logging: every topic is sampled at once, texts and commands from now."""
        self._due = [now_s] * len(self.topics)
        self._last = [None] * len(self.topics)
        self._written_s = [-math.inf] * len(self.topics)
        self._step_s = [None] * len(self.topics)
        self._param_changes.clear()
        self._text_seq = max((t.seq for t in self._texts(0)), default=self._text_seq)
        journal = self._journal
        self._command_seq = journal.seq if journal is not None else 0
        self._ack_seq = journal.ack_seq if journal is not None else 0
        self._log_seq = journal.log_seq if journal is not None else 0
        if self._events is not None:
            self._event_seq = self._events.latest

    def _start_mavlink(self, now_s: float) -> None:
        """Logger::start_log_mavlink: the stream's own header and definitions, reliably."""
        writer = self._mavlink
        writer.start()
        writer.set_reliable(True, now_s)
        header, definitions = self._definitions(now_s)
        writer.write_raw(header, now_s)
        writer.write(definitions, now_s)
        writer.set_reliable(False, now_s)
        if self._path is None:
            self._reset_sampling(now_s)

    def _handle_commands(self, now_s: float) -> None:
        """LOGGING_START / LOGGING_STOP that a link passed on (module rules)."""
        journal = self._journal
        assert journal is not None
        for record in journal.after(self._handled_seq):
            if record.result is not None:  # answered by the link (no bandwidth, no logger)
                continue
            source = (record.source_system, record.source_component)
            if record.command == M.MAV_CMD_LOGGING_START:
                p1 = record.params[0]
                if not math.isfinite(p1) or int(p1 + 0.5) != 0:
                    result = CommandResult.UNSUPPORTED
                elif self._mavlink.started:
                    result = CommandResult.TEMPORARILY_REJECTED
                else:
                    result = CommandResult.ACCEPTED
                journal.onboard_ack(now_s, record.command, int(result), source)
                if result == CommandResult.ACCEPTED:
                    self._start_mavlink(now_s)
            elif record.command == M.MAV_CMD_LOGGING_STOP:
                if self._mavlink.started:
                    journal.onboard_ack(now_s, record.command, int(CommandResult.IN_PROGRESS),
                                        source)
                    self._mavlink.stop()
                journal.onboard_ack(now_s, record.command, int(CommandResult.ACCEPTED), source)
        self._handled_seq = journal.seq

    def _stop(self) -> None:
        if self._path is not None:
            self._file_bytes += len(self._buf)
            self._out.append((self._path, bytes(self._buf), True))
            self._buf.clear()
            self._path = None

    def _texts(self, after: int) -> list:
        texts = getattr(self.vehicle, "status_texts", None)
        return texts(after) if texts is not None else []

    def tick(self, now_s: float) -> None:
        """Start or stop a log as SDLOG_MODE says; sample what is due (module rules)."""
        writer = self._mavlink
        if writer.blocked:  # waiting for a stream's ack
            writer.poll(now_s)
            if writer.blocked:
                return
        journal = self._journal
        if journal is not None and journal.seq > self._handled_seq:
            self._handle_commands(now_s)
            if writer.blocked:
                return
        if not self.file_backend:
            if writer.started:
                self._sample(now_s, False, _Sample(self))
            return
        mode = self.vehicle.params.get("SDLOG_MODE", SDLOG_ARMED)
        mode = SDLOG_ARMED if mode is None else int(mode)
        view = _Sample(self)
        armed = view.autopilot.commander.armed  # status.armed, without building the status
        boot = not self._booted
        self._booted = True
        if self._path is None:
            if (boot and mode in (SDLOG_BOOT_TO_DISARM, SDLOG_BOOT_TO_SHUTDOWN)) or (
                    armed and not self._was_armed and mode != SDLOG_OFF
                    and not (mode == SDLOG_FIRST_ARM and self._armed_once)):
                self._start(now_s)
        elif self._was_armed and not armed and not self.override and mode in (
                SDLOG_ARMED, SDLOG_BOOT_TO_DISARM, SDLOG_AUX1):
            self._sample(now_s, True, view)
            self._stop()
        self._armed_once = self._armed_once or armed
        self._was_armed = armed
        if self._path is not None or writer.started:
            self._sample(now_s, False, view)

    # --- the console's ``logger on`` / ``off`` / ``status`` ------------------------------------
    def on(self, now_s: float) -> None:
        """Logger::set_arm_override(true): log now, whatever the arming state, until ``off``."""
        self.override = True
        if self._path is None and self.file_backend:
            self._start(now_s)
            self._sample(now_s, False, _Sample(self))

    def off(self, now_s: float) -> None:
        """set_arm_override(false): logging follows SDLOG_MODE again, so an unarmed vehicle's
        log ends (unless SDLOG_MODE logs until shutdown)."""
        self.override = False
        mode = self.vehicle.params.get("SDLOG_MODE", SDLOG_ARMED)
        if (self._path is not None and not self.vehicle.status.armed
                and mode != SDLOG_BOOT_TO_SHUTDOWN):
            self._sample(now_s, True, _Sample(self))
            self._stop()

    def status(self, now_s: float) -> list[str]:
        """Logger::print_status's lines (the file backend; LoggerSubscription is 40 bytes)."""
        n = len(self.topics)
        lines = ["Running in mode: all", f"Number of subscriptions: {n} ({n * 40} bytes)"]
        if self._path is not None:
            kib = (self._file_bytes + len(self._buf)) / 1024.0
            seconds = max(now_s - self._started_s, 1e-6)
            wrote = f"{kib:4.2f} KiB" if kib / 1024.0 < 0.1 else f"{kib / 1024.0:4.2f} MiB"
            lines += ["Full File Logging Running:", f"Log file: ./{self._path}",
                      f"Wrote {wrote} (avg {kib / seconds:5.2f} KiB/s)",
                      "Since last status: dropouts: 0 (max len: 0.000 s), max used buffer: 0 / "
                      "12288 B"]
        if self._mavlink.started:
            lines.append("Mavlink Logging Running (Full log)")
        if self._path is None and not self._mavlink.started:
            lines.append("Not logging")
        return lines

    def _sample(self, now_s: float, force: bool, view: _Sample) -> None:
        us = int(now_s * 1e6)
        buf = self._buf if self._path is not None else self._scratch
        start = len(buf)
        for name, value in self._param_changes:
            info = self.vehicle.params.info(name)
            buf += ulog.parameter(name, value, info.type is ParamType.INT32)
        self._param_changes.clear()
        for text in self._texts(self._text_seq):
            buf += ulog.logged_string(LEVELS.get(text.severity, ulog.LOG_INFO),
                                      int(text.time_s * 1e6), text.text)
            self._text_seq = text.seq
        journal = self._journal
        for m in journal.log_messages_after(self._log_seq) if journal is not None else ():
            buf += ulog.logged_string(ord("0") + m.severity, m.timestamp_us, m.text)  # log_message
            self._log_seq = m.seq
        if journal is not None and journal.seq > self._command_seq:
            command, ack = self._event_structs[:2]
            for record in journal.after(self._command_seq):
                t = int(record.time_s * 1e6)
                buf += self._event_prefixes[0]
                buf += command.pack(t, *command_values(record))
                if record.result is not None:
                    buf += self._event_prefixes[1]
                    buf += ack.pack(t, *command_ack_values(record))
            self._command_seq = journal.seq
        if journal is not None and journal.ack_seq > self._ack_seq:
            ack = self._event_structs[1]
            for onboard in journal.acks_after(self._ack_seq):
                buf += self._event_prefixes[1]
                buf += ack.pack(int(onboard.time_s * 1e6), *onboard_ack_values(onboard))
            self._ack_seq = journal.ack_seq
        events = self._events
        if events is not None and events.latest != self._event_seq:
            st, prefix = self._event_structs[2], self._event_prefixes[2]
            for event in events.after(self._event_seq):
                buf += prefix
                buf += st.pack(int(event.time_s * 1e6), *event_values(event))
            self._event_seq = events.latest
        due, last, written = self._due, self._last, self._written_s
        soon = now_s + 1e-9
        reads = self._unstepped_reads if self._sample_steps(view, force, buf) else self._reads
        for i, topic, read, pack, every_s, on_change, republish_s, fixed_rate in reads:
            # a topic published at a fixed rate has no record but its publications
            if soon < due[i] and (fixed_rate or not force):
                continue
            try:
                values = read(view, us)
                if values is None:  # not published yet
                    continue
                if on_change and values == last[i] and not force and not (
                        republish_s and soon >= written[i] + republish_s):
                    due[i] = now_s + every_s  # looked again after the interval
                    continue
                record = pack(us, *values)
            except Exception:  # a topic that cannot be read is missing, the log goes on
                self.errors += 1
                if self.errors == 1:
                    log.exception("logger: topic %s could not be sampled", topic.name)
                continue
            last[i] = values
            written[i] = now_s
            due[i] = now_s + every_s
            buf += record
        if now_s - self._last_sync_s > SYNC_PERIOD_S:
            buf += SYNC
            self._last_sync_s = now_s
        if self._mavlink.started and len(buf) > start:
            self._mavlink.write(bytes(buf[start:]), now_s)
        if buf is self._scratch:
            buf.clear()

    def _sample_steps(self, view: _Sample, force: bool, buf: bytearray) -> bool:
        """The topics PX4 publishes at the sensors' rate: one record per physics step since the
        last sample, each at its step's time, keeping the topic's interval (logged_topics.py).
        Whether they were written here: not when the vehicle keeps no recent steps."""
        steps = self._steps
        recent = getattr(view, "recent_steps", None)
        if not steps or recent is None:
            return False
        last, due = self._step_s, self._due
        since = [t for t in (last[i] for i in self._stepped) if t is not None]
        after_s = None
        if len(since) == len(steps):
            newest = max(since)  # not asked for: the steps up to it that intervals skip
            after_s = min(newest if not force and newest + 1e-9 < due[i] else t
                          for i, t in zip(self._stepped, since))
        rows = [(t, t + 1e-9, round(t * 1e6), row) for t, row in recent(after_s)]  # time, µs
        for i, topic, step, pack, interval_s in steps:
            after, next_s = last[i], due[i]
            floor = -math.inf if after is None else after + 1e-9  # logged up to here
            for t_s, late_s, us, row in rows:
                if t_s <= floor or (late_s < next_s and not force):
                    continue
                try:
                    buf += pack(us, *step(row, us))
                except Exception:  # as for the other topics: missing, the log goes on
                    self.errors += 1
                    if self.errors == 1:
                        log.exception("logger: topic %s could not be sampled", topic.name)
                    continue
                next_s, after = t_s + interval_s, t_s
            last[i], due[i] = after, next_s
        return True

    def drain(self) -> list[tuple[str, bytes, bool]]:
        """What to append to which file since the last drain: (path, bytes, closed)."""
        out = self._out
        self._out = []
        if self._path is not None and self._buf:
            self._file_bytes += len(self._buf)
            out.append((self._path, bytes(self._buf), False))
            self._buf.clear()
        return out

    def close(self) -> list[tuple[str, bytes, bool]]:
        """Shutdown: the log in progress ends."""
        self._stop()
        return self.drain()
