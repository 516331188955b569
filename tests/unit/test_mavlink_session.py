"""Session: heartbeat/modes, SYS_STATUS health, streams and rates, commands, ping, statustext."""

import math

import pytest
from pymavlink.dialects.v20 import common as M
from test_mavlink_support import acks, make, of_type

from gateway.mavlink import modes
from gateway.mavlink.session import LinkKind
from vehicles.types import NavState, Severity

# PX4 commander px4_custom_mode.h: every NavState → (custom_mode, base disarmed, base armed)
EXPECTED_MODES = {
    NavState.MANUAL: (65536, 81, 209),
    NavState.ALTCTL: (131072, 81, 209),
    NavState.POSCTL: (196608, 81, 209),
    NavState.ORBIT: (16973824, 17, 145),
    NavState.POSITION_SLOW: (33751040, 81, 209),
    NavState.AUTO_TAKEOFF: (33816576, 29, 157),
    NavState.AUTO_LOITER: (50593792, 29, 157),
    NavState.AUTO_MISSION: (67371008, 29, 157),
    NavState.AUTO_RTL: (84148224, 29, 157),
    NavState.AUTO_LAND: (100925440, 29, 157),
    NavState.DESCEND: (100925440, 29, 157),
    NavState.AUTO_FOLLOW_TARGET: (134479872, 17, 145),
    NavState.AUTO_PRECLAND: (151257088, 29, 157),
    NavState.ACRO: (327680, 65, 193),
    NavState.OFFBOARD: (393216, 17, 145),
    NavState.STAB: (458752, 81, 209),
    NavState.TERMINATION: (655360, 1, 129),
}


def test_mode_table_covers_every_nav_state():
    assert set(EXPECTED_MODES) == set(NavState) == set(modes.MODE_TABLE)


@pytest.mark.parametrize("nav", list(NavState), ids=lambda n: n.name)
@pytest.mark.parametrize("armed", [False, True])
def test_heartbeat_modes(nav, armed):
    vehicle, session, client = make()
    vehicle.nav_state, vehicle.armed = nav, armed
    vehicle.position_valid = True
    hb = of_type(client.run_until(0.001), "HEARTBEAT")[0]
    custom, base_disarmed, base_armed = EXPECTED_MODES[nav]
    assert hb.custom_mode == custom
    assert hb.base_mode == (base_armed if armed else base_disarmed)
    assert (hb.type, hb.autopilot, hb.mavlink_version) == (2, 12, 3)
    assert hb.get_srcSystem() == 1 and hb.get_srcComponent() == 1


# Commander's DO_SET_MODE does not select these by their HEARTBEAT custom mode: Descend (shown
# as AUTO.LAND), Termination (a main mode it does not decode: nothing asked) and Orbit (POSCTL's
# ORBIT sub mode is Position).
NOT_BY_SET_MODE = {NavState.DESCEND: NavState.AUTO_LAND, NavState.TERMINATION: None,
                   NavState.ORBIT: NavState.POSCTL}


@pytest.mark.parametrize("nav", list(NavState), ids=lambda n: n.name)
def test_do_set_mode_round_trip(nav):
    vehicle, session, client = make()
    main, sub = modes.split_custom_mode(modes.custom_mode_of(nav))
    got = client.command_long(M.MAV_CMD_DO_SET_MODE, 1, main, sub)
    assert [a.result for a in acks(got)] == [0]
    selected = NOT_BY_SET_MODE.get(nav, nav)
    if selected is None:
        assert vehicle.calls == []
    else:
        assert vehicle.calls[-1] == ("set_nav_state", 0.0, selected)


