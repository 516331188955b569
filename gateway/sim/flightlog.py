"""Flight logs of one run: per-link ``.tlog``, a vehicle-state CSV, the packet trace, ``meta.json``.

One directory per run (``new_run_dir`` names one under a base directory):

    meta.json         what ran: vehicles (sysid, EKF origin, spawn offset), home, boot epoch, network
    v<i>-gcs.tlog     every MAVLink frame on vehicle i's GCS link, both directions (QGC/MAVProxy
    v<i>-api.tlog     format: 8-byte big-endian µs Unix timestamp + the raw frame, one per frame)
    v<i>-<radio>.tlog the same for each extra radio's link (gateway/sim/radios.py)
    state.csv         every vehicle at a fixed simulated rate (STATE_COLUMNS)
    packets.trace     the network's log (time event link size detail; one instant's lines vehicle by vehicle)

A shard of a sharded daemon (gateway/daemon/shard/) writes its own vehicles' tlogs and its
part of the rest as ``meta.json.shard<k>``, ``state.csv.shard<k>``, ``packets.trace.shard<k>``
(``part=k``); ``merge_parts`` makes them the files one process writes, once every shard is done.

How it is wired (the tracer must exist before the Simulation, which takes it at construction):

    flog = FlightLog(run_dir, boot_unix_s=...)
    sim = Simulation(n, network, tracer=flog.tracer)       # or fan it out with other tracers
    flog.attach(sim)                                       # meta.json, state sampling, flushing
    flog.record_datagram("up", i, kind, datagram, sim.now)   # where a client datagram enters
    flog.record_datagram("down", i, kind, datagram, sim.now) # in sim.on_downlink
    flog.close()                                           # on stop (flushes)

Rules and invariants:
- Timestamps are ``boot_unix_s + simulated time`` (in whole µs: the epoch's, plus the simulated
  time's): no wall clock is read here, so a lockstep run
  with a fixed epoch writes byte-identical files (the daemon passes its wall-clock start).
- The tlog records what the client sees: uplink frames when the client sends them (before the
  simulated network), downlink frames when the network delivers them. A datagram may hold several
  frames; they are split with the MAVLink length fields and garbage between frames is skipped.
- Everything is flushed every ``flush_period_s`` of simulated time (1 s) and on ``close``, so a
  crash loses at most the last second.
"""

from __future__ import annotations

import csv
import io
import json
import logging
import math
import os
import struct
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

from gateway.sim.files import write_atomic
from gateway.sim.radios import LinkTag, tag_name
from netsim.link import InstantSortedTrace

if TYPE_CHECKING:
    from gateway.sim.simulation import Simulation

log = logging.getLogger(__name__)

STATE_PERIOD_S = 0.1  # 10 Hz state log
FLUSH_PERIOD_S = 1.0  # a crash loses at most this much simulated time of logs
TRACE_FILE = "packets.trace"
STATE_FILE = "state.csv"
META_FILE = "meta.json"
UP, DOWN = "up", "down"

MAGIC_V1 = 0xFE
MAGIC_V2 = 0xFD
_TLOG_STAMP = struct.Struct(">Q")

STATE_COLUMNS = (
    "t_s", "sysid",
    "n_world_m", "e_world_m", "d_world_m",  # world frame: NED from the world's home
    "n_m", "e_m", "d_m",  # local frame: NED from the vehicle's EKF origin (its spawn point)
    "vn_mps", "ve_mps", "vd_mps",
    "roll_rad", "pitch_rad", "yaw_rad",
    "mode", "armed", "landed_state",
    "battery_remaining", "battery_v",
    "sp_n_m", "sp_e_m", "sp_d_m",  # the position setpoint (trajectory carrot), empty if idle
    "mission_seq", "mission_state",
)


def part_name(name: str, part: int | None) -> str:
    """A shard's part of a file that holds every vehicle (merged by ``merge_parts``)."""
    return name if part is None else f"{name}.shard{part}"


