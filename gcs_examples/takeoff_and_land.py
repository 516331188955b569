#!/usr/bin/env python3
"""Take off, hover, land — the MAVSDK-Python example flow, unchanged, against `make run`.

    .venv/bin/python gcs_examples/takeoff_and_land.py            # vehicle 1 (API port 14540)
    .venv/bin/python gcs_examples/takeoff_and_land.py --port 14541   # vehicle 2

Needs MAVSDK-Python 3.x (`pip install "mavsdk<4"`; `make run` installs it in .venv).
"""

import argparse
import asyncio

from mavsdk import System


async def run(port: int, grpc_port: int) -> None:
    drone = System(port=grpc_port)
    await drone.connect(system_address=f"udpin://0.0.0.0:{port}")

    print("Waiting for drone to connect...")
    async for state in drone.core.connection_state():
        if state.is_connected:
            print("-- Connected to drone!")
            break

    print("Waiting for drone to have a global position estimate...")
    async for health in drone.telemetry.health():
        if health.is_global_position_ok and health.is_home_position_ok:
            print("-- Global position estimate OK")
            break

    print("-- Arming")
    await drone.action.arm()

    print("-- Taking off")
    await drone.action.takeoff()

    await asyncio.sleep(10)

    async for position in drone.telemetry.position():
        print(f"-- Hovering at {position.relative_altitude_m:.2f} m above home")
        break

    print("-- Landing")
    await drone.action.land()

    async for in_air in drone.telemetry.in_air():
        if not in_air:
            print("-- Landed")
            break

    async for armed in drone.telemetry.armed():
        if not armed:
            print("-- Disarmed by the vehicle after landing")
            break


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--port", type=int, default=14540, help="UDP port to listen on")
    parser.add_argument("--grpc-port", type=int, default=50051, help="mavsdk_server gRPC port")
    args = parser.parse_args()
    asyncio.run(run(args.port, args.grpc_port))
