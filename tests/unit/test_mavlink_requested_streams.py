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


# PX4 v1.15.2's configure_streams_to_default: (msg_id, NORMAL with px4-rc.mavlink's GCS link
# overrides, ONBOARD) in µs as MESSAGE_INTERVAL reports them; −1 is unlimited_rate.
SILENT_DEFAULTS = [
    (M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, 1_000_000, 100_000),
    (M.MAVLINK_MSG_ID_GPS_STATUS, 1_000_000, 1_000_000),
    (M.MAVLINK_MSG_ID_GPS2_RAW, 1_000_000, -1),
    (M.MAVLINK_MSG_ID_MOUNT_ORIENTATION, 100_000, 100_000),
    (M.MAVLINK_MSG_ID_GIMBAL_MANAGER_STATUS, 2_000_000, 2_000_000),
    (M.MAVLINK_MSG_ID_OPTICAL_FLOW_RAD, 100_000, 100_000),  # the GCS link: px4-rc.mavlink's 10 Hz
    (M.MAVLINK_MSG_ID_HYGROMETER_SENSOR, 10_000_000, 1_000_000),
    (M.MAVLINK_MSG_ID_TRAJECTORY_REPRESENTATION_WAYPOINTS, 0, 200_000),
    (M.MAVLINK_MSG_ID_ADSB_VEHICLE, -1, -1),
    (M.MAVLINK_MSG_ID_CAMERA_TRIGGER, 0, -1),
    (M.MAVLINK_MSG_ID_STATUSTEXT, 50_000, 50_000),  # Mavlink::task_main, on every link
    (M.MAVLINK_MSG_ID_COMMAND_LONG, -1, -1),
]


@pytest.mark.parametrize("kind", [LinkKind.GCS, LinkKind.API], ids=["gcs", "api"])
@pytest.mark.parametrize("msg_id, gcs_us, api_us", SILENT_DEFAULTS,
                         ids=[M.mavlink_map[m].msgname for m, _, _ in SILENT_DEFAULTS])
def test_px4s_streams_without_data_here_are_configured_as_in_px4(kind, msg_id, gcs_us, api_us):
    """Every stream of PX4's list can be set (ACCEPTED), and MESSAGE_INTERVAL reports what the
    link's mode configured, though nothing publishes the topic here: the stream sends nothing,
    and a REQUEST_MESSAGE for it is DENIED (its send() has nothing)."""
    vehicle, session, client = make(kind)
    vehicle.become_ready()
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)
    assert got[0].interval_us == (gcs_us if kind is LinkKind.GCS else api_us)
    assert _enable(client, msg_id, 4.0) == ACCEPTED
    assert client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)[0].interval_us == 250_000
    assert acks(client.command_long(M.MAV_CMD_REQUEST_MESSAGE, msg_id))[0].result == 2  # DENIED
    msgs = client.run_until(client.now_s + 2.0)
    assert [m for m in msgs if m.get_msgId() == msg_id] == []


def test_gps_raw_int_onboard_is_unlimited_and_comes_with_each_fix():
    """ONBOARD configures GPS_RAW_INT at unlimited_rate: MESSAGE_INTERVAL says −1, and it goes
    out with every sensor_gps sample (8 Hz); a rate set by a client paces it as any stream."""
    vehicle, session, client = make(LinkKind.API)
    vehicle.become_ready()
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_GPS_RAW_INT)
    assert got[0].interval_us == -1
    assert abs(len(of_type(client.run_until(2.0), "GPS_RAW_INT")) - 16) <= 1
    assert _enable(client, M.MAVLINK_MSG_ID_GPS_RAW_INT, 2.0) == ACCEPTED
    assert abs(len(of_type(client.run_until(4.0), "GPS_RAW_INT")) - 4) <= 1
    # the default again: unlimited
    assert acks(client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL,
                                    M.MAVLINK_MSG_ID_GPS_RAW_INT, 0))[0].result == ACCEPTED
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_GPS_RAW_INT)
    assert got[0].interval_us == -1