def link_vehicle(link: str) -> int:
    """The vehicle number a link's name starts with (``v12/gcs/up``: 12), 0 if none. The packet
    trace's lines of one instant come vehicle by vehicle (``InstantSortedTrace``), so that a
    sharded run's merged trace is the one one process writes (gateway/sim/logparts.py)."""
    head = link.split("/", 1)[0]
    return int(head[1:]) if head[:1] == "v" and head[1:].isdigit() else 0


def tlog_name(index: int, kind: LinkTag) -> str:
    return f"v{index + 1}-{tag_name(kind)}.tlog"


def split_frames(datagram: bytes) -> list[bytes]:
    """The MAVLink 1/2 frames in a datagram, by their length fields (CRC not checked).

    Bytes that do not start a frame are skipped; a truncated last frame is dropped.
    """
    n = len(datagram)
    if n > 2 and datagram[0] == MAGIC_V2 and n == 12 + datagram[1] + (
            13 if datagram[2] & 1 else 0):
        return [datagram[:]]  # one MAVLink 2 frame, as PX4 sends every message
    out = []
    i = 0
    while i < n:
        magic = datagram[i]
        if magic == MAGIC_V2 and i + 3 <= n:
            size = 12 + datagram[i + 1] + (13 if datagram[i + 2] & 1 else 0)
        elif magic == MAGIC_V1 and i + 2 <= n:
            size = 8 + datagram[i + 1]
        else:
            i += 1
            continue
        if i + size > n:
            break
        out.append(datagram[i:i + size])
        i += size
    return out


def frame_msgid(frame: bytes) -> int:
    if frame[0] == MAGIC_V2:
        return frame[7] | (frame[8] << 8) | (frame[9] << 16)
    return frame[5]


def frame_source(frame: bytes) -> tuple[int, int]:
    """(sysid, compid) of the sender."""
    if frame[0] == MAGIC_V2:
        return frame[5], frame[6]
    return frame[3], frame[4]


def read_tlog(path: str | Path) -> Iterator[tuple[float, bytes]]:
    """(unix time s, frame) for every record of a tlog written here."""
    data = Path(path).read_bytes()
    i, n = 0, len(data)
    while i + 9 <= n:
        (stamp_us,) = _TLOG_STAMP.unpack_from(data, i)
        frames = split_frames(data[i + 8:i + 8 + 280])
        if not frames:
            break
        yield stamp_us * 1e-6, frames[0]
        i += 8 + len(frames[0])


def new_run_dir(base: str | Path, name: str) -> Path:
    """``base/name`` (``name-2``, ``name-3`` … if taken), created: one directory per run.

    The shell passes a wall-clock name (e.g. ``run-20261122-101500``); lockstep runs a fixed one.
    """
    base = Path(base)
    base.mkdir(parents=True, exist_ok=True)
    path, k = base / name, 1
    while True:
        try:
            path.mkdir()
            return path
        except FileExistsError:
            k += 1
            path = base / f"{name}-{k}"


def _f(x: float, digits: int = 4) -> str:
    return "" if math.isnan(x) else f"{x:.{digits}f}"


