"""A lockstep flight's ULog as Flight Review (PX4/flight_review, app/plot_app/configured_plots.py
and helper.py) reads it: PX4 1.15's topic and field names, the info fields it switches on."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import pyulog
from pyulog.px4 import PX4ULog

from gateway.onboard.logged_topics import TOPICS
from gateway.testing import Sim


def takeoff_hover_land(sim: Sim) -> None:
    """Boot, takeoff, 2 s of hover, land and disarm, then 1 s on the ground (a short flight
    log from boot, SDLOG_MODE 1)."""
    assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
    api = sim.api(0)
    assert api.arm() == 0 and api.takeoff() == 0
    assert sim.run_until(lambda: sim.status(0).nav_state.name == "AUTO_LOITER", timeout_s=30)
    sim.advance(2.0)
    assert api.land() == 0
    assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=60)
    sim.advance(1.0)


@pytest.fixture(scope="module")
def flight_log(tmp_path_factory) -> pyulog.ULog:
    log_dir: Path = tmp_path_factory.mktemp("flight-review")
    with Sim(log_dir=log_dir) as sim:
        takeoff_hover_land(sim)
    (path,) = sorted((log_dir / "vehicle-1" / "log").rglob("*.ulg"))
    return pyulog.ULog(str(path))


def test_ver_data_format_2_so_gps_altitude_is_read_as_altitude_msl_m(flight_log):
    """logger.cpp write_version writes ver_data_format 2; without it Flight Review reads
    vehicle_gps_position.alt (the pre-1.14 int32 field) and the page fails."""
    assert flight_log.msg_info_dict["ver_data_format"] == 2
    # write_version: time_ref_utc is SDLOG_UTC_OFFSET (0) in seconds; sys_uuid with SDLOG_UUID 1
    assert flight_log.msg_info_dict["time_ref_utc"] == 0 and "sys_uuid" in flight_log.msg_info_dict
    gps = flight_log.get_dataset("vehicle_gps_position").data
    assert 400.0 < gps["altitude_msl_m"].mean() < 600.0


# PX4 1.15 logged_topics.cpp add_default_topics on a SITL build (default profile): the interval
# of the last add_topic of each topic CORNET logs, in ms (0: every update).
PX4_SITL_INTERVALS_MS = {
    "vehicle_attitude": 0, "vehicle_local_position": 0, "vehicle_global_position": 0,
    "vehicle_status": 0, "sensor_combined": 0, "vehicle_gps_position": 100,
    "battery_status": 200, "actuator_outputs": 100, "vehicle_local_position_setpoint": 100,
    "trajectory_setpoint": 200, "vehicle_land_detected": 0, "estimator_status": 0, "wind": 0,
    "vehicle_attitude_setpoint": 50, "vehicle_rates_setpoint": 20,
    "vehicle_angular_velocity": 10, "vehicle_thrust_setpoint": 20, "actuator_motors": 100,
    "hover_thrust_estimate": 100, "home_position": 0, "vehicle_control_mode": 0,
    "manual_control_setpoint": 200, "vehicle_air_data": 200, "vehicle_magnetometer": 500,
    "vehicle_attitude_groundtruth": 10, "vehicle_angular_velocity_groundtruth": 10,
    "vehicle_local_position_groundtruth": 20, "vehicle_global_position_groundtruth": 100,
    "failsafe_flags": 0, "sensor_baro": 1000, "vehicle_imu_status": 1000,
    "vehicle_torque_setpoint": 20, "rate_ctrl_status": 200, "position_setpoint_triplet": 200,
    "cpuload": 0, "esc_status": 250, "actuator_armed": 0, "rtl_time_estimate": 1000,
    "takeoff_status": 1000, "vehicle_acceleration": 50, "failure_detector_status": 100,
    "mission_result": 0, "vehicle_roi": 1000, "telemetry_status": 1000, "timesync_status": 1000,
}


def test_intervals_are_px4s_sitl_default_profile():
    assert {t.name: round(t.interval_s * 1000) for t in TOPICS} == PX4_SITL_INTERVALS_MS


# What Flight Review's default plots of a multicopter log read (configured_plots.py, helper.py
# ActuatorControls / get_flight_mode_changes, plotting.py plot_map, plotted_tables.py,
# db_entry.py), topic by topic, for the plots CORNET's log can fill. An add_graph call with one
# field missing draws none of its lines, so every field of a call is needed.
FLIGHT_REVIEW_FIELDS = {
    "vehicle_local_position": ["x", "y", "z", "vx", "vy", "vz", "xy_valid", "z_valid",
                               "v_xy_valid", "v_z_valid", "ref_lat", "ref_lon"],
    "vehicle_local_position_setpoint": ["x", "y", "z", "vx", "vy", "vz"],
    "vehicle_local_position_groundtruth": ["x", "y"],
    "vehicle_gps_position": ["latitude_deg", "longitude_deg", "altitude_msl_m", "fix_type",
                             "eph", "epv", "hdop", "vdop", "s_variance_m_s", "satellites_used",
                             "noise_per_ms", "jamming_indicator", "time_utc_usec", "vel_m_s"],
    "vehicle_air_data": ["baro_alt_meter"],
    "vehicle_global_position": ["alt"],
    "position_setpoint_triplet": ["current.alt", "current.lat", "current.lon"],
    "vehicle_attitude": ["roll", "pitch", "yaw"],
    "vehicle_attitude_setpoint": ["roll_d", "pitch_d", "yaw_d", "yaw_sp_move_rate"],
    "vehicle_attitude_groundtruth": ["roll", "pitch", "yaw"],
    "vehicle_angular_velocity": ["xyz[0]", "xyz[1]", "xyz[2]"],
    "vehicle_angular_velocity_groundtruth": ["xyz[0]", "xyz[1]", "xyz[2]"],
    "vehicle_rates_setpoint": ["roll", "pitch", "yaw"],
    "vehicle_thrust_setpoint": ["xyz[0]", "xyz[1]", "xyz[2]"],
    "vehicle_torque_setpoint": ["xyz[0]", "xyz[1]", "xyz[2]"],
    "rate_ctrl_status": ["rollspeed_integ", "pitchspeed_integ", "yawspeed_integ"],
    "actuator_motors": [f"control[{i}]" for i in range(12)],
    "sensor_combined": ["accelerometer_m_s2[0]", "accelerometer_m_s2[1]",
                        "accelerometer_m_s2[2]", "gyro_rad[0]", "gyro_rad[1]", "gyro_rad[2]"],
    "vehicle_imu_status": ["accel_vibration_metric"],
    "vehicle_magnetometer": ["magnetometer_ga[0]", "magnetometer_ga[1]", "magnetometer_ga[2]"],
    "battery_status": ["voltage_v", "current_a", "discharged_mah", "remaining", "temperature"],
    "sensor_baro": ["temperature"],
    "estimator_status": ["health_flags", "timeout_flags", "time_slip"],
    "vehicle_status": ["nav_state", "is_vtol", "failsafe", "failsafe_and_user_took_over"],
    "failsafe_flags": ["manual_control_signal_lost", "gcs_connection_lost"],
    "event": ["id", "arguments[0]"],
    "cpuload": ["load", "ram_usage"],  # the CPU & RAM plot
}
# Published only once stick input came (the flight has none): checked on the format.
FLIGHT_REVIEW_FORMAT_FIELDS = {
    "manual_control_setpoint": ["roll", "pitch", "yaw", "throttle", "aux1", "aux2"],
}


def test_every_field_flight_reviews_plots_read_is_in_the_log(flight_log):
    PX4ULog(flight_log).add_roll_pitch_yaw()  # as Flight Review's main.py does
    missing = []
    for topic, fields in FLIGHT_REVIEW_FIELDS.items():
        data = flight_log.get_dataset(topic, 0).data  # instance 0, as Flight Review reads
        missing += [f"{topic}.{f}" for f in fields if f not in data]
    for topic, fields in FLIGHT_REVIEW_FORMAT_FIELDS.items():
        names = {name for _, _, name in flight_log.message_formats[topic].fields}
        missing += [f"{topic}.{f}" for f in fields if f not in names]
    assert missing == []


def test_the_velocity_setpoint_is_the_position_controllers(flight_log):
    """mc_pos_control publishes its velocity setpoint in vehicle_local_position_setpoint:
    Flight Review's Velocity plot draws it beside the estimate."""
    sp = flight_log.get_dataset("vehicle_local_position_setpoint").data
    flying = np.isfinite(sp["z"])
    controlled = np.isfinite(sp["vz"])  # not before the takeoff (PX4: an empty setpoint)
    assert controlled.sum() > 0.8 * flying.sum() and not (controlled & ~flying).any()
    assert sp["vz"][controlled].min() < -0.5 and sp["vz"][controlled].max() > 0.3  # up, down
    # the thrust vector (NED) points up, the attitude setpoint's collective thrust
    assert (sp["thrust[2]"][flying] <= 0.0).all() and sp["thrust[2]"][controlled].min() < -0.1


