"""The loggers of every vehicle of a Simulation, and the files they write (the shell around
logger.py).

Rules:
- Each vehicle's logs go under each of its roots (``roots_for(sysid)``: the state dir's and the
  run's ``vehicle-<sysid>``), at PX4's paths (``log/<date>/<time>.ulg``), like a PX4 SITL
  instance's rootfs.
- The loggers tick at 50 Hz of simulated time; their bytes are appended to the files every
  simulated second and at ``close`` (a crash loses at most the last second, as flightlog.py).
- Without storage (``storage=False``) the loggers write no file but still stream: every link of
  a vehicle gets its logger's ulog_stream (gateway/mavlink/log_streaming.py), and the link that
  streams is woken when a tick published packets. The log list is empty (``NoStorage``), and
  the first request for it says in the daemon's log which flags keep logs.
- ``LogFiles`` is what a vehicle's log handler (gateway/mavlink/log_handler.py) reads: every
  ``.ulg`` under its first root's ``log/`` (earlier runs' too, as PX4 lists its SD card), oldest
  first, dated by their path (``<date>/<time>.ulg``; ``sess<N>/log<M>.ulg``: N days and M
  minutes after 1970, PX4's rule); erasing spares the log being written.
"""

from __future__ import annotations

import calendar
import logging
import re
import time
from collections.abc import Callable
from pathlib import Path

from gateway.onboard.logger import VehicleLogger
from gateway.sim.simulation import Simulation, VehicleLink

log = logging.getLogger(__name__)

TICK_S = 0.02
FLUSH_S = 1.0


class Logs:
    def __init__(self, sim: Simulation, roots_for: Callable[[int], list[Path]],
                 boot_unix_s: float | None, *, storage: bool = True) -> None:
        self.roots_for = roots_for
        self.loggers: dict[int, VehicleLogger] = {}
        for vehicle in sim.vehicles:
            sysid = int(vehicle.params.get("MAV_SYS_ID", 1) or 1)
            self.loggers[sysid] = VehicleLogger(vehicle, boot_unix_s, file_backend=storage)
        self._failed = False
        self.told_no_storage = False  # NoStorage's hint, once per daemon
        self._links: dict[int, list[VehicleLink]] = {}
        for link in sim.links.values():
            sysid = link.session.sysid
            if sysid in self.loggers:
                link.session.logs.store = LogFiles(self, sysid) if storage else NoStorage(self)
                link.session.log_streaming.topic = self.loggers[sysid].stream
                self._links.setdefault(sysid, []).append(link)
        for sysid, links in self._links.items():  # PX4's mavlink instances: telemetry_status
            self.loggers[sysid].links = tuple(link.session for link in links)
        sim.every(TICK_S, self._tick)
        sim.every(FLUSH_S, lambda now: self.flush())

    def set_epoch(self, boot_unix_s: float) -> None:
        """Simulated t = 0 is the Unix time ``boot_unix_s``: the logs' names (PX4 names them by
        the real-time clock)."""
        for logger in self.loggers.values():
            if logger.boot_unix_s is not None:
                logger.boot_unix_s = boot_unix_s

    def _tick(self, now_s: float) -> None:
        for sysid, logger in self.loggers.items():
            stream = logger.stream
            published = stream.generation
            logger.tick(now_s)
            if stream.generation != published and stream.owner is not None:
                for link in self._links.get(sysid, ()):
                    if link.session.log_streaming is stream.owner:
                        link.service()  # its next deadline: the packets

    def _write(self, sysid: int, chunks: list[tuple[str, bytes, bool]]) -> None:
        for rel, data, _closed in chunks:
            for root in self.roots_for(sysid):
                path = root / rel
                try:
                    path.parent.mkdir(parents=True, exist_ok=True)
                    with open(path, "ab") as f:
                        f.write(data)
                except OSError as exc:
                    if not self._failed:
                        log.error("cannot write the log %s: %s (logging goes on elsewhere)",
                                  path, exc)
                        self._failed = True

    def flush(self) -> None:
        for sysid, logger in self.loggers.items():
            self._write(sysid, logger.drain())

    def close(self) -> None:
        for sysid, logger in self.loggers.items():
            self._write(sysid, logger.close())


_DATED = re.compile(r"(\d{4}-\d{2}-\d{2})/(\d{2}_\d{2}_\d{2})\.ulg$")
_SESSION = re.compile(r"sess(\d+)/log(\d+)\.ulg$")


class NoStorage:
    """The log list of a vehicle without storage: empty, as PX4's without an SD card. The first
    request says, in the daemon's log, how to keep the logs."""

    def __init__(self, logs: Logs) -> None:
        self.logs = logs

    def entries(self) -> list[tuple[int, int]]:
        if not self.logs.told_no_storage:
            self.logs.told_no_storage = True
            log.warning("a client asked for the vehicles' logs, and there are none: without "
                        "--state-dir DIR or --log-dir DIR the vehicles keep no ULog files "
                        "(PX4 without its SD card); start with one of them to download logs")
        return []

    def read(self, index: int, offset: int, count: int) -> bytes:
        return b""

    def erase(self) -> None:
        pass


def log_time_utc(path: Path) -> int:
    """A log's start, UTC seconds, from its path (module rules); 0 if it tells none."""
    text = path.as_posix()
    if m := _DATED.search(text):
        return calendar.timegm(time.strptime(f"{m[1]} {m[2]}", "%Y-%m-%d %H_%M_%S"))
    if m := _SESSION.search(text):
        return int(m[1]) * 86400 + int(m[2]) * 60
    return 0


class LogFiles:
    """One vehicle's logs as its log handler sees them (module rules)."""

    def __init__(self, logs: Logs, sysid: int) -> None:
        self.logs = logs
        self.sysid = sysid
        self._files: list[Path] = []

    def _root(self) -> Path | None:
        roots = self.logs.roots_for(self.sysid)
        return roots[0] / "log" if roots else None

    def entries(self) -> list[tuple[int, int]]:
        self.logs.flush()  # what was logged so far is in the files
        root = self._root()
        files = sorted(root.rglob("*.ulg"), key=lambda p: (log_time_utc(p), p.as_posix())) \
            if root is not None and root.is_dir() else []
        self._files = files
        out = []
        for path in files:
            try:
                out.append((path.stat().st_size, log_time_utc(path)))
            except OSError:
                out.append((0, log_time_utc(path)))
        return out

    def read(self, index: int, offset: int, count: int) -> bytes:
        if not 0 <= index < len(self._files):
            return b""
        try:
            with open(self._files[index], "rb") as f:
                f.seek(offset)
                return f.read(count)
        except OSError:
            return b""

    def erase(self) -> None:
        root = self._root()
        if root is None or not root.is_dir():
            return
        logger = self.logs.loggers[self.sysid]
        active = root.parent / logger.current if logger.current is not None else None
        for path in root.rglob("*.ulg"):
            if path != active:
                try:
                    path.unlink()
                except OSError as exc:
                    log.warning("cannot erase the log %s: %s", path, exc)
        self._files = []