class FlightLog:
    def __init__(self, log_dir: str | Path, *, boot_unix_s: float = 0.0,
                 state_period_s: float = STATE_PERIOD_S,
                 flush_period_s: float = FLUSH_PERIOD_S, part: int | None = None) -> None:
        self.dir = Path(log_dir)
        self.part = part
        self.dir.mkdir(parents=True, exist_ok=True)
        self.boot_unix_s = boot_unix_s
        # A record's stamp is this plus the simulated time in µs: two runs of one flight differ
        # in their tlogs' stamps by their epochs' difference only.
        self._boot_us = int(round(boot_unix_s * 1e6))
        self.state_period_s = state_period_s
        self.flush_period_s = flush_period_s
        self._trace_file = open(self.dir / part_name(TRACE_FILE, part), "w", encoding="ascii", newline="\n")
        self.tracer = InstantSortedTrace(self._trace_file, link_vehicle)
        self._tlogs: dict[tuple[int, LinkTag], BinaryIO] = {}
        self._recorders: dict[tuple[str, int, LinkTag],
                              Callable[[Sequence[bytes], float], None]] = {}
        self._state_file: io.TextIOWrapper | None = None
        self._state_csv: Any = None  # a csv.writer (the type csv does not export)
        self._sim: Simulation | None = None
        self._extra_meta: dict = {}
        self._tickers: list = []
        self.frames = {UP: 0, DOWN: 0}
        self.closed = False

    def set_epoch(self, boot_unix_s: float) -> None:
        """Simulated t = 0 is the Unix time ``boot_unix_s`` (stamped by the shell when time
        starts): the stamps of every record from now on and meta.json's ``boot_unix_s``."""
        self.boot_unix_s = boot_unix_s
        self._boot_us = int(round(boot_unix_s * 1e6))
        if self._sim is not None:
            self._write_meta(self._sim, self._extra_meta)

    # --- wiring -------------------------------------------------------------------------------
    def attach(self, sim: Simulation, extra_meta: dict | None = None) -> None:
        """Write meta.json, start the state log and the periodic flush on ``sim``'s clock."""
        self._sim = sim
        self._extra_meta = extra_meta or {}
        self._write_meta(sim, self._extra_meta)
        self._state_file = open(self.dir / part_name(STATE_FILE, self.part), "w",
                                encoding="ascii", newline="")
        self._state_csv = csv.writer(self._state_file, lineterminator="\n")
        self._state_csv.writerow(STATE_COLUMNS)
        for i, kind in sim.links:
            self._tlog(i, kind)
        self._tickers = [sim.every(self.state_period_s, self._sample),
                         sim.every(self.flush_period_s, lambda now: self.flush())]

    def _write_meta(self, sim: Simulation, extra: dict) -> None:
        home = getattr(sim.world, "home", None)
        vehicles = []
        for i, v in zip(sim.indices, sim.vehicles):
            n0, e0 = sim.world.spawn_offset_ned_m(v.index)
            vehicles.append({"index": i, "sysid": int(v.params["MAV_SYS_ID"]),
                             "origin": [v.origin.lat_deg, v.origin.lon_deg, v.origin.alt_amsl_m],
                             "spawn_ned_m": [n0, e0],
                             "tlogs": [tlog_name(i, k) for k in sim.link_tags]})
        meta = {"format": "cornet-flightlog/1", "boot_unix_s": self.boot_unix_s,
                "state_period_s": self.state_period_s,
                "home": None if home is None else [home.lat_deg, home.lon_deg, home.alt_amsl_m],
                "network": sim.network.summary, "seed": sim.network.seed,
                "vehicles": vehicles,
                "faults": [{"at_s": f.at_s, "fault": f.describe()}
                           for f in getattr(sim, "faults", ())], **extra}
        write_atomic(self.dir / part_name(META_FILE, self.part),
                     json.dumps(meta, indent=1, sort_keys=True) + "\n")

    def _tlog(self, index: int, kind: LinkTag) -> BinaryIO:
        f = self._tlogs.get((index, kind))
        if f is None:
            f = open(self.dir / tlog_name(index, kind), "wb")
            self._tlogs[(index, kind)] = f
        return f

    # --- hooks --------------------------------------------------------------------------------
    def record_datagram(self, direction: str, index: int, kind: LinkTag, datagram: bytes,
                        t: float) -> None:
        """A datagram the client sent (``"up"``) or received (``"down"``) at simulated ``t``."""
        key = (direction, index, kind)
        record = self._recorders.get(key)
        if record is None:
            record = self._recorders[key] = self.recorder(direction, index, kind)
        record(split_frames(datagram), t)

    def recorder(self, direction: str, index: int, kind: LinkTag
                 ) -> Callable[[Sequence[bytes], float], None]:
        """``record_datagram`` bound to one link and direction, for those who record every
        datagram of a link: ``record(frames, t)``, with the datagram's ``split_frames``."""
        write = self._tlog(index, kind).write
        stamp_of = _TLOG_STAMP.pack
        counts = self.frames
        # the frames of one instant share their stamp (of one epoch: set_epoch may come at t = 0)
        last_t, last_boot_us, stamp = math.nan, 0, b""

        def record(frames: Sequence[bytes], t: float) -> None:
            nonlocal last_t, last_boot_us, stamp
            if self.closed:
                return
            boot_us = self._boot_us
            if t != last_t or boot_us != last_boot_us:
                last_t, last_boot_us = t, boot_us
                stamp = stamp_of(boot_us + round(t * 1e6))
            for frame in frames:
                write(stamp)
                write(frame)
            counts[direction] += len(frames)

        return record

    def record_frame(self, direction: str, index: int, kind: LinkTag, frame: bytes,
                     t: float) -> None:
        """One already-split frame (see ``record_datagram``)."""
        if self.closed:
            return
        f = self._tlog(index, kind)
        f.write(_TLOG_STAMP.pack(self._boot_us + round(t * 1e6)))
        f.write(frame)
        self.frames[direction] += 1

    def _sample(self, now: float) -> None:
        sim, w = self._sim, self._state_csv
        if sim is None or w is None:
            return
        world = sim.vehicle_positions_ned_m()
        for i, v in zip(sim.indices, sim.vehicles):
            st, status = v.state, v.status
            p, vel = st.position_ned_m, st.velocity_ned_mps
            roll, pitch, yaw = st.euler_rad()
            wn, we, wd = world[f"v{i + 1}"]
            sp = v.position_setpoint_ned_m or (math.nan,) * 3
            ms = getattr(v, "mission_status", None)
            bat = status.battery
            w.writerow((f"{now:.3f}", int(v.params["MAV_SYS_ID"]), _f(wn), _f(we), _f(wd),
                        _f(p[0]), _f(p[1]), _f(p[2]), _f(vel[0]), _f(vel[1]), _f(vel[2]),
                        _f(roll), _f(pitch), _f(yaw), status.nav_state.name, int(status.armed),
                        status.landed_state.name, _f(bat.remaining, 3), _f(bat.voltage_v, 3),
                        _f(sp[0]), _f(sp[1]), _f(sp[2]),
                        "" if ms is None else ms.current_seq,
                        "" if ms is None else ms.state.name))

    # --- lifetime -----------------------------------------------------------------------------
    def flush(self) -> None:
        if self.closed:
            return
        self.tracer.flush()
        self._trace_file.flush()
        for f in self._tlogs.values():
            f.flush()
        if self._state_file is not None:
            self._state_file.flush()

    def sync(self) -> None:
        """Flush and fsync every log file: what is written survives a power loss, not only a
        crash of the process (the daemon calls it every few wall seconds)."""
        if self.closed:
            return
        self.flush()
        files = [self._trace_file, *self._tlogs.values(), self._state_file]
        for f in files:
            if f is not None:
                os.fsync(f.fileno())

    def close(self) -> None:
        if self.closed:
            return
        for ticker in self._tickers:
            ticker.cancel()
        self._tickers = []
        self.flush()
        self.closed = True
        self._trace_file.close()
        for f in self._tlogs.values():
            f.close()
        if self._state_file is not None:
            self._state_file.close()

    def __enter__(self) -> FlightLog:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def resolve_run_dir(log_dir: str | Path) -> Path:
    """``log_dir`` if it holds meta.json, else its newest run sub-directory (by name)."""
    path = Path(log_dir)
    if (path / META_FILE).is_file():
        return path
    runs = sorted(p for p in path.iterdir() if (p / META_FILE).is_file()) if path.is_dir() else []
    if not runs:
        raise FileNotFoundError(f"{path}: no flight log here (no {META_FILE}, nor in a "
                                "sub-directory)")
    return runs[-1]
