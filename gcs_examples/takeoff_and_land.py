#!/usr/bin/env python3
"""Take off, hover, land — the MAVSDK-Python example flow against `make run` (a command that
timed out on a lossy link is asked again).

    .venv/bin/python gcs_examples/takeoff_and_land.py            # vehicle 1 (API port 14540)
    .venv/bin/python gcs_examples/takeoff_and_land.py --port 14541   # vehicle 2

Needs MAVSDK-Python 3.x (`pip install "mavsdk<4"`; `make run` installs it in .venv).
"""

import asyncio

from _common import arguments, connect, first_value, retry, wait_landed


async def run(port: int, grpc_port: int) -> None:
    drone = await connect(port, grpc_port)

    print("-- Arming")
    await retry(drone.action.arm)

    print("-- Taking off")
    await retry(drone.action.takeoff)

    await asyncio.sleep(10)

    position = await first_value(drone.telemetry.position())
    print(f"-- Hovering at {position.relative_altitude_m:.2f} m above home")

    print("-- Landing")
    await retry(drone.action.land)
    await wait_landed(drone)


if __name__ == "__main__":
    args = arguments(__doc__.splitlines()[0])
    asyncio.run(run(args.port, args.grpc_port))
