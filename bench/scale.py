#!/usr/bin/env python3
"""How far does one daemon scale? N vehicles side by side, measured in one run (issue 7).

For each N (default 1, 10, 30, 100, 200), `cornet run --vehicles N [--shards K]` is started as a
user starts it (embedded ideal network, no --zmq-pub), and, for ``--seconds`` wall seconds after
a warm-up:

- real-time factor: simulated seconds per wall second, from the vehicles' own telemetry. A
  separate listener process drains the GCS client port 14550+offset and the API client ports
  14540..14549+offset (vehicles past the tenth all send to 14549, PX4's scheme) in batches (a
  2 ms nap between passes keeps its own CPU small) and walks the MAVLink 2 frames of every
  datagram it receives: per sysid, simulated time from ATTITUDE's time_boot_ms, the armed flag
  from HEARTBEAT, the altitude from GLOBAL_POSITION_INT. Every 20 ms it hands the parent the
  minimum simulated time across all N vehicles (shards may be up to 1.5 sync periods apart; the
  slowest counts), stamped with its own wall clock; the factor is the least-squares slope of
  that minimum against wall time over the window. Below 0.99 the table says the daemon cannot
  keep up (its pacer lets simulated time slip; it never bursts to catch up);
- CPU per vehicle-second: the daemon's CPU time (utime + stime from /proc, over the process and
  its descendants, so a sharded daemon's workers count) over the window / (N x simulated
  seconds in the window), and that as a multiple of the physics floor: one PyBullet DIRECT world
  with N boxes on the daemon's spawn grid (5 m apart, so they never touch), each getting
  applyExternalForce + applyExternalTorque every 4 ms step, CPU seconds per simulated second
  / N, measured in this run. The listener's own CPU (it shares the machine) goes to the CSV;
- the wire's floor under that: PX4 sends every message in a datagram of its own (one
  ``sendto`` per message, mavlink_main.cpp), and the kernel charges each ``sendto`` to the
  sender. After the window the parent sends the daemon's mean datagram to the listener's GCS
  port (5,000 of them, in bursts of 100 with the listener's nap between) and times its own
  thread's CPU; that per-datagram cost times the daemon's datagrams per vehicle-second is
  what the sends alone cost, whatever the daemon does in Python ("UDP sends alone");
- memory: VmRSS summed over the daemon's processes, and (RSS at N - RSS at 1) / (N - 1) per
  vehicle (a sharded point counts K interpreters more than the baseline: a coordinator and
  K workers against one process);
- datagrams/s out of the daemon, as received by the listener plus vehicle 1's API stream at the
  ping client. PX4 SITL streams to these ports unasked, so the traffic is the real one.
  Datagrams the listeners' own sockets dropped (/proc/net/udp) are reported;
- gateway-added latency: a client process sends PING (target 0/0: the request form that
  gateway/mavlink/ping.py answers, as PX4 does; a PING addressed to a system is treated as a
  reply and ignored) to vehicle 1's API port 14580+offset from its own socket, up to 200 at
  20 Hz during the window, and times the round trip to the reply with the same seq and
  time_usec. PING rather than TIMESYNC: both are answered on the same path, and PING echoes the
  client's own seq and timestamp, so a reply cannot be mistaken. Each ping waits for its reply
  (stop-and-wait, 5 s at most) so that a slow daemon is measured, not buried under a backlog.
  Interleaved with those (same process, same code), the same frames go to a plain UDP echo
  process on loopback: p50/p99 of both round trips and their difference.

With ``--mavsdk [EXAMPLE]``, at the largest vehicle count vehicle 1 stays on the ground and the
unmodified MAVSDK example gcs_examples/EXAMPLE.py (takeoff_and_land by default, or mission: upload,
fly and return; MAVSDK-Python 3.x with its mavsdk_server)
flies it from vehicle 1's API client port, started with the measurement window, while every
other vehicle flies; the table's notes say PASS or FAIL and how long it took (the ping client
then pings vehicle 2, so that the two clients do not share a link).

With ``--scenario FILE`` every point runs ``cornet run --scenario FILE --vehicles N``: the paper's
case of many vehicles through the real ns-3 is ``--vehicles 30 --scenario ns3-wifi``
(every datagram of every vehicle through ns-3's 802.11 at exact time); the notes give the ns-3
engine's CPU beside the daemon's, and say when ns-3 could not keep exact time (the backend's
fallback to its pipeline).

Shards: ``--shards auto`` (the default) runs 1 shard below 50 vehicles and min(2, cores) from
50 on; a comma-separated list gives K per entry of ``--vehicles``. K > 1 adds ``--shards K`` to
the command line. The helper processes are bound to the daemon's client ports before the daemon
starts, so "first HEARTBEAT" is the wall time from starting the daemon process to the
listener's receiving the first HEARTBEAT of any vehicle; launch time is the wall time from
starting it to its ready line.

With ``--flying`` (the default) every vehicle is armed and takes off first (COMMAND_LONG
MAV_CMD_COMPONENT_ARM_DISARM then MAV_CMD_NAV_TAKEOFF to the default takeoff altitude, sent by
the listener from the vehicle's API client port once every vehicle's simulated time is past the
position estimate's start-up, and measured once the telemetry shows every vehicle armed and at
least 1 m up; the table gives how long that took), so the whole autopilot runs; ``--idle``
leaves the vehicles on the ground (PX4 SITL streams the same telemetry there). Each daemon is
stopped with SIGTERM and must exit 0; every wait is bounded.

    .venv/bin/python bench/scale.py [--vehicles 1,10,30,100,200] [--shards auto|K,K,...]
                                    [--seconds 20] [--idle | --mavsdk [EXAMPLE]]
                                    [--scenario FILE]
                                    [--out bench/results]

Prints a markdown table and writes scale-<date>-<time>.csv and .png (real-time factor and
CPU per vehicle-second against N) to ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import math
import multiprocessing as mp
import os
import platform
import queue
import re
import select
import socket
import struct
import subprocess
import sys
import threading
import time
from dataclasses import asdict, dataclass, field
from multiprocessing.pool import ThreadPool
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink2  # noqa: E402

from gateway.ci.launcher import CornetDaemon, start_daemon  # noqa: E402
from gateway.ci.ports import (  # noqa: E402
    API_CLIENT_PORT,
    GCS_CLIENT_PORT,
    VEHICLE_API_PORT,
    free_port_offset,
)

# PyBullet (and gateway.sim, vehicles.physics) are imported where used: the helper processes are
# started with "spawn", which re-imports this module, and they need neither.

KEEPS_UP_RTF = 0.99  # the pacer holds 1.000 when it keeps up; below this it is slipping
WARMUP_S = 3.0  # wall seconds after the vehicles fly (or after ready, idle) before measuring
WARMUP_SIM_S = 2.0  # ... and at least this simulated time since boot (position estimate valid)
ARM_AFTER_SIM_S = 1.5  # PX4's position estimate is valid after ~1 s: arming before is denied
MAVSDK_TIMEOUT_S = 240.0  # wall seconds for the MAVSDK takeoff-and-land example (--mavsdk)
FLY_TIMEOUT_S = 300.0  # wall seconds to get every vehicle armed and off the ground
FLYING_REL_ALT_M = 1.0  # takeoff goes to MIS_TAKEOFF_ALT (2.5 m); past this it is flying
# Arm + takeoff go once to each vehicle, again only if no vehicle armed for this long: an
# overloaded daemon takes its incoming datagrams slowly, and re-sending would only queue more.
RESEND_AFTER_S = 10.0
HELPER_START_TIMEOUT_S = 20.0
LAUNCH_TIMEOUT_S = 60.0  # to the ready line (a sharded daemon waits up to 60 s for its workers)
SHARDS_FROM_VEHICLES = 50  # --shards auto: one shard below this many vehicles, else two
MAX_AUTO_SHARDS = 2
PING_COUNT = 200
PING_HZ = 20.0
PING_REPLY_TIMEOUT_S = 5.0  # a reply later than this counts as lost
BARE_BODY_SECONDS = 400.0  # bodies x simulated seconds stepped for the physics floor
RCVBUF_BYTES = 8 << 20
CLIENT_SYSID, CLIENT_COMPID = 255, 190  # a GCS-like source (MAV_COMP_ID_MISSIONPLANNER)
MSG_ID_PING = 4
MSG_ID_HEARTBEAT, MSG_ID_ATTITUDE, MSG_ID_GLOBAL_POSITION_INT = 0, 30, 33
MAV_COMP_ID_AUTOPILOT1 = 1
MAV_MODE_FLAG_SAFETY_ARMED = 0x80
PUBLISH_PERIOD_S = 0.02  # the listener hands its telemetry to the parent this often
# The listener sleeps this long after each pass over its sockets, so datagrams arrive in batches:
# a wake-up per datagram burst costs it several times the CPU of the receiving and parsing (its
# sockets' buffers hold far more than a pass's worth).
LISTENER_NAP_S = 0.002
SAMPLE_PERIOD_S = 0.05  # the parent samples the minimum simulated time this often
_U32 = struct.Struct("<I").unpack_from
_I32 = struct.Struct("<i").unpack_from


# --- the physics floor ----------------------------------------------------------------------------
def bare_pybullet_cpu_per_body_sim_s(n: int) -> float:
    """CPU seconds per simulated second per body for N bodies (bench/floor.py), stepped long
    enough to measure: BARE_BODY_SECONDS of body-time, 5 to 60 simulated seconds."""
    from bench.floor import bare_pybullet_cpu_per_body_sim_s as floor

    return floor(n, min(max(BARE_BODY_SECONDS / n, 5.0), 60.0))


def _stat_fields(pid: int) -> list[str]:
    with open(f"/proc/{pid}/stat") as f:
        return f.read().rpartition(")")[2].split()  # fields from 3 (state) on


def process_tree(pid: int) -> set[int]:
    """``pid`` and its live descendants (a sharded daemon's workers are its children)."""
    parents: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                parents[int(entry)] = int(_stat_fields(int(entry))[1])
            except (OSError, IndexError, ValueError):
                pass
    tree, grew = {pid}, True
    while grew:
        more = {p for p, pp in parents.items() if pp in tree} - tree
        tree |= more
        grew = bool(more)
    return tree


def tree_cpu_s(pid: int) -> float:
    """utime + stime of ``pid`` and its live descendants, plus its reaped children's times."""
    tick = os.sysconf("SC_CLK_TCK")
    total = 0
    for p in process_tree(pid):
        try:
            f = _stat_fields(p)
        except OSError:
            continue
        total += int(f[11]) + int(f[12]) + (int(f[13]) + int(f[14]) if p == pid else 0)
    return total / tick


def rss_bytes(pid: int) -> int:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError(f"no VmRSS for pid {pid}")


def tree_rss_bytes(pid: int) -> int:
    """VmRSS summed over ``pid`` and its live descendants (pages they share count more than
    once; spawned workers share little)."""
    total = 0
    for p in process_tree(pid):
        try:
            total += rss_bytes(p)
        except (OSError, RuntimeError):
            pass
    return total


def udp_drops(ports: set[int]) -> int:
    """Datagrams the kernel dropped at the local UDP sockets bound to ``ports``."""
    total = 0
    with open("/proc/net/udp") as f:
        next(f)
        for line in f:
            cols = line.split()
            if int(cols[1].rpartition(":")[2], 16) in ports:
                total += int(cols[-1])
    return total


# --- helper processes -------------------------------------------------------------------------------
def _client_socket(port: int = 0) -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RCVBUF_BYTES)
    s.bind(("127.0.0.1", port))
    s.setblocking(False)
    return s


