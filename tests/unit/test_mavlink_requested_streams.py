"""Messages PX4 SITL sends only on request (MAVSDK's telemetry.set_rate_*): SET_MESSAGE_INTERVAL
is ACCEPTED on both links, then each comes at the rate with PX4's fields and units, or, where
SITL has no data, nothing comes (PX4's streams send only on a uORB update)."""

import math

import pytest
from pymavlink.dialects.v20 import common as M
from test_mavlink_support import acks, make, of_type

from gateway.mavlink.session import LinkKind

ACCEPTED, FAILED = 0, 4
REQUESTED = {  # MAVSDK call -> message
    "set_rate_scaled_imu": M.MAVLINK_MSG_ID_SCALED_IMU,
    "set_rate_ground_truth": M.MAVLINK_MSG_ID_HIL_STATE_QUATERNION,
    "set_rate_actuator_output_status": M.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS,
}


def _enable(client, msg_id, hz):
    return acks(client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz))[0].result


@pytest.mark.parametrize("kind", [LinkKind.GCS, LinkKind.API], ids=["gcs", "api"])
@pytest.mark.parametrize("msg_id", REQUESTED.values(), ids=REQUESTED.keys())
def test_set_message_interval_is_accepted_and_off_by_default(kind, msg_id):
    vehicle, session, client = make(kind)
    vehicle.become_ready()
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)
    assert got[0].interval_us == 0  # not streamed: not in the mode's list, PX4 answers 0
    assert [m for m in client.run_until(2.0) if m.get_msgId() == msg_id] == []
    assert _enable(client, msg_id, 20.0) == ACCEPTED
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)
    assert got[0].interval_us == 50_000


@pytest.mark.parametrize("kind, msg_id, default_us", [
    (LinkKind.GCS, M.MAVLINK_MSG_ID_RC_CHANNELS, 50_000),  # normal 5 Hz, px4-rc.mavlink 20
    (LinkKind.API, M.MAVLINK_MSG_ID_RC_CHANNELS, 50_000),
    (LinkKind.GCS, M.MAVLINK_MSG_ID_DISTANCE_SENSOR, 2_000_000),
    (LinkKind.API, M.MAVLINK_MSG_ID_DISTANCE_SENSOR, 100_000),
], ids=["rc-gcs", "rc-api", "distance-gcs", "distance-api"])
def test_default_streams_without_data_report_px4s_rate_and_send_nothing(kind, msg_id,
                                                                         default_us):
    """configure_streams_to_default sets RC_CHANNELS and DISTANCE_SENSOR on both links, but
    SITL has no RC input and no range finder: MESSAGE_INTERVAL tells the rate, nothing comes,
    also when a client sets one (MAVSDK's set_rate_rc_status, set_rate_distance_sensor)."""
    vehicle, session, client = make(kind)
    vehicle.become_ready()
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)
    assert got[0].interval_us == default_us
    assert _enable(client, msg_id, 10.0) == ACCEPTED
    assert client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)[0].interval_us == 100_000
    assert [m for m in client.run_until(2.0) if m.get_msgId() == msg_id] == []


@pytest.mark.parametrize("msg_id", [27, 140])  # RAW_IMU, ACTUATOR_CONTROL_TARGET
def test_messages_px4_has_no_stream_for_stay_failed(msg_id):
    _, _, client = make(LinkKind.API)
    assert _enable(client, msg_id, 10.0) == FAILED


def test_scaled_imu_at_the_rate_in_mg_mrads_mgauss():
    vehicle, session, client = make(LinkKind.API)
    vehicle.become_ready()
    assert _enable(client, M.MAVLINK_MSG_ID_SCALED_IMU, 20.0) == ACCEPTED
    got = of_type(client.run_until(2.0), "SCALED_IMU")
    assert abs(len(got) - 40) <= 1
    imu = got[-1]
    assert (imu.xacc, imu.yacc, imu.zacc) == (0, 0, -1000)  # level, at rest: -1 g
    assert (imu.xgyro, imu.ygyro, imu.zgyro) == (0, 0, 0)
    assert (imu.xmag, imu.ymag, imu.zmag) == (214, 11, 429)  # gauss -> mgauss, truncated
    assert imu.temperature == 0  # gz bridge IMU and sensor_mag_sim: NaN, so never set
    assert 1900 <= imu.time_boot_ms <= 2000