def test_gps_as_px4s_simulated_receiver_reports_it(flight_log):
    """sensor_gps_sim: a 3D fix, eph 0.9, epv 1.78, hdop 0.7, vdop 1.1, s_variance 0.4 m/s,
    no UTC time, no jamming; vel_m_s the ground speed."""
    gps = flight_log.get_dataset("vehicle_gps_position").data
    assert set(gps["fix_type"]) == {3} and set(gps["satellites_used"]) == {10}
    for field, value in (("eph", 0.9), ("epv", 1.78), ("hdop", 0.7), ("vdop", 1.1),
                         ("s_variance_m_s", 0.4)):
        assert gps[field] == pytest.approx(value), field
    assert not gps["time_utc_usec"].any() and not gps["noise_per_ms"].any()
    assert gps["vel_m_s"] == pytest.approx(np.hypot(gps["vel_n_m_s"], gps["vel_e_m_s"]), abs=1e-4)
    assert gps["altitude_ellipsoid_m"] == pytest.approx(gps["altitude_msl_m"])


def test_vehicle_status_is_a_multicopters(flight_log):
    status = flight_log.get_dataset("vehicle_status").data
    assert set(status["vehicle_type"]) == {1} and not status["is_vtol"].any()
    assert not status["failsafe_and_user_took_over"].any()
    # the mode the user asked for: Takeoff, then Hold, then Land
    assert {17, 4, 18} <= set(status["nav_state_user_intention"])


