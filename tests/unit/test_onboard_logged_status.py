"""The status topics of the flight log (gateway/onboard/logged_status.py) read with pyulog:
takeoff_status, vehicle_acceleration, failure_detector_status, mission_result and
telemetry_status, with PX4 1.15's generated formats and logged_topics.cpp's rates."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import pyulog

from gateway.ci.lockstep import Sim, mission_item
from gateway.mavlink.session import LinkKind
from gateway.onboard import ulog
from tests.unit.test_onboard_flight_review import takeoff_hover_land
from vehicles.plan_types import MavCmd, PlanResult
from vehicles.types import PX4_SITL_HOME
from vehicles.vehicle_acceleration import lowpass2p

# PX4 1.15's ULog formats (px_generate_uorb_topic_helper: by type size, then the padding)
FORMATS = {
    "takeoff_status": ["timestamp", "tilt_limit", "takeoff_state", "_padding0"],
    "vehicle_acceleration": ["timestamp", "timestamp_sample", "xyz", "_padding0"],
    "failure_detector_status": [
        "timestamp", "imbalanced_prop_metric", "motor_failure_mask", "fd_roll", "fd_pitch",
        "fd_alt", "fd_ext", "fd_arm_escs", "fd_battery", "fd_imbalanced_prop", "fd_motor",
        "_padding0"],
    "mission_result": [
        "timestamp", "mission_id", "geofence_id", "home_position_counter", "seq_reached",
        "seq_current", "seq_total", "item_changed_index", "item_do_jump_remaining", "valid",
        "warning", "finished", "failure", "item_do_jump_changed", "execution_mode",
        "_padding0"],
}


def _log(log_dir: Path) -> pyulog.ULog:
    return pyulog.ULog(str(sorted((log_dir / "vehicle-1" / "log").rglob("*.ulg"))[0]))


@pytest.fixture(scope="module")
def takeoff_log(tmp_path_factory) -> pyulog.ULog:
    """Boot, takeoff, hover, land (SDLOG_MODE 1: from boot), on PX4 SITL's two links."""
    log_dir = tmp_path_factory.mktemp("takeoff")
    with Sim(log_dir=log_dir, links=(LinkKind.GCS, LinkKind.API)) as sim:
        takeoff_hover_land(sim)
    return _log(log_dir)


def test_formats_are_px4s_generated_ones_and_records_leave_the_end_padding_out(takeoff_log):
    formats = takeoff_log.message_formats
    for name, fields in FORMATS.items():
        assert [f for _, _, f in formats[name].fields] == fields, name
    assert formats["takeoff_status"].fields[-1] == ("uint8_t", 3, "_padding0")
    telemetry = [f for _, _, f in formats["telemetry_status"].fields]
    assert telemetry[:4] == ["timestamp", "data_rate", "rate_multiplier", "tx_rate_avg"]
    assert telemetry[13:16] == ["rx_message_lost_rate", "type", "mode"]
    assert telemetry[-1] == "_padding0" and len(telemetry) == 41
    # a record is the struct without its trailing padding (o_size_no_padding)
    st = ulog.struct_of((("uint64_t", "timestamp"), ("float", "tilt_limit"),
                         ("uint8_t", "takeoff_state"), ("uint8_t[3]", "_padding0")))
    assert st.size == 13


def test_takeoff_status_follows_the_takeoff_state_machine_to_flight(takeoff_log):
    data = takeoff_log.get_dataset("takeoff_status").data
    states = list(data["takeoff_state"])
    assert states[0] == 1  # TAKEOFF_STATE_DISARMED
    assert 5 in states and states.index(5) > states.index(2)  # spoolup, then flight
    assert states[-1] == 1  # disarmed after landing
    first_flight = states.index(5)
    assert list(data["takeoff_state"][:first_flight + 1]) == sorted(states[:first_flight + 1])
    tilt = data["tilt_limit"]
    land, air = math.radians(12.0), math.radians(45.0)  # MPC_TILTMAX_LND, MPC_TILTMAX_AIR
    assert tilt[0] == pytest.approx(land, abs=1e-6) and tilt.max() == pytest.approx(air, abs=1e-6)
    # logged at most once a second (logged_topics.cpp: 1000 ms)
    assert np.diff(data["timestamp"]).min() >= 1_000_000


