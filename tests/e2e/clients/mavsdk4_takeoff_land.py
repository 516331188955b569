"""MAVSDK 4.x (native binding) takeoff → hover → land, run in its own venv by the e2e test.

Usage: python mavsdk4_takeoff_land.py UDP_PORT
Prints one line per phase and "RESULT ok hover_min=.. hover_max=.." on success; exits 1 otherwise.
"""

import asyncio
import sys

from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.param import ParamAsync
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync


async def wait_for(what, check, timeout_s, period_s=0.1):
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while loop.time() < deadline:
        if await check():
            print(f"ok: {what}", flush=True)
            return
        await asyncio.sleep(period_s)
    raise SystemExit(f"FAIL: timed out waiting for {what}")


async def main(port: int) -> None:
    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as mavsdk:
        await mavsdk.add_any_connection(f"udpin://0.0.0.0:{port}")
        system = await mavsdk.first_autopilot(timeout_s=20.0)
        if system is None:
            raise SystemExit("FAIL: no autopilot discovered")
        print("ok: discovered autopilot", flush=True)
        action = ActionAsync(system)
        telemetry = TelemetryAsync(system)
        param = ParamAsync(system)
        # What the MAVSDK 4 example does first.
        takeoff_alt = await param.get_param_float("MIS_TAKEOFF_ALT")
        rtl_alt = await param.get_param_float("RTL_RETURN_ALT")
        print(f"ok: MIS_TAKEOFF_ALT={takeoff_alt} RTL_RETURN_ALT={rtl_alt}", flush=True)

        async def healthy():
            h = await telemetry.health()
            return h.is_global_position_ok and h.is_home_position_ok

        await wait_for("health", healthy, 30)
        await action.arm()
        print("ok: armed", flush=True)
        await action.takeoff()

        async def high_enough():
            return (await telemetry.position()).relative_altitude_m > 2.3

        await wait_for("takeoff altitude", high_enough, 30)
        await asyncio.sleep(2.0)
        alts = []
        for _ in range(30):
            alts.append((await telemetry.position()).relative_altitude_m)
            await asyncio.sleep(0.1)
        await action.land()

        async def on_ground():
            return not await telemetry.in_air()

        await wait_for("landed", on_ground, 60)

        async def disarmed():
            return not await telemetry.armed()

        await wait_for("auto-disarm", disarmed, 15)
        print(f"RESULT ok hover_min={min(alts):.2f} hover_max={max(alts):.2f}", flush=True)


if __name__ == "__main__":
    asyncio.run(main(int(sys.argv[1])))