def _takeoff_datagram(mav: mavlink2.MAVLink, sysid: int) -> bytes:
    arm = mav.command_long_encode(sysid, 1, mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                                  1, 0, 0, 0, 0, 0, 0)
    takeoff = mav.command_long_encode(sysid, 1, mavlink2.MAV_CMD_NAV_TAKEOFF, 0,
                                      -1, 0, 0, math.nan, math.nan, math.nan, math.nan)
    return arm.pack(mav) + takeoff.pack(mav)


def read_telemetry(buf: bytearray, n: int, sim_t: list[float], armed: list[int],
                   rel_alt: list[float]) -> bool:
    """Walk the MAVLink 2 frames of one datagram (``buf[:n]``, frames concatenated) and note,
    by sysid: simulated time from ATTITUDE's time_boot_ms, the armed flag from the autopilot's
    HEARTBEAT base_mode, relative_alt from GLOBAL_POSITION_INT. MAVLink 2 trims a payload's
    trailing zeros, so a short payload reads as zero-padded. CRC and signature are not checked;
    the walk stops at a byte that does not start a MAVLink 2 frame. Returns the sysid of an
    autopilot HEARTBEAT among the frames (PX4 sends each message in a datagram of its own), else
    0."""
    heartbeat = 0
    i = 0
    while i + 10 <= n and buf[i] == 0xFD:
        length = buf[i + 1]
        start = i + 10
        end = start + length
        if end > n:
            break
        if not (buf[i + 8] or buf[i + 9]):  # the three message ids fit in the low byte
            msg_id = buf[i + 7]
            if msg_id == MSG_ID_ATTITUDE:
                ms = (_U32(buf, start)[0] if length >= 4
                      else _U32(bytes(buf[start:end]).ljust(4, b"\0"))[0])
                sim_t[buf[i + 5]] = ms / 1e3
            elif msg_id == MSG_ID_HEARTBEAT and buf[i + 6] == MAV_COMP_ID_AUTOPILOT1:
                armed[buf[i + 5]] = (1 if length > 6 and buf[start + 6] & MAV_MODE_FLAG_SAFETY_ARMED
                                     else 0)
                heartbeat = buf[i + 5]
            elif msg_id == MSG_ID_GLOBAL_POSITION_INT:
                mm = (_I32(buf, start + 16)[0] if length >= 20
                      else _I32(bytes(buf[start:end]).ljust(20, b"\0"), 16)[0])
                rel_alt[buf[i + 5]] = mm / 1e3
        i = end + 2 + (13 if buf[i + 2] & 1 else 0)
    return heartbeat


