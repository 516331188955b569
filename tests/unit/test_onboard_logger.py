"""PX4's logger (gateway/onboard): ULog files that pyulog reads, at PX4's paths, from arming to
disarming (SDLOG_MODE), with the topics, parameters, parameter changes and messages; the same
lockstep flight writes the same bytes."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
import pyulog

from gateway.ci.lockstep import CLIENT_SYSID
from gateway.onboard import ulog
from gateway.testing import Sim
from vehicles.events import event_id

TOPICS = {"vehicle_attitude", "vehicle_local_position", "vehicle_global_position",
          "vehicle_status", "sensor_combined", "vehicle_gps_position", "battery_status",
          "actuator_outputs", "vehicle_local_position_setpoint", "trajectory_setpoint",
          "vehicle_land_detected", "estimator_status", "wind", "vehicle_attitude_setpoint",
          "vehicle_rates_setpoint", "vehicle_angular_velocity", "vehicle_thrust_setpoint",
          "actuator_motors", "hover_thrust_estimate", "home_position", "vehicle_control_mode",
          "vehicle_air_data", "vehicle_magnetometer", "vehicle_attitude_groundtruth",
          "vehicle_angular_velocity_groundtruth", "vehicle_local_position_groundtruth",
          "vehicle_global_position_groundtruth"}


def fly(log_dir: Path, **params) -> list[Path]:
    with Sim(log_dir=log_dir, params=params) as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        assert api.arm() == 0 and api.takeoff() == 0
        assert sim.run_until(lambda: sim.status(0).nav_state.name == "AUTO_LOITER", timeout_s=30)
        sim.advance(2.0)
        from pymavlink.dialects.v20 import common as M
        api.send(M.MAVLink_param_set_message(1, 1, b"MPC_XY_CRUISE", 7.0, 9))
        assert api.land() == 0
        assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=60)
        sim.advance(1.0)
    return sorted((log_dir / "vehicle-1" / "log").rglob("*.ulg"))


def test_a_flight_is_one_ulog_that_pyulog_reads(tmp_path):
    files = fly(tmp_path / "a")
    assert len(files) == 1  # SDLOG_MODE 1 (PX4 SITL): from boot to disarming
    path = files[0]
    # PX4's layout: log/<date>/<time>.ulg (UTC, from the run's epoch)
    assert path.parent.name.count("-") == 2 and path.stem.count("_") == 2
    log = pyulog.ULog(str(path))
    names = {d.name for d in log.data_list}
    assert TOPICS <= names
    pos = log.get_dataset("vehicle_local_position").data
    assert min(pos["z"]) < -2.0  # the takeoff is in it
    status = log.get_dataset("vehicle_status").data
    assert 2 in set(status["arming_state"]) and status["arming_state"][-1] == 1
    assert log.initial_parameters["MPC_XY_CRUISE"] == pytest.approx(5.0)
    assert any(name == "MPC_XY_CRUISE" and v == pytest.approx(7.0)
               for _, name, v in log.changed_parameters)
    texts = [m.message for m in log.logged_messages]
    assert any("Takeoff" in t or "takeoff" in t for t in texts), texts
    assert log.msg_info_dict["sys_name"] == "PX4" and "ver_sw" in log.msg_info_dict
    gps = log.get_dataset("vehicle_gps_position").data
    assert set(gps["fix_type"]) == {3}
    # a sync message every 500 ms of logging, as PX4's logger writes them
    seconds = (log.last_timestamp - log.start_timestamp) / 1e6
    assert path.read_bytes().count(ulog.SYNC_MAGIC) >= int(seconds / 0.5) - 1


def test_the_log_has_what_px4s_log_analysis_reads(tmp_path):
    """Setpoints beside the estimate (attitude, rates, thrust), the motors, the hover thrust
    estimator, home, the control mode, and SITL's ground truth beside the estimate; the
    firmware version as flight review reads it."""
    log = pyulog.ULog(str(fly(tmp_path)[0]))
    assert log.get_version_info_str() == "v1.15.2"
    assert log.msg_info_dict["ver_hw"] == "PX4_SITL"

    def data(topic: str) -> dict:
        return log.get_dataset(topic).data

    att_sp = data("vehicle_attitude_setpoint")
    q_norm = np.sqrt(sum(att_sp[f"q_d[{i}]"] ** 2 for i in range(4)))
    assert np.allclose(q_norm, 1.0, atol=1e-5)
    hover = data("hover_thrust_estimate")
    flying = att_sp["thrust_body[2]"] < -0.1
    assert flying.any() and (att_sp["thrust_body[2]"] <= 0).all()
    rates = data("vehicle_rates_setpoint")
    assert np.allclose(rates["thrust_body[2]"][-1], 0.0)  # landed and disarmed
    motors = data("actuator_motors")
    assert np.nanmax(motors["control[0]"]) <= 1.0 and np.nanmax(motors["control[0]"]) > 0.3
    assert np.isnan(motors["control[4]"]).all()  # a quadrotor: four motors
    assert 0.1 < hover["hover_thrust"].max() <= 0.9 and hover["valid"].any()
    home = data("home_position")
    assert home["valid_hpos"].all() and abs(home["lat"][-1] - 47.397742) < 1e-4
    mode = data("vehicle_control_mode")
    auto = mode["flag_control_auto_enabled"] == 1
    assert auto.any() and (mode["flag_control_position_enabled"][auto] == 1).all()
    assert (mode["flag_armed"] == 1).any() and mode["flag_armed"][-1] == 0
    est, truth = data("vehicle_local_position"), data("vehicle_local_position_groundtruth")
    n = min(len(est["z"]), len(truth["z"]))
    assert np.max(np.abs(est["z"][:n] - truth["z"][:n])) < 0.5 and truth["z"].min() < -2.0
    gyro = data("vehicle_angular_velocity")
    assert (gyro["timestamp_sample"] == gyro["timestamp"]).all()
    assert not log.get_default_parameters(0)  # nothing differs from a default here
    commands, acks = data("vehicle_command"), data("vehicle_command_ack")
    sent = list(commands["command"])
    assert sent[:2] == [400, 22] and 21 in sent  # arm, takeoff, ..., land
    assert commands["param1"][0] == 1.0 and commands["from_external"].all()
    assert list(acks["command"]) == sent and set(acks["result"]) == {0}
    assert acks["target_system"][0] == CLIENT_SYSID  # the client that sent it
    air = data("vehicle_air_data")
    assert 90_000 < air["baro_pressure_pa"][0] < 101_325
    # getDensityFromPressureAndTemp takes the gz bridge's 288.15 (kelvin) as °C: ~0.59 kg/m³.
    assert air["baro_temp_celcius"][0] == pytest.approx(288.15)
    assert air["rho"][0] == pytest.approx(air["baro_pressure_pa"][0] / (287.1 * 561.3), rel=1e-5)
    # The events, named by the events metadata the log carries (pyulog's PX4Events, as Flight
    # Review shows them), from the arming on.
    from pyulog.px4_events import PX4Events

    events = PX4Events()
    events.set_default_json_definitions_cb(lambda _: None)  # no download: the log's metadata
    shown = [m for _, _, m in events.get_logged_events(log)]
    assert shown == ["Armed by external command", "Using default takeoff altitude: 2.50 m",
                     "Takeoff detected", "Landing at current position", "Landing detected",
                     "Disarmed by landing"], shown
    assert set(data("event")["id"]) >= {event_id("commander_takeoff_detected"),
                                        event_id("commander_arming_check_summary")}


def test_same_lockstep_flight_same_bytes_and_sdlog_mode_0_starts_at_arming(tmp_path):
    a = fly(tmp_path / "a")
    b = fly(tmp_path / "b")
    assert [p.read_bytes() for p in a] == [p.read_bytes() for p in b]
    armed_only = fly(tmp_path / "c", SDLOG_MODE=0)
    log = pyulog.ULog(str(armed_only[0]))
    assert set(log.get_dataset("vehicle_status").data["arming_state"]) == {2, 1}
    assert log.start_timestamp > pyulog.ULog(str(a[0])).start_timestamp


def test_writer_parts_follow_the_spec():
    assert ulog.header(5)[:7] == b"ULog\x01\x12\x35" and len(ulog.header(5)) == 16
    assert len(ulog.flag_bits()) == 3 + 40
    assert ulog.format_message("t", (("uint64_t", "timestamp"), ("float[3]", "v")))[3:] == \
        b"t:uint64_t timestamp;float[3] v;"
    assert ulog.struct_of((("uint64_t", "timestamp"), ("float[3]", "v"), ("bool", "b"))).size == 21
    assert ulog.data_prefix(3, 5) + b"12345" == ulog.data(3, b"12345")
    # a nested format's fields are packed in its place
    nested = {"sp": (("bool", "valid"), ("double", "lat"))}
    assert ulog.struct_of((("uint64_t", "timestamp"), ("sp", "current")), nested).format == "<Q?d"
    assert ulog.struct_of((("sp[2]", "two"),), nested).size == 18


def test_log_download_over_mavlink_as_px4s_log_handler(tmp_path):
    """LOG_REQUEST_LIST → LOG_ENTRY (0-based ids, size, UTC start); LOG_REQUEST_DATA → LOG_DATA
    chunks that rebuild the file; unknown ids ignored; LOG_ERASE spares the log being written."""
    from pymavlink.dialects.v20 import common as M

    with Sim(log_dir=tmp_path, params={"SDLOG_MODE": 0}) as sim:
        api = sim.api(0)
        for _ in range(2):  # two flights: two logs
            assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
            assert api.arm() == 0
            sim.advance(2.0)
            assert api.disarm() == 0
            sim.advance(1.0)
        api.send(M.MAVLink_log_request_list_message(1, 1, 0, 0xFFFF))
        sim.advance(0.2)
        entries = api.messages("LOG_ENTRY")
        assert [(e.id, e.num_logs, e.last_log_num) for e in entries] == [(0, 2, 1), (1, 2, 1)]
        files = sorted((tmp_path / "vehicle-1" / "log").rglob("*.ulg"))
        assert [e.size for e in entries] == [p.stat().st_size for p in files]
        assert entries[0].time_utc <= entries[1].time_utc and entries[0].time_utc > 1.6e9
        api.send(M.MAVLink_log_request_data_message(1, 1, 7, 0, 0xFFFFFFFF))  # no such log
        api.send(M.MAVLink_log_request_data_message(1, 1, 1, 0, 0xFFFFFFFF))
        sim.advance(2.0)
        chunks = {m.ofs: bytes(m.data[:m.count]) for m in api.messages("LOG_DATA")}
        assert {m.id for m in api.messages("LOG_DATA")} == {1}
        assert b"".join(chunks[k] for k in sorted(chunks)) == files[1].read_bytes()
        assert pyulog.ULog(str(files[1])).msg_info_dict["sys_name"] == "PX4"
        assert api.arm() == 0  # a third log, being written
        sim.advance(1.0)
        api.send(M.MAVLink_log_erase_message(1, 1))
        sim.advance(0.2)
        assert len(list((tmp_path / "vehicle-1" / "log").rglob("*.ulg"))) == 1


def test_without_storage_the_list_is_empty_and_the_daemon_says_how_to_keep_logs(caplog):
    """No --state-dir or --log-dir: no ULog files (PX4 without its SD card), so LOG_REQUEST_LIST
    gets PX4's empty answer (one LOG_ENTRY, num_logs 0); the first request, once per daemon,
    says in its log which flags keep logs."""
    from pymavlink.dialects.v20 import common as M

    with Sim(vehicles=2) as sim:
        sim.advance(1.0)
        for index in (0, 1, 0):
            sim.api(index).send(M.MAVLink_log_request_list_message(index + 1, 1, 0, 0xFFFF))
            sim.advance(0.2)
        for index, requests in ((0, 2), (1, 1)):
            assert [(e.id, e.num_logs, e.last_log_num)
                    for e in sim.api(index).messages("LOG_ENTRY")] == [(0, 0, 0)] * requests
    hints = [r.getMessage() for r in caplog.records if "--log-dir" in r.getMessage()]
    assert len(hints) == 1 and "--state-dir DIR" in hints[0]


def test_parameter_defaults_as_px4s_logger_writes_them(tmp_path):
    """'Q' messages (logger.cpp write_parameter_defaults): a launch value (``param
    set-default``) is the current setup's default, PX4's own the system default; a parameter at
    both defaults has none, one a client changed has both; volatile ones never."""
    with Sim(log_dir=tmp_path, params={"MPC_XY_CRUISE": 7.0, "SDLOG_MODE": 0}) as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        params = sim.vehicles[0].params
        params.set("MIS_TAKEOFF_ALT", 4.0)
        params.set("MPC_XY_CRUISE", 6.0)
        params.set("COM_FLIGHT_UUID", 9, notify=False)
        api = sim.api(0)
        assert api.arm() == 0
        sim.advance(1.0)
        assert api.disarm() == 0
        sim.advance(1.0)
    log = pyulog.ULog(str(sorted((tmp_path / "vehicle-1" / "log").rglob("*.ulg"))[0]))
    assert log.has_default_parameters
    system, setup = log.get_default_parameters(0), log.get_default_parameters(1)
    assert system == {"MIS_TAKEOFF_ALT": 2.5, "MPC_XY_CRUISE": 5.0, "SDLOG_MODE": 1}
    assert setup == {"MIS_TAKEOFF_ALT": 2.5, "MPC_XY_CRUISE": 7.0}
    assert log.initial_parameters["COM_FLIGHT_UUID"] == 9


def test_what_px4_publishes_at_the_imu_rate_is_logged_at_that_rate(tmp_path):
    """logged_topics.cpp: sensor_combined and (SITL) vehicle_attitude at every update, here every
    4 ms physics step although the logger samples at 50 Hz; vehicle_angular_velocity and the
    attitude ground truth at their 10 ms interval, which on 4 ms samples is every third (12 ms)
    as uORB's interval keeps it. At rest the IMU measures -g along z (FRD)."""
    log = pyulog.ULog(str(fly(tmp_path)[0]))
    for topic, spacing in (("sensor_combined", 4000), ("vehicle_attitude", 4000),
                           ("vehicle_angular_velocity", 12000),
                           ("vehicle_attitude_groundtruth", 12000),
                           ("vehicle_angular_velocity_groundtruth", 12000)):
        t = log.get_dataset(topic).data["timestamp"]
        steps = np.diff(t)
        assert len(t) > 1000 and np.median(steps) == spacing, topic
        assert steps.min() >= 4000 and steps.max() <= spacing, topic  # none lost, none twice
    imu = log.get_dataset("sensor_combined").data
    assert abs(np.mean(imu["accelerometer_m_s2[2]"][:100]) + 9.80665) < 0.1
    assert set(imu["gyro_integral_dt"]) == {4000}
    gyro = log.get_dataset("vehicle_angular_velocity").data
    assert (gyro["timestamp_sample"] == gyro["timestamp"]).all()
    est, truth = log.get_dataset("vehicle_attitude").data, \
        log.get_dataset("vehicle_attitude_groundtruth").data
    at = np.searchsorted(est["timestamp"], truth["timestamp"])
    dot = sum(est[f"q[{i}]"][at] * truth[f"q[{i}]"] for i in range(4))
    assert np.abs(dot).min() > 0.999  # the estimate of the same instant


