"""Failure injection (MAV_CMD_INJECT_FAILURE) as PX4 SITL with SYS_FAILURE_EN: the GPS off →
no fixes → the estimator is unaided after EKF2_NOAID_TOUT → the position is lost → Descend
(failsafe.cpp's mode fallback: Return and Land need a position) → landed and disarmed; refused
with DENIED when SYS_FAILURE_EN is 0; units and types it does not simulate are UNSUPPORTED."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.mavlink.link import LinkKind
from gateway.testing import Sim
from vehicles import failure_injection as fi
from vehicles.estimation import E_POS
from vehicles.types import NavState

GPS, OFF, OK = 4, 1, 0
NAN = math.nan


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
        # EKF2_NOAID_TOUT after the last fix, which came at most one GPS period (sensor_gps_sim:
        # 125 ms) before the failure (simulated time is a float sum).
        assert 5.0 - 0.125 - 1e-9 <= lost_after < 5.5
        assert sim.run_until(lambda: sim.status(0).nav_state is NavState.DESCEND, timeout_s=1)
        assert sim.status(0).failsafe
        # Down at about MPC_LAND_SPEED (0.7 m/s) from 10 m, then disarmed after landing.
        assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=40)
        truth = sim.vehicles[0].truth
        assert truth.position_ned_m[2] > -0.3
        assert math.hypot(*truth.position_ned_m[:2]) < 5.0  # it drifts a little, no more
        sim.advance(0.5)  # the disarm's STATUSTEXT goes out at the next send
        texts = [m.text for m in api.messages("STATUSTEXT")]
        assert "Failsafe activated\t" in texts and "Disarmed by landing\t" in texts
        # The GPS back: the position is valid again.
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OK, 0) == 0
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)


def test_without_gps_arming_is_denied_in_hold_and_allowed_in_stabilized():
    """HealthAndArmingChecks canArm(nav_state): with the position lost, Hold (which needs one)
    refuses to arm; Stabilized (attitude only) arms on the sticks, and home stays where it was."""
    with Sim() as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        api.start_heartbeat()
        assert api.arm() == 0 and api.disarm() == 0
        home = sim.status(0).home
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OFF, 0) == 0
        assert sim.run_until(lambda: not sim.status(0).position_valid, timeout_s=10)
        assert api.arm() == M.MAV_RESULT_TEMPORARILY_REJECTED
        sticks = sim.every(0.05, lambda t: api.send(  # the throttle down: Stabilized arms so
            M.MAVLink_manual_control_message(1, 0, 0, 0, 0, 0)))
        sim.advance(0.2)
        assert api.set_mode(NavState.STAB) == 0
        assert not sim.status(0).position_valid and sim.status(0).prearm_ok
        assert api.arm() == 0 and sim.status(0).armed
        assert sim.status(0).home == home
        sticks.cancel()


def test_a_sensor_off_denies_arming_with_its_preflight_text():
    """gyroCheck.cpp: no gyro data for 1 s fails the check in every mode; the arming request
    says "Preflight Fail: No valid data from Gyro 0" before "Arming denied"."""
    with Sim() as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        api.start_heartbeat()
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 0, OFF, 0) == 0  # FAILURE_UNIT_SENSOR_GYRO
        assert sim.status(0).prearm_ok  # still publishing within the last second
        assert sim.run_until(lambda: not sim.status(0).prearm_ok, timeout_s=1.5)
        assert api.arm() == M.MAV_RESULT_TEMPORARILY_REJECTED
        sim.advance(0.1)
        texts: list[str] = []
        for m in api.messages("STATUSTEXT"):  # the 52-byte denial comes in two chunks
            texts[-1:] = [texts[-1] + m.text] if m.chunk_seq else [*texts[-1:], m.text]
        assert texts[-2:] == ["Preflight Fail: No valid data from Gyro 0",
                              "Arming denied: Resolve system health failures first\t"], texts
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 0, OK, 0) == 0
        assert sim.run_until(lambda: sim.status(0).prearm_ok, timeout_s=0.5)
        assert api.arm() == 0


@pytest.mark.parametrize("params, unit, kind, result", [
    ({"SYS_FAILURE_EN": 0}, GPS, OFF, 2),  # DENIED: failure injection disabled
    ({}, 100, 2, None),  # the battery stuck: BatterySimulator takes only ok and off, no ACK
    ({}, GPS, 2, 3),  # GPS stuck: UNSUPPORTED
    ({}, 3, 3, 3),  # baro garbage: UNSUPPORTED
    ({}, 6, OFF, 0),  # VIO: SimulatorMavlink ACCEPTs it (none here to fail)
    ({}, 8, OFF, 0),  # airspeed: ACCEPTED as PX4 SITL does, no sensor on a multicopter
    ({}, 8, 4, 0),  # airspeed wrong (pitot blockage): ACCEPTED
    ({}, 5, OFF, None),  # optical flow: no SITL module takes it, no ACK
])
def test_refusals_and_the_units_without_effect(params, unit, kind, result):
    with Sim(params=params) as sim:
        sim.advance(1.0)
        assert sim.api(0).command_long(M.MAV_CMD_INJECT_FAILURE, unit, kind, 0,
                                       retries=0) == result
        sim.advance(7.0)
        assert sim.status(0).position_valid


def test_fault_timeline_in_a_scenario_is_deterministic_and_fly_reports_the_failsafe(tmp_path):
    """The gps-loss scenario: the GPS goes off at t=20 s, the square mission is cut short by
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
    with pytest.raises(scenario_mod.ScenarioError, match=r"faults\[0\].type: gps can be ok, off"):
        scenario_mod.parse({"faults": [{"at_s": 1.0, "unit": "gps", "type": "stuck"}]})
    stuck = scenario_mod.parse({"faults": [{"at_s": 1.0, "unit": "baro", "type": "stuck"}]})
    assert stuck.faults[0].describe() == "vehicle 1 baro stuck"


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
        # FailureInjector takes off for any instance (a motor 9 changes nothing)
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 101, OFF, 9) == 0