def listener(offset: int, vehicles: int, counts, telemetry, clock, commands, bound,
             stop, gaps, leave_first_api_port: bool = False) -> None:
    """Drain the GCS and API client ports; count datagrams (counts[0]) and bytes (counts[1]);
    read every datagram's telemetry (read_telemetry). Every PUBLISH_PERIOD_S it hands the
    parent each vehicle's armed flag (telemetry[0:N]) and relative altitude (telemetry[N:2N])
    and, under the lock of ``clock``, [its monotonic time, the minimum simulated time across
    vehicles 1..N (-1 until each has sent an ATTITUDE)]; clock[2] is the monotonic time of the
    first HEARTBEAT (stamped when read, so up to LISTENER_NAP_S late). While ``gaps[2]`` is
    non-zero (the measurement window), ``gaps[0]`` and ``gaps[1]`` hold the longest wall time
    between two HEARTBEATs of one vehicle on the GCS client port, over every vehicle and of
    vehicle 1 (what a client's link time-out sees: MAVSDK drops a system after 3 s). Sysid lists on
    ``commands`` get arm + takeoff, sent from the vehicle's API client port so the vehicle keeps
    talking to this process. ``leave_first_api_port``: vehicle 1's API client port is left to
    a MAVSDK client (--mavsdk)."""
    first = 1 if leave_first_api_port else 0
    ports = [GCS_CLIENT_PORT + offset] + [API_CLIENT_PORT + k + offset for k in range(first, 10)]
    socks = {p: _client_socket(p) for p in ports}
    by_fd = {s.fileno(): s for s in socks.values()}
    poller = select.epoll()
    for fd in by_fd:
        poller.register(fd, select.EPOLLIN)
    mav = mavlink2.MAVLink(None, srcSystem=CLIENT_SYSID, srcComponent=CLIENT_COMPID)
    buf = bytearray(65536)
    datagrams = nbytes = 0
    sim_t, armed, rel_alt = [-1.0] * 256, [0] * 256, [0.0] * 256  # by sysid (one byte)
    first_heartbeat = False
    gcs_fd = socks[GCS_CLIENT_PORT + offset].fileno()
    last_heartbeat = [0.0] * 256  # by sysid: when its latest HEARTBEAT came to the GCS port
    longest = [0.0, 0.0]
    window = False
    next_publish = 0.0
    bound.set()
    try:
        while True:
            for fd, _ in poller.poll(0.05):
                s = by_fd[fd]
                for _ in range(512):  # bounded, so one busy port cannot starve the others
                    try:
                        n = s.recv_into(buf)
                    except BlockingIOError:
                        break
                    datagrams += 1
                    nbytes += n
                    sysid = read_telemetry(buf, n, sim_t, armed, rel_alt)
                    if not sysid:
                        continue
                    if not first_heartbeat:
                        first_heartbeat = True
                        with clock.get_lock():
                            clock[2] = time.monotonic()
                    if fd == gcs_fd:
                        now = time.monotonic()
                        last, last_heartbeat[sysid] = last_heartbeat[sysid], now
                        if window and last:
                            longest[0] = max(longest[0], now - last)
                            if sysid == 1:
                                longest[1] = max(longest[1], now - last)
            counts[0], counts[1] = datagrams, nbytes
            now = time.monotonic()
            if now < next_publish:
                time.sleep(LISTENER_NAP_S)
                continue
            next_publish = now + PUBLISH_PERIOD_S
            telemetry[0:vehicles] = armed[1:vehicles + 1]
            telemetry[vehicles:2 * vehicles] = rel_alt[1:vehicles + 1]
            t_min = min(sim_t[1:vehicles + 1])
            with clock.get_lock():
                clock[0], clock[1] = now, t_min
            window = bool(gaps[2])
            if window:
                gaps[0], gaps[1] = longest
            if stop.is_set():
                break
            try:
                while True:
                    for sysid in commands.get_nowait():
                        index = sysid - 1
                        sock = socks[API_CLIENT_PORT + min(index, 9) + offset]
                        sock.sendto(_takeoff_datagram(mav, sysid),
                                    ("127.0.0.1", VEHICLE_API_PORT + index + offset))
            except queue.Empty:
                pass
    finally:
        poller.close()
        for s in socks.values():
            s.close()


def echo_server(port_out, stop) -> None:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(0.2)
    port_out.put(s.getsockname()[1])
    while not stop.is_set():
        try:
            data, addr = s.recvfrom(65536)
        except TimeoutError:
            continue
        s.sendto(data, addr)
    s.close()


def ping_frames(datagram: bytes):
    """(seq, time_usec) of every PING frame in a datagram (MAVLink 1 or 2, CRC not checked)."""
    i, n = 0, len(datagram)
    while i < n:
        magic = datagram[i]
        if magic == 0xFD and i + 10 <= n:
            length, incompat = datagram[i + 1], datagram[i + 2]
            msg_id = datagram[i + 7] | datagram[i + 8] << 8 | datagram[i + 9] << 16
            start = i + 10
            i = start + length + 2 + (13 if incompat & 1 else 0)
        elif magic == 0xFE and i + 6 <= n:
            length, msg_id, start = datagram[i + 1], datagram[i + 5], i + 6
            i = start + length + 2
        else:
            i += 1
            continue
        if msg_id == MSG_ID_PING:
            payload = datagram[start:start + length].ljust(14, b"\0")  # MAVLink 2 trims zeros
            time_usec, seq = struct.unpack_from("<QI", payload)
            yield seq, time_usec


