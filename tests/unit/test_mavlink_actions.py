"""Action commands of the PX4 persona (Commander.cpp, navigator) and QGC's connect requests."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as M
from test_mavlink_mission import mavsdk_mission, upload
from test_mavlink_support import acks, make, of_type

from vehicles.plan_types import PlanItem
from vehicles.types import GeoPoint, NavState

NAN = math.nan
INT32_MAX = 2**31 - 1


def command_int(client, command, frame, p1=NAN, p2=NAN, p3=NAN, p4=NAN, x=INT32_MAX,
                y=INT32_MAX, z=NAN, target=(1, 1)):
    return client.send(M.MAVLink_command_int_message(*target, frame, command, 0, 0, p1, p2, p3,
                                                     p4, x, y, z))


def results(msgs):
    return [(a.command, a.result) for a in acks(msgs)]


def test_mavsdk_goto_location():
    """MAVSDK action.goto_location: DO_SET_MODE Hold, then COMMAND_INT DO_REPOSITION frame 5."""
    vehicle, _, client = make()
    vehicle.become_ready()
    assert results(client.command_long(176, 1 | 128, 4, 3)) == [(176, 0)]
    got = command_int(client, 192, 5, p1=NAN, p2=1, p3=0, p4=math.radians(90), x=473980000,
                      y=85460000, z=510.0)
    assert results(got) == [(192, 0)]
    name, _, lat, lon, alt, yaw, speed = vehicle.calls[-1]
    assert name == "goto" and (lat, lon, alt) == pytest.approx((47.398, 8.546, 510.0))
    assert yaw == pytest.approx(math.pi / 2, abs=1e-6) and math.isnan(speed)


def test_qgc_goto_pause_and_change_altitude():
    vehicle, _, client = make()
    got = command_int(client, 192, 0, p1=-1, p2=1, p3=0, p4=NAN, x=473980000, y=85460000,
                      z=500.0)
    assert results(got) == [(192, 0)]
    _, _, lat, lon, alt, yaw, speed = vehicle.calls[-1]
    assert (lat, lon, alt) == pytest.approx((47.398, 8.546, 500.0))
    assert math.isnan(yaw) and math.isnan(speed)  # p1 −1 = default speed
    # pause: DO_REPOSITION −1, 1, 0, NaN… → goto with everything NaN (brake and hold)
    assert results(client.command_long(192, -1, 1, 0, NAN, NAN, NAN, NAN)) == [(192, 0)]
    assert all(math.isnan(v) for v in vehicle.calls[-1][2:])
    # change altitude: only p7; speed given in p1
    client.command_long(192, 3.0, 1, 0, NAN, NAN, NAN, 520.0)
    assert vehicle.calls[-1][4] == 520.0 and vehicle.calls[-1][6] == 3.0
    assert math.isnan(vehicle.calls[-1][2]) and math.isnan(vehicle.calls[-1][3])


@pytest.mark.parametrize("p2", [0, NAN, 2, 3, -1])
def test_reposition_needs_exactly_the_change_mode_flag(p2):
    vehicle, _, client = make()
    n = len(vehicle.calls)
    assert results(client.command_long(192, -1, p2, 0, NAN, 47.4, 8.5, 500)) == [(192, 3)]
    assert len(vehicle.calls) == n


def test_reposition_frames_all_take_z_as_amsl():
    vehicle, _, client = make()
    for frame in (0, 3, 5, 6):
        assert results(command_int(client, 192, frame, p2=1, x=473980000, y=85460000,
                                   z=30.0)) == [(192, 0)]
        assert vehicle.calls[-1][4] == 30.0


def test_change_speed():
    vehicle, _, client = make()
    assert results(client.command_long(178, 1, 7.5, -1, 0)) == [(178, 0)]
    assert vehicle.calls[-1] == ("change_speed", 0.0, 7.5)
    client.command_long(178, 1, NAN, -1, 0)
    assert vehicle.calls[-1] == ("change_speed", 0.0, -1.0)  # non-finite → back to cruise
    client.command_long(178, 1, 1e-8, -1, 0)  # navigator_main.cpp: not above FLT_EPSILON
    assert vehicle.calls[-1] == ("change_speed", 0.0, -1.0)
    client.command_long(178, 1, math.inf, -1, 0)  # above it: the speed limit applies
    assert vehicle.calls[-1] == ("change_speed", 0.0, math.inf)


def test_set_home():
    vehicle, _, client = make()
    vehicle.become_ready()
    vehicle.move_to(10.0, 0.0, 0.0)
    assert results(client.command_long(179, 1)) == [(179, 0)]
    assert vehicle.calls[-1] == ("set_home", 0.0, None)
    home = of_type(client.command_long(512, 242), "HOME_POSITION")[0]
    assert home.latitude > 473977420
    # MAVSDK4: COMMAND_INT frame 3, p1 0 and x/y/z
    got = command_int(client, 179, 3, p1=0, x=473990000, y=85470000, z=489.0)
    assert results(got) == [(179, 0)]
    assert vehicle.calls[-1][2] == GeoPoint(pytest.approx(47.399), pytest.approx(8.547), 489.0)
    n = len(vehicle.calls)
    assert results(client.command_long(179, 0, 0, 0, 0, NAN, 8.5, 500)) == [(179, 2)]
    assert results(command_int(client, 179, 0, p1=0, z=500.0)) == [(179, 2)]  # unset x/y
    assert len(vehicle.calls) == n


def test_mission_start():
    vehicle, _, client = make()
    vehicle.become_ready()
    assert results(client.command_long(300, 0, 0)) == [(300, 2)]  # no mission → DENIED
    upload(client, mavsdk_mission())
    assert results(client.command_long(300, 2, 0)) == [(300, 0)]
    assert vehicle.calls[-1] == ("start_mission", 0.0, 2)
    assert vehicle.nav_state is NavState.AUTO_MISSION and vehicle.armed
    client.command_long(300, NAN, NAN)
    # param1 goes to the vehicle as it came: Commander.cpp denies a non-finite one there
    # (tests/unit/test_hostile.py flies the real vehicle through it).
    assert vehicle.calls[-1][:2] == ("start_mission", 0.0) and math.isnan(vehicle.calls[-1][2])


def test_land_start_jumps_to_the_missions_landing_sequence_or_is_cancelled():
    """MAVProxy's `land` sends DO_LAND_START (189). PX4's navigator: MISSION_START from the
    DO_LAND_START marker → ACCEPTED; no marker → CANCELLED (not UNSUPPORTED)."""
    vehicle, _, client = make()
    vehicle.become_ready()
    assert results(client.command_long(189, 0, 0, 0, 0, 0, 0, 0)) == [(189, 6)]  # no mission
    upload(client, mavsdk_mission())
    n = len(vehicle.calls)
    assert results(client.command_long(189, 0, 0, 0, 0, 0, 0, 0)) == [(189, 6)]  # no marker
    assert len(vehicle.calls) == n and not vehicle.armed
    items = mavsdk_mission()[:-1]
    items.append(PlanItem(len(items), 2, 189, 0, 1, 0.0, 0.0, 0.0, 0.0, 0, 0, 0.0))
    items.append(PlanItem(len(items), 6, 21, 0, 1, NAN, NAN, NAN, NAN, items[0].x, items[0].y,
                          0.0))  # NAV_LAND has a position (frame 2 is MAV_MISSION_UNSUPPORTED)
    upload(client, items)
    assert results(client.command_long(189, 0, 0, 0, 0, 0, 0, 0)) == [(189, 0)]
    assert vehicle.calls[-1] == ("start_mission", 0.0, len(items) - 2)
    assert vehicle.nav_state is NavState.AUTO_MISSION


def test_set_actuator_is_accepted_as_commander_does():
    """MAVSDK action.set_actuator(1, 0.5): DO_SET_ACTUATOR (187) p1 = 0.5, p7 = 0 (set 1)."""
    vehicle, _, client = make()
    n = len(vehicle.calls)
    assert results(client.command_long(187, 0.5, NAN, NAN, NAN, NAN, NAN, 0)) == [(187, 0)]
    assert len(vehicle.calls) == n


def test_flight_termination():
    vehicle, _, client = make()
    assert results(client.command_long(185, 1)) == [(185, 2)]  # disarmed: vehicle DENIES
    vehicle.armed = True
    n = len(vehicle.calls)
    assert results(client.command_long(185, 0.4)) == [(185, 2)]  # p1 ≤ 0.5: not even asked
    assert len(vehicle.calls) == n
    assert results(client.command_long(185, 1)) == [(185, 0)]
    assert vehicle.terminated and vehicle.nav_state is NavState.TERMINATION


def test_mission_and_offboard_modes_reach_the_vehicle():
    vehicle, _, client = make()
    assert results(client.command_long(176, 1, 4, 4)) == [(176, 0)]
    assert vehicle.calls[-1][2] is NavState.AUTO_MISSION
    assert results(client.command_long(176, 1, 6, 0)) == [(176, 0)]
    assert vehicle.calls[-1][2] is NavState.OFFBOARD


def test_orbit_hands_its_parameters_to_the_vehicle():
    vehicle, _, client = make()
    assert results(command_int(client, 34, 5, p1=-10, p2=2, x=473980000, y=85460000,
                               z=500)) == [(34, 0)]
    _, _, radius, speed, yaw_behaviour, lat, lon, alt = vehicle.calls[-1]
    assert (radius, speed, lat, lon, alt) == (-10, 2, pytest.approx(47.398),
                                              pytest.approx(8.546), 500)
    assert math.isnan(yaw_behaviour)  # p3 not given (NaN): keep the present behaviour


def test_vehicle_without_actions_answers_unsupported():
    vehicle, _, client = make()
    for name in ("goto", "change_speed", "set_home", "start_mission", "terminate", "orbit"):
        setattr(vehicle, name, None)
    for cmd, params in [(192, (-1, 1)), (178, (1, 5)), (179, (1,)), (300, (0,)), (185, (1,))]:
        assert results(client.command_long(cmd, *params)) == [(cmd, 3)]


def test_qgc_initial_connect_is_answered_at_once():
    """QGC's connect (§10): every request answered immediately, downloads of all plan types."""
    vehicle, _, client = make(sysid=1)
    vehicle.become_ready()
    got = client.command_long(512, 148)
    assert [m.get_type() for m in got] == ["AUTOPILOT_VERSION", "COMMAND_ACK"]
    caps = got[0].capabilities
    assert caps & M.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    assert caps & M.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
    assert caps & M.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
    assert caps & M.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    assert caps & M.MAV_PROTOCOL_CAPABILITY_FTP  # served (gateway/mavlink/ftp.py), as PX4
    assert results(client.command_long(512, 300)) == [(512, 0)]
    for msg_id in (397, 395):  # COMPONENT_METADATA / _INFORMATION without the FTP files
        assert results(client.command_long(512, msg_id)) == [(512, 2)]  # at once, as PX4
    got = client.command_long(512, 435)  # AVAILABLE_MODES: every mode, then the ACK
    assert [m.get_type() for m in got] == ["AVAILABLE_MODES"] * 25 + ["COMMAND_ACK"]
    assert results(got) == [(512, 0)]
    for mission_type in (0, 1, 2):
        got = client.send(M.MAVLink_mission_request_list_message(1, 190, mission_type))
        assert [(m.get_type(), m.count) for m in got] == [("MISSION_COUNT", 0)]
    ss = of_type(client.run_until(1.0), "SYS_STATUS")[-1]
    prearm = 0x10000000  # PX4 v1.15 SYS_STATUS.hpp: a health bit only (canArm), never enabled
    assert not ss.onboard_control_sensors_enabled & prearm
    assert ss.onboard_control_sensors_health & prearm