def health(sim: Sim) -> int:
    return sim.api(0).last("SYS_STATUS").onboard_control_sensors_health


BARO_HEALTH, MAG_HEALTH, GYRO_HEALTH = 0x8, 0x4, 0x1


def test_baro_off_the_height_follows_the_gps_and_the_health_bit_clears():
    """PX4 SITL's baro off: no more samples; EKF2 falls back to GNSS height, so the vehicle
    holds its altitude (to the GPS's vertical noise); SYS_STATUS shows the barometer unhealthy."""
    with Sim(params={"MIS_TAKEOFF_ALT": 10.0}) as sim:
        hover(sim)
        api = sim.api(0)
        assert health(sim) & BARO_HEALTH
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 3, OFF, 0) == 0
        sensed = sim.vehicles[0].sensors[9]  # S_BARO_DOWN
        alts = []
        for _ in range(20):
            sim.advance(1.0)
            alts.append(-sim.vehicles[0].truth.position_ned_m[2])
        assert sim.vehicles[0].sensors[9] == sensed  # nothing new from the barometer
        assert all(8.0 < a < 12.0 for a in alts), alts
        assert not health(sim) & BARO_HEALTH
        assert sim.status(0).armed and sim.status(0).position_valid
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 3, OK, 0) == 0
        sim.advance(1.0)
        assert health(sim) & BARO_HEALTH and sim.vehicles[0].sensors[9] != sensed


def test_mag_off_and_stuck_keep_flying_on_the_gyro():
    """Mag off: no heading corrections (the gyro holds it: its bias drifts the heading slowly);
    stuck: the frozen field is fused while it agrees (the vehicle does not turn)."""
    with Sim(params={"MIS_TAKEOFF_ALT": 10.0}) as sim:
        hover(sim)
        api = sim.api(0)
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 2, OFF, 0) == 0
        sim.advance(20.0)
        assert not health(sim) & MAG_HEALTH
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 2, 2, 0) == 0  # stuck
        sim.advance(10.0)
        assert not health(sim) & MAG_HEALTH
        truth = sim.vehicles[0].truth
        assert abs(truth.position_ned_m[2] + 10.0) < 1.0
        assert math.hypot(*truth.position_ned_m[:2]) < 1.0
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 2, OK, 0) == 0
        sim.advance(1.0)
        assert health(sim) & MAG_HEALTH


def test_gyro_stuck_loses_attitude_control():
    """The gyro stuck (its last sample repeated, as PX4 SITL's simulator does): the rate
    controller flies on a frozen rate and the estimator integrates it: the vehicle departs from
    level and leaves its position; SYS_STATUS shows the gyro unhealthy."""
    with Sim(params={"MIS_TAKEOFF_ALT": 10.0}) as sim:
        hover(sim)
        api = sim.api(0)
        start = sim.vehicles[0].truth.position_ned_m
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 0, 2, 0) == 0
        sim.advance(10.0)
        assert not health(sim) & GYRO_HEALTH
        end = sim.vehicles[0].truth.position_ned_m
        assert math.dist(start, end) > 3.0, (start, end)