def test_torque_and_rate_integrators_are_the_rate_controllers(flight_log):
    """vehicle_torque_setpoint (Flight Review's Actuator Controls plot and its FFT): the rate
    controller's normalized torque while flying, 0 before arming; rate_ctrl_status: its
    integrators, within MC_*R_INT_LIM."""
    torque = flight_log.get_dataset("vehicle_torque_setpoint").data
    xyz = np.array([torque[f"xyz[{i}]"] for i in range(3)])
    assert np.abs(xyz).max() > 1e-3 and np.abs(xyz).max() <= 1.0
    assert (xyz[:, 0] == 0.0).all()  # disarmed at the start of the log (SDLOG_MODE 1)
    integ = flight_log.get_dataset("rate_ctrl_status").data
    for axis, limit in (("roll", "MC_RR_INT_LIM"), ("pitch", "MC_PR_INT_LIM"),
                        ("yaw", "MC_YR_INT_LIM")):
        values = integ[f"{axis}speed_integ"]
        assert np.abs(values).max() <= flight_log.initial_parameters[limit] + 1e-6
    assert any(np.abs(integ[f"{a}speed_integ"]).max() > 0.0 for a in ("roll", "pitch", "yaw"))


def test_the_navigators_setpoint_is_position_setpoint_triplet_current(flight_log):
    """position_setpoint_triplet (nested position_setpoint formats, as PX4 writes them):
    Flight Review's Altitude Estimate plot draws current.alt, its map current.lat/lon. The
    takeoff's and Hold's setpoint is 2.5 m above home (MIS_TAKEOFF_ALT)."""
    assert "position_setpoint" in flight_log.message_formats
    triplet = flight_log.get_dataset("position_setpoint_triplet").data
    valid = triplet["current.valid"] == 1
    home_alt = flight_log.get_dataset("home_position").data["alt"][0]
    assert valid.any() and np.isfinite(triplet["current.lat"][valid]).all()
    assert (np.abs(triplet["current.alt"][valid] - home_alt - 2.5) < 0.1).any()
    gps = flight_log.get_dataset("vehicle_gps_position").data
    assert abs(triplet["current.lat"][valid][0] - gps["latitude_deg"][0]) < 1e-4


