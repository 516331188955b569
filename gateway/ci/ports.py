"""Free local ports for side-by-side daemons (tests, examples, the pytest plugin).

Standard library only, so that importing it (from the pytest plugin, at pytest start-up) loads
nothing heavy. The port numbers are PX4 SITL's (gateway/sim/simulation.py ``px4_ports``).
"""

from __future__ import annotations

import contextlib
import os
import socket
from collections.abc import Sequence

API_CLIENT_PORT = 14540  # vehicle i's MAVSDK link: 14540+i (i > 9: 14549)
GCS_CLIENT_PORT = 14550
VEHICLE_GCS_PORT = 18570
VEHICLE_API_PORT = 14580
OFFSET_STEP = 200
MIN_VEHICLES_CHECKED = 10  # a scenario file may spawn more vehicles than --vehicles says
# Extra radio r of vehicle i binds VEHICLE_GCS_PORT + r·RADIO_PORT_STRIDE + i
# (gateway/sim/radios.py); a scenario file may give every vehicle up to this many.
RADIO_PORT_STRIDE = 1000
RADIOS_CHECKED = 2


def _free(kind: socket.SocketKind, port: int) -> bool:
    """Whether ``port`` can be bound on every address for ``kind`` (SOCK_DGRAM or SOCK_STREAM)."""
    with contextlib.closing(socket.socket(socket.AF_INET, kind)) as s:
        try:
            s.bind(("0.0.0.0", port))
        except OSError:
            return False
    return True


def udp_free(port: int) -> bool:
    return _free(socket.SOCK_DGRAM, port)


def daemon_ports(offset: int, vehicles: int, radios: int = 0) -> list[int]:
    """Every UDP port a daemon with ``vehicles`` vehicles, each with ``radios`` extra radios,
    and its clients use at ``offset`` (extra radios talking to the GCS client port)."""
    ports = [GCS_CLIENT_PORT + offset]
    for i in range(vehicles):
        ports += [VEHICLE_GCS_PORT + i + offset, VEHICLE_API_PORT + i + offset,
                  API_CLIENT_PORT + min(i, 9) + offset]
        ports += [VEHICLE_GCS_PORT + r * RADIO_PORT_STRIDE + i + offset
                  for r in range(1, radios + 1)]
    return ports


def _process_slot() -> int:
    """This process's number among parallel ones: a pytest-xdist worker's (gw0, gw1, ...), else
    the pid."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    return int(worker[2:]) if worker[2:].isdigit() else os.getpid()


def free_port_offset(vehicles: int = 1, start: int = 1000, skip: Sequence[int] = (),
                     radios: int = RADIOS_CHECKED) -> int:
    """A ``--port-offset`` at which every UDP port a daemon with ``vehicles`` vehicles (and
    ``radios`` extra radios each) and its clients use is free (the search starts at a
    per-process place, for parallel test runs)."""
    n = max(vehicles, MIN_VEHICLES_CHECKED)
    # Parallel workers start far apart (7 offsets, not a multiple of the radios' stride), so
    # that two daemons starting at once do not both find the same offset free.
    base = start + (_process_slot() % 8) * 7 * OFFSET_STEP
    for k in [*range(base, 40000, OFFSET_STEP), *range(start, base, OFFSET_STEP)]:
        if k not in skip and all(udp_free(p) for p in daemon_ports(k, n, radios)):
            return k
    raise RuntimeError("no free port offset for cornet run")


# TCP ports handed out below the kernel's ephemeral range, in blocks of TCP_BLOCK, one block per
# process (a pytest-xdist worker's own by its number).
TCP_PORTS_FROM = 10000
TCP_BLOCK = 400
_tcp_next: list[int] = []  # this process's next candidate


def _ephemeral_low(path: str = "/proc/sys/net/ipv4/ip_local_port_range") -> int:
    try:
        with open(path) as f:
            return int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return 32768  # Linux's default


def free_tcp_port() -> int:
    """A free local TCP port, e.g. for MAVSDK-Python's ``System(port=...)`` (its gRPC server),
    which binds it a second or two later, once it has found the vehicle.

    Not from the kernel's ephemeral range: connections and ``bind(0)`` of every process draw
    their ports from there, and one of them could take the port in those seconds (mavsdk_server
    then exits, 2: "Failed to bind server"). Below it, each process (pytest-xdist worker) has a
    block of its own and walks it, so two calls never return the same port."""
    low = _ephemeral_low()
    blocks = (low - TCP_PORTS_FROM) // TCP_BLOCK
    if blocks < 1:  # an unusual ephemeral range: the kernel's choice
        with contextlib.closing(socket.socket()) as s:
            s.bind(("127.0.0.1", 0))
            return s.getsockname()[1]
    first = TCP_PORTS_FROM + (_process_slot() % blocks) * TCP_BLOCK
    if not _tcp_next:
        _tcp_next.append(0)
    for _ in range(TCP_BLOCK):
        port = first + _tcp_next[0] % TCP_BLOCK
        _tcp_next[0] += 1
        if _free(socket.SOCK_STREAM, port):
            return port
    raise RuntimeError(f"no free TCP port in {first}..{first + TCP_BLOCK - 1}")