def test_battery_off_is_an_empty_battery_and_the_vehicle_lands():
    """PX4's battery simulator forced empty: BAT1_V_EMPTY per cell, remaining 0 → the
    emergency level → COM_LOW_BAT_ACT 2 (SITL: Land) lands; ok, disarmed: a full battery again."""
    with Sim(params={"MIS_TAKEOFF_ALT": 10.0}) as sim:
        hover(sim)
        api = sim.api(0)
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 100, OFF, 1) == 3  # instance 0 only
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 100, OFF, 0) == 0
        sim.advance(1.0)
        status = api.last("SYS_STATUS")
        assert status.battery_remaining == 0
        assert status.voltage_battery == 4 * (3600 - 100)  # 4 × (BAT1_V_EMPTY - BAT1_V_LOAD_DROP)
        assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=60)
        texts = [m.text for m in api.messages("STATUSTEXT")]
        assert any("battery" in t.lower() for t in texts), texts
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, 100, OK, 0) == 0
        sim.advance(1.0)
        assert api.last("SYS_STATUS").battery_remaining == 100  # disarmed: a fresh battery


def test_loss_burst_and_latency_step_in_the_fault_timeline():
    """[[faults]] network events beyond the outage: a loss burst (each packet lost with the
    given probability, counted as loss) and a latency step (every packet later by latency_ms)
    on one link, for their durations only; same seed, same drops."""
    from gateway.sim import scenario as scenario_mod

    doc = {"faults": [
        {"at_s": 2.0, "link": "v1/api/down", "event": "loss", "loss": 0.5, "duration_s": 2.0},
        {"at_s": 5.0, "link": "v1/api/down", "event": "latency", "latency_ms": 300.0,
         "duration_s": 2.0}]}

    def run():
        with Sim(scenario=scenario_mod.parse(doc)) as sim:
            api = sim.api(0)
            sim.advance(2.0)
            quiet = sum(1 for t, _, _ in api.frames if 1.0 <= t < 2.0)
            sim.advance(2.0)
            burst = sum(1 for t, _, _ in api.frames if 2.5 <= t < 3.5)
            stats = sim.simulation.link_stats()["v1/api/down"]
            sim.advance(1.0)
            # a frame sent at 5.0 s arrives 0.3 s later: nothing between 5.0 and 5.3 s
            sim.advance(1.0)
            gap = sum(1 for t, _, _ in api.frames if 5.0 < t < 5.29)
            late = sum(1 for t, _, _ in api.frames if 5.3 <= t < 6.0)
            described = [f.describe() for _, f in sim.simulation.faults_fired]
            return quiet, burst, stats, gap, late, described, [t for t, _, _ in api.frames]

    quiet, burst, stats, gap, late, described, times = run()
    assert 0.3 * quiet < burst < 0.7 * quiet, (quiet, burst)
    assert stats["dropped"]["loss"] == stats["sent"] - stats["delivered"] > 0
    assert gap == 0 and late > 0
    assert described == ["link v1/api/down loss 0.5 for 2 s",
                         "link v1/api/down latency +300 ms for 2 s"]
    assert run()[-1] == times  # deterministic
    with pytest.raises(scenario_mod.ScenarioError, match=r"faults\[0\].loss: missing"):
        scenario_mod.parse({"faults": [{"at_s": 1.0, "link": "v1", "event": "loss",
                                        "duration_s": 1.0}]})
    with pytest.raises(scenario_mod.ScenarioError, match=r"faults\[0\].latency_ms: only for"):
        scenario_mod.parse({"faults": [{"at_s": 1.0, "link": "v1", "event": "loss", "loss": 0.1,
                                        "latency_ms": 5.0, "duration_s": 1.0}]})


def test_gps_off_the_log_and_gps_raw_int_show_no_fix(tmp_path):
    """sensor_gps stops publishing while the GPS is off: the logger writes no
    vehicle_gps_position record, and GPS_RAW_INT.hpp sends nothing, then a NO_GPS message
    (fix 0, unknowns at their maxima) once the last went out over 1 s ago, at most every
    second; fixes come again with the GPS."""
    import numpy as np
    import pyulog

    with Sim(log_dir=tmp_path) as sim:
        hover(sim, 2.5)
        api = sim.api(0)
        t_off = sim.now
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OFF, 0) == 0
        sim.advance(3.55)
        t_on = sim.now
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OK, 0) == 0
        sim.advance(1.0)
        assert api.land() == 0
        assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=60)
        sim.advance(0.5)
        gps_raw = api.timed_messages("GPS_RAW_INT")
    during = [(t, m) for t, m in gps_raw if t_off + 0.3 < t < t_on]
    no_gps = [(t, m) for t, m in during if m.fix_type == 0]
    assert len(during) == len(no_gps) and len(no_gps) in (2, 3)
    assert all(m.eph == m.epv == m.vel == m.cog == 65535 and m.satellites_visible == 255
               and m.lat == m.lon == 0 for _, m in no_gps)
    times = [t for t, _ in no_gps]
    assert times[0] - t_off > 1.0 and min(np.diff(times)) > 1.0
    assert any(m.fix_type == 3 for t, m in gps_raw if t > t_on + 0.3)
    (path,) = sorted((tmp_path / "vehicle-1" / "log").rglob("*.ulg"))
    gps = pyulog.ULog(str(path)).get_dataset("vehicle_gps_position").data
    t_s = gps["timestamp"] / 1e6
    assert not ((t_s > t_off + 0.1) & (t_s < t_on - 0.1)).any()  # no record while off
    assert (t_s > t_on + 0.1).any() and set(gps["fix_type"]) == {3}