def test_do_set_mode_special_cases():
    vehicle, session, client = make()
    assert acks(client.command_long(M.MAV_CMD_DO_SET_MODE, 1, 4, 0))[0].result == 0
    assert vehicle.calls[-1][2] is NavState.AUTO_MISSION
    n_calls = len(vehicle.calls)
    for main, sub in [(4, 1), (4, 7)]:  # unsupported auto modes
        assert acks(client.command_long(M.MAV_CMD_DO_SET_MODE, 129, main, sub))[0].result == 1
    for main, sub in [(9, 0), (42, 0)]:  # no mode asked for: ACCEPTED, nothing changes
        assert acks(client.command_long(M.MAV_CMD_DO_SET_MODE, 129, main, sub))[0].result == 0
    assert len(vehicle.calls) == n_calls
    # legacy SET_MODE (11) is ACKed as DO_SET_MODE
    got = client.send(M.MAVLink_set_mode_message(1, 1, modes.custom_mode_of(NavState.AUTO_RTL)))
    assert [(a.command, a.result) for a in acks(got)] == [(176, 0)]
    assert vehicle.nav_state is NavState.AUTO_RTL


def test_system_status_progression():
    vehicle, session, client = make()

    def state():
        client.now_s = max(client.now_s, session.get_timer())
        session.handle_timer(client.now_s)
        hb = of_type(client.drain(), "HEARTBEAT")
        return hb[-1].system_status if hb else state()

    assert state() == 0
    vehicle.position_valid = True  # HEARTBEAT.hpp: STANDBY needs pre_flight_checks_pass (canArm)
    assert state() == 0
    vehicle.prearm_ok = True
    assert state() == 3
    vehicle.armed = True
    assert state() == 4
    vehicle.failsafe = True
    assert state() == 5
    vehicle.terminated = True
    assert state() == 8


def _mavsdk_health(ss):
    """MAVSDK3/4 telemetry_impl.cpp rules."""
    gps = 32
    return {
        "global": bool(ss.onboard_control_sensors_present & gps
                       and ss.onboard_control_sensors_health & gps),
        "armable": bool(ss.onboard_control_sensors_health & 0x10000000),
        "gyro": bool(ss.onboard_control_sensors_present & 1 and ss.onboard_control_sensors_health & 1),
        "accel": bool(ss.onboard_control_sensors_health & 2),
        "mag": bool(ss.onboard_control_sensors_present & 4 and ss.onboard_control_sensors_health & 4),
    }


def test_sys_status_health_bits():
    vehicle, session, client = make()
    # SYS_STATUS.hpp fillOutComponent: gyro, accel, mag, baro, estimator (AHRS), battery and,
    # once EKF2 fuses it, GPS present; every mapped component healthy unless flagged (no GPS fix
    # yet; no stick input: remote_control); enabled = present or unhealthy; PREARM_CHECK only
    # ever in health.
    ss = of_type(client.run_until(0.001), "SYS_STATUS")[0]
    assert ss.onboard_control_sensors_present == 0x0220000F
    assert ss.onboard_control_sensors_health == 0x2220801F
    assert ss.onboard_control_sensors_enabled == 0x0221002F
    assert _mavsdk_health(ss) == {"global": False, "armable": False, "gyro": True, "accel": True,
                                  "mag": True}
    vehicle.become_ready()
    ss = of_type(client.run_until(1.001), "SYS_STATUS")[-1]
    assert ss.onboard_control_sensors_present == 0x0220002F
    assert ss.onboard_control_sensors_health == 0x3220803F
    assert ss.onboard_control_sensors_enabled == 0x0221002F
    assert all(_mavsdk_health(ss).values())
    # the parachute component (extended RECOVERY_SYSTEM): healthy, absent; EXTENSION_USED unset
    assert (ss.onboard_control_sensors_present_extended, ss.onboard_control_sensors_enabled_extended,
            ss.onboard_control_sensors_health_extended) == (0, 0, 1)
    assert ss.voltage_battery == 16200 and ss.battery_remaining == 90
    assert ss.load == 200  # SYS_STATUS.hpp: cpuload.load (0.2) x 1000


