"""Helpers for MAVSDK 3.x flows: connect as the MSDK-Py examples do, wait on telemetry."""

from __future__ import annotations

import asyncio
import contextlib

from mavsdk import System

from gateway.ci.launcher import free_tcp_port
from vehicles.geodesy import distance_m, project, reproject  # noqa: F401 (re-exported)

HOME_LAT = 47.397742
HOME_LON = 8.545594


def offset_deg(lat: float, lon: float, north_m: float, east_m: float) -> tuple[float, float]:
    return reproject(lat, lon, north_m, east_m)


async def first(gen, predicate, timeout_s: float, what: str):
    async def scan():
        async for item in gen:
            if predicate(item):
                return item

    try:
        return await asyncio.wait_for(scan(), timeout_s)
    except asyncio.TimeoutError:
        raise AssertionError(f"timed out after {timeout_s} s waiting for {what}") from None


async def latest(gen):
    """The next value of a telemetry stream."""
    async for item in gen:
        return item


@contextlib.asynccontextmanager
async def connected(udp_port: int, *, healthy: bool = True):
    drone = System(port=free_tcp_port())
    await drone.connect(system_address=f"udpin://0.0.0.0:{udp_port}")
    try:
        await first(drone.core.connection_state(), lambda s: s.is_connected, 30, "connection")
        if healthy:
            await first(drone.telemetry.health(),
                        lambda h: h.is_global_position_ok and h.is_home_position_ok, 30, "health")
        yield drone
    finally:
        drone._stop_mavsdk_server()


async def land_and_disarm(drone, timeout_s: float = 90) -> None:
    await first(drone.telemetry.in_air(), lambda x: not x, timeout_s, "landed")
    await first(drone.telemetry.armed(), lambda a: not a, 15, "disarmed")