def pinger(gateway_port: int, echo_port: int, counts, bound, go, stop_pings, stop, out) -> None:
    """Stop-and-wait PINGs at up to PING_HZ: each round sends one to vehicle 1's API port and
    waits for its reply, then one to the loopback echo and waits for its reply. Ends after
    PING_COUNT rounds or at ``stop_pings``; puts the two RTT lists and the rounds lost on ``out``;
    drains vehicle 1's API stream (counts[2], counts[3]) until ``stop``."""
    gw, lo = _client_socket(), _client_socket()
    counts[4] = gw.getsockname()[1]
    targets = ((gw, ("127.0.0.1", gateway_port)), (lo, ("127.0.0.1", echo_port)))
    mav = mavlink2.MAVLink(None, srcSystem=CLIENT_SYSID, srcComponent=CLIENT_COMPID)
    poller = select.epoll()
    which_of = {gw.fileno(): 0, lo.fileno(): 1}
    for fd in which_of:
        poller.register(fd, select.EPOLLIN)
    buf = bytearray(65536)
    tally = [0, 0]  # datagrams and bytes from the gateway socket

    def drain(timeout_s: float) -> list[tuple[int, float, int, int]]:
        """(socket, receive time, seq, time_usec) of the PING frames that came in."""
        got = []
        for fd, _ in poller.poll(max(timeout_s, 0.0)):
            which = which_of[fd]
            sock = targets[which][0]
            while True:
                try:
                    n = sock.recv_into(buf)
                except BlockingIOError:
                    break
                t = time.perf_counter()
                if which == 0:
                    tally[0] += 1
                    tally[1] += n
                got += [(which, t, seq, usec) for seq, usec in ping_frames(bytes(buf[:n]))]
        counts[2], counts[3] = tally
        return got

    rtts: list[list[float]] = [[], []]
    lost = [0, 0]
    bound.set()
    if not go.wait(LAUNCH_TIMEOUT_S + 2 * FLY_TIMEOUT_S + WARMUP_S + 60) or stop.is_set():
        out.put((rtts, lost))  # the point was abandoned before its window
        return
    t0 = time.perf_counter()
    for seq in range(PING_COUNT):
        while not stop_pings.is_set() and time.perf_counter() < t0 + seq / PING_HZ:
            drain(min(t0 + seq / PING_HZ - time.perf_counter(), 0.05))
        if stop_pings.is_set():
            break
        for which in (0, 1):
            time_usec = time.time_ns() // 1000
            frame = mav.ping_encode(time_usec, seq, 0, 0).pack(mav)
            sock, addr = targets[which]
            sent = time.perf_counter()
            sock.sendto(frame, addr)
            deadline = sent + PING_REPLY_TIMEOUT_S
            while (now := time.perf_counter()) < deadline:
                replies = [t for w, t, s_, u in drain(min(deadline - now, 0.05))
                           if w == which and s_ == seq and u == time_usec]
                if replies:
                    rtts[which].append(replies[0] - sent)
                    break
            else:
                lost[which] += 1
    out.put((rtts, lost))
    while not stop.is_set():
        drain(0.05)
    poller.close()
    gw.close()
    lo.close()


# --- the vehicles' simulated clock, from their telemetry -----------------------------------------
class SimClock(threading.Thread):
    """(wall, minimum simulated time across vehicles) samples from what the listener publishes
    (its own monotonic time of publication, so the listener's lag does not stretch the wall
    axis), and the vehicles' armed flags and altitudes."""

    def __init__(self, clock, telemetry, vehicles: int) -> None:
        super().__init__(daemon=True)
        self.clock, self.telemetry, self.vehicles = clock, telemetry, vehicles
        self.samples: list[tuple[float, float]] = []
        self.stop = threading.Event()

    def run(self) -> None:
        last = math.nan
        while not self.stop.wait(SAMPLE_PERIOD_S):
            with self.clock.get_lock():
                wall, t_min = self.clock[0], self.clock[1]
            if wall != last and t_min >= 0:
                self.samples.append((wall, t_min))
                last = wall

    def now(self) -> float:
        """The latest minimum simulated time, -1 before every vehicle sent an ATTITUDE."""
        return self.samples[-1][1] if self.samples else -1.0

    def first_heartbeat(self) -> float:
        with self.clock.get_lock():
            return self.clock[2]

    def rtf(self, w0: float, w1: float) -> float:
        """Simulated seconds per wall second over [w0, w1]: the least-squares slope of the
        minimum simulated time against wall time (the minimum steps by the telemetry period,
        20 ms; the fit keeps that from the ends of a short window)."""
        pts = np.array([(w, t) for w, t in self.samples if w0 <= w <= w1])
        if len(pts) < 2 or pts[-1, 0] <= pts[0, 0]:
            return math.nan
        return float(np.polyfit(pts[:, 0] - pts[0, 0], pts[:, 1], 1)[0])

    def flying(self) -> tuple[list[int], list[int]]:
        """(sysids flying, sysids not armed) in the latest telemetry."""
        n = self.vehicles
        values = self.telemetry[0:2 * n]
        up, unarmed = [], []
        for k in range(n):
            if not values[k]:
                unarmed.append(k + 1)
            elif values[n + k] >= FLYING_REL_ALT_M:
                up.append(k + 1)
        return up, unarmed


# --- the wire's own cost -----------------------------------------------------------------------------
SEND_FLOOR_DATAGRAMS = 5000
SEND_FLOOR_BURST = 100


def send_cost_us(port: int, size: int) -> float:
    """CPU µs (this thread's user + system time) of one ``sendto`` of a ``size``-byte datagram
    to the listener's ``port`` on loopback, while it drains the port as it drains the daemon's
    datagrams: what the kernel charges the daemon for each datagram it sends, whatever the
    daemon does in Python. Sent in bursts with naps between them so the listener keeps up."""
    data = bytes(max(1, size))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.setblocking(False)
        peer = ("127.0.0.1", port)
        spent = 0.0
        sent = 0
        while sent < SEND_FLOOR_DATAGRAMS:
            t0 = time.thread_time()
            for _ in range(SEND_FLOOR_BURST):
                try:
                    s.sendto(data, peer)
                except OSError:
                    pass
            spent += time.thread_time() - t0
            sent += SEND_FLOOR_BURST
            time.sleep(LISTENER_NAP_S)
    return spent / sent * 1e6


