"""MAVSDK-Python on the gRPC wrapper published as ``mavsdk-grpc`` 4.x (import ``mavsdk_grpc``,
its bundled mavsdk_server v4), run in its own venv by the e2e test.

Usage: python mavsdk_grpc_flight.py takeoff_land|mission|services UDP_PORT GRPC_PORT
Prints one line per phase and "RESULT ok ..." on success; exits 1 otherwise.
"""

import asyncio
import base64
import math
import sys

from mavsdk_grpc import System
from mavsdk_grpc.geofence import FenceType, GeofenceData, Point, Polygon
from mavsdk_grpc.mission import MissionItem, MissionPlan
from mavsdk_grpc.offboard import VelocityNedYaw
from mavsdk_grpc.shell import Device

# The square of the persona tests, 20 m sides, 2 m north-east of PX4's SITL home.
HOME_LAT, HOME_LON = 47.397742, 8.545594
EARTH_RADIUS_M = 6371000.0


async def first(stream, predicate, timeout_s, what):
    async def scan():
        async for item in stream:
            if predicate(item):
                return item

    try:
        item = await asyncio.wait_for(scan(), timeout_s)
    except asyncio.TimeoutError:
        raise SystemExit(f"FAIL: timed out waiting for {what}") from None
    print(f"ok: {what}", flush=True)
    return item


def offset_deg(north_m, east_m):
    lat = HOME_LAT + math.degrees(north_m / EARTH_RADIUS_M)
    lon = HOME_LON + math.degrees(east_m / (EARTH_RADIUS_M * math.cos(math.radians(HOME_LAT))))
    return lat, lon


def square(side_m=20.0):
    items = []
    for i, (n, e) in enumerate([(side_m, 0), (side_m, side_m), (0, side_m), (0, 0)]):
        lat, lon = offset_deg(n + 2, e + 2)
        items.append(MissionItem(lat, lon, 12.0 + i, 5.0, True, float("nan"), float("nan"),
                                 MissionItem.CameraAction.NONE, float("nan"), float("nan"),
                                 float("nan"), float("nan"), float("nan"),
                                 MissionItem.VehicleAction.NONE))
    return items


async def takeoff_land(drone):
    """...with the flight's ULog streamed (log_streaming): its size and whether it is one."""
    parts = []

    async def collect():
        async for part in drone.log_streaming.log_streaming_raw():
            parts.append(base64.b64decode(part.data_base64))

    receiver = asyncio.ensure_future(collect())
    await asyncio.sleep(0.5)
    await drone.log_streaming.start_log_streaming()
    print("ok: log streaming", flush=True)
    await drone.action.arm()
    print("ok: armed", flush=True)
    await drone.action.takeoff()
    await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 2.3, 30,
                "takeoff altitude")
    await asyncio.sleep(2.0)
    alts = []
    for _ in range(30):
        alts.append((await first(drone.telemetry.position(), lambda p: True, 5,
                                 "position")).relative_altitude_m)
    await drone.action.land()
    await first(drone.telemetry.in_air(), lambda x: not x, 60, "landed")
    await first(drone.telemetry.armed(), lambda a: not a, 15, "auto-disarm")
    await drone.log_streaming.stop_log_streaming()
    await asyncio.sleep(0.5)
    receiver.cancel()
    data = b"".join(parts)
    return (f"hover_min={min(alts):.2f} hover_max={max(alts):.2f} ulog_bytes={len(data)} "
            f"ulog_magic={data[:7] == bytes.fromhex('554c6f67011235')}")


async def mission(drone):
    items = square()
    await drone.mission.set_return_to_launch_after_mission(True)
    await drone.mission.upload_mission(MissionPlan(items))
    downloaded = await drone.mission.download_mission()
    if len(downloaded.mission_items) != len(items):
        raise SystemExit(f"FAIL: downloaded {len(downloaded.mission_items)} items")
    print("ok: uploaded and downloaded", flush=True)
    await drone.action.arm()
    await drone.mission.start_mission()
    progress = await first(drone.mission.mission_progress(),
                           lambda p: p.total > 0 and p.current == p.total, 240, "mission done")
    await first(drone.telemetry.in_air(), lambda x: not x, 120, "landed")
    await first(drone.telemetry.armed(), lambda a: not a, 15, "auto-disarm")
    finished = await drone.mission.is_mission_finished()
    return f"items={progress.total} finished={finished}"


