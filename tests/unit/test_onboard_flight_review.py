"""A lockstep flight's ULog as Flight Review (PX4/flight_review, app/plot_app/configured_plots.py
and helper.py) reads it: PX4 1.15's topic and field names, the info fields it switches on."""

from __future__ import annotations

from pathlib import Path

import pytest
import pyulog

from gateway.onboard.logged_topics import TOPICS
from gateway.testing import Sim


@pytest.fixture(scope="module")
def flight_log(tmp_path_factory) -> pyulog.ULog:
    log_dir: Path = tmp_path_factory.mktemp("flight-review")
    with Sim(log_dir=log_dir) as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        assert api.arm() == 0 and api.takeoff() == 0
        assert sim.run_until(lambda: sim.status(0).nav_state.name == "AUTO_LOITER", timeout_s=30)
        sim.advance(2.0)
        assert api.land() == 0
        assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=60)
        sim.advance(1.0)
    (path,) = sorted((log_dir / "vehicle-1" / "log").rglob("*.ulg"))
    return pyulog.ULog(str(path))


def test_ver_data_format_2_so_gps_altitude_is_read_as_altitude_msl_m(flight_log):
    """logger.cpp write_version writes ver_data_format 2; without it Flight Review reads
    vehicle_gps_position.alt (the pre-1.14 int32 field) and the page fails."""
    assert flight_log.msg_info_dict["ver_data_format"] == 2
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
}


def test_intervals_are_px4s_sitl_default_profile():
    assert {t.name: round(t.interval_s * 1000) for t in TOPICS} == PX4_SITL_INTERVALS_MS
