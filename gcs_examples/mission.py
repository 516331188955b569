#!/usr/bin/env python3
"""Upload a 4-waypoint square, read it back, fly it and return to launch."""

import asyncio

from _common import arguments, connect, first_value, offset, retry, wait_landed
from mavsdk.mission import MissionItem, MissionPlan

NAN = float("nan")


def waypoint(lat: float, lon: float, rel_alt_m: float, speed_mps: float) -> MissionItem:
    return MissionItem(lat, lon, rel_alt_m, speed_mps, True, NAN, NAN,
                       MissionItem.CameraAction.NONE, NAN, NAN, NAN, NAN, NAN,
                       MissionItem.VehicleAction.NONE)


async def run(port: int, grpc_port: int) -> None:
    drone = await connect(port, grpc_port)
    home = await first_value(drone.telemetry.home())
    corners = [(20, 0, 12), (20, 20, 13), (0, 20, 14), (0, 0, 15)]
    items = [waypoint(*offset(home.latitude_deg, home.longitude_deg, n, e), alt, 5.0)
             for n, e, alt in corners]
    await retry(drone.mission.set_return_to_launch_after_mission, True)
    print(f"-- Uploading {len(items)} waypoints")
    await retry(drone.mission.upload_mission, MissionPlan(items))
    downloaded = await retry(drone.mission.download_mission)
    print(f"-- Downloaded {len(downloaded.mission_items)} waypoints back")

    async def progress():
        async for p in drone.mission.mission_progress():
            print(f"Mission progress: {p.current}/{p.total}")

    progress_task = asyncio.ensure_future(progress())
    print("-- Arming")
    await retry(drone.action.arm)
    print("-- Starting mission")
    await retry(drone.mission.start_mission)
    async for in_air in drone.telemetry.in_air():
        if in_air:
            break
    await wait_landed(drone)
    progress_task.cancel()
    print(f"-- Mission finished: {await drone.mission.is_mission_finished()}")


if __name__ == "__main__":
    args = arguments(__doc__.splitlines()[0])
    asyncio.run(run(args.port, args.grpc_port))
