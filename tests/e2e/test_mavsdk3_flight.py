"""Unmodified MAVSDK-Python 3.x (gRPC + bundled mavsdk_server) flies the daemon."""

import asyncio

import pytest

from tests.e2e.flows import takeoff_hover_land

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


@pytest.mark.asyncio
async def test_takeoff_hover_land_two_vehicles_at_once(daemon_factory):
    d = daemon_factory(vehicles=2)
    r1, r2 = await asyncio.gather(takeoff_hover_land(d.api_port(0)),
                                  takeoff_hover_land(d.api_port(1)))
    for r in (r1, r2):
        assert 2.2 <= r.hover_alt_min_m and r.hover_alt_max_m <= 2.8, r
        assert r.disarmed_after_landing
    assert any("Armed by external command" in t for t in r1.status_texts), r1.status_texts


@pytest.mark.asyncio
async def test_takeoff_land_over_lossy_jittery_network(daemon_factory):
    d = daemon_factory("--latency-ms", "80", "--jitter-ms", "20", "--loss", "0.2", "--seed", "3")
    r = await takeoff_hover_land(d.api_port(0), hover_s=3.0, timeout_scale=2.0)
    assert 2.2 <= r.hover_alt_min_m and r.hover_alt_max_m <= 2.8, r


@pytest.mark.asyncio
async def test_takeoff_land_over_the_lossy_wifi_scenario(daemon_factory):
    d = daemon_factory("--scenario", "lossy-wifi", vehicles=1)
    r = await takeoff_hover_land(d.api_port(0), hover_s=3.0, timeout_scale=2.0)
    assert 2.2 <= r.hover_alt_min_m and r.hover_alt_max_m <= 2.8, r


@pytest.mark.asyncio
async def test_takeoff_land_over_the_real_ns3_backend(daemon_factory):
    from netsim.ns3.bridge import BINARY, build_missing_message

    if not BINARY.exists():
        pytest.skip(build_missing_message())
    d = daemon_factory("--scenario", "ns3-wifi", vehicles=1)
    r = await takeoff_hover_land(d.api_port(0), hover_s=3.0, timeout_scale=2.0)
    assert 2.2 <= r.hover_alt_min_m and r.hover_alt_max_m <= 2.8, r