def test_ground_truth_as_px4_fills_hil_state_quaternion():
    vehicle, session, client = make(LinkKind.API)
    vehicle.become_ready()
    vehicle.move_to(10.0, 0.0, -5.0, yaw_rad=math.pi / 2)
    vehicle.state.velocity_ned_mps[:] = (1.239, -0.5, 0.25)
    vehicle.state.acceleration_ned_mps2[:] = (0.9, -2.7, 0.0)
    assert _enable(client, M.MAVLINK_MSG_ID_HIL_STATE_QUATERNION, 25.0) == ACCEPTED
    got = of_type(client.run_until(2.0), "HIL_STATE_QUATERNION")
    assert abs(len(got) - 50) <= 1
    gt = got[-1]
    assert gt.time_usec == 0  # PX4 never sets it
    w, x, y, z = gt.attitude_quaternion
    assert (round(w, 6), x, y, round(z, 6)) == (round(math.sqrt(0.5), 6), 0.0, 0.0,
                                                round(math.sqrt(0.5), 6))
    geo = vehicle.global_position
    assert gt.lat == math.trunc(geo.lat_deg * 1e7) and gt.lat > 473977420
    assert gt.alt == 493000  # mm AMSL
    assert (gt.vx, gt.vy, gt.vz) == (123, -50, 25)  # cm/s, truncated
    assert (gt.xacc, gt.yacc, gt.zacc) == (0, -2, 0)  # m/s² truncated, as PX4 puts them
    assert (gt.ind_airspeed, gt.true_airspeed) == (0, 0)


def test_actuator_output_status_carries_the_motor_outputs():
    """The commanded outputs (actuator_outputs), not the rotors' speeds that lag them."""
    vehicle, session, client = make(LinkKind.GCS)
    vehicle.motor_outputs = (512.5, 530.0, 498.25, 505.0)
    vehicle.rotor_speeds_radps = (400.0, 410.0, 420.0, 430.0)
    assert _enable(client, M.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS, 10.0) == ACCEPTED
    got = of_type(client.run_until(3.0), "ACTUATOR_OUTPUT_STATUS")
    assert abs(len(got) - 30) <= 1
    st = got[-1]
    assert st.active == 16  # MixingOutput's channels
    assert list(st.actuator[:4]) == [512.5, 530.0, 498.25, 505.0]
    assert list(st.actuator[4:]) == [0.0] * 28
    assert 2_800_000 <= st.time_usec <= 3_000_000


@pytest.mark.parametrize("msg_id", [M.MAVLINK_MSG_ID_RC_CHANNELS,
                                    M.MAVLINK_MSG_ID_DISTANCE_SENSOR])
def test_streams_without_data_in_sitl_send_nothing(msg_id):
    vehicle, session, client = make(LinkKind.API)
    vehicle.become_ready()
    assert _enable(client, msg_id, 50.0) == ACCEPTED
    msgs = client.run_until(3.0)
    assert [m for m in msgs if m.get_msgId() == msg_id] == []
    assert of_type(msgs, "ATTITUDE")  # the other streams go on


def test_flight_information_as_px4_on_request():
    """FLIGHT_INFORMATION.hpp: arming and takeoff times in microseconds since boot (0 until
    then, and again after disarming); COM_FLIGHT_UUID, which each disarm counts up."""
    from gateway.testing import Sim

    def info(api):
        since = len(api.frames)
        assert api.command_long(M.MAV_CMD_REQUEST_MESSAGE,
                                M.MAVLINK_MSG_ID_FLIGHT_INFORMATION) == 0
        api.sim.advance(0.05)
        return api.messages("FLIGHT_INFORMATION", since)[-1]

    with Sim() as sim:
        sim.advance(6.0)
        api = sim.api(0)
        first = info(api)
        assert (first.arming_time_utc, first.takeoff_time_utc, first.flight_uuid) == (0, 0, 0)
        assert abs(first.time_boot_ms - 6000) < 100
        assert api.arm() == 0
        armed_at = sim.now
        assert api.takeoff() == 0
        sim.run_until(lambda: sim.status(0).landed_state == 2, 20.0)  # in the air
        flying = info(api)
        assert abs(flying.arming_time_utc - armed_at * 1e6) < 50_000
        assert flying.takeoff_time_utc > flying.arming_time_utc
        assert api.land() == 0
        sim.run_until(lambda: not sim.status(0).armed, 60.0)
        landed = info(api)
        assert (landed.arming_time_utc, landed.takeoff_time_utc, landed.flight_uuid) == (0, 0, 1)
        params = sim.vehicles[0].params
        assert params["COM_FLIGHT_UUID"] == 1
        # The land detector's total flight time: from takeoff to disarming, in µs.
        flown_us = landed.time_boot_ms * 1000 - flying.takeoff_time_utc
        assert params["LND_FLIGHT_T_HI"] == 0
        assert 0.5 * flown_us < params["LND_FLIGHT_T_LO"] < flown_us, flown_us
        since = len(api.frames)  # the deprecated command, answered as REQUEST_MESSAGE
        assert api.command_long(M.MAV_CMD_REQUEST_FLIGHT_INFORMATION, 1) == 0
        sim.advance(0.05)
        assert api.messages("FLIGHT_INFORMATION", since)[-1].flight_uuid == 1