def _counts(kind, seconds=10.0):
    vehicle, session, client = make(kind, boot_unix_s=1.7e9)
    vehicle.become_ready()
    msgs = client.run_until(seconds)
    counts = {}
    for m in msgs:
        counts[m.get_type()] = counts.get(m.get_type(), 0) + 1
    return counts


@pytest.mark.parametrize("kind, expected", [
    (LinkKind.GCS, {"HEARTBEAT": 1, "SYS_STATUS": 1, "EXTENDED_SYS_STATE": 1, "ATTITUDE": 50,
                    "ATTITUDE_QUATERNION": 50, "LOCAL_POSITION_NED": 50,
                    "ATTITUDE_TARGET": 50, "POSITION_TARGET_LOCAL_NED": 50,
                    "SERVO_OUTPUT_RAW": 50, "ESC_INFO": 1, "ESC_STATUS": 1,
                    "GLOBAL_POSITION_INT": 50, "GPS_RAW_INT": 5, "HOME_POSITION": 0.5,
                    "VFR_HUD": 4, "ALTITUDE": 1, "BATTERY_STATUS": 0.5, "MISSION_CURRENT": 1,
                    "SCALED_PRESSURE": 1, "ESTIMATOR_STATUS": 0.5, "VIBRATION": 0.1,
                    "PING": 0.1, "GPS_GLOBAL_ORIGIN": 0.1, "CURRENT_MODE": 0.5,
                    "OPEN_DRONE_ID_LOCATION": 1, "OPEN_DRONE_ID_SYSTEM": 1,
                    "TIME_ESTIMATE_TO_TARGET": 0.1,  # once: one publication
                    "LINK_NODE_STATUS": 1}),
    (LinkKind.API, {"HEARTBEAT": 1, "SYS_STATUS": 5, "EXTENDED_SYS_STATE": 5, "ATTITUDE": 100,
                    "ATTITUDE_QUATERNION": 50, "LOCAL_POSITION_NED": 30,
                    "ATTITUDE_TARGET": 10, "POSITION_TARGET_LOCAL_NED": 10,
                    "SERVO_OUTPUT_RAW": 10, "ESC_INFO": 10, "ESC_STATUS": 10,
                    "GLOBAL_POSITION_INT": 50, "GPS_RAW_INT": 8, "HOME_POSITION": 0.5,
                    "VFR_HUD": 10, "ALTITUDE": 10, "BATTERY_STATUS": 0.5, "SYSTEM_TIME": 1,
                    "MISSION_CURRENT": 1, "HIGHRES_IMU": 50, "ODOMETRY": 30,
                    "SCALED_PRESSURE": 1, "ESTIMATOR_STATUS": 1, "VIBRATION": 0.5,
                    "TIMESYNC": 10, "PING": 1, "CURRENT_MODE": 0.5,
                    "OPEN_DRONE_ID_LOCATION": 1, "OPEN_DRONE_ID_SYSTEM": 1,
                    "GPS_GLOBAL_ORIGIN": 0.1,  # once: it is sent again only if it moves
                    "TIME_ESTIMATE_TO_TARGET": 0.1, "LINK_NODE_STATUS": 1}),
], ids=["gcs", "api"])
def test_stream_rates(kind, expected):
    counts = _counts(kind)
    assert set(counts) == set(expected)
    for name, hz in expected.items():
        assert abs(counts[name] - hz * 10) <= 1, (name, counts[name])


def test_home_position_only_once_home_is_set():
    vehicle, session, client = make()
    assert of_type(client.run_until(5.0), "HOME_POSITION") == []
    got = client.command_long(M.MAV_CMD_REQUEST_MESSAGE, 242)
    assert [a.result for a in acks(got)] == [2] and len(got) == 1
    vehicle.become_ready()
    got = client.command_long(M.MAV_CMD_REQUEST_MESSAGE, 242)
    assert [m.get_type() for m in got] == ["HOME_POSITION", "COMMAND_ACK"]
    assert got[0].latitude == 473977420 and got[0].altitude == 488000
    assert len(of_type(client.run_until(10.0), "HOME_POSITION")) in (2, 3)