def test_imu_rate_records_are_the_samples_of_each_step():
    """Between two 50 Hz samples the logger writes each physics step's IMU sample, the values
    the vehicle flew on at that step, with that step's time."""
    from gateway.onboard.logged_topics import TOPICS as LOGGED
    from gateway.onboard.logger import VehicleLogger
    from vehicles.estimation import S_ACC, S_GYRO

    with Sim() as sim:
        sim.advance(1.0)
        vehicle = sim.vehicles[0]
        logger = VehicleLogger(vehicle, None, [t for t in LOGGED if t.name == "sensor_combined"])
        logger.tick(sim.now)
        seen = []
        for _ in range(12):
            sim.advance(0.004)
            s = vehicle.sensors
            seen.append((round(sim.now * 1e6), *s[S_GYRO:S_GYRO + 3], *s[S_ACC:S_ACC + 3]))
        logger.tick(sim.now)
        (_path, data, _closed), = logger.close()
    log = pyulog.ULog(io.BytesIO(data))
    imu = log.get_dataset("sensor_combined").data
    fields = ["timestamp", *(f"gyro_rad[{i}]" for i in range(3)),
              *(f"accelerometer_m_s2[{i}]" for i in range(3))]
    logged = list(zip(*(imu[f] for f in fields)))[-12:]
    assert len(imu["timestamp"]) == 13  # the first sample's step, then every step since
    for row, want in zip(logged, seen):
        assert row[0] == want[0]
        assert np.allclose(row[1:], want[1:], rtol=1e-6, atol=1e-7)


