#!/usr/bin/env python3
"""Offboard with position NED setpoints: a 10 m box at 5-8 m, a yaw turn, then land."""

import asyncio

from _common import arguments, connect, retry, wait_landed
from mavsdk.offboard import OffboardError, PositionNedYaw


async def run(port: int, grpc_port: int) -> None:
    drone = await connect(port, grpc_port)
    print("-- Arming")
    await retry(drone.action.arm)
    print("-- Setting initial setpoint")
    await drone.offboard.set_position_ned(PositionNedYaw(0.0, 0.0, 0.0, 0.0))
    print("-- Starting offboard")
    try:
        await retry(drone.offboard.start)
    except OffboardError as error:
        print(f"Starting offboard mode failed: {error._result.result}")
        await retry(drone.action.disarm)
        return
    for north, east, down, yaw in [(0, 0, -5, 0), (10, 0, -5, 0), (10, 10, -8, 0),
                                   (10, 10, -8, 90)]:
        print(f"-- Go to N {north} m, E {east} m, D {down} m, yaw {yaw} deg")
        await drone.offboard.set_position_ned(PositionNedYaw(north, east, down, yaw))
        await asyncio.sleep(8)
    async for pv in drone.telemetry.position_velocity_ned():
        p = pv.position
        print(f"-- At N {p.north_m:.2f} E {p.east_m:.2f} D {p.down_m:.2f}")
        break
    print("-- Stopping offboard")
    await retry(drone.offboard.stop)
    print("-- Landing")
    await retry(drone.action.land)
    await wait_landed(drone)


if __name__ == "__main__":
    args = arguments(__doc__.splitlines()[0])
    asyncio.run(run(args.port, args.grpc_port))
