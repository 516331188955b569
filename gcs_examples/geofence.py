#!/usr/bin/env python3
"""Upload a 30 m square inclusion geofence, then fly out of it: PX4's GF_ACTION (Hold) stops us.

A goto outside the fence would be refused ("Reposition is outside geofence"), so the vehicle
leaves the fence under offboard velocity control, as a misbehaving companion computer would.
What follows is PX4's failsafe chain: the breach switches to Hold; MAVSDK stops streaming
offboard setpoints a few seconds after the vehicle left Offboard; that is an offboard loss, whose
action (COM_OBL_RC_ACT, with no RC: NAV_RCL_ACT = Return) is more severe than Hold, so after the
COM_FAIL_ACT_T delay the vehicle returns home and lands. Watch the status texts.
"""

import asyncio

from _common import arguments, connect, first_value, offset, retry, wait_landed
from mavsdk.geofence import FenceType, GeofenceData, Point, Polygon
from mavsdk.offboard import VelocityNedYaw


async def run(port: int, grpc_port: int) -> None:
    drone = await connect(port, grpc_port)
    home = await first_value(drone.telemetry.home())
    lat0, lon0 = home.latitude_deg, home.longitude_deg
    corners = [offset(lat0, lon0, n, e) for n, e in [(-15, -15), (15, -15), (15, 15), (-15, 15)]]
    polygon = Polygon([Point(lat, lon) for lat, lon in corners], FenceType.INCLUSION)
    print("-- Uploading the geofence")
    await retry(drone.geofence.upload_geofence, GeofenceData([polygon], []))

    async def texts():
        async for t in drone.telemetry.status_text():
            print(f"   [{t.type}] {t.text}")

    text_task = asyncio.ensure_future(texts())
    await retry(drone.action.arm)
    await retry(drone.action.takeoff)
    await asyncio.sleep(8)
    print("-- Flying north at 3 m/s in offboard, towards the fence")
    await drone.offboard.set_velocity_ned(VelocityNedYaw(3.0, 0.0, 0.0, 0.0))
    await retry(drone.offboard.start)
    await asyncio.sleep(15)
    async for mode in drone.telemetry.flight_mode():
        print(f"-- Flight mode now: {mode}")
        break
    async for pv in drone.telemetry.position_velocity_ned():
        print(f"-- Stopped {pv.position.north_m:.1f} m north of the start")
        break
    print("-- Landing")
    await retry(drone.offboard.stop)
    await retry(drone.action.land)
    await wait_landed(drone)
    text_task.cancel()


if __name__ == "__main__":
    args = arguments(__doc__.splitlines()[0])
    asyncio.run(run(args.port, args.grpc_port))