def test_global_position_fields():
    vehicle, session, client = make()
    vehicle.become_ready()
    vehicle.move_to(10.0, 0.0, -5.0)
    gp = of_type(client.run_until(0.001), "GLOBAL_POSITION_INT")[0]
    assert gp.relative_alt == 5000 and gp.alt == 493000
    assert gp.lat > 473977420
    gps = of_type(client.run_until(0.2), "GPS_RAW_INT")[0]
    assert (gps.fix_type, gps.satellites_visible, gps.eph, gps.epv) == (3, 10, 70, 110)


def test_request_message_emits_message_before_ack():
    vehicle, session, client = make()
    got = client.command_long(M.MAV_CMD_REQUEST_MESSAGE, 148)
    assert [m.get_type() for m in got] == ["AUTOPILOT_VERSION", "COMMAND_ACK"]
    av, ack = got
    assert av.capabilities == 59647 and av.capabilities & 32 and av.capabilities & 4 and av.capabilities & 16
    assert av.flight_sw_version == 0x010F02FF
    assert (ack.command, ack.result, ack.target_system, ack.target_component) == (512, 0, 245, 190)
    assert ack.get_srcSystem() == 1 and ack.get_srcComponent() == 1
    got = client.command_long(M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1, target_component=0)
    assert [m.get_type() for m in got] == ["AUTOPILOT_VERSION", "COMMAND_ACK"]
    # PROTOCOL_VERSION (300) is unknown to pymavlink 2.4.50: it arrives as an unknown frame
    got = client.command_long(M.MAV_CMD_REQUEST_MESSAGE, 300)
    raw = bytes(got[0].get_msgbuf())
    assert raw[7:10] == (300).to_bytes(3, "little") and acks(got)
    payload = raw[10:10 + raw[1]].ljust(22, b"\0")  # MAVLink 2 trims trailing zeros
    assert payload[:6] == bytes([200, 0, 100, 0, 200, 0])  # version 200, min 100, max 200
    assert acks(got)[0].result == 0
    for msg_id in (397, 395, 437, 9999):
        assert [a.result for a in acks(client.command_long(M.MAV_CMD_REQUEST_MESSAGE, msg_id))] == [2]
    got = client.command_long(M.MAV_CMD_REQUEST_MESSAGE, 30)  # any streamed message
    assert [m.get_type() for m in got] == ["ATTITUDE", "COMMAND_ACK"]


def test_autopilot_version_custom_version_is_a_binary_git_hash():
    """PX4 sends the top 5 bytes of its git hash's uint64, little-endian, over a 3-byte vendor
    version (0); MAVSDK's flight_sw_git_hash is bytes 3..7 read back to front, in hex."""
    _, _, client = make()
    av = client.command_long(M.MAV_CMD_REQUEST_MESSAGE, 148)[0]
    custom = bytes(av.flight_custom_version)
    assert custom[:3] == bytes(3)  # vendor patch, minor, major
    assert custom[3:][::-1].hex() == "3fccf9453a"
    assert bytes(av.middleware_custom_version) == custom
    assert bytes(av.os_custom_version) == bytes(8)


def test_uid_differs_per_sysid():
    _, _, c1 = make(sysid=1)
    _, _, c2 = make(sysid=2)
    a = c1.command_long(M.MAV_CMD_REQUEST_MESSAGE, 148)[0]
    b = c2.command_long(M.MAV_CMD_REQUEST_MESSAGE, 148, target_system=2)[0]
    assert a.uid != b.uid and b.get_srcSystem() == 2