# --- one point ---------------------------------------------------------------------------------------
@dataclass
class Point:
    vehicles: int
    shards: int
    mode: str
    launch_s: float = math.nan
    first_heartbeat_s: float = math.nan
    flying: int = 0
    fly_wait_s: float = math.nan
    rtf: float = math.nan
    window_s: float = math.nan
    sim_s: float = math.nan
    cpu_ms_per_vehicle_s: float = math.nan
    bare_ms_per_body_s: float = math.nan
    cpu_over_bare: float = math.nan
    rss_mb: float = math.nan
    rss_per_vehicle_mb: float = math.nan
    datagrams_per_s: float = math.nan
    mbytes_per_s: float = math.nan
    listener_drops: int = 0
    listener_cpu_pct: float = math.nan
    send_us: float = math.nan
    send_floor_ms_per_vehicle_s: float = math.nan
    gw_p50_ms: float = math.nan
    gw_p99_ms: float = math.nan
    lo_p50_ms: float = math.nan
    lo_p99_ms: float = math.nan
    added_p50_ms: float = math.nan
    added_p99_ms: float = math.nan
    heartbeat_gap_s: float = math.nan  # the longest wall time between one vehicle's HEARTBEATs
    heartbeat_gap_v1_s: float = math.nan  # vehicle 1's, over the MAVSDK example's run (--mavsdk)
    pings: int = 0
    pings_lost: int = 0
    exit_code: int | None = None
    slips: str = ""
    notes: list[str] = field(default_factory=list)


def launch_daemon(n: int, shards: int, offset: int, scenario: Path | None = None
                  ) -> tuple[CornetDaemon, float, float]:
    """``cornet run --vehicles N [--shards K] [--scenario FILE]`` at ``offset`` as a user starts
    it (the listener already bound to the client ports); (daemon, monotonic start, monotonic
    time of the ready line). Not ready within LAUNCH_TIMEOUT_S: stopped, RuntimeError."""
    args = ["--shards", str(shards)] if shards > 1 else []
    if scenario is not None:
        args += ["--scenario", str(scenario)]
    d = start_daemon(*args, vehicles=n, port_offset=offset, ready_timeout_s=LAUNCH_TIMEOUT_S)
    return d, d.started_at, d.ready_at


def _fly(clock: SimClock, commands, n: int, deadline: float, alive, skip: int = 0) -> None:
    """Arm and take off every vehicle but sysid ``skip`` (see RESEND_AFTER_S); returns when
    they all fly or at ``deadline``."""
    sent: set[int] = {skip}
    best, progress_at = -1, time.monotonic()
    while time.monotonic() < deadline and alive():
        if clock.now() < ARM_AFTER_SIM_S:
            time.sleep(0.2)
            continue
        up, unarmed = clock.flying()
        up = [sysid for sysid in up if sysid != skip]
        unarmed = [sysid for sysid in unarmed if sysid != skip]
        if len(up) == n - (1 if skip else 0):
            return
        now = time.monotonic()
        if n - len(unarmed) > best:
            best, progress_at = n - len(unarmed), now
        if now - progress_at > RESEND_AFTER_S:
            sent = {skip}
            progress_at = now
        todo = [sysid for sysid in unarmed if sysid not in sent]
        if todo:
            commands.put(todo)
            sent.update(todo)
        time.sleep(0.5)


# What the unmodified MAVSDK examples (--mavsdk EXAMPLE) print when they succeed.
MAVSDK_EXAMPLES = {"takeoff_and_land": "Disarmed", "mission": "-- Mission finished: True"}


def run_mavsdk_example(example: str, offset: int, timeout_s: float) -> tuple[bool, float, str]:
    """gcs_examples/<example>.py, unmodified (MAVSDK 3.x, its own mavsdk_server), on vehicle
    1's API client port: (passed, wall seconds, last lines of its output)."""
    script = Path(__file__).resolve().parents[1] / "gcs_examples" / f"{example}.py"
    grpc_port = free_tcp_port()
    t0 = time.monotonic()
    try:
        done = subprocess.run([sys.executable, str(script), "--port", str(API_CLIENT_PORT + offset),
                               "--grpc-port", str(grpc_port)], capture_output=True, text=True,
                              timeout=timeout_s)
    except subprocess.TimeoutExpired as exc:
        out = (exc.stdout or b"").decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        return False, time.monotonic() - t0, f"timed out; {out.strip().splitlines()[-3:]}"
    out = done.stdout.strip().splitlines()
    passed = done.returncode == 0 and any(MAVSDK_EXAMPLES[example] in line for line in out)
    # What the example said last, and why it stopped (the end of a traceback), not the
    # warnings MAVSDK prints on import.
    said = out[-3:] + [line for line in done.stderr.strip().splitlines()[-2:]
                       if done.returncode != 0]
    return passed, time.monotonic() - t0, f"exit {done.returncode}: " + " | ".join(said)