def test_vehicle_acceleration_is_the_filtered_imu_at_its_interval(takeoff_log):
    acc = takeoff_log.get_dataset("vehicle_acceleration").data
    t = acc["timestamp"]
    assert (acc["timestamp_sample"] == t).all()
    # 50 ms on 4 ms samples: every 13th step, as uORB's interval keeps it (the log's last
    # sample, at disarming, writes every step since the one before)
    assert np.median(np.diff(t)) == 52_000 and np.diff(t[:-20]).min() >= 50_000
    assert abs(np.median(acc["xyz[2]"]) + 9.80665) < 0.05  # -g along z (FRD) at rest and hover
    # PX4's LowPassFilter2p (direct form II) over sensor_combined's samples at every step
    imu = takeoff_log.get_dataset("sensor_combined").data
    b0, b1, b2, a1, a2 = lowpass2p(250.0, 30.0)
    x = imu["accelerometer_m_s2[0]"].astype(float)
    d1 = d2 = x[0] / (1 + a1 + a2)
    out = np.empty_like(x)
    for k, sample in enumerate(x):
        d0 = sample - d1 * a1 - d2 * a2
        out[k] = d0 * b0 + d1 * b1 + d2 * b2
        d1, d2 = d0, d1
    at = np.searchsorted(imu["timestamp"], t[100:])
    assert (imu["timestamp"][at] == t[100:]).all()
    assert np.allclose(acc["xyz[0]"][100:], out[at], atol=1e-4)
    assert not np.allclose(acc["xyz[0]"][100:], x[at], atol=1e-4)  # not the raw samples


def test_failure_detector_status_with_vehicle_status_every_500_ms(takeoff_log):
    fd = takeoff_log.get_dataset("failure_detector_status").data
    assert np.median(np.diff(fd["timestamp"])) == 500_000
    for flag in ("fd_roll", "fd_pitch", "fd_motor", "fd_arm_escs"):
        assert not fd[flag].any(), flag
    assert (fd["motor_failure_mask"] == 0).all()


def test_commander_topics_every_500_ms_and_at_once_on_change(takeoff_log):
    """Commander::run publishes actuator_armed, vehicle_control_mode and vehicle_status 500 ms
    after its last publication and at once when they change: so they are logged (no logger
    interval)."""
    for name in ("vehicle_status", "actuator_armed", "vehicle_control_mode"):
        data = takeoff_log.get_dataset(name).data
        gaps = np.diff(data["timestamp"])
        assert np.median(gaps) == pytest.approx(500_000, abs=20_000), name
        assert gaps.max() <= 520_000, name
    status = takeoff_log.get_dataset("vehicle_status").data
    armed = np.flatnonzero(np.diff(status["arming_state"].astype(int)) != 0)
    assert len(armed) == 2  # armed, then disarmed after the landing
    # the changes are logged at the tick they happen, not at the next 500 ms
    assert (np.diff(status["timestamp"])[armed] < 500_000).all()


def test_telemetry_status_per_mavlink_instance_every_second(takeoff_log):
    by_instance = {d.multi_id: d.data for d in takeoff_log.data_list
                   if d.name == "telemetry_status"}
    assert set(by_instance) == {0, 1}  # the GCS link, then the API link, as PX4 SITL starts them
    gcs, api = by_instance[0], by_instance[1]
    assert list(gcs["mode"][:1]) == [0] and list(api["mode"][:1]) == [2]  # normal, onboard
    for data in (gcs, api):
        assert np.median(np.diff(data["timestamp"])) == 1_000_000
        assert (np.diff(data["tx_message_count"].astype(np.int64)) > 0).all()
        assert data["tx_rate_avg"][-1] > 1000.0 and data["rx_message_count"][-1] > 0
        assert (data["data_rate"] == 4e6).all() and data["mavlink_v2"].all()
        assert data["streams"][-1] > 10
    # the API client (MAVSDK) sends GCS heartbeats; the GCS link's client here sends none
    assert api["heartbeat_type_gcs"][-1] == 1 and not gcs["heartbeat_type_gcs"].any()


def geo(n: float, e: float) -> tuple[float, float]:
    g = PX4_SITL_HOME.offset_ned(n, e, 0.0)
    return g.lat_deg, g.lon_deg