def test_message_interval_commands():
    vehicle, session, client = make(LinkKind.GCS, boot_unix_s=1.7e9)
    got = client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, 32, 200_000)  # LPN 5 Hz
    assert acks(got)[0].result == 0
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, 32)
    assert [(m.get_type()) for m in got] == ["MESSAGE_INTERVAL", "COMMAND_ACK"]
    assert got[0].interval_us == 200_000 and got[0].message_id == 32
    got = client.command_long(M.MAV_CMD_REQUEST_MESSAGE, 244, 30)  # no such stream in v1.15
    assert [(m.get_type(), m.result) for m in got] == [("COMMAND_ACK", 2)]
    assert acks(client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, 33, -1))[0].result == 0
    assert acks(client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, 2, 1e6))[0].result == 0
    for bad in (0, 9999):  # HEARTBEAT is fixed; unknown stream
        assert acks(client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, bad, 1e6))[0].result == 4
    msgs = client.run_until(10.0)
    assert abs(len(of_type(msgs, "LOCAL_POSITION_NED")) - 50) <= 1
    assert of_type(msgs, "GLOBAL_POSITION_INT") == []
    assert abs(len(of_type(msgs, "SYSTEM_TIME")) - 10) <= 1
    assert acks(client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, 33, 0))[0].result == 0
    msgs = client.run_until(20.0)
    assert abs(len(of_type(msgs, "GLOBAL_POSITION_INT")) - 500) <= 1
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, 147)
    assert got[0].interval_us == 2_000_000


@pytest.mark.parametrize("interval_us, expected_hz, reported_us", [
    (1.0, 1e6 / 1500, 1),  # accepted as set; Mavlink's loop sends at most every 1500 µs
    (0.4, 0.0, 0),  # under 1 µs: configure_stream's interval truncates to 0, stopped
    (math.inf, 0.0, 0), (3e38, 0.0, 0),  # a rate of ~0: stopped (deleted: GET says 0)
    (-math.inf, 0.0, 0), (-3e38, 0.0, 0),  # negative: stopped
    (math.nan, 50.0, 20_000), (1e-6, 50.0, 20_000),  # neither: the default
])
def test_hostile_message_intervals_get_px4s_reading_and_never_flood(interval_us, expected_hz,
                                                                      reported_us):
    """MavlinkReceiver::set_message_interval reads p2 as a float rate; a 1 µs interval cannot
    make a stream outrun the MAVLink loop (which would stall every vehicle of the daemon)."""
    vehicle, session, client = make(LinkKind.GCS)
    got = client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, 30, interval_us)  # ATTITUDE
    assert acks(got)[0].result == 0 and session.stats.handler_errors == 0
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, 30)
    assert got[0].interval_us == reported_us
    t0 = client.now_s
    n = len(of_type(client.run_until(t0 + 2.0), "ATTITUDE"))
    assert abs(n - expected_hz * 2.0) <= 2, n


def test_arm_takeoff_land_commands():
    vehicle, session, client = make()
    assert acks(client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1))[0].result == 1
    vehicle.become_ready()
    assert acks(client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1))[0].result == 0
    assert vehicle.armed and vehicle.calls[-1] == ("arm", 0.0, False)
    got = client.command_long(M.MAV_CMD_NAV_TAKEOFF, *([math.nan] * 7))
    assert acks(got)[0].result == 0 and math.isnan(vehicle.calls[-1][2])
    client.command_long(M.MAV_CMD_NAV_TAKEOFF, -1, 0, 0, math.nan, math.nan, math.nan, 498.0)
    assert vehicle.calls[-1] == ("takeoff", 0.0, 498.0)
    assert acks(client.command_long(M.MAV_CMD_NAV_LAND, *([math.nan] * 7)))[0].result == 0
    assert acks(client.command_long(M.MAV_CMD_NAV_RETURN_TO_LAUNCH))[0].result == 0
    assert vehicle.nav_state is NavState.AUTO_RTL
    got = client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 21196)
    assert acks(got)[0].result == 0 and vehicle.calls[-1] == ("disarm", 0.0, True)
    n = len(vehicle.calls)
    assert client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 2) == []  # no ACK
    assert len(vehicle.calls) == n