def test_a_topic_that_cannot_be_read_is_left_out_and_the_log_goes_on(tmp_path):
    from gateway.onboard.logged_topics import TOPICS, Topic
    from gateway.onboard.logger import VehicleLogger

    def broken(v, now_us):
        raise RuntimeError("no such sensor")

    with Sim() as sim:
        sim.advance(1.0)
        logger = VehicleLogger(sim.vehicles[0], None,
                               (TOPICS[1], Topic("broken", (("float", "x"),), 0.0, broken)))
        for k in range(5):
            logger.tick(1.0 + 0.02 * k)
        (path, data, _closed), = logger.close()
    (tmp_path / "log.ulg").write_bytes(data)
    log = pyulog.ULog(str(tmp_path / "log.ulg"))
    assert logger.errors == 5
    assert len(log.get_dataset("vehicle_local_position").data["timestamp"]) == 5


def test_an_on_change_topic_with_an_interval_is_looked_at_once_per_interval():
    """position_setpoint_triplet (200 ms, written when it changed): read every 200 ms, not at
    every 50 Hz tick."""
    from gateway.onboard.logged_topics import Topic
    from gateway.onboard.logger import VehicleLogger

    reads = []

    def steady(v, now_us):
        reads.append(now_us)
        return (1.0,)

    with Sim() as sim:
        sim.advance(1.0)
        logger = VehicleLogger(sim.vehicles[0], None,
                               (Topic("steady", (("float", "x"),), 0.2, steady, on_change=True),))
        logger.on(1.0)
        for k in range(1, 50):
            logger.tick(1.0 + 0.02 * k)
        (_path, data, _closed), = logger.close()
    assert len(reads) == 5 and data.count(logger._prefixes[0]) == 1


