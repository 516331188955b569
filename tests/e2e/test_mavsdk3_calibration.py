"""MAVSDK-Python 3.x's calibration plugin against PX4's calibration routines (its example
calibration.py's calls): the gyro calibration reports progress to 100 %; the accelerometer
calibration measures the side the vehicle rests on and then fails as PX4 SITL's does when nobody
turns the vehicle; a cancelled one ends at once."""

import asyncio

import pytest
from mavsdk.calibration import CalibrationError

from gateway.ci.launcher import free_port_offset, start_daemon
from tests.e2e.persona import connected

pytestmark = [pytest.mark.e2e]


@pytest.mark.asyncio
async def test_mavsdk_calibrations_follow_px4s_texts():
    # Real time: PX4 sends STATUSTEXT only while a GCS heartbeat came within the last few
    # (simulated) seconds, and MAVSDK beats once per wall second.
    d = start_daemon(port_offset=free_port_offset(1, start=5200))
    try:
        async with connected(d.api_port(), healthy=False) as drone:
            progress = [p.progress async for p in drone.calibration.calibrate_gyro()
                        if p.has_progress]
            assert progress[-1] == 1.0 and progress == sorted(progress), progress

            said = []
            with pytest.raises(CalibrationError) as failed:
                async for p in drone.calibration.calibrate_accelerometer():
                    if p.has_status_text:
                        said.append(p.status_text)
            assert failed.value._result.result.name == "FAILED", failed.value
            assert said[0] == "pending: back front left right up down", said
            assert any(s.startswith("down side result: [") for s in said), said
            assert said.count("down side already completed") == 5, said

            # PX4's routine lets its last text propagate for 0.6 s before the next may start.
            await asyncio.sleep(1.0)
            texts = []

            async def mag():
                async for p in drone.calibration.calibrate_magnetometer():
                    if p.has_status_text:
                        texts.append(p.status_text)

            task = asyncio.ensure_future(mag())
            while "Rotate vehicle" not in texts:  # mavsdk_server drops the "[cal] "
                assert not task.done(), task
                await asyncio.sleep(0.1)
            # Let any text still queued pass first (PX4's STATUSTEXT stream runs at 20 Hz):
            # mavsdk_server's cancel() holds its calibration lock while it waits for the
            # COMMAND_ACK, and a STATUSTEXT reaching the plugin in that time blocks the receive
            # thread on the same lock, so the ACK never comes.
            await asyncio.sleep(0.5)
            await drone.calibration.cancel()
            with pytest.raises(CalibrationError) as cancelled:
                await asyncio.wait_for(task, 10)
            assert cancelled.value._result.result.name == "CANCELLED", cancelled.value
    finally:
        assert d.stop() == 0, d.log_tail()