def test_command_int_takeoff_and_frames():
    vehicle, session, client = make()
    vehicle.become_ready()
    for frame in (0, 3, 5, 6):
        got = client.send(M.MAVLink_command_int_message(1, 1, frame, M.MAV_CMD_NAV_TAKEOFF, 0, 0,
                                                        -1, 0, 0, math.nan, 2**31 - 1,
                                                        2**31 - 1, 500.0))
        assert [(a.command, a.result) for a in acks(got)] == [(22, 0)]
        assert vehicle.calls[-1] == ("takeoff", 0.0, 500.0)


@pytest.mark.parametrize("command, params, result", [
    (M.MAV_CMD_PREFLIGHT_CALIBRATION, (1,), 3),  # a vehicle that cannot calibrate
    (M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (0,), 0),
    (M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (1,), 2),
    (M.MAV_CMD_RUN_PREARM_CHECKS, (), 0),
    (M.MAV_CMD_DO_SET_ROI_LOCATION, (0, 0, 0, 0, 47.4, 8.5, 500), 0),
    (M.MAV_CMD_DO_SET_ROI_NONE, (), 0),
    (M.MAV_CMD_GET_HOME_POSITION, (), 2),
    (31999, (), 3),
    (M.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, 0, 2147483648.0, 2147483648.0, 0), 2),  # INT32_MAX p5/p6
])
def test_command_results(command, params, result):
    _, _, client = make()
    got = client.command_long(command, *params)
    assert [(a.command, a.result, a.target_system, a.target_component) for a in got] == [
        (command, result, 245, 190)]


@pytest.mark.parametrize("target_system, target_component, result", [
    (0, 0, 4), (1, 1, 0), (0, 1, 4), (1, 0, 0), (2, 1, 4), (1, 190, 4), (1, 100, 4),
])
def test_command_target_filtering(target_system, target_component, result):
    """MavlinkReceiver::evaluate_target_ok: this system exactly, this component or 0; any other
    target is answered FAILED (no other link heard it to forward it to)."""
    _, session, client = make()
    got = client.command_long(M.MAV_CMD_RUN_PREARM_CHECKS, target_system=target_system,
                              target_component=target_component)
    assert [a.result for a in acks(got)] == [result]


def test_capabilities_request_ignores_component():
    _, _, client = make()
    got = client.command_long(M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1, target_component=190)
    assert [m.get_type() for m in got] == ["AUTOPILOT_VERSION", "COMMAND_ACK"]


def test_ping_and_timesync():
    _, session, client = make()
    client.now_s = 2.5
    got = client.send(M.MAVLink_ping_message(123456, 7, 0, 0))
    assert [(m.time_usec, m.seq, m.target_system, m.target_component) for m in got] == [
        (123456, 7, 245, 190)]
    assert client.send(M.MAVLink_ping_message(1, 1, 1, 1)) == []  # a reply, not a request
    got = client.send(M.MAVLink_timesync_message(0, 999))
    assert [(m.tc1, m.ts1) for m in got] == [(2_500_000_000, 999)]
    assert client.send(M.MAVLink_timesync_message(5, 999)) == []


def test_gcs_heartbeat_tracking():
    vehicle, session, client = make()
    client.now_s = 1.0
    client.heartbeat(M.MAV_TYPE_QUADROTOR)
    assert vehicle.gcs_heartbeats == [] and not session.gcs_present(1.0)
    client.heartbeat()
    assert vehicle.gcs_heartbeats == [1.0] and session.gcs_present(3.5)
    assert not session.gcs_present(3.6)


