"""MAVSDK-Python 3.x's info plugin reads AUTOPILOT_VERSION as it reads PX4 SITL's: version
1.15.2, a hex git hash (from 5 bytes of flight_custom_version), vendor version 0.0.0."""

import pytest

from gateway.ci.launcher import free_port_offset, start_daemon
from tests.e2e.persona import connected

pytestmark = [pytest.mark.e2e]


@pytest.mark.asyncio
async def test_info_version_shows_a_hex_git_hash():
    d = start_daemon(port_offset=free_port_offset(1, start=5000))
    try:
        async with connected(d.api_port(), healthy=False) as drone:
            version = await drone.info.get_version()
            assert (version.flight_sw_major, version.flight_sw_minor,
                    version.flight_sw_patch) == (1, 15, 2), version
            # Bytes 3..7 of flight_custom_version back to front ("3fccf9453a"); MAVSDK's
            # buffer is one short, so its last digit is the NUL (so it is with PX4 SITL too).
            assert version.flight_sw_git_hash == "3fccf9453\0", version
            assert (version.flight_sw_vendor_major, version.flight_sw_vendor_minor,
                    version.flight_sw_vendor_patch) == (0, 0, 0), version
    finally:
        assert d.stop() == 0, d.log_tail()
