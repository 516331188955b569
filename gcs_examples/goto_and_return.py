#!/usr/bin/env python3
"""Take off to 6 m, go to a point 35 m away at 15 m, hold, then return to launch."""

import asyncio

from _common import arguments, connect, first_value, offset, retry, wait_landed


async def run(port: int, grpc_port: int) -> None:
    drone = await connect(port, grpc_port)
    print(f"-- Takeoff altitude was {await drone.action.get_takeoff_altitude()} m; set 6 m")
    await retry(drone.action.set_takeoff_altitude, 6.0)
    await retry(drone.action.arm)
    await retry(drone.action.takeoff)
    await asyncio.sleep(8)
    home = await first_value(drone.telemetry.home())
    lat, lon = offset(home.latitude_deg, home.longitude_deg, 21.0, 28.0)
    print("-- Going 35 m north-east at 15 m above home")
    await retry(drone.action.goto_location, lat, lon, home.absolute_altitude_m + 15.0, 0.0)
    await asyncio.sleep(20)
    print("-- Holding")
    await retry(drone.action.hold)
    await asyncio.sleep(5)
    async for p in drone.telemetry.position():
        print(f"-- At {p.latitude_deg:.7f}, {p.longitude_deg:.7f}, {p.relative_altitude_m:.1f} m")
        break
    print("-- Returning to launch")
    await retry(drone.action.return_to_launch)
    await wait_landed(drone)


if __name__ == "__main__":
    args = arguments(__doc__.splitlines()[0])
    asyncio.run(run(args.port, args.grpc_port))
