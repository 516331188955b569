#!/usr/bin/env python3
"""Offboard with velocity setpoints: climb in NED velocity, then fly forward in the body frame."""

import asyncio

from _common import arguments, connect, retry, wait_landed
from mavsdk.offboard import OffboardError, VelocityBodyYawspeed, VelocityNedYaw


async def run(port: int, grpc_port: int) -> None:
    drone = await connect(port, grpc_port)
    print("-- Arming")
    await retry(drone.action.arm)
    await drone.offboard.set_velocity_ned(VelocityNedYaw(0.0, 0.0, 0.0, 0.0))
    print("-- Starting offboard")
    try:
        await retry(drone.offboard.start)
    except OffboardError as error:
        print(f"Starting offboard mode failed: {error._result.result}")
        await retry(drone.action.disarm)
        return
    print("-- Climb at 2 m/s for 3 s, facing east")
    await drone.offboard.set_velocity_ned(VelocityNedYaw(0.0, 0.0, -2.0, 90.0))
    await asyncio.sleep(3)
    print("-- Hover")
    await drone.offboard.set_velocity_ned(VelocityNedYaw(0.0, 0.0, 0.0, 90.0))
    await asyncio.sleep(3)
    print("-- Forward at 3 m/s in the body frame (that is east)")
    await drone.offboard.set_velocity_body(VelocityBodyYawspeed(3.0, 0.0, 0.0, 0.0))
    await asyncio.sleep(5)
    print("-- Turn at 30 deg/s while flying forward: a circle")
    await drone.offboard.set_velocity_body(VelocityBodyYawspeed(3.0, 0.0, 0.0, 30.0))
    await asyncio.sleep(12)
    await drone.offboard.set_velocity_body(VelocityBodyYawspeed(0.0, 0.0, 0.0, 0.0))
    await asyncio.sleep(2)
    async for pv in drone.telemetry.position_velocity_ned():
        p = pv.position
        print(f"-- At N {p.north_m:.2f} E {p.east_m:.2f} D {p.down_m:.2f}")
        break
    print("-- Stopping offboard, landing")
    await retry(drone.offboard.stop)
    await retry(drone.action.land)
    await wait_landed(drone)


if __name__ == "__main__":
    args = arguments(__doc__.splitlines()[0])
    asyncio.run(run(args.port, args.grpc_port))
