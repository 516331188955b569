"""MAVSDK 4.x (native binding) takeoff → hover → land, run in its own venv by the e2e test, with
the flight's ULog streamed (log_streaming) into ULOG_FILE.

Usage: python mavsdk4_takeoff_land.py UDP_PORT ULOG_FILE
Prints one line per phase and "RESULT ok hover_min=.. hover_max=.." on success; exits 1 otherwise.
"""

import asyncio
import base64
import sys

from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.log_streaming import LogStreamingAsync
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


async def main(port: int, ulog_file: str) -> None:
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
        stream = LogStreamingAsync(system)
        parts: list[bytes] = []

        async def collect():
            async for part in stream.subscribe_log_streaming_raw():
                parts.append(base64.b64decode(part.data_base64))

        receiver = asyncio.ensure_future(collect())
        await asyncio.sleep(0.5)
        await stream.start_log_streaming()
        print("ok: log streaming", flush=True)
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
        await stream.stop_log_streaming()
        await asyncio.sleep(0.5)
        receiver.cancel()
        with open(ulog_file, "wb") as f:
            f.write(b"".join(parts))
        print(f"RESULT ok hover_min={min(alts):.2f} hover_max={max(alts):.2f}", flush=True)


if __name__ == "__main__":
    asyncio.run(main(int(sys.argv[1]), sys.argv[2]))