@pytest.mark.parametrize("unit, kind, instance, result", [
    (NAN, OFF, 0, None),  # static_cast<int>(NaN + 0.5f): INT_MIN, a unit nobody takes
    (31, OFF, 0, None),
    (101, OK, NAN, 3),  # motors ok: instance INT_MIN is out of range
    (101, OFF, NAN, 0),  # motors off: any instance
    (101, OK, 8, 0), (101, OK, 9, 3),  # up to CONNECTED_ESC_MAX
    (101, 4, 1, 0),  # motor wrong (an ESC report)
    (101, 2, 1, 3),  # motor stuck
    (GPS, OFF, 3, 0),  # SimulatorMavlink ignores the GPS instance
    (100, OFF, NAN, 3),  # the battery: instance 0 only
    (0.6, OFF, -0.7, 0),  # (int)(0.6 + 0.5f) = 1 (accel), (int)(-0.7 + 0.5f) = 0 (all)
])
def test_the_modules_answers_and_casts(unit, kind, instance, result):
    """The simulator, battery simulator and FailureInjector read static_cast<int>(param +
    0.5f) and ACK only the units they take."""
    with Sim() as sim:
        sim.advance(1.0)
        assert sim.api(0).command_long(M.MAV_CMD_INJECT_FAILURE, unit, kind, instance,
                                       retries=0) == result


def test_the_modules_ack_goes_to_everyone_on_every_link():
    """A module's vehicle_command_ack has target system and component 0, and every MAVLink
    instance that heard anyone sends it: the GCS link sees the API client's ACK too."""
    with Sim(links=(LinkKind.API, LinkKind.GCS)) as sim:
        sim.advance(1.0)
        api, gcs = sim.api(0), sim.gcs(0)
        gcs.heartbeat()
        since = len(gcs.frames)
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OFF, 0) == 0
        (ack,) = api.messages("COMMAND_ACK")[-1:]
        assert (ack.target_system, ack.target_component) == (0, 0)
        sim.advance(0.1)
        assert [(a.command, a.result, a.target_system) for a in
                gcs.messages("COMMAND_ACK", since)] == [(420, 0, 0)]


class Recorder:
    def __init__(self):
        self.calls = []

    def set_sensor_failed(self, bits, failed):
        self.calls.append(("sensor", bits, failed))

    def set_motor_off(self, motor, off):
        self.calls.append(("motor", motor, off))

    def set_battery_empty(self, empty):
        self.calls.append(("battery", empty))


def test_a_baros_ok_unblocks_it_but_leaves_it_stuck():
    """SimulatorMavlink: baro stuck sets _baro_stuck, ok clears only _baro_blocked; off blocks
    without unsticking. Gyro, accel and mag ok clear both; other IMUs than ours change nothing."""
    t = Recorder()
    fi.apply(t, 4, fi.FAILURE_UNIT_SENSOR_BARO, fi.FAILURE_TYPE_OK, 0)
    fi.apply(t, 4, fi.FAILURE_UNIT_SENSOR_BARO, fi.FAILURE_TYPE_OFF, 0)
    fi.apply(t, 4, fi.FAILURE_UNIT_SENSOR_MAG, fi.FAILURE_TYPE_OK, 0)
    fi.apply(t, 4, fi.FAILURE_UNIT_SENSOR_MAG, fi.FAILURE_TYPE_OFF, 2)
    off_b, stuck_b = fi.SENSOR_FAILURES[fi.FAILURE_UNIT_SENSOR_BARO]
    off_m, stuck_m = fi.SENSOR_FAILURES[fi.FAILURE_UNIT_SENSOR_MAG]
    assert t.calls == [("sensor", off_b, False), ("sensor", off_b, True),
                       ("sensor", off_m | stuck_m, False)]