def test_stick_input_is_logged_as_manual_control_publishes_it(tmp_path):
    """manual_control_setpoint (200 ms), each record a publication of PX4's ManualControl: the
    zero setpoint, invalid, from boot; the sticks the vehicle flies on; once the input is lost,
    one record of the last sticks marked invalid (the selector keeps them), then none."""
    from pymavlink.dialects.v20 import common as M

    with Sim(log_dir=tmp_path, params={"SDLOG_MODE": 2}) as sim:
        sim.advance(2.0)
        api = sim.api(0)
        for _ in range(20):
            api.send(M.MAVLink_manual_control_message(1, 300, -200, 500, 100, 0b101))
            sim.advance(0.05)
        last_sample_us = round(sim.now * 1e6) - 50_000
        sim.advance(3.0)  # COM_RC_LOSS_T later: lost
    log = pyulog.ULog(str(sorted((tmp_path / "vehicle-1" / "log").rglob("*.ulg"))[0]))
    sticks = log.get_dataset("manual_control_setpoint").data
    assert (sticks["timestamp"][0], sticks["timestamp_sample"][0], sticks["valid"][0]) == (0, 0, 0)
    assert sticks["pitch"][0] == 0.0 and sticks["throttle"][0] == 0.0
    assert sticks["timestamp"][1] >= 2_000_000
    assert sticks["valid"][1] == 1 and sticks["pitch"][1] == pytest.approx(0.3)
    # the invalid publication, 600 ms after the last sample (Runs at +200 and +400 ms still
    # valid), is the last record
    assert sticks["valid"][-1] == 0 and sticks["pitch"][-1] == pytest.approx(0.3)
    assert sticks["timestamp"][-1] == last_sample_us + 600_000
    assert sticks["timestamp_sample"][-1] == last_sample_us
    assert list(sticks["valid"]).count(0) == 2
    # mavlink_receiver: the buttons passed on, flaps and aux channels 0 (Flight Review plots
    # aux1 and aux2 with the sticks)
    assert sticks["buttons"][1] == 0b101
    assert not any(sticks[f"aux{i}"].any() for i in range(1, 7)) and not sticks["flaps"].any()


