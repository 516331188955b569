"""Multi-hop through ns-3's OLSR (the ns3-olsr scenario): unmodified MAVSDK flies vehicle 1,
which reaches the ground only through vehicle 2; when the relay flies off, vehicle 1's link dies
and PX4's data-link-loss failsafe lands it; when the relay comes back, so does the link."""

from __future__ import annotations

import asyncio
import re
import time
from pathlib import Path

import pytest
from mavsdk.mission import MissionItem, MissionPlan

from netsim.ns3 import BINARY, build_missing_message
from tests.e2e.flows import retry_on_timeout
from tests.e2e.persona import HOME_LAT, HOME_LON, connected, first, latest, offset_deg

pytestmark = [
    pytest.mark.e2e,
    pytest.mark.slow,
    # ns-3 runs beside the daemon on the simulated clock; starved of CPU by parallel tests, OLSR's
    # HELLOs miss their sync cycle and the relay's route is lost for good.
    pytest.mark.solo,
    pytest.mark.skipif(not BINARY.is_file(), reason=build_missing_message()),
]

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "ns3-olsr.toml"
FAR_N = 140.0  # vehicle 1's spawn point, metres north of home (the scenario's)
RELAY_N = 70.0  # vehicle 2's
# Real time: PX4's ~790 messages per vehicle-second, relayed, keep ns-3 busy (an ad-hoc 802.11g
# channel with OLSR); at 2x ns-3 could not keep up and its late packets were dropped.
SPEED = 1.0


def item(north_m: float, east_m: float, alt_m: float) -> MissionItem:
    lat, lon = offset_deg(HOME_LAT, HOME_LON, north_m, east_m)
    return MissionItem(lat, lon, alt_m, 5.0, True, float("nan"), float("nan"),
                       MissionItem.CameraAction.NONE, float("nan"), float("nan"),
                       float("nan"), float("nan"), float("nan"),
                       MissionItem.VehicleAction.NONE)


async def connected_until_lost(drone, timeout_s: float) -> float:
    """Wall seconds until MAVSDK says the system is no longer connected."""
    t0 = time.monotonic()
    await first(drone.core.connection_state(), lambda s: not s.is_connected, timeout_s,
                "vehicle 1's link to die")
    return time.monotonic() - t0


@pytest.mark.asyncio
async def test_mavsdk_flies_the_far_vehicle_through_a_relay_and_loses_it_when_the_relay_leaves(
        daemon_factory):
    d = daemon_factory("--scenario", str(SCENARIO), "--speed", str(SPEED), vehicles=2)
    async with connected(d.api_port(1)) as relay, connected(d.api_port(0)) as far:
        # The relay takes off and holds where it spawned, between the ground and vehicle 1.
        await retry_on_timeout(relay.action.arm)
        await retry_on_timeout(relay.action.takeoff)
        # Vehicle 1 flies a mission near its spawn point, every message relayed by vehicle 2.
        plan = [item(FAR_N - 5, 0, 15), item(FAR_N - 15, 0, 15), item(FAR_N - 15, 10, 15),
                item(FAR_N - 5, 10, 15)]
        await far.mission.upload_mission(MissionPlan(plan))
        await retry_on_timeout(far.action.arm)
        await far.mission.start_mission()
        done = await first(far.mission.mission_progress(),
                           lambda p: p.total > 0 and p.current == p.total, 120,
                           "vehicle 1's mission to finish")
        assert done.total == len(plan)

        # The relay flies off towards home, out of vehicle 1's range: the link dies.
        lat, lon = offset_deg(HOME_LAT, HOME_LON, 15.0, 25.0)
        await retry_on_timeout(lambda: relay.action.goto_location(lat, lon, 490.0, 0.0))
        await connected_until_lost(far, 60)

        # Without its ground station vehicle 1 lands (NAV_DLL_ACT = 3 after COM_DL_LOSS_T).
        # The relay comes back; when OLSR has the route again, MAVSDK hears a landed vehicle.
        await asyncio.sleep(15 / SPEED)
        lat, lon = offset_deg(HOME_LAT, HOME_LON, RELAY_N, 0.0)
        await retry_on_timeout(lambda: relay.action.goto_location(lat, lon, 490.0, 0.0))
        await first(far.core.connection_state(), lambda s: s.is_connected, 90,
                    "vehicle 1's link to come back with the relay")
        # It landed and disarmed where it lost its link (the daemon logs PX4's messages). The
        # link may come back between the landing and the disarm COM_DISARM_LAND (2 s) later.
        assert not await latest(far.telemetry.in_air())
        await first(far.telemetry.armed(), lambda armed: not armed, 10.0,
                    "vehicle 1 to disarm after its landing")
        pos = await latest(far.telemetry.position())
        north = (pos.latitude_deg - HOME_LAT) * 111_195.0
        assert FAR_N - 20 < north < FAR_N + 5, north
    log = d.log_tail(2000)
    for text in (r"\[INFO\] Connection to ground station lost",
                 r"\[CRITICAL\] Failsafe activated", r"\[INFO\] Disarmed by landing"):
        assert re.search(r"vehicle 1 t=[0-9.]+ " + text, log), log
