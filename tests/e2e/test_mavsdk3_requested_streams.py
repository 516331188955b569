"""MAVSDK-Python 3.x's telemetry.set_rate_* for the messages PX4 SITL streams only on request
(SCALED_IMU, RC_CHANNELS, DISTANCE_SENSOR, HIL_STATE_QUATERNION, ACTUATOR_OUTPUT_STATUS): each
call succeeds (a FAILED SET_MESSAGE_INTERVAL raised TelemetryError UNKNOWN), and the messages
SITL has data for arrive."""

import asyncio

import pytest

from gateway.ci.launcher import free_port_offset, start_daemon
from tests.e2e.persona import HOME_LAT, HOME_LON, connected, first

pytestmark = [pytest.mark.e2e]


@pytest.mark.asyncio
async def test_set_rate_of_the_on_request_streams():
    d = start_daemon(port_offset=free_port_offset(1, start=5000))
    try:
        async with connected(d.api_port()) as drone:
            t = drone.telemetry
            for set_rate in (t.set_rate_scaled_imu, t.set_rate_rc_status,
                             t.set_rate_distance_sensor, t.set_rate_ground_truth,
                             t.set_rate_actuator_output_status):
                await set_rate(10.0)
            imu = await first(t.scaled_imu(), lambda _: True, 10, "SCALED_IMU")
            assert abs(imu.acceleration_frd.down_m_s2 + 9.81) < 0.3, imu
            gt = await first(t.ground_truth(), lambda _: True, 10, "HIL_STATE_QUATERNION")
            assert abs(gt.latitude_deg - HOME_LAT) < 1e-4, gt
            assert abs(gt.longitude_deg - HOME_LON) < 1e-4, gt
            status = await first(t.actuator_output_status(), lambda _: True, 10,
                                 "ACTUATOR_OUTPUT_STATUS")
            assert status.active == 16, status
            t0 = asyncio.get_running_loop().time()
            n = 0
            async for _ in t.ground_truth():
                n += 1
                if n == 21:
                    break
            assert 1.6 < asyncio.get_running_loop().time() - t0 < 2.6  # 20 intervals at 10 Hz
    finally:
        assert d.stop() == 0, d.log_tail()
