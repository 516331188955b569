"""PX4's own SITL tests (PX4 v1.15.2 ``test/mavsdk_tests/test_multicopter_*.cpp``, the cases
its CI runs on the iris quadrotor: tags [multicopter], [offboard], [offboard_attitude]), each
against a fresh ``cornet run`` at speed 20 as PX4's CI runs them (``mavsdk_test_runner.py
--speed-factor 20``), through the same harness (tests/e2e/autopilot_tester.py).

Not here: [controlallocation] (PX4 runs it on the typhoon_h480 hexacopter; a quadrotor cannot
lose a motor and fly), [vtol], and the cases PX4 compiles out (``#if 0``)."""

from __future__ import annotations

import pytest
import pytest_asyncio
from mavsdk.failure import FailureType, FailureUnit
from mavsdk.offboard import PositionNedYaw

from tests.e2e.autopilot_tester import (
    HEIGHT_SOURCE_BARO,
    HEIGHT_SOURCE_GPS,
    RC_LOSS_EXCEPTION_OFFBOARD,
    AutopilotTester,
    MissionOptions,
    connected,
)

pytestmark = [pytest.mark.e2e, pytest.mark.slow, pytest.mark.asyncio]

SPEED = "20"


@pytest_asyncio.fixture
async def tester(daemon_factory):
    d = daemon_factory("--speed", SPEED)
    async with connected(AutopilotTester(), d.api_port(0)) as t:
        yield t
    assert not t.failures, t.failures


# --- test_multicopter_mission.cpp ---------------------------------------------------------------

async def test_takeoff_and_land(tester):
    await tester.wait_until_ready()
    await tester.arm()
    await tester.takeoff()
    await tester.wait_until_hovering()
    await tester.land()
    await tester.wait_until_disarmed(180)


async def test_fly_square_multicopter_missions_including_rtl(tester):
    await tester.wait_until_ready()
    await tester.prepare_square_mission(MissionOptions(rtl_at_end=True))
    await tester.arm()
    await tester.execute_mission()
    await tester.wait_until_disarmed(180)


async def test_fly_square_multicopter_missions_with_manual_rtl(tester):
    await tester.wait_until_ready()
    await tester.prepare_square_mission(MissionOptions(rtl_at_end=False))
    await tester.check_tracks_mission(5.0)
    await tester.arm()
    await tester.execute_mission()
    await tester.wait_until_hovering()
    await tester.execute_rtl()
    await tester.wait_until_disarmed(180)


async def test_fly_straight_multicopter_mission(tester):
    await tester.wait_until_ready()
    await tester.prepare_straight_mission(MissionOptions(rtl_at_end=False, fly_through=True))
    await tester.check_mission_item_speed_above(2, 4.0)
    await tester.check_tracks_mission(5.0)
    await tester.arm()
    await tester.execute_mission()
    await tester.wait_until_hovering()
    await tester.execute_rtl()
    await tester.wait_until_disarmed(180)


# --- test_multicopter_failure_injection.cpp -----------------------------------------------------

async def test_failure_injection_reject_mid_air_when_disabled(tester):
    await tester.create_failure_plugin()
    await tester.wait_until_ready()
    await tester.set_param_int("SYS_FAILURE_EN", 0)
    await tester.arm()
    await tester.takeoff()
    await tester.wait_until_hovering()
    await tester.inject_failure(FailureUnit.SYSTEM_MOTOR, FailureType.OFF, 1, "DISABLED")
    await tester.execute_rtl()
    await tester.wait_until_disarmed(180)


# --- test_multicopter_manual.cpp ----------------------------------------------------------------

async def test_fly_forward_in_position_control(tester):
    await tester.fly_forward_in_posctl()
    await tester.wait_until_disarmed(180)
    tester.check_home_not_within(5.0)


async def test_fly_forward_in_altitude_control(tester):
    await tester.fly_forward_in_altctl()
    await tester.wait_until_disarmed(180)
    tester.check_home_not_within(5.0)


# --- test_multicopter_offboard.cpp --------------------------------------------------------------

ACCEPTANCE_RADIUS = 0.3


async def test_offboard_takeoff_and_land(tester):
    await tester.wait_until_ready()
    await tester.store_home()
    await tester.set_rc_loss_exception(RC_LOSS_EXCEPTION_OFFBOARD)
    await tester.arm()
    await tester.offboard_goto(PositionNedYaw(0.0, 0.0, -2.0, 0.0), ACCEPTANCE_RADIUS, 90)
    await tester.offboard_land()
    await tester.wait_until_disarmed(120)
    tester.check_home_within(1.0)


async def test_offboard_position_control(tester):
    takeoff = PositionNedYaw(0.0, 0.0, -2.0, 0.0)
    await tester.wait_until_ready()
    await tester.store_home()
    await tester.set_rc_loss_exception(RC_LOSS_EXCEPTION_OFFBOARD)
    await tester.arm()
    for target in (takeoff, PositionNedYaw(0.0, 5.0, -2.0, 180.0),
                   PositionNedYaw(5.0, 5.0, -4.0, 180.0), PositionNedYaw(5.0, 0.0, -4.0, 90.0),
                   takeoff):
        await tester.offboard_goto(target, ACCEPTANCE_RADIUS, 10)
    await tester.offboard_land()
    await tester.wait_until_disarmed(120)
    tester.check_home_within(1.0)


async def test_offboard_attitude_control(tester):
    await tester.set_rc_loss_exception(RC_LOSS_EXCEPTION_OFFBOARD)
    await tester.fly_forward_in_offboard_attitude()
    await tester.wait_until_disarmed(120)


# --- test_multicopter_failsafe.cpp --------------------------------------------------------------

async def _mission_with_failure(tester, height_source, execute, disarm_timeout_s=180):
    if height_source is not None:
        await tester.set_height_source(height_source)
    await tester.wait_until_ready()
    await tester.prepare_square_mission(MissionOptions(rtl_at_end=True))
    await tester.arm()
    await execute()
    await tester.wait_until_disarmed(disarm_timeout_s)


async def test_land_on_gps_lost_during_mission_baro_height(tester):
    await _mission_with_failure(tester, HEIGHT_SOURCE_BARO, tester.execute_mission_and_lose_gps,
                                300)


async def test_land_on_gps_lost_during_mission_gps_height(tester):
    await _mission_with_failure(tester, HEIGHT_SOURCE_GPS, tester.execute_mission_and_lose_gps)


async def test_continue_on_mag_lost_during_mission(tester):
    await _mission_with_failure(tester, None, tester.execute_mission_and_lose_mag)


@pytest.mark.parametrize("height_source", [HEIGHT_SOURCE_BARO, HEIGHT_SOURCE_GPS],
                         ids=["baro_height", "gps_height"])
async def test_continue_on_baro_lost_during_mission(tester, height_source):
    await _mission_with_failure(tester, height_source, tester.execute_mission_and_lose_baro)


@pytest.mark.parametrize("height_source", [HEIGHT_SOURCE_BARO, HEIGHT_SOURCE_GPS],
                         ids=["baro_height", "gps_height"])
async def test_continue_on_baro_stuck_during_mission(tester, height_source):
    await _mission_with_failure(tester, height_source, tester.execute_mission_and_get_baro_stuck)
