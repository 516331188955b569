"""100,000 hostile datagrams at both vehicle ports during a MAVSDK flight: the flight completes."""

import asyncio
import re
import socket
import struct
import threading

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from tests.e2e.flows import takeoff_hover_land

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

TOTAL = 100_000


def hostile_datagrams(seed: int, n: int):
    """Random bytes, truncated and corrupted frames, frames for other systems, unknown ids."""
    rng = np.random.default_rng(seed)
    mav = mavlink2.MAVLink(None, srcSystem=77, srcComponent=1)
    good = mav.command_long_encode(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0).pack(mav)  # ARM for sysid 1
    other = mav.command_long_encode(42, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0).pack(mav)  # other sysid
    for i in range(n):
        kind = i % 5
        if kind == 0:
            yield rng.bytes(int(rng.integers(1, 300)))
        elif kind == 1:
            yield good[: int(rng.integers(1, len(good)))]  # truncated
        elif kind == 2:
            b = bytearray(good)
            b[-1] ^= 0xFF  # bad CRC
            yield bytes(b)
        elif kind == 3:
            yield other
        else:
            # A v2 header claiming an unknown message id with random payload.
            payload = rng.bytes(20)
            yield struct.pack("<BBBBBBBHB", 0xFD, len(payload), 0, 0, 0, 9, 1, 0xBEEF, 0x7F) + \
                payload + b"\x00\x00"


def flood(ports: list[int], stop: threading.Event, sent: list[int]) -> None:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        for i, data in enumerate(hostile_datagrams(1234, TOTAL)):
            if stop.is_set():
                break
            s.sendto(data, ("127.0.0.1", ports[i % len(ports)]))
            sent[0] += 1
            if i % 500 == 499:
                stop.wait(0.05)  # ~10k datagrams/s
    finally:
        s.close()


@pytest.mark.asyncio
async def test_flight_survives_garbage_flood(daemon_factory):
    d = daemon_factory()
    stop = threading.Event()
    sent = [0]
    flooder = threading.Thread(
        target=flood, args=([d.vehicle_port(0, "gcs"), d.vehicle_port(0, "api")], stop, sent))

    async def start_flood_when_airborne():
        await asyncio.sleep(15)
        flooder.start()

    starter = asyncio.ensure_future(start_flood_when_airborne())
    try:
        r = await takeoff_hover_land(d.api_port(0), hover_s=12.0, timeout_scale=2.0)
    finally:
        starter.cancel()
        if flooder.is_alive():
            flooder.join(timeout=60)
        stop.set()
    assert sent[0] == TOTAL, "the flood did not finish during the flight"
    assert 2.2 <= r.hover_alt_min_m and r.hover_alt_max_m <= 2.8, r
    code = d.stop()
    assert code == 0
    stop_line = next(line for line in reversed(d.stderr_lines) if "stopping after" in line)
    # One source sends ~5,000 datagrams/s to each port: beyond its token bucket (2,000/s) they
    # are dropped unread (rate_limited); the kernel may drop a few when the socket buffer is
    # full. Of those let in, 3 of 5 kinds are malformed (random, truncated, bad CRC).
    m = re.search(r"malformed=(\d+) rate_limited=(\d+) kernel_dropped=(\d+) "
                  r"internal_errors=(\d+)", stop_line)
    assert m, stop_line
    malformed, limited, kernel_dropped, errors = (int(g) for g in m.groups())
    assert limited > 0.2 * TOTAL, stop_line
    assert malformed > 0.5 * (TOTAL - limited - kernel_dropped), stop_line
    assert errors == 0, stop_line
