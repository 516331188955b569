"""Failure injection (MAV_CMD_INJECT_FAILURE) as PX4 SITL with SYS_FAILURE_EN: the GPS off →
no fixes → the estimator is unaided after EKF2_NOAID_TOUT → the position is lost → Descend
(failsafe.cpp's mode fallback: Return and Land need a position) → landed and disarmed; refused
with DENIED when SYS_FAILURE_EN is 0; units and types it does not simulate are UNSUPPORTED."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.testing import Sim
from vehicles.types import NavState

GPS, OFF, OK = 4, 1, 0


def hover(sim: Sim, alt_m: float = 10.0) -> None:
    assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
    api = sim.api(0)
    assert api.arm() == 0 and api.takeoff() == 0
    assert sim.run_until(lambda: sim.status(0).nav_state is NavState.AUTO_LOITER, timeout_s=30)
    sim.advance(3.0)


def test_gps_off_in_hold_descends_lands_and_disarms():
    with Sim(params={"MIS_TAKEOFF_ALT": 10.0}) as sim:
        hover(sim)
        api = sim.api(0)
        t0 = sim.now
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OFF, 0) == 0
        assert sim.run_until(lambda: not sim.status(0).position_valid, timeout_s=10)
        lost_after = sim.now - t0
        assert 5.0 <= lost_after < 5.5  # EKF2_NOAID_TOUT
        assert sim.run_until(lambda: sim.status(0).nav_state is NavState.DESCEND, timeout_s=1)
        assert sim.status(0).failsafe
        # Down at about MPC_LAND_SPEED (0.7 m/s) from 10 m, then disarmed after landing.
        assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=40)
        truth = sim.vehicles[0].truth
        assert truth.position_ned_m[2] > -0.3
        assert math.hypot(*truth.position_ned_m[:2]) < 5.0  # it drifts a little, no more
        texts = [m.text for m in api.messages("STATUSTEXT")]
        assert "Failsafe activated" in texts and "Disarmed by landing" in texts
        # The GPS back: the position is valid again.
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OK, 0) == 0
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)


@pytest.mark.parametrize("params, unit, kind, result", [
    ({"SYS_FAILURE_EN": 0}, GPS, OFF, 2),  # DENIED: failure injection disabled
    ({}, 100, OFF, 3),  # the battery: not simulated here, UNSUPPORTED
    ({}, GPS, 2, 3),  # GPS stuck: UNSUPPORTED
])
def test_refusals(params, unit, kind, result):
    with Sim(params=params) as sim:
        sim.advance(1.0)
        assert sim.api(0).command_long(M.MAV_CMD_INJECT_FAILURE, unit, kind, 0) == result
        sim.advance(7.0)
        assert sim.status(0).position_valid


def test_fault_timeline_in_a_scenario_is_deterministic_and_fly_reports_the_failsafe(tmp_path):
    """scenarios/gps-loss.toml: the GPS goes off at t=20 s, the square mission is cut short by
    the Descend failsafe; two lockstep runs write identical logs; `cornet fly` says so."""
    from gateway.ci.fly import fly
    from gateway.sim import scenario as scenario_mod

    root = Path(__file__).resolve().parents[2]
    plan, sc = root / "gcs_examples/plans/square.plan", root / "scenarios/gps-loss.toml"
    runs = [fly(plan, scenario=sc, log_dir=tmp_path / name, time_limit_s=200)
            for name in ("a", "b")]
    res = runs[0]
    assert not res.passed and res.exit_code == 1
    assert res.faults == ["t=20.0 s vehicle 1 gps off"]
    assert any("Failsafe activated" in f for f in res.failsafes)
    assert res.landed and res.disarmed and not res.mission_finished
    summary = res.summary()
    assert "faults: t=20.0 s vehicle 1 gps off" in summary and "failsafes:" in summary
    import json
    meta = json.loads((tmp_path / "a" / "meta.json").read_text())
    assert meta["faults"] == [{"at_s": 20.0, "fault": "vehicle 1 gps off"}]
    for name in ("state.csv", "v1-api.tlog"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    ulogs = [sorted((tmp_path / r).rglob("*.ulg")) for r in ("a", "b")]
    assert [p.read_bytes() for p in ulogs[0]] == [p.read_bytes() for p in ulogs[1]]
    with pytest.raises(scenario_mod.ScenarioError, match=r"faults\[0\].unit"):
        scenario_mod.parse({"faults": [{"at_s": 1.0, "unit": "warp drive", "type": "off"}]})
    with pytest.raises(scenario_mod.ScenarioError, match=r"faults\[0\].vehicle"):
        scenario_mod.parse({"faults": [{"at_s": 1.0, "vehicle": 3, "unit": "gps", "type": "off"}]})


def test_network_outage_in_the_fault_timeline():
    """A [[faults]] link outage: nothing crosses the link for its duration, then it carries on;
    the outage is recorded with the vehicle faults."""
    from gateway.sim import scenario as scenario_mod

    sc = scenario_mod.parse({"faults": [{"at_s": 3.0, "link": "v1", "event": "outage",
                                         "duration_s": 2.0}]})
    with Sim(scenario=sc) as sim:
        api = sim.api(0)
        sim.advance(3.0)
        before = len(api.frames)
        sim.advance(1.9)
        assert len(api.frames) == before  # the outage
        sim.advance(1.0)
        assert len(api.frames) > before
        assert [(t, f.describe()) for t, f in sim.simulation.faults_fired] == [
            (3.0, "link v1 outage for 2 s")]
    with pytest.raises(scenario_mod.ScenarioError, match=r"faults\[0\].duration_s"):
        scenario_mod.parse({"faults": [{"at_s": 1.0, "link": "v1", "event": "outage"}]})
    with pytest.raises(scenario_mod.ScenarioError, match="embedded backend"):
        scenario_mod.parse({"network": {"backend": "ns3"},
                            "faults": [{"at_s": 1.0, "link": "v1", "event": "outage",
                                        "duration_s": 1.0}]})


def test_a_motor_off_is_lost_thrust_and_the_vehicle_comes_down():
    """FAILURE_UNIT_SYSTEM_MOTOR off: the rotor spins down (physics, no failure detector is
    simulated): a quadrotor with one motor out loses height and control; ok restores it."""
    with Sim(params={"MIS_TAKEOFF_ALT": 10.0}) as sim:
        hover(sim)
        api = sim.api(0)
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 101, OFF, 1) == 0
        sim.advance(0.5)
        speeds = sim.status(0).extra["rotor_speed_radps"]
        assert speeds[0] < 0.2 * max(speeds)
        sim.advance(1.5)
        assert sim.vehicles[0].truth.position_ned_m[2] > -9.0  # falling
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 101, OFF, 9) == 2  # no motor 9