async def services(drone):
    """The v4 core's other plugins a ground-station script uses: info, param, shell, geofence,
    ftp, log_files, then an Offboard velocity leg."""
    version = await drone.info.get_version()
    print(f"ok: version {version.flight_sw_major}.{version.flight_sw_minor}", flush=True)
    cruise = await drone.param.get_param_float("MPC_XY_CRUISE")
    await drone.param.set_param_float("MIS_TAKEOFF_ALT", 4.0)
    takeoff_alt = await drone.param.get_param_float("MIS_TAKEOFF_ALT")
    print("ok: params", flush=True)

    texts = []

    async def shell_out():
        async for received in drone.shell.receive():  # v4: text and device
            texts.append(received.data)

    reader = asyncio.ensure_future(shell_out())
    await asyncio.sleep(0.5)
    await drone.shell.send("ver all", Device.SHELL)  # v4: the device too
    for _ in range(50):
        if "PX4_SITL" in "".join(texts):
            break
        await asyncio.sleep(0.1)
    reader.cancel()
    shell_ok = "HW arch: PX4_SITL" in "".join(texts)
    print("ok: shell", flush=True)

    corners = [offset_deg(n, e) for n, e in [(-50, -50), (50, -50), (50, 50), (-50, 50)]]
    polygon = Polygon([Point(lat, lon) for lat, lon in corners], FenceType.INCLUSION)
    await drone.geofence.upload_geofence(GeofenceData([polygon], []))
    fence = await drone.geofence.download_geofence()
    print("ok: geofence", flush=True)

    listing = await drone.ftp.list_directory("/")
    entries = await drone.log_files.get_entries()
    print("ok: ftp and log_files", flush=True)

    await drone.action.arm()
    await drone.action.takeoff()
    await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 3.5, 30,
                "takeoff altitude")
    start = await first(drone.telemetry.position_velocity_ned(), lambda p: True, 5, "position")
    await drone.offboard.set_velocity_ned(VelocityNedYaw(0.0, 0.0, 0.0, 0.0))
    await drone.offboard.start()
    await drone.offboard.set_velocity_ned(VelocityNedYaw(2.0, 0.0, 0.0, 0.0))
    await first(drone.telemetry.flight_mode(), lambda m: m.name == "OFFBOARD", 10, "offboard")
    await asyncio.sleep(4.0)
    await drone.offboard.stop()
    end = await first(drone.telemetry.position_velocity_ned(), lambda p: True, 5, "position")
    north_m = end.position.north_m - start.position.north_m
    await drone.action.land()
    await first(drone.telemetry.in_air(), lambda x: not x, 60, "landed")
    await first(drone.telemetry.armed(), lambda a: not a, 15, "auto-disarm")
    return (f"cruise={cruise:.1f} takeoff_alt={takeoff_alt:.1f} shell={shell_ok} "
            f"fence_vertices={sum(len(p.points) for p in fence.polygons)} "
            f"ftp_entries={len(listing.entries)} logs={len(entries)} "
            f"offboard_north_m={north_m:.1f}")


async def main(flow, udp_port, grpc_port):
    drone = System(port=grpc_port)
    await drone.connect(system_address=f"udpin://0.0.0.0:{udp_port}")
    try:
        await first(drone.core.connection_state(), lambda s: s.is_connected, 30, "connected")
        await first(drone.telemetry.health(),
                    lambda h: h.is_global_position_ok and h.is_home_position_ok, 30, "health")
        result = await {"takeoff_land": takeoff_land, "mission": mission,
                        "services": services}[flow](drone)
        print(f"RESULT ok {result}", flush=True)
    finally:
        drone._stop_mavsdk_server()


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3])))