def free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def engine_cpu_s(pid: int) -> float:
    """CPU seconds of the daemon's ns-3 engine process (cornet-ns3), 0 without one."""
    total = 0.0
    for p in process_tree(pid):
        try:
            name = Path(f"/proc/{p}/comm").read_text().strip()
        except OSError:
            continue
        if name.startswith("cornet-ns3"):
            f = _stat_fields(p)
            total += (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")
    return total


def measure(n: int, shards: int, seconds: float, flying: bool, bare_s: float, echo_port: int,
            ctx, mavsdk: str | None = None, scenario: Path | None = None) -> Point:
    """One point. ``mavsdk``: vehicle 1 is left on the ground for an unmodified MAVSDK example
    (gcs_examples/<mavsdk>.py) started with the measurement window while the others fly; the
    ping client then pings vehicle 2."""
    point = Point(n, shards, "flying" if flying else "idle", bare_ms_per_body_s=bare_s * 1e3)
    try:
        offset = free_port_offset(n)
    except RuntimeError as exc:
        point.notes.append(str(exc))
        return point
    counts = ctx.Array("d", 6, lock=False)
    telemetry = ctx.Array("d", 2 * n, lock=False)
    clock_shared = ctx.Array("d", [math.nan, -1.0, math.nan])  # with a lock
    gaps = ctx.Array("d", 3, lock=False)  # listener(): longest HEARTBEAT gaps, window flag
    commands, rtt_out = ctx.Queue(), ctx.Queue()
    listen_bound, ping_bound = ctx.Event(), ctx.Event()
    go, stop_pings, stop = ctx.Event(), ctx.Event(), ctx.Event()
    helpers = [
        ctx.Process(target=listener, args=(offset, n, counts, telemetry, clock_shared, commands,
                                           listen_bound, stop, gaps, bool(mavsdk)),
                    daemon=True),
        ctx.Process(target=pinger, args=(VEHICLE_API_PORT + (1 if mavsdk else 0) + offset,
                                          echo_port, counts,
                                          ping_bound, go, stop_pings, stop, rtt_out),
                    daemon=True),
    ]
    clock = SimClock(clock_shared, telemetry, n)
    d: CornetDaemon | None = None
    try:
        for h in helpers:
            h.start()
        if not (listen_bound.wait(HELPER_START_TIMEOUT_S)
                and ping_bound.wait(HELPER_START_TIMEOUT_S)):
            point.notes.append("helper processes did not start")
            return point
        clock.start()
        try:
            d, t_start, t_ready = launch_daemon(n, shards, offset, scenario)
        except RuntimeError as exc:
            point.notes.append(f"did not start: {str(exc).splitlines()[0]}")
            return point
        point.launch_s = t_ready - t_start
        pid = d.proc.pid
        alive = lambda: d.proc.poll() is None
        t_fly = time.monotonic()
        if flying:
            _fly(clock, commands, n, t_fly + FLY_TIMEOUT_S, alive, skip=1 if mavsdk else 0)
            point.fly_wait_s = time.monotonic() - t_fly
        warm_until = time.monotonic() + WARMUP_S
        while alive() and (time.monotonic() < warm_until or clock.now() < WARMUP_SIM_S):
            if time.monotonic() > warm_until + FLY_TIMEOUT_S:
                break
            time.sleep(0.1)
        point.first_heartbeat_s = clock.first_heartbeat() - t_start
        if not alive():
            point.notes.append(f"daemon exited early ({d.proc.returncode})")
            return point

        listener_ports = {GCS_CLIENT_PORT + offset, int(counts[4]),
                          *(API_CLIENT_PORT + k + offset for k in range(10))}
        drops0 = udp_drops(listener_ports)
        out0 = counts[0] + counts[2], counts[1] + counts[3]
        cpu0, lcpu0, w0 = tree_cpu_s(pid), tree_cpu_s(helpers[0].pid), time.monotonic()
        ecpu0 = engine_cpu_s(pid)
        go.set()
        gaps[2] = 1.0
        example = None
        if mavsdk:
            example = ThreadPool(1).apply_async(run_mavsdk_example,
                                                (mavsdk, offset, MAVSDK_TIMEOUT_S))
        time.sleep(seconds)
        cpu1, lcpu1, w1 = tree_cpu_s(pid), tree_cpu_s(helpers[0].pid), time.monotonic()
        ecpu1 = engine_cpu_s(pid)
        time.sleep(2 * PUBLISH_PERIOD_S)  # the listener's figures of the window
        point.heartbeat_gap_s = gaps[0]
        if scenario is not None:
            point.notes.append(f"ns-3 engine CPU {(ecpu1 - ecpu0) / (w1 - w0) * 100:.0f} %, "
                               f"daemon {(cpu1 - cpu0 - ecpu1 + ecpu0) / (w1 - w0) * 100:.0f} %")
        out1 = counts[0] + counts[2], counts[1] + counts[3]
        drops1 = udp_drops(listener_ports)
        sent = out1[0] - out0[0]
        if sent > 0:  # the daemon's mean datagram, to the port most of them go to
            point.send_us = send_cost_us(GCS_CLIENT_PORT + offset,
                                         round((out1[1] - out0[1]) / sent))
        stop_pings.set()
        point.rss_mb = tree_rss_bytes(pid) / 2**20
        point.flying = len(clock.flying()[0]) if flying else 0
        point.window_s = w1 - w0
        point.rtf = clock.rtf(w0, w1)
        point.sim_s = point.rtf * point.window_s
        if point.sim_s > 1e-3:
            point.cpu_ms_per_vehicle_s = (cpu1 - cpu0) / (n * point.sim_s) * 1e3
        else:  # no ATTITUDE of some vehicle arrived in the window (a saturated network)
            point.notes.append("the slowest vehicle's telemetry did not advance in the window")
        point.cpu_over_bare = point.cpu_ms_per_vehicle_s / point.bare_ms_per_body_s
        point.datagrams_per_s = (out1[0] - out0[0]) / point.window_s
        point.mbytes_per_s = (out1[1] - out0[1]) / point.window_s / 1e6
        point.listener_drops = drops1 - drops0
        point.listener_cpu_pct = (lcpu1 - lcpu0) / point.window_s * 100
        if point.sim_s > 1e-3:  # one sendto per datagram, per vehicle and simulated second
            point.send_floor_ms_per_vehicle_s = (point.send_us * (out1[0] - out0[0])
                                                 / (n * point.sim_s) / 1e3)
        if example is not None:
            passed, took, tail = example.get(MAVSDK_TIMEOUT_S + 10)
            time.sleep(2 * PUBLISH_PERIOD_S)  # the listener's last figures
            point.heartbeat_gap_v1_s = gaps[1]
            others = len([sysid for sysid in clock.flying()[0] if sysid != 1])
            point.notes.append(f"MAVSDK {mavsdk}.py on vehicle 1 while "
                               f"{others} others fly: {'PASS' if passed else 'FAIL'} in "
                               f"{took:.0f} s; longest wall time between its HEARTBEATs "
                               f"{point.heartbeat_gap_v1_s:.2f} s (MAVSDK drops a system "
                               f"after 3 s)")
            print(f"    mavsdk: {'PASS' if passed else 'FAIL'} in {took:.1f} s: {tail}",
                  file=sys.stderr, flush=True)
        try:
            (gw_rtts, lo_rtts), (gw_lost, lo_lost) = rtt_out.get(
                timeout=2 * PING_REPLY_TIMEOUT_S + 10)
        except queue.Empty:
            point.notes.append("ping client did not report")
        else:
            point.pings = len(gw_rtts) + gw_lost
            point.pings_lost = gw_lost
            if gw_rtts and lo_rtts:
                gw = np.percentile(np.array(gw_rtts) * 1e3, [50, 99])
                lo = np.percentile(np.array(lo_rtts) * 1e3, [50, 99])
                point.gw_p50_ms, point.gw_p99_ms = gw
                point.lo_p50_ms, point.lo_p99_ms = lo
                point.added_p50_ms, point.added_p99_ms = gw - lo
            if lo_lost:
                point.notes.append(f"{lo_lost} loopback pings lost")
    finally:
        stop_pings.set()
        go.set()
        if d is not None:
            code = d.stop()
            took = d.stop_took_s  # the helpers keep draining until the daemon is gone
            point.exit_code = code
            if code != 0:
                point.notes.append(f"exit {code} after SIGTERM ({took:.1f} s)")
                print(d.log_tail(20), file=sys.stderr, flush=True)
        stop.set()
        for h in helpers:
            h.join(timeout=5)
            if h.is_alive():
                h.terminate()
                h.join(timeout=5)
        clock.stop.set()
        clock.join(timeout=2)
    stop_line = next((ln for ln in reversed(d.stderr_lines) if "stopping after" in ln), "")
    print(f"    daemon: {stop_line.strip() or '(no stop line)'}", file=sys.stderr, flush=True)
    counters = dict(re.findall(r"(\w+)=([\d.]+)", stop_line))
    point.slips = counters.get("slips", "?")
    for name in ("kernel_dropped", "internal_errors", "net_dropped", "rate_limited"):
        if counters.get(name, "0") != "0":
            point.notes.append(f"{name}={counters[name]}")
    if flying and point.flying < n - (1 if mavsdk else 0):  # --mavsdk: vehicle 1 has landed
        point.notes.append(f"only {point.flying}/{n} flying")
    if any("exchanges took longer than a sync period" in ln for ln in d.stderr_lines):
        point.notes.append("ns-3 could not keep exact time: pipeline")
    if not point.rtf >= KEEPS_UP_RTF:
        point.notes.append("cannot keep up with real time")
    if point.listener_drops:
        point.notes.append(f"listener dropped {point.listener_drops} datagrams")
    return point


# --- report ------------------------------------------------------------------------------------------
def machine_text() -> str:
    import pybullet

    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            model = next(ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name"))
    except (OSError, StopIteration):
        pass
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    return (f"date: {time.strftime('%Y-%m-%d %H:%M:%S %Z')}\n"
            f"machine: {model}, {os.cpu_count()} cores, load average {load}\n"
            f"Python {platform.python_version()}, pybullet API {pybullet.getAPIVersion()}")


def _f(x: float, spec: str) -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def markdown_table(points: list[Point]) -> str:
    head = ["vehicles", "shards", "launch", "first HEARTBEAT", "flying (wait)", "real-time factor",
            "CPU per vehicle-s", "bare PyBullet per body-s", "÷ bare", "UDP sends alone per vehicle-s",
            "RSS", "RSS per vehicle",
            "datagrams/s out", "MB/s out", "longest HEARTBEAT gap", "ping RTT gateway p50 / p99",
            "loopback p50 / p99", "added p50 / p99", "notes"]
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for p in points:
        flying = (f"{p.flying}/{p.vehicles} ({_f(p.fly_wait_s, '.0f')} s)"
                  if p.mode == "flying" else "idle")
        pings = []
        if p.pings != PING_COUNT:
            pings.append(f"{p.pings} pings")
        if p.pings_lost:
            pings.append(f"{p.pings_lost} lost")
        rows.append("| " + " | ".join([
            str(p.vehicles), str(p.shards), _f(p.launch_s, ".2f") + " s",
            _f(p.first_heartbeat_s, ".2f") + " s", flying, _f(p.rtf, ".3f"),
            _f(p.cpu_ms_per_vehicle_s, ".1f") + " ms", _f(p.bare_ms_per_body_s, ".2f") + " ms",
            _f(p.cpu_over_bare, ".0f") + "×",
            f"{_f(p.send_floor_ms_per_vehicle_s, '.1f')} ms ({_f(p.send_us, '.1f')} µs each)",
            _f(p.rss_mb, ".0f") + " MB",
            _f(p.rss_per_vehicle_mb, ".2f") + " MB" if p.vehicles > 1 else "-",
            _f(p.datagrams_per_s, ",.0f"), _f(p.mbytes_per_s, ".2f"),
            _f(p.heartbeat_gap_s, ".2f") + " s",
            f"{_f(p.gw_p50_ms, '.2f')} / {_f(p.gw_p99_ms, '.2f')} ms"
            + (f" ({', '.join(pings)})" if pings else ""),
            f"{_f(p.lo_p50_ms, '.2f')} / {_f(p.lo_p99_ms, '.2f')} ms",
            f"{_f(p.added_p50_ms, '.2f')} / {_f(p.added_p99_ms, '.2f')} ms",
            "; ".join(p.notes) or "ok",
        ]) + " |")
    return "\n".join(rows)


def write_csv(points: list[Point], path: Path) -> None:
    names = [k for k in asdict(points[0]) if k != "notes"] + ["notes"]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        for p in points:
            row = asdict(p)
            row["notes"] = "; ".join(p.notes)
            w.writerow([round(v, 4) if isinstance(v, float) else v
                        for v in (row[k] for k in names)])


def plot(points: list[Point], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    n = [p.vehicles for p in points]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ax1.plot(n, [p.rtf for p in points], "o-", label="achieved")
    ax1.axhline(1.0, color="grey", linestyle="--", linewidth=1, label="real time")
    ax1.set_xscale("log")
    ax1.set_xlabel("vehicles")
    ax1.set_ylabel("simulated s per wall s")
    ax1.set_title("real-time factor")
    ax1.set_ylim(0, max(1.1, np.nanmax([p.rtf for p in points] + [0.0]) * 1.1))
    ax1.legend()
    ax2.plot(n, [p.cpu_ms_per_vehicle_s for p in points], "o-", label="daemon")
    ax2.plot(n, [p.bare_ms_per_body_s for p in points], "s--", label="bare PyBullet (floor)")
    ax2.set_xscale("log")
    ax2.set_yscale("log")
    ax2.set_xlabel("vehicles")
    ax2.set_ylabel("CPU ms per vehicle-second")
    ax2.set_title("CPU per vehicle-second")
    ax2.legend()
    for ax in (ax1, ax2):
        ax.set_xticks(n)
        ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.grid(True, which="major", alpha=0.3)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def auto_shards(n: int) -> int:
    return 1 if n < SHARDS_FROM_VEHICLES else max(1, min(MAX_AUTO_SHARDS, os.cpu_count() or 1))


def parse_shards(parser: argparse.ArgumentParser, text: str, asked: list[int],
                 counts: list[int]) -> dict[int, int]:
    """Shards per vehicle count from --shards (the added 1-vehicle baseline runs 1 shard)."""
    if text.strip() == "auto":
        return {n: auto_shards(n) for n in counts}
    try:
        ks = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        parser.error(f"--shards must be auto or comma-separated integers, got {text!r}")
    if len(ks) != len(asked):
        parser.error(f"--shards has {len(ks)} entries, --vehicles {len(asked)}")
    out: dict[int, int] = {}
    for n, k in zip(asked, ks):
        if out.get(n, k) != k:
            parser.error(f"--vehicles {n} appears twice with different --shards")
        if not 1 <= k <= n:
            parser.error(f"--shards {k} for {n} vehicles: must be 1..{n}")
        out[n] = k
    out.setdefault(1, 1)
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicles", default="1,10,30,100,200",
                        help="comma-separated vehicle counts (1 is always measured: the RSS "
                        "baseline)")
    parser.add_argument("--shards", default="auto",
                        help="`cornet run --shards` per vehicle count: a comma-separated list "
                        "matching --vehicles, or auto (default): 1 below "
                        f"{SHARDS_FROM_VEHICLES} vehicles, else min({MAX_AUTO_SHARDS}, cores)")
    parser.add_argument("--seconds", type=float, default=20.0,
                        help="wall seconds measured per point, after the warm-up")
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--flying", dest="flying", action="store_true", default=True,
                      help="arm and take off every vehicle first (default)")
    mode.add_argument("--idle", dest="flying", action="store_false",
                      help="leave the vehicles on the ground")
    parser.add_argument("--mavsdk", nargs="?", const="takeoff_and_land", default=None,
                        choices=sorted(MAVSDK_EXAMPLES), metavar="EXAMPLE",
                        help="at the largest vehicle count, fly vehicle 1 with the unmodified "
                        "MAVSDK example gcs_examples/EXAMPLE.py (takeoff_and_land, the default, "
                        "or mission) while the others fly (needs --flying)")
    parser.add_argument("--scenario", type=Path,
                        help="run every point with `--scenario FILE` (e.g. ns3-wifi:"
                        " the vehicles through the real ns-3; its network, the given counts)")
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results",
                        help="directory for the CSV and PNG (default bench/results/)")
    args = parser.parse_args()
    try:
        asked = [int(x) for x in args.vehicles.split(",") if x.strip()]
    except ValueError:
        parser.error(f"--vehicles must be comma-separated integers, got {args.vehicles!r}")
    counts = sorted(set(asked) | {1})
    if counts[0] < 1 or not args.seconds > 0:
        parser.error("vehicle counts must be >= 1 and --seconds > 0")
    shards_of = parse_shards(parser, args.shards, asked, counts)
    if args.mavsdk and not args.flying:
        parser.error("--mavsdk needs the other vehicles flying (drop --idle)")

    header = machine_text()
    print(header, flush=True)
    ctx = mp.get_context("spawn")
    port_out, echo_stop = ctx.Queue(), ctx.Event()
    echo = ctx.Process(target=echo_server, args=(port_out, echo_stop), daemon=True)
    echo.start()
    points: list[Point] = []
    t_run = time.monotonic()
    try:
        echo_port = port_out.get(timeout=HELPER_START_TIMEOUT_S)
        for n in counts:
            bare = bare_pybullet_cpu_per_body_sim_s(n)
            p = measure(n, shards_of[n], args.seconds, args.flying, bare, echo_port, ctx,
                        mavsdk=args.mavsdk if n == max(counts) else None,
                        scenario=args.scenario)
            points.append(p)
            print(f"  {n} vehicles, {shards_of[n]} shard(s): rtf {_f(p.rtf, '.3f')}, "
                  f"CPU {_f(p.cpu_ms_per_vehicle_s, '.1f')} ms per vehicle-s, "
                  f"{'; '.join(p.notes) or 'ok'}", file=sys.stderr, flush=True)
    finally:
        echo_stop.set()
        echo.join(timeout=2)
        if echo.is_alive():
            echo.terminate()
    base = points[0].rss_mb
    for p in points[1:]:
        p.rss_per_vehicle_mb = (p.rss_mb - base) / (p.vehicles - 1)

    print(f"mode: {'flying (armed, taken off)' if args.flying else 'idle on the ground'}; "
          f"{args.seconds:g} wall s measured per point after a {WARMUP_S:g} s warm-up; "
          f"network: embedded ideal; shards: {args.shards}; "
          f"whole run {time.monotonic() - t_run:.0f} s")
    print()
    print(markdown_table(points))
    print()
    print("Real-time factor: minimum simulated time across vehicles (ATTITUDE time_boot_ms) "
          "per wall second. First HEARTBEAT: daemon start to the first HEARTBEAT received. "
          "Longest HEARTBEAT gap: the most wall time between two HEARTBEATs of one vehicle on "
          "the GCS port in the window (PX4 sends one per simulated second; MAVSDK drops a system "
          "after 3 s without one). "
          "CPU per vehicle-s: daemon CPU (all its processes) / (N x simulated s); ÷ bare: over "
          "N PyBullet boxes stepped alone. UDP sends alone: the CPU one sendto of the daemon's "
          "mean datagram costs (measured here, to the listener's port while it drains) times "
          "the datagrams per vehicle-s, the floor under the daemon's CPU while PX4's "
          "one-datagram-per-message streams go out. RSS: summed over the daemon's processes; per vehicle: "
          "(RSS at N - RSS at 1) / (N - 1). Ping: MAVLink PING "
          "to vehicle 1's API port vs a UDP echo on loopback, interleaved, stop-and-wait, "
          f"up to {PING_COUNT} each at {PING_HZ:g} Hz within the window.")
    args.out.mkdir(parents=True, exist_ok=True)
    stem = args.out / time.strftime("scale-%Y%m%d-%H%M%S")
    write_csv(points, stem.with_suffix(".csv"))
    plot(points, stem.with_suffix(".png"), header.replace("\n", " | "))
    print(f"\nwrote {stem.with_suffix('.csv')} and {stem.with_suffix('.png')}")
    ok = all(p.exit_code == 0 for p in points)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