def test_boot_streams_stop_on_a_request_for_their_default():
    """STATUSTEXT is configured by Mavlink::task_main, not by the mode: a SET_MESSAGE_INTERVAL
    for the default rate runs configure_streams_to_default for it, which finds it in no list
    and stops it (MESSAGE_INTERVAL 0); texts then wait, and go out once a rate is set again."""
    vehicle, session, client = make(LinkKind.GCS)
    vehicle.become_ready()
    client.heartbeat()
    assert acks(client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL,
                                    M.MAVLINK_MSG_ID_STATUSTEXT, 0))[0].result == ACCEPTED
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_STATUSTEXT)
    assert got[0].interval_us == 0
    vehicle.say(client.now_s, "first")
    vehicle.say(client.now_s, "second")
    assert of_type(client.run_until(client.now_s + 0.5), "STATUSTEXT") == []
    client.heartbeat()
    assert _enable(client, M.MAVLINK_MSG_ID_STATUSTEXT, 2.0) == ACCEPTED
    sent = of_type(client.run_until(client.now_s + 0.1), "STATUSTEXT")
    assert [m.text for m in sent] == ["first"]  # one text per run, 0.5 s apart
    sent = of_type(client.run_until(client.now_s + 0.55), "STATUSTEXT")
    assert [m.text for m in sent] == ["second"]


@pytest.mark.parametrize("msg_id", [M.MAVLINK_MSG_ID_UTM_GLOBAL_POSITION,
                                    M.MAVLINK_MSG_ID_MISSION_CURRENT])
def test_messages_no_px4_stream_sends_cannot_be_set_or_requested(msg_id):
    """PX4 #21663 took UTM_GLOBAL_POSITION out of the stream list before v1.15; MISSION_CURRENT
    is the mission manager's. SET_MESSAGE_INTERVAL FAILS, REQUEST_MESSAGE is DENIED,
    MESSAGE_INTERVAL says 0 — MISSION_CURRENT still comes at its own 1 Hz."""
    vehicle, session, client = make(LinkKind.API)
    vehicle.become_ready()
    assert _enable(client, msg_id, 10.0) == FAILED
    assert acks(client.command_long(M.MAV_CMD_REQUEST_MESSAGE, msg_id))[0].result == 2
    assert client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)[0].interval_us == 0
    sent = [m for m in client.run_until(client.now_s + 3.0) if m.get_msgId() == msg_id]
    assert len(sent) == (0 if msg_id == M.MAVLINK_MSG_ID_UTM_GLOBAL_POSITION else 3)


def test_setpoint_publications_follow_manual_controls_run():
    """ManualControl publishes at boot (the zero setpoint, invalid), on every accepted sample,
    again at each 200 ms timer Run while the sample is younger than COM_RC_LOSS_T, and once
    more, invalid, at the first Run after that."""
    from vehicles.manual_control import CENTRED, Sticks
    from vehicles.manual_setpoint import SetpointPublications

    pub = SetpointPublications(CENTRED)
    assert (pub.count(10.0, 0.5), pub.sticks) == (1, CENTRED)
    held = Sticks(pitch=0.5)
    pub.on_input(1.0, held, 0.5)
    counts = [pub.count(t, 0.5) for t in (1.0, 1.19, 1.21, 1.41, 1.59, 1.61, 5.0)]
    assert counts == [2, 2, 3, 4, 4, 5, 5]  # Runs at 1.2 and 1.4 valid, 1.6 invalid, then none
    assert pub.sticks == held  # the selector keeps the last sticks when the input is lost
    pub.on_input(6.0, CENTRED, 0.5)
    assert pub.count(6.0, 0.5) == 6
    pub.on_input(6.1, CENTRED, 0.5)  # a sample every 100 ms: no timer Run between
    assert pub.count(6.1, 0.5) == 7
    assert pub.count(6.3, 1.0) == 7 and pub.count(6.31, 1.0) == 8  # COM_RC_LOSS_T 1 s


def test_manual_control_echoes_each_manual_control_setpoint_as_px4():
    """MANUAL_CONTROL.hpp, once asked: first the boot's zero setpoint, then each stick sample a
    client sends, in PX4's float32 arithmetic (x 511 → 0.511f → 510; z 45 → throttle -0.91 →
    -909; MAVSDK's centred 750 → 500), target this system, buttons 0 (no RC switches); after
    the sender stops, the timer's two republications and the invalid one, then nothing."""
    from gateway.testing import Sim

    with Sim() as sim:
        sim.advance(3.0)
        api = sim.api(0)
        since = len(api.frames)
        assert api.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_MANUAL_CONTROL,
                                50_000) == 0
        sim.advance(1.0)
        boot = api.messages("MANUAL_CONTROL", since)
        assert [(m.target, m.x, m.y, m.z, m.r, m.buttons) for m in boot] == [(1, 0, 0, 0, 0, 0)]
        since = len(api.frames)
        samples = [(511, -253, 45, 100), (300, 0, 750, -1000)] * 5
        for x, y, z, r in samples:  # 10 Hz, as MAVSDK's example sends
            api.send(api.mav.manual_control_encode(1, x, y, z, r, 0))
            sim.advance(0.1)
        sent_at = sim.now
        sim.advance(2.0)
        echoed = [(m.x, m.y, m.z, m.r) for m in api.messages("MANUAL_CONTROL", since)]
        expected = [(510, -252, -909, 100), (300, 0, 500, -1000)] * 5
        assert echoed == expected + [expected[-1]] * 3, echoed
        assert sim.now - sent_at > 1.5  # nothing after the invalid publication