def test_cpuload_is_load_mons_every_500_ms(flight_log):
    """load_mon publishes cpuload every 500 ms (the logger has no interval for it), the values
    SYS_STATUS's load is sent from."""
    from gateway.mavlink.heartbeat import CPULOAD_LOAD, CPULOAD_RAM_USAGE

    cpuload = flight_log.get_dataset("cpuload").data
    gaps = np.diff(cpuload["timestamp"])
    assert len(gaps) > 10 and gaps.min() >= 480_000 and gaps.max() <= 520_000
    assert cpuload["load"] == pytest.approx(CPULOAD_LOAD)
    assert cpuload["ram_usage"] == pytest.approx(CPULOAD_RAM_USAGE)
    assert 0.0 < CPULOAD_LOAD < 1.0 and 0.0 < CPULOAD_RAM_USAGE < 1.0


def test_esc_status_is_the_gz_bridges_report_of_the_commanded_rotor_speeds(flight_log):
    """GZMixingInterfaceESC publishes esc_status for every motor command (logged every 250 ms):
    four ESCs online, esc_rpm the mixer's output, armed while that is above 0."""
    esc = flight_log.get_dataset("esc_status").data
    motors = flight_log.get_dataset("actuator_outputs").data
    assert (esc["esc_count"] == 4).all() and (esc["esc_online_flags"] == 0b1111).all()
    flying = esc["esc_armed_flags"] == 0b1111
    assert flying.any() and (esc["esc_armed_flags"][:3] == 0).all()  # disarmed at the start
    rpm = esc["esc[0].esc_rpm"][flying]
    # (the two topics are logged at their own instants: a maximum the other's sample missed)
    assert rpm.min() > 0 and rpm.max() <= 1.02 * motors["output[0]"].max()
    assert (esc["esc[4].esc_rpm"] == 0).all() and (esc["esc[0].timestamp"] == esc["timestamp"]).all()


def test_actuator_armed_and_rtl_time_estimate_are_logged(tmp_path):
    """Commander's actuator_armed (on change: ready_to_arm with the checks, armed, never
    prearmed without a safety button) and RTL's rtl_time_estimate (every ~2 s, as published)."""
    import pyulog

    from gateway.ci.lockstep import Sim

    with Sim(1, log_dir=tmp_path) as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
        assert sim.api(0).arm() == 0 and sim.api(0).takeoff() == 0
        sim.advance(10.0)
    (path,) = tmp_path.rglob("*.ulg")
    log = pyulog.ULog(str(path))
    armed = log.get_dataset("actuator_armed").data
    assert list(armed["armed"])[-1] == 1 and not any(armed["prearmed"])
    assert list(armed["ready_to_arm"])[-1] == 1 and not any(armed["lockdown"])
    rtl = log.get_dataset("rtl_time_estimate").data
    gaps = set((rtl["timestamp"][1:] - rtl["timestamp"][:-1]).tolist())
    assert gaps == {2_000_000} and rtl["safe_time_estimate"][-1] > 100.0
