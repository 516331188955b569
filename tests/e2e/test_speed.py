"""Faster than real time with unmodified MAVSDK scripts: --speed scales the whole simulation."""

import pytest

from tests.e2e.flows import fly_square_mission, takeoff_hover_land
from tests.e2e.persona import connected

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


@pytest.mark.asyncio
async def test_mission_at_speed_10(daemon_factory):
    d = daemon_factory("--speed", "10")
    assert "speed 10x" in d.ready_line
    async with connected(d.api_port()) as drone:
        # Client time-outs are counted in simulated time, scaled as PX4's rcS does.
        assert await drone.param.get_param_float("COM_OF_LOSS_T") == pytest.approx(10.0)
        assert await drone.param.get_param_int("COM_DL_LOSS_T") == 100
        await fly_square_mission(drone, 60, 60)


@pytest.mark.asyncio
async def test_takeoff_and_land_at_speed_20(daemon_factory):
    d = daemon_factory("--speed", "20")
    r = await takeoff_hover_land(d.api_port(0), hover_s=1.0)
    assert 2.2 <= r.hover_alt_min_m and r.hover_alt_max_m <= 2.8, r
