"""A user's flight regression tests with CORNET's pytest plugin (gateway/ci/pytest_plugin.py).

- ``test_square_mission_lockstep``: the QGroundControl plan ``square.plan`` flown in lockstep on the
  simulated clock (``cornet_sim``: no sockets, ~1 minute of flight in a few seconds of wall time,
  deterministic), then judged on its flight logs.
- ``test_square_mission_cornet_fly``: the same plan through ``gateway.ci.fly.fly`` (what
  ``cornet fly PLAN`` runs), its verdict and the same assertions on its logs.
- ``test_square_mission_matches_its_baseline``: the same flight compared with its stored baseline
  (``cornet_baseline``; ``pytest --cornet-update-baselines`` records it again).
- ``test_mavsdk_takeoff_and_land``: an unmodified MAVSDK-Python 3.x script against a real
  ``cornet run --speed 10`` subprocess (``cornet_daemon``), then assertions on its logs.

Run: ``pytest gcs_examples/ci`` (see README.md next to this file).
"""

from __future__ import annotations

import asyncio
from pathlib import Path

from gateway.ci.pytest_plugin import FlightLogView, free_tcp_port, landed_within, max_deviation_m, reached

PLAN = Path(__file__).resolve().parents[2] / "gcs_examples" / "plans" / "square.plan"
CRUISE_ALT_M = 15.0  # the plan's waypoints: 15 m above home
WAYPOINT_TOLERANCE_M = 2.0
MAX_DEVIATION_M = 3.0
FLIGHT_TIMEOUT_S = 300.0  # simulated


def square_corners() -> list[tuple[float, float]]:
    """The plan's waypoints (lat, lon), read from the .plan file."""
    from gateway.ci.fly import POSITION_COMMANDS, load_plan

    return [(it.x * 1e-7, it.y * 1e-7) for it in load_plan(PLAN).mission
            if it.command in POSITION_COMMANDS]


def assert_flew_the_square(log: FlightLogView) -> None:
    for lat, lon in square_corners():
        assert reached(log, lat, lon, rel_alt_m=CRUISE_ALT_M, within_m=WAYPOINT_TOLERANCE_M)
    assert landed_within(log, "home", 2)
    assert max_deviation_m(log, PLAN) < MAX_DEVIATION_M


def test_square_mission_lockstep(cornet_sim):
    from gateway.ci.fly import load_plan
    from gateway.ci.lockstep import PlanType

    plan = load_plan(PLAN)
    sim = cornet_sim(home=plan.planned_home)
    api = sim.api(0)
    assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
    assert api.upload_mission(plan.mission) == 0  # MAV_MISSION_ACCEPTED
    assert api.upload_mission(plan.fence, PlanType.FENCE) == 0
    assert api.upload_mission(plan.rally, PlanType.RALLY) == 0
    assert api.arm() == 0  # MAV_RESULT_ACCEPTED
    assert api.start_mission() == 0
    assert sim.run_until(lambda: sim.status(0).armed, timeout_s=5)
    assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=FLIGHT_TIMEOUT_S), \
        "the vehicle did not land and disarm"

    log = FlightLogView.load(sim)  # flushes the logs first
    modes = [mode for _, mode in log.modes()]
    if modes[-1] == "AUTO_MISSION":  # once disarmed, PX4 goes back to the mode before Return
        modes.pop()
    assert modes[-1] == "AUTO_RTL"  # the plan ends with a return-to-launch item
    assert_flew_the_square(log)


def test_square_mission_cornet_fly(tmp_path):
    from gateway.ci.fly import fly

    result = fly(PLAN, log_dir=tmp_path, max_deviation_m=MAX_DEVIATION_M)
    assert result.passed, result.summary()
    assert_flew_the_square(FlightLogView.load(tmp_path))


async def _takeoff_and_land(url: str, timeout_s: float = 60.0) -> None:
    """The MAVSDK-Python example, unmodified apart from where it connects."""
    from mavsdk import System

    async def first(stream, predicate, what: str):
        async def scan():
            async for item in stream:
                if predicate(item):
                    return item

        try:
            return await asyncio.wait_for(scan(), timeout_s)
        except asyncio.TimeoutError:
            raise AssertionError(f"timed out waiting for {what}") from None

    drone = System(port=free_tcp_port())  # its own mavsdk_server gRPC port
    await drone.connect(system_address=url)
    try:
        await first(drone.core.connection_state(), lambda s: s.is_connected, "connection")
        await first(drone.telemetry.health(),
                    lambda h: h.is_global_position_ok and h.is_home_position_ok, "health")
        await drone.action.arm()
        await drone.action.takeoff()
        await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 2.3,
                    "takeoff altitude")
        await drone.action.land()
        await first(drone.telemetry.in_air(), lambda in_air: not in_air, "landed")
        await first(drone.telemetry.armed(), lambda armed: not armed, "auto-disarm")
    finally:
        drone._stop_mavsdk_server()


def test_mavsdk_takeoff_and_land(cornet_daemon):
    daemon = cornet_daemon("--speed", "10")
    asyncio.run(_takeoff_and_land(daemon.mavsdk_url(0)))
    assert daemon.stop() == 0  # SIGTERM: the daemon flushes its logs

    log = daemon.log()
    home_lat, home_lon, _ = log.home()
    assert reached(log, home_lat, home_lon, rel_alt_m=2.5, within_m=0.5)  # takeoff altitude
    assert landed_within(log, "home", 1)
    assert log.tlog(0, "api").stat().st_size > 0  # every MAVLink frame, for mavlogdump.py


def test_square_mission_matches_its_baseline(cornet_baseline):
    """The flight compared with the one stored in baselines/<this test's name>/ (track at equal
    progress, mission item and mode timing, events, link loss); record it again with
    ``pytest --cornet-update-baselines`` after an intended change."""
    outcome = cornet_baseline(PLAN)
    assert outcome.comparison is None or outcome.comparison.track.max_m == 0.0