def test_mission_result_advances_with_the_mission(tmp_path):
    """Takeoff, a waypoint, a DO_JUMP back to it once, land: seq_reached and seq_current move
    along, the jump is reported once, the mission finishes."""
    items = [mission_item(MavCmd.NAV_TAKEOFF, *geo(0, 0), 5.0),
             mission_item(MavCmd.NAV_WAYPOINT, *geo(8, 0), 5.0),
             mission_item(MavCmd.DO_JUMP, params=(1, 1, 0, 0)),
             mission_item(MavCmd.NAV_LAND, *geo(0, 0), 0.0)]
    with Sim(log_dir=tmp_path) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        assert api.upload_mission(items) == PlanResult.ACCEPTED
        assert api.arm() == 0 and api.start_mission() == 0
        assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=120)
        sim.advance(1.0)
        mission_id = sim.vehicles[0].mission_status.mission_id
    result = _log(tmp_path).get_dataset("mission_result").data
    assert result["valid"][-1] and not result["warning"][-1] and result["finished"][-1]
    assert (result["seq_total"][-5:] == 4).all() and result["mission_id"][-1] == mission_id
    assert result["home_position_counter"][-1] >= 1
    reached = [int(s) for s in result["seq_reached"] if s >= 0]
    assert reached[0] == 0 and reached == sorted(reached) and reached[-1] == 3
    current = [int(s) for s in result["seq_current"]]
    assert 1 in current and current[-1] == 3 and current == sorted(current)
    jumps = result["item_do_jump_changed"] == 1
    assert jumps.sum() == 1
    assert result["item_changed_index"][jumps][0] == 2
    assert result["item_do_jump_remaining"][jumps][0] == 0
    assert not result["failure"].any() and (result["execution_mode"] == 0).all()


def test_vehicle_roi_is_logged_from_the_mission_item_that_sets_it(tmp_path, takeoff_log):
    """A mission's DO_SET_ROI_LOCATION (relative altitude) publishes vehicle_roi as the command
    does (issue_command): mode LOCATION, the item's position, its altitude above home's. The
    mission's own reset (update_mission) publishes nothing; a flight without a ROI has none."""
    assert "vehicle_roi" not in {d.name for d in takeoff_log.data_list}
    lat, lon = geo(10, 10)
    items = [mission_item(MavCmd.NAV_TAKEOFF, *geo(0, 0), 5.0),
             mission_item(195, lat, lon, 2.0),  # DO_SET_ROI_LOCATION
             mission_item(MavCmd.NAV_WAYPOINT, *geo(8, 0), 5.0),
             mission_item(MavCmd.NAV_LAND, *geo(0, 0), 0.0)]
    with Sim(log_dir=tmp_path) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        assert api.upload_mission(items) == PlanResult.ACCEPTED
        assert api.arm() == 0 and api.start_mission() == 0
        assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=120)
        sim.advance(1.0)
    log = _log(tmp_path)
    assert [f for _, _, f in log.message_formats["vehicle_roi"].fields] == [
        "timestamp", "lat", "lon", "alt", "roll_offset", "pitch_offset", "yaw_offset", "mode",
        "_padding0"]
    roi = log.get_dataset("vehicle_roi").data
    # one publication: its record, and the same again in the log's last sample
    assert (roi["mode"] == 3).all() and len(set(roi["lat"])) == len(set(roi["alt"])) == 1
    assert roi["lat"][0] == pytest.approx(lat, abs=1e-7)
    assert roi["lon"][0] == pytest.approx(lon, abs=1e-7)
    # (home: the estimated altitude at arming, which the GPS height reference moves by cm)
    assert roi["alt"][0] == pytest.approx(PX4_SITL_HOME.alt_amsl_m + 2.0, abs=0.1)
    assert not roi["yaw_offset"].any()


def test_each_vehicle_roi_publication_is_a_record_even_a_repeat(tmp_path):
    """navigator_main.cpp stamps and publishes vehicle_roi at every ROI command: the same ROI
    sent again 3 s later is a second record, with the second command's time."""
    lat, lon = geo(10, 10)
    with Sim(log_dir=tmp_path, params={"SDLOG_MODE": 1}) as sim:
        api = sim.api(0)
        sim.advance(1.0)
        sent = []
        for _ in range(2):
            sent.append(sim.now)
            assert api.command_long(195, 0, 0, 0, 0, lat, lon, 500.0) == 0  # DO_SET_ROI_LOCATION
            sim.advance(3.0)
    roi = _log(tmp_path).get_dataset("vehicle_roi").data
    stamps = sorted(set(roi["timestamp"]))
    assert len(stamps) == 2 and len(set(roi["lat"])) == 1
    assert [s * 1e-6 for s in stamps] == [pytest.approx(t, abs=0.01) for t in sent]
