"""The MAVSDK-Python (3.x, gRPC) example flow, with measurements, used by several tests."""

from __future__ import annotations

import asyncio
from dataclasses import dataclass

from mavsdk import System

from gateway.ci.launcher import free_tcp_port
from tests.e2e.persona import first


@dataclass
class FlightReport:
    hover_alt_min_m: float
    hover_alt_max_m: float
    disarmed_after_landing: bool
    status_texts: list[str]


async def retry_on_timeout(action, attempts: int = 3):
    """Call a MAVSDK action again when its command timed out. MAVSDK sends a command 4 times
    (0.5 s apart); at 20 % loss each way an attempt fails with p = 0.36, all four with p = 1.7 %,
    which a script meant for lossy links handles by asking again."""
    from mavsdk.action import ActionError, ActionResult

    for attempt in range(attempts):
        try:
            return await action()
        except ActionError as exc:
            if exc._result.result != ActionResult.Result.TIMEOUT or attempt == attempts - 1:
                raise


async def takeoff_hover_land(udp_port: int, hover_s: float = 5.0,
                             timeout_scale: float = 1.0) -> FlightReport:
    drone = System(port=free_tcp_port())
    await drone.connect(system_address=f"udpin://0.0.0.0:{udp_port}")
    texts: list[str] = []

    async def collect_texts():
        async for t in drone.telemetry.status_text():
            texts.append(t.text)

    text_task = asyncio.ensure_future(collect_texts())
    try:
        t = timeout_scale
        await first(drone.core.connection_state(), lambda s: s.is_connected, 30 * t, "connection")
        await first(drone.telemetry.health(),
                     lambda h: h.is_global_position_ok and h.is_home_position_ok, 30 * t, "health")
        await retry_on_timeout(drone.action.arm)
        await retry_on_timeout(drone.action.takeoff)
        await first(drone.telemetry.in_air(), bool, 20 * t, "in_air")
        # Takeoff climbs at 1.5 m/s to 2.5 m; then the vehicle holds.
        await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 2.3, 30 * t,
                     "takeoff altitude")
        await asyncio.sleep(2.0)
        alts = []

        async def sample():
            async for p in drone.telemetry.position():
                alts.append(p.relative_altitude_m)

        sampler = asyncio.ensure_future(sample())
        await asyncio.sleep(hover_s)
        sampler.cancel()
        await retry_on_timeout(drone.action.land)
        await first(drone.telemetry.in_air(), lambda x: not x, 60 * t, "landed")
        await first(drone.telemetry.armed(), lambda a: not a, 15 * t, "auto-disarm")
        return FlightReport(min(alts), max(alts), True, texts)
    finally:
        text_task.cancel()
        drone._stop_mavsdk_server()


async def fly_square_mission(drone, mission_timeout_s: float, land_timeout_s: float) -> None:
    """MAVSDK's mission flow on the persona tests' square (return after it): upload, arm,
    start, every item reached, landed and disarmed, mission finished."""
    from mavsdk.mission import MissionPlan

    from tests.e2e.persona import first, land_and_disarm
    from tests.e2e.test_mavsdk3_persona import square_mission

    await drone.mission.set_return_to_launch_after_mission(True)
    await drone.mission.upload_mission(MissionPlan(square_mission()))
    await drone.action.arm()
    await drone.mission.start_mission()
    await first(drone.mission.mission_progress(),
                lambda p: p.total > 0 and p.current == p.total, mission_timeout_s, "mission done")
    await land_and_disarm(drone, land_timeout_s)
    assert await drone.mission.is_mission_finished()
