#!/usr/bin/env python3
"""Print the vehicle's health and arming report and its events — MAVSDK's events plugin against
`make run`, as QGroundControl's arming-check view reads them (PX4's events protocol).

    .venv/bin/python gcs_examples/health_report.py              # the report, then exit
    .venv/bin/python gcs_examples/health_report.py --fly        # and the events of a flight

The report is what PX4's Commander last sent: for the current mode whether it can arm (or, armed,
run), every failing check and the health of each component. Needs MAVSDK-Python 3.x
(`pip install "mavsdk<4"`; `make run` installs it in .venv).
"""

import argparse
import asyncio

from _common import arguments, connect, retry, wait_landed

REPORT_TIMEOUT_S = 30.0


def show(report) -> None:
    mode = report.current_mode_intention
    verdict = "can arm" if mode.can_arm_or_run else "cannot arm"
    print(f"-- {mode.mode_name}: {verdict}")
    for problem in report.all_problems:
        where = f" [{problem.health_component}]" if problem.health_component else ""
        print(f"   {problem.log_level.name.lower()}: {problem.message}{where}")
    present = [c.label for c in report.health_components if c.is_present]
    failing = [c.label for c in report.health_components if c.has_error or c.has_warning]
    print(f"-- present: {', '.join(present)}")
    print(f"-- errors or warnings: {', '.join(failing) or 'none'}")


async def run(port: int, grpc_port: int, fly: bool) -> int:
    drone = await connect(port, grpc_port)

    async def first_report():
        async for report in drone.events.health_and_arming_checks():
            if report.current_mode_intention.mode_name:
                return report

    try:
        report = await asyncio.wait_for(first_report(), REPORT_TIMEOUT_S)
    except asyncio.TimeoutError:
        print(f"no health and arming report within {REPORT_TIMEOUT_S:.0f} s")
        return 1
    show(report)
    if not fly:
        return 0

    async def print_events():
        async for event in drone.events.events():
            print(f"-- event ({event.log_level.name.lower()}): {event.message}")

    printer = asyncio.ensure_future(print_events())
    print("-- Arming")
    await retry(drone.action.arm)
    print("-- Taking off")
    await retry(drone.action.takeoff)
    await asyncio.sleep(8)
    print("-- Landing")
    await retry(drone.action.land)
    await wait_landed(drone)
    await asyncio.sleep(1.0)  # the landing event
    printer.cancel()
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fly", action="store_true", help="take off, land, print the events")
    args = arguments(parser.description or "", parser)
    raise SystemExit(asyncio.run(run(args.port, args.grpc_port, args.fly)))