def test_statustext_of_the_vehicles_own_system_is_logged(tmp_path):
    """MavlinkReceiver::handle_message_statustext: a STATUSTEXT from the vehicle's own system
    (its companion computer) becomes a log_message, which the logger writes; chunks are put
    together (MavlinkStatustextHandler). Another system's is not logged."""
    from pymavlink.dialects.v20 import common as M

    with Sim(log_dir=tmp_path) as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        companion = M.MAVLink(None, srcSystem=1, srcComponent=191)
        other = M.MAVLink(None, srcSystem=CLIENT_SYSID, srcComponent=190)
        api.send_bytes(companion.statustext_encode(4, b"companion up").pack(companion))
        api.send_bytes(other.statustext_encode(4, b"from the GCS").pack(other))
        for seq, part in enumerate((b"x" * 50, b"y" * 10)):
            api.send_bytes(companion.statustext_encode(6, part, 7, seq).pack(companion))
        sim.advance(1.0)
        assert api.arm() == 0
        sim.advance(1.0)
        assert api.disarm() == 0
        sim.advance(1.0)
    log = pyulog.ULog(str(sorted((tmp_path / "vehicle-1" / "log").rglob("*.ulg"))[0]))
    logged = [(m.log_level, m.message) for m in log.logged_messages]
    assert (ord("4"), "companion up") in logged and (ord("6"), "x" * 50 + "y" * 10) in logged
    assert not any(text == "from the GCS" for _, text in logged)
