"""The in-process lockstep API (gateway/ci/lockstep.py): a 4-waypoint mission, deterministic logs."""

import hashlib
import time
from pathlib import Path

import pytest

from gateway.ci.lockstep import Sim, mission_item
from gateway.mavlink.session import LinkKind
from gateway.sim.scenario import NetworkConfig
from vehicles.plan_types import MavCmd, PlanResult, PlanType
from vehicles.types import PX4_SITL_HOME, NavState

LOSSY = NetworkConfig.from_flags(latency_ms=50, jitter_ms=10, loss=0.15, seed=7)
CORNERS_NE = [(40, 0), (40, 40), (0, 40), (0, 0)]
LOG_FILES = ("state.csv", "packets.trace", "v1-api.tlog", "meta.json")


def geo(n: float, e: float) -> tuple[float, float]:
    g = PX4_SITL_HOME.offset_ned(n, e, 0.0)
    return g.lat_deg, g.lon_deg


def square_mission(alt_m: float = 10.0):
    """Takeoff, 4 waypoints (a 40 m square), land: ~60 s simulated."""
    return ([mission_item(MavCmd.NAV_TAKEOFF, *geo(0, 0), alt_m)]
            + [mission_item(MavCmd.NAV_WAYPOINT, *geo(n, e), alt_m) for n, e in CORNERS_NE]
            + [mission_item(MavCmd.NAV_LAND, *geo(0, 0), 0.0)])


def fly_square(sim: Sim) -> None:
    api = sim.api(0)
    assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
    assert api.upload_mission(square_mission()) == PlanResult.ACCEPTED
    assert api.arm() == 0
    assert api.start_mission() == 0
    assert sim.run_until(lambda: sim.status(0).armed is False, timeout_s=120)


def digests(run_dir: Path) -> dict[str, str]:
    names = LOG_FILES + (("v1-gcs.tlog",) if (run_dir / "v1-gcs.tlog").exists() else ())
    return {name: hashlib.sha256((run_dir / name).read_bytes()).hexdigest() for name in names}


@pytest.fixture(scope="module")
def lockstep_runs(tmp_path_factory):
    """The square flown twice on an ideal network (the API link) and twice on a lossy one (the
    API and the GCS link), with flight logs."""
    out = {}
    for label, network, links in (("ideal", None, (LinkKind.API,)),
                                  ("lossy", LOSSY, (LinkKind.API, LinkKind.GCS))):
        for k in (1, 2):
            run_dir = tmp_path_factory.mktemp(f"{label}{k}")
            with Sim(1, network, log_dir=run_dir, links=links) as sim:
                t0 = time.perf_counter()
                fly_square(sim)
                wall = time.perf_counter() - t0
                reached = {m.seq for m in sim.api(0).messages("MISSION_ITEM_REACHED")}
                last_reached = sim.vehicles[0].mission_status.reached_seq
                out[(label, k)] = {"dir": run_dir, "sim_s": sim.now, "wall_s": wall,
                                   "reached": reached, "last_reached": last_reached,
                                   "plan": sim.vehicles[0].plan(PlanType.MISSION),
                                   "landed": sim.status(0).landed_state.name}
    return out


def test_square_mission_flies_in_lockstep(lockstep_runs):
    run = lockstep_runs[("ideal", 1)]
    assert run["reached"] == set(range(6))
    assert run["landed"] == "ON_GROUND"
    assert 45 < run["sim_s"] < 80
    ratio = run["sim_s"] / run["wall_s"]
    # Speed is measured by bench/lockstep.py, not asserted here.
    print(f"lockstep: {run['sim_s']:.1f} s simulated in {run['wall_s']:.2f} s wall = {ratio:.0f}x")


@pytest.mark.parametrize("label", ["ideal", "lossy"])
def test_two_runs_write_byte_identical_logs(lockstep_runs, label):
    a, b = lockstep_runs[(label, 1)], lockstep_runs[(label, 2)]
    assert digests(a["dir"]) == digests(b["dir"])
    assert (a["dir"] / "packets.trace").stat().st_size > 0
    assert ("v1-gcs.tlog" in digests(a["dir"])) == (label == "lossy")


def test_lossy_link_really_lost_and_the_mission_still_flew(lockstep_runs):
    run = lockstep_runs[("lossy", 1)]
    trace = (run["dir"] / "packets.trace").read_text()
    assert " drop v1/api/up " in trace and " drop v1/api/down " in trace
    # The vehicle reached every item; its client heard most of the MISSION_ITEM_REACHEDs (PX4
    # sends each once: a lossy link may lose one).
    assert run["last_reached"] == 5 and run["landed"] == "ON_GROUND"
    assert run["reached"] <= set(range(6)) and len(run["reached"]) >= 4
    sent = [(it.command, it.x, it.y, it.z) for it in square_mission()]
    assert [(it.command, it.x, it.y, it.z) for it in run["plan"]] == sent
    assert digests(run["dir"]) != digests(lockstep_runs[("ideal", 1)]["dir"])


def test_command_retries_through_heavy_uplink_loss():
    net = NetworkConfig.from_flags(latency_ms=20, jitter_ms=0, loss=0.5, seed=11)
    with Sim(1, net) as sim:
        sim.run_until(lambda: sim.status().position_valid, timeout_s=5)
        for _ in range(3):  # each call has 4 tries; at 50 % loss each way some calls fail
            if sim.api().arm() == 0:
                break
        assert sim.status().armed
        # every try was a COMMAND_LONG with a higher confirmation, visible in the trace counters
        assert sim.link_stats()["v1/api/up"]["sent"] >= 2


def test_state_status_advance_and_messages():
    with Sim(2, links=(LinkKind.API, LinkKind.GCS)) as sim:
        sim.advance(2.0)
        assert sim.now == pytest.approx(2.0)
        assert sim.status(1).nav_state is NavState.AUTO_LOITER
        assert sim.state(1).position_ned_m[2] == pytest.approx(0.0, abs=0.05)
        hb = sim.client(1, LinkKind.GCS).messages("HEARTBEAT")
        assert len(hb) == 3 and {m.get_srcSystem() for m in hb} == {2}
        assert sim.api(0).last("ATTITUDE") is not None
        assert sim.api(0).arm() == 0 and sim.api(0).takeoff() == 0
        assert sim.run_until(lambda: sim.state(0).position_ned_m[2] < -2.0, timeout_s=20)
        assert not sim.status(1).armed


def test_scenario_file_sets_vehicles_and_network(tmp_path):
    path = tmp_path / "two.toml"
    path.write_text("[vehicles]\ncount = 2\n[network]\nseed = 4\n"
                    "link = {model = \"fixed\", latency_s = 0.03}\n")
    with Sim(scenario=path) as sim:
        assert len(sim.vehicles) == 2
        sim.advance(1.0)
        assert sim.link_stats()["v2/api/down"]["latency_mean_ms"] == pytest.approx(30, abs=1)


def test_links_default_to_the_api_link_and_the_gcs_link_is_asked_for():
    with Sim(1) as sim:
        sim.advance(1.0)
        assert sim.api().last("HEARTBEAT") is not None
        assert set(sim.link_stats()) == {"v1/api/up", "v1/api/down"}
        with pytest.raises(KeyError, match="links=\\(LinkKind.API, LinkKind.GCS\\)"):
            sim.gcs()
    with Sim(1, links=(LinkKind.GCS,)) as sim:  # QGC's link alone: its client sends heartbeats
        sim.advance(1.5)
        assert sim.gcs().last("HEARTBEAT") is not None
        assert sim.gcs().arm() == 0