def test_statustext_gating_and_chunking():
    vehicle, session, client = make()
    vehicle.say(0.0, "before any GCS\t")
    assert of_type(client.run_until(0.5), "STATUSTEXT") == []  # no GCS heartbeat: it waits
    client.heartbeat()
    vehicle.say(0.5, "Takeoff detected\t", Severity.INFO)
    vehicle.say(-10.0, "too old")
    long = "x" * 120
    vehicle.say(0.5, long, Severity.WARNING)
    texts = of_type(client.run_until(1.0), "STATUSTEXT")
    # STATUSTEXT.hpp: the text queued before the GCS came (younger than 5 s) goes first, the
    # tab goes out (QGC drops such a text from PX4 and shows its event), the link's id counts
    # every text from 0, single-chunk ones too, and the stale one is skipped.
    assert [(t.text, t.id, t.chunk_seq) for t in texts[:2]] == [
        ("before any GCS\t", 0, 0), ("Takeoff detected\t", 1, 0)]
    chunks = texts[2:]
    assert [c.chunk_seq for c in chunks] == [0, 1, 2] and {c.id for c in chunks} == {2}
    assert "".join(c.text for c in chunks) == long
    assert all(c.severity == Severity.WARNING for c in chunks)
    client.now_s = 5.0  # GCS heartbeat 4.5 s old: gated again
    vehicle.say(5.0, "late")
    assert of_type(client.run_until(6.0), "STATUSTEXT") == []


def test_statustext_is_px4s_20_hz_stream_over_an_8_text_queue():
    """MavlinkLog's uORB queue keeps 8 texts; the stream sends one per 50 ms run: a burst of 12
    loses its 4 oldest, the others go out 50 ms apart."""
    vehicle, session, client = make()
    client.heartbeat()
    for n in range(12):
        vehicle.say(0.1, f"text {n}")
    times, texts = [], []
    while client.now_s < 1.0:
        for m in of_type(client.run_until(client.now_s + 0.01), "STATUSTEXT"):
            times.append(client.now_s)
            texts.append(m.text)
    assert texts == [f"text {n}" for n in range(4, 12)]
    # (seen at the end of 10 ms steps: 50 ms apart, to within a step)
    assert all(b - a >= 0.04 - 1e-6 for a, b in zip(times, times[1:])), times
    assert times[-1] - times[0] >= 7 * 0.05 - 0.01
    assert session.statustext.missed == 4


def test_statustext_framing_follows_px4s_stream():
    """STATUSTEXT.hpp: a text of exactly 50 or 100 bytes ends with a full chunk (no empty one),
    an empty text sends nothing but takes its id, a text is cut at mavlink_log_s's 126 bytes,
    and an onboard controller's heartbeat opens the stream as a GCS's does."""
    vehicle, session, client = make()
    client.heartbeat(M.MAV_TYPE_ONBOARD_CONTROLLER)
    for text in ("a" * 50, "", "b" * 100, "c" * 200):
        vehicle.say(0.1, text)
    texts = of_type(client.run_until(0.5), "STATUSTEXT")
    assert [(t.id, t.chunk_seq, len(t.text)) for t in texts] == [
        (0, 0, 50), (2, 0, 50), (2, 1, 50), (3, 0, 50), (3, 1, 50), (3, 2, 26)]
    client.now_s = 4.0  # the onboard controller's heartbeat is 4 s old
    vehicle.say(4.0, "unheard")
    assert of_type(client.run_until(4.5), "STATUSTEXT") == []


def test_unsupported_auto_mode_text_when_gcs_present():
    vehicle, session, client = make()
    client.heartbeat()
    client.command_long(M.MAV_CMD_DO_SET_MODE, 1, 4, 1)
    texts = of_type(client.run_until(0.05), "STATUSTEXT")
    assert [t.text for t in texts] == ["Unsupported auto mode"]


def test_unhandled_messages_are_counted():
    _, session, client = make()
    client.send(M.MAVLink_named_value_float_message(0, b"x", 1.0))
    assert session.stats.rx_unhandled == 1 and session.stats.get("rx_frames") == 1


