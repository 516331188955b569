"""Faster than real time with unmodified MAVSDK scripts: --speed scales the whole simulation."""

import pytest
from mavsdk.mission import MissionPlan

from tests.e2e.flows import takeoff_hover_land
from tests.e2e.persona import connected, first, land_and_disarm
from tests.e2e.test_mavsdk3_persona import square_mission

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


@pytest.mark.asyncio
async def test_mission_at_speed_10(daemon_factory):
    d = daemon_factory("--speed", "10")
    assert "speed 10x" in d.ready_line
    async with connected(d.api_port()) as drone:
        # Client time-outs are counted in simulated time, scaled as PX4's rcS does.
        assert await drone.param.get_param_float("COM_OF_LOSS_T") == pytest.approx(10.0)
        assert await drone.param.get_param_int("COM_DL_LOSS_T") == 100
        items = square_mission()
        await drone.mission.set_return_to_launch_after_mission(True)
        await drone.mission.upload_mission(MissionPlan(items))
        await drone.action.arm()
        await drone.mission.start_mission()
        await first(drone.mission.mission_progress(),
                    lambda p: p.total > 0 and p.current == p.total, 60, "mission done")
        await land_and_disarm(drone, 60)
        assert await drone.mission.is_mission_finished()


@pytest.mark.asyncio
async def test_takeoff_and_land_at_speed_20(daemon_factory):
    d = daemon_factory("--speed", "20")
    r = await takeoff_hover_land(d.api_port(0), hover_s=1.0)
    assert 2.2 <= r.hover_alt_min_m and r.hover_alt_max_m <= 2.8, r
