#!/usr/bin/env python3
"""Stream the vehicle's ULog over MAVLink while it takes off, hovers and lands — MAVSDK's
log_streaming plugin against `make run` (no state directory needed: PX4's logger streams
without its SD card too).

    .venv/bin/python gcs_examples/stream_log.py                     # streamed.ulg
    .venv/bin/python gcs_examples/stream_log.py --out hover.ulg --hover 5

pyulog (`ulog_info streamed.ulg`), Flight Review and PlotJuggler read the file. Needs
MAVSDK-Python 3.x (`pip install "mavsdk<4"`; `make run` installs it in .venv).
"""

import argparse
import asyncio
import base64
from pathlib import Path

from _common import arguments, connect, first_value, retry, wait_landed
from mavsdk.log_streaming import LogStreamingError

ULOG_MAGIC = b"ULog\x01\x12\x35"


def timed_out(error: Exception) -> bool:
    return getattr(getattr(getattr(error, "_result", None), "result", None), "name", "") == "TIMEOUT"


async def start_stream(drone, parts: list[bytes]) -> None:
    """LOGGING_START, asked again only if nothing streams: over a lossy link the answer can be
    late, because PX4's logger answers nothing while it sends its header reliably (a packet per
    acknowledgement), and mavsdk_server has been seen to stop answering after repeated starts."""
    for _ in range(3):
        try:
            await drone.log_streaming.start_log_streaming()
            return
        except LogStreamingError as error:
            if not timed_out(error):
                raise
        print("-- start_log_streaming: no answer yet")
        for _ in range(50):
            if parts:
                return
            await asyncio.sleep(0.1)


async def run(port: int, grpc_port: int, out: Path, hover_s: float) -> int:
    drone = await connect(port, grpc_port)
    parts: list[bytes] = []

    async def collect() -> None:
        async for part in drone.log_streaming.log_streaming_raw():
            parts.append(base64.b64decode(part.data_base64))

    receiver = asyncio.ensure_future(collect())
    await asyncio.sleep(0.5)  # subscribed before the first packet comes
    print("-- Starting the log stream")
    await start_stream(drone, parts)
    print("-- Arming")
    await retry(drone.action.arm)
    print("-- Taking off")
    await retry(drone.action.takeoff)
    await asyncio.sleep(hover_s)
    position = await first_value(drone.telemetry.position())
    print(f"-- Hovering at {position.relative_altitude_m:.2f} m above home")
    print("-- Landing")
    await retry(drone.action.land)
    await wait_landed(drone)
    print("-- Stopping the log stream")
    try:  # not asked again: a late answer is fine, the parts so far are kept
        await drone.log_streaming.stop_log_streaming()
    except LogStreamingError as error:
        if not timed_out(error):
            raise
        print("-- stop_log_streaming: no answer")
    await asyncio.sleep(0.5)  # the last parts
    receiver.cancel()
    data = b"".join(parts)
    if not data.startswith(ULOG_MAGIC):
        print(f"no ULog came (received {len(data)} bytes)")
        return 1
    out.write_bytes(data)
    print(f"-- saved {out} ({len(data)} bytes in {len(parts)} parts)")
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("streamed.ulg"),
                        help="file to write (default: streamed.ulg)")
    parser.add_argument("--hover", type=float, default=10.0, help="seconds to hover")
    args = arguments(parser.description or "", parser)
    raise SystemExit(asyncio.run(run(args.port, args.grpc_port, args.out, args.hover)))