# --- the client address (peer) ------------------------------------------------------------------
def test_the_peer_is_who_last_sent_a_valid_frame_for_this_vehicle():
    vehicle, session, client = make()
    heartbeat = M.MAVLink_heartbeat_message(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)
    assert session.peer is None
    session.receive_datagram(client.encode(heartbeat), 1.0)  # no address: nothing to follow
    assert session.peer is None
    session.receive_datagram(client.encode(heartbeat), 1.0, "client")
    assert session.peer == "client"
    session.receive_datagram(b"\xfd\x09garbage", 1.1, "attacker")
    for msg in (
        M.MAVLink_command_long_message(42, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0),  # another system
        M.MAVLink_param_request_list_message(1, 5),  # another component: the service says so
        M.MAVLink_mission_request_list_message(0, 1, 0),  # the mission service wants our sysid
        M.MAVLink_manual_control_message(42, 0, 0, 500, 0, 0),
    ):
        session.receive_datagram(client.encode(msg), 1.2, "attacker")
    assert session.peer == "client"
    assert session.stats.rx_malformed == 1 and session.stats.rx_other_target == 4
    # A message nobody handles, for us, still comes from our client (a restarted one, here).
    session.receive_datagram(client.encode(M.MAVLink_named_value_float_message(0, b"x", 1.0)),
                             2.0, "restarted")
    assert session.peer == "restarted"
    # One frame for us among others in a datagram is enough.
    other = client.encode(M.MAVLink_command_long_message(42, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0))
    session.receive_datagram(other + client.encode(heartbeat), 2.1, "client")
    assert session.peer == "client"


def test_a_frame_a_service_fails_on_still_moves_the_peer():
    vehicle, session, client = make()

    def broken(now_s, forced=False):
        raise RuntimeError("bug")

    vehicle.arm = broken
    frame = client.encode(M.MAVLink_command_long_message(1, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                                                         1, 0, 0, 0, 0, 0, 0))
    session.receive_datagram(frame, 1.0, "client")  # counted, not raised (tests below)
    assert session.peer == "client" and session.stats.handler_errors == 1


# --- a bug in one service is counted and contained ------------------------------------------------
def test_a_failing_service_costs_only_its_frame_and_logs_once(caplog):
    vehicle, session, client = make()

    def boom(msg, now_s):
        raise RuntimeError("a bug in a service")

    session._routes[M.MAVLINK_MSG_ID_PING] = boom
    ping = client.encode(M.MAVLink_ping_message(1, 0, 0, 0))
    arm = client.encode(M.MAVLink_command_long_message(1, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                                                       1, 0, 0, 0, 0, 0, 0))
    vehicle.become_ready()
    with caplog.at_level("ERROR"):
        for k in range(50):
            session.receive_datagram(ping + ping + arm, 0.01 * k)
    assert session.stats.handler_errors == 100
    assert [c[0] for c in vehicle.calls].count("arm") == 50  # the frames after it still count
    logged = [r for r in caplog.records if "error while handling PING" in r.getMessage()]
    assert len(logged) == 1 and logged[0].exc_info is not None


def test_a_failing_telemetry_builder_does_not_silence_the_other_streams(monkeypatch):
    from dataclasses import replace

    from gateway.mavlink import streams

    def broken(enc, snap):
        raise OverflowError("a bug in a builder")

    patched = tuple(replace(s, builder=broken) if s.msg_id == M.MAVLINK_MSG_ID_ATTITUDE else s
                    for s in streams.STREAMS)
    monkeypatch.setattr(streams, "STREAMS", patched)
    _, session, client = make()
    got = client.run_until(2.0)
    assert of_type(got, "ATTITUDE") == []
    assert len(of_type(got, "HEARTBEAT")) >= 2 and of_type(got, "GLOBAL_POSITION_INT")
    assert session.stats.handler_errors > 10