@pytest.mark.parametrize("kind", [LinkKind.GCS, LinkKind.API], ids=["gcs", "api"])
def test_autopilot_version_and_storage_information_stream_at_a_set_rate(kind):
    """PX4's stream list has AUTOPILOT_VERSION (send_autopilot_capabilities at every interval)
    and STORAGE_INFORMATION (a stream object's storage 0: the first storage): not streamed by
    default, SET_MESSAGE_INTERVAL ACCEPTED, then each at the rate, as a request answers it."""
    vehicle, session, client = make(kind)
    vehicle.become_ready()
    for msg_id, name in ((M.MAVLINK_MSG_ID_AUTOPILOT_VERSION, "AUTOPILOT_VERSION"),
                         (M.MAVLINK_MSG_ID_STORAGE_INFORMATION, "STORAGE_INFORMATION")):
        assert client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)[0].interval_us == 0
        assert of_type(client.run_until(client.now_s + 2.0), name) == []
        asked = of_type(client.command_long(M.MAV_CMD_REQUEST_MESSAGE, msg_id), name)
        assert _enable(client, msg_id, 2.0) == ACCEPTED
        assert client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)[0].interval_us \
            == 500_000
        got = of_type(client.run_until(client.now_s + 3.0), name)
        assert abs(len(got) - 6) <= 1
        first, last = asked[0].to_dict(), got[-1].to_dict()
        if name == "STORAGE_INFORMATION":
            assert last["time_boot_ms"] > first["time_boot_ms"]
            assert (last["storage_id"], last["storage_count"], last["status"]) == (1, 1, 2)
            first.pop("time_boot_ms"), last.pop("time_boot_ms")
        assert last == first  # what a request answers
        stop = client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, -1)  # -1: stop
        assert acks(stop)[0].result == ACCEPTED
        assert of_type(client.run_until(client.now_s + 2.0), name) == []


def test_autopilot_state_for_gimbal_device_as_px4_fills_it():
    """AUTOPILOT_STATE_FOR_GIMBAL_DEVICE.hpp once asked: the attitude (the same quaternion and
    instant as ATTITUDE_QUATERNION), the local velocity, the solution flags ESTIMATOR_STATUS
    carries, on the ground (1) then in the air (2, take-off included), target 0/0, delays 0."""
    from gateway.testing import Sim

    with Sim() as sim:
        sim.advance(6.0)
        api = sim.api(0)
        assert api.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL,
                                M.MAVLINK_MSG_ID_AUTOPILOT_STATE_FOR_GIMBAL_DEVICE, 100_000) == 0
        since = len(api.frames)
        sim.advance(1.0)
        got = api.messages("AUTOPILOT_STATE_FOR_GIMBAL_DEVICE", since)
        assert abs(len(got) - 10) <= 1
        ground = got[-1]
        quats = {m.time_boot_ms * 1000: m for m in api.messages("ATTITUDE_QUATERNION", since)}
        att = quats[ground.time_boot_us]
        assert list(ground.q) == pytest.approx([att.q1, att.q2, att.q3, att.q4])
        status = api.messages("ESTIMATOR_STATUS", since)[-1]
        assert ground.estimator_status == status.flags
        assert (ground.target_system, ground.target_component, ground.landed_state) == (0, 0, 1)
        assert (ground.q_estimated_delay_us, ground.v_estimated_delay_us) == (0, 0)
        assert api.arm() == 0 and api.takeoff() == 0
        sim.run_until(lambda: sim.state(0).position_ned_m[2] < -1.0, 20.0)
        climbing = api.messages("AUTOPILOT_STATE_FOR_GIMBAL_DEVICE")[-1]
        assert climbing.landed_state == 2 and climbing.vz < -0.3
        assert math.isfinite(climbing.feed_forward_angular_velocity_z)
