"""Shared by the MAVSDK examples: connect as the MSDK-Py examples do, wait for a healthy vehicle."""

import argparse

from mavsdk import System

from vehicles.geodesy import reproject


def arguments(description: str, parser: argparse.ArgumentParser | None = None
              ) -> argparse.Namespace:
    """--port and --grpc-port (added to ``parser``, a script's own, if given), parsed."""
    parser = parser or argparse.ArgumentParser(description=description)
    parser.add_argument("--port", type=int, default=14540,
                        help="UDP port to listen on (vehicle i talks to 14540+i)")
    parser.add_argument("--grpc-port", type=int, default=50051, help="mavsdk_server gRPC port")
    return parser.parse_args()


async def connect(port: int, grpc_port: int, healthy: bool = True) -> System:
    """Connected, and (``healthy``) with a global position estimate and a home position."""
    drone = System(port=grpc_port)
    await drone.connect(system_address=f"udpin://0.0.0.0:{port}")
    print("Waiting for drone to connect...")
    async for state in drone.core.connection_state():
        if state.is_connected:
            print("-- Connected to drone!")
            break
    if not healthy:
        return drone
    print("Waiting for drone to have a global position estimate...")
    async for health in drone.telemetry.health():
        if health.is_global_position_ok and health.is_home_position_ok:
            print("-- Global position estimate OK")
            break
    return drone


async def retry(call, *args, attempts: int = 5):
    """``await call(*args)``, asked again when it timed out. MAVSDK sends a command a few times
    before it gives up; over a lossy link (e.g. ``--scenario lossy-wifi``, 20 % each way) all of
    them can be lost, and a script meant for such links asks again, as a pilot would."""
    for attempt in range(attempts):
        try:
            return await call(*args)
        except Exception as exc:  # ActionError, MissionError, OffboardError, GeofenceError, ...
            result = getattr(getattr(exc, "_result", None), "result", None)
            if getattr(result, "name", "") != "TIMEOUT" or attempt == attempts - 1:
                raise
            print(f"-- {call.__name__}: no answer, asking again")


def offset(lat_deg: float, lon_deg: float, north_m: float, east_m: float) -> tuple[float, float]:
    """The point north_m / east_m away (PX4's map projection, as the vehicle computes it)."""
    return reproject(lat_deg, lon_deg, north_m, east_m)


async def first_value(stream):
    """The next value of a MAVSDK telemetry stream."""
    async for value in stream:
        return value


async def wait_landed(drone) -> None:
    async for in_air in drone.telemetry.in_air():
        if not in_air:
            print("-- Landed")
            break
    async for armed in drone.telemetry.armed():
        if not armed:
            print("-- Disarmed")
            break
