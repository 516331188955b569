"""PX4's events protocol against MAVSDK's `events` plugin (libevents inside mavsdk_server): it
downloads the events metadata named by COMPONENT_METADATA over MAVLink FTP, asks for the health
and arming report (MAV_CMD_RUN_PREARM_CHECKS) and shows the report and the vehicle's events."""

import asyncio

import pytest

from tests.e2e.persona import connected, first, land_and_disarm

pytestmark = pytest.mark.e2e


def collect_events(drone) -> tuple[list[str], asyncio.Future]:
    """The messages of the vehicle's events as MAVSDK renders them, collected in the background
    (cancel the task when done)."""
    messages: list[str] = []

    async def collect():
        async for event in drone.events.events():
            messages.append(event.message)

    return messages, asyncio.ensure_future(collect())


@pytest.mark.asyncio
async def test_mavsdk_events_health_report_and_takeoff_event(daemon_factory):
    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        messages, task = collect_events(drone)
        report = await first(drone.events.health_and_arming_checks(),
                             lambda r: r.current_mode_intention.mode_name != "", 30,
                             "a health and arming report")
        # Hold with the position estimate, no mission, no sticks: it can arm.
        assert report.current_mode_intention.can_arm_or_run, report
        problems = [p.message for p in report.all_problems]
        assert "No manual control input" in problems and "No valid mission available" in problems
        by_name = {c.name: c for c in report.health_components}
        assert by_name["gps"].is_present and not by_name["gps"].has_error
        assert by_name["accel"].is_present and by_name["gyro"].is_present
        await drone.action.arm()
        await drone.action.takeoff()
        await first(drone.telemetry.in_air(), bool, 30, "in the air")
        await drone.action.land()
        await land_and_disarm(drone)
        for _ in range(50):
            if "Disarmed by landing" in messages:
                break
            await asyncio.sleep(0.1)
        task.cancel()
        # commander_armed_by / _disarmed_by: libevents names the reason from the metadata's
        # arm_disarm_reason_t.
        assert messages[-6:] == ["Armed by external command",
                                 "Using default takeoff altitude: 2.50 m", "Takeoff detected",
                                 "Landing at current position", "Landing detected",
                                 "Disarmed by landing"], messages


@pytest.mark.asyncio
async def test_mavsdk_events_say_why_the_failsafe_acts(daemon_factory):
    """The battery emptied in flight (failure injection): PX4's failsafe framework tells the
    user what it does and why (commander_failsafe_enter_hold, then commander_failsafe_enter),
    libevents naming the action and the cause from the metadata's enums; PX4 SITL's
    COM_LOW_BAT_ACT 2 lands at the emergency level after the COM_FAIL_ACT_T hold."""
    from mavsdk.failure import FailureType, FailureUnit

    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        messages, task = collect_events(drone)
        await drone.param.set_param_int("SYS_FAILURE_EN", 1)
        await drone.action.arm()
        await drone.action.takeoff()
        await first(drone.telemetry.in_air(), bool, 30, "in the air")
        await drone.failure.inject(FailureUnit.SYSTEM_BATTERY, FailureType.OFF, 0)
        want = ["Emergency battery level: switching to Land in 5 seconds",
                "Emergency battery level: switching to Land"]
        for _ in range(200):
            if all(m in messages for m in want):
                break
            await asyncio.sleep(0.1)
        task.cancel()
        # the failsafe's events, in order, and no other ("… switching to …", "Failsafe …")
        assert [m for m in messages if "switching to" in m or m.startswith("Failsafe")] == want, \
            messages
        await land_and_disarm(drone)


async def report_with_failure(drone, unit: str, predicate, what: str):
    """SYS_FAILURE_EN 1, a first report, then sensor ``unit`` (FailureUnit's name) off: the
    first report that satisfies ``predicate``."""
    from mavsdk.failure import FailureType, FailureUnit

    await drone.param.set_param_int("SYS_FAILURE_EN", 1)
    await first(drone.events.health_and_arming_checks(),
                lambda r: r.current_mode_intention.mode_name != "", 30, "a report")
    await drone.failure.inject(getattr(FailureUnit, unit), FailureType.OFF, 0)
    return await first(drone.events.health_and_arming_checks(), predicate, 30, what)


@pytest.mark.asyncio
async def test_mavsdk_health_report_names_the_failed_sensor(daemon_factory):
    """A GPS failure injected (MAV_CMD_INJECT_FAILURE, SYS_FAILURE_EN 1) is an error of the GPS
    component in the next report."""
    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        report = await report_with_failure(
            drone, "SENSOR_GPS", lambda r: any(c.name == "gps" and c.has_error
                                               for c in r.health_components),
            "the GPS failure in a report")
        assert report is not None


@pytest.mark.asyncio
async def test_mavsdk_health_report_and_arming_with_the_gyro_off(daemon_factory):
    """The gyro off (failure injection) for a second: PX4's "No valid data from Gyro 0" health
    failure, rendered by libevents from the metadata with its instance argument, and arming
    refused in every mode."""
    from mavsdk.action import ActionError

    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        report = await report_with_failure(
            drone, "SENSOR_GYRO", lambda r: any("Gyro" in p.message for p in r.all_problems),
            "the gyro failure in a report")
        problems = [p.message for p in report.all_problems]
        assert "No valid data from Gyro 0" in problems, problems
        assert not report.current_mode_intention.can_arm_or_run
        assert any(c.name == "gyro" and c.has_error for c in report.health_components)
        with pytest.raises(ActionError):
            await drone.action.arm()


def test_health_report_example_prints_the_report(daemon_factory):
    """gcs_examples/health_report.py as a user runs it."""
    import subprocess
    import sys
    from pathlib import Path

    from gateway.ci.launcher import free_tcp_port

    d = daemon_factory()
    script = Path(__file__).resolve().parents[2] / "gcs_examples" / "health_report.py"
    run = subprocess.run([sys.executable, str(script), "--port", str(d.api_port(0)),
                          "--grpc-port", str(free_tcp_port())],
                         capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    assert run.returncode == 0, f"{run.stdout}\n{run.stderr}"
    assert "-- Hold: can arm" in run.stdout, run.stdout
    assert "warning: No manual control input [remote_control]" in run.stdout, run.stdout
    assert "-- present: " in run.stdout and "GPS" in run.stdout, run.stdout