def test_ekf2_gps_ctrl_0_unaids_the_estimator_while_the_receiver_still_reports():
    """EKF2_GPS_CTRL 0 (ekf2/module.yaml: no lon/lat, altitude or velocity fusion) in flight:
    the fixes still come (GPS_RAW_INT stays fresh and 3D) but the estimator stops fusing them,
    so after EKF2_NOAID_TOUT the position is lost and the failsafe descends, as with the GPS
    off; velocity fusion alone (4) keeps it aided."""
    with Sim(params={"MIS_TAKEOFF_ALT": 10.0}) as sim:
        hover(sim)
        api = sim.api(0)
        params = sim.vehicles[0].params
        assert params.set("EKF2_GPS_CTRL", 4)
        sim.advance(8.0)
        assert sim.status(0).position_valid and sim.status(0).nav_state is NavState.AUTO_LOITER
        t0 = sim.now
        assert params.set("EKF2_GPS_CTRL", 0)
        assert sim.run_until(lambda: not sim.status(0).position_valid, timeout_s=10)
        assert 5.0 - 0.125 - 1e-9 <= sim.now - t0 < 5.5
        assert sim.run_until(lambda: sim.status(0).nav_state is NavState.DESCEND, timeout_s=1)
        since = len(api.frames)
        sim.advance(1.0)
        fixes = api.messages("GPS_RAW_INT", since)
        assert len(fixes) >= 7 and all(m.fix_type == 3 for m in fixes)
        assert fixes[-1].time_usec > (sim.now - 0.3) * 1e6  # fresh: the receiver works
        # fusion back on: aided again at the next fixes
        assert params.set("EKF2_GPS_CTRL", 7)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=2)


def test_global_position_int_stops_while_the_position_is_lost(tmp_path):
    """EKF2 publishes vehicle_global_position only while global_position_is_valid (not
    dead-reckoning past EKF2_NOAID_TOUT), and GLOBAL_POSITION_INT.hpp sends at each
    publication: with the GPS off the stream stops when the position is lost, and comes back
    with the fixes; LOCAL_POSITION_NED goes on (dead-reckoned). The log has the same gap."""
    with Sim(params={"MIS_TAKEOFF_ALT": 10.0}, log_dir=tmp_path) as sim:
        hover(sim)
        api = sim.api(0)
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OFF, 0) == 0
        assert sim.run_until(lambda: not sim.status(0).position_valid, timeout_s=10)
        sim.advance(0.1)
        since = len(api.frames)
        sim.advance(2.0)
        assert api.messages("GLOBAL_POSITION_INT", since) == []
        assert len(api.messages("LOCAL_POSITION_NED", since)) >= 55
        lost_at = sim.now
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OK, 0) == 0
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
        since = len(api.frames)
        sim.advance(1.0)
        assert len(api.messages("GLOBAL_POSITION_INT", since)) >= 45
    import pyulog
    log = pyulog.ULog(str(sorted((tmp_path / "vehicle-1" / "log").rglob("*.ulg"))[0]))
    stamps = log.get_dataset("vehicle_global_position").data["timestamp"] * 1e-6
    assert not ((stamps > lost_at - 1.9) & (stamps < lost_at)).any()
    assert (stamps > lost_at + 1.0).any()


def test_a_position_glitch_on_the_ground_denies_arming_until_the_reset():
    """An estimate 20 m off the fixes while disarmed: estimator_status's pos_test_ratio
    (20 m / (5 × 0.9 m) ≈ 4.4) over COM_ARM_EKF_POS denies arming with "Preflight Fail: position
    estimate error"; the reset to the fix 14 s later (shouldResetGpsFusion) clears it."""
    with Sim() as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        api.start_heartbeat()
        world = sim.vehicles[0]._world
        e, ring = world.estimation.est[0], world.estimation.ehist[0]
        e[E_POS] += 20.0
        ring[:, 0] += 20.0
        assert sim.run_until(lambda: not sim.status(0).prearm_ok, timeout_s=1.0)
        assert api.arm() == M.MAV_RESULT_TEMPORARILY_REJECTED
        sim.advance(0.1)
        texts = [m.text for m in api.messages("STATUSTEXT")]
        assert "Preflight Fail: position estimate error" in texts, texts
        sim.advance(1.0)  # ESTIMATOR_STATUS: 1 Hz on the API link
        status = api.messages("ESTIMATOR_STATUS")[-1]
        assert 4.0 < status.pos_horiz_ratio < 5.0
        assert sim.run_until(lambda: sim.status(0).prearm_ok, timeout_s=15.0)
        assert api.arm() == 0
