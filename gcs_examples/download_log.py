#!/usr/bin/env python3
"""Download the vehicle's newest ULog flight log — MAVSDK-Python's logfile_download flow against
`make run`, whose vehicles log from boot (PX4 SITL's SDLOG_MODE 1) into state/.

    .venv/bin/python gcs_examples/download_log.py                  # into the current directory
    .venv/bin/python gcs_examples/download_log.py --out flight.ulg

pyulog (`ulog_info flight.ulg`), Flight Review and PlotJuggler read the file. Needs MAVSDK-Python
3.x (`pip install "mavsdk<4"`; `make run` installs it in .venv).
"""

import argparse
import asyncio
import sys
from pathlib import Path

from _common import arguments, connect

ULOG_MAGIC = b"ULog\x01\x12\x35"


async def run(port: int, grpc_port: int, out: Path | None) -> int:
    drone = await connect(port, grpc_port, healthy=False)
    entries = await drone.log_files.get_entries()
    for entry in entries:
        print(f"-- log {entry.id}: {entry.date}, {entry.size_bytes} bytes")
    if not entries:
        print("no logs on the vehicle (started without a state directory?)")
        return 1
    newest = entries[-1]
    path = out or Path(f"log-{newest.date.replace(':', '-')}.ulg")
    async for progress in drone.log_files.download_log_file(newest, str(path)):
        print(f"\r-- downloading log {newest.id}: {100 * progress.progress:5.1f} %", end="")
    print()
    head = path.read_bytes()[:len(ULOG_MAGIC)]
    if head != ULOG_MAGIC:
        print(f"{path} is not a ULog file (starts {head!r})")
        return 1
    print(f"-- saved {path} ({path.stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="file to write (default: log-<date>.ulg)")
    args = arguments(parser.description or "", parser)
    sys.exit(asyncio.run(run(args.port, args.grpc_port, args.out)))
