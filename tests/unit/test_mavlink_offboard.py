"""Offboard setpoint messages → OffboardSetpoint (PX4 mavlink_receiver.cpp), in memory."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as M
from test_mavlink_support import make, of_type

from gateway.mavlink import offboard
from vehicles.types import GeoPoint

NAN = math.nan


def local_ned(frame, mask, pos=(0, 0, 0), vel=(0, 0, 0), acc=(0, 0, 0), yaw=0.0, yaw_rate=0.0,
              target=(1, 1)):
    return M.MAVLink_set_position_target_local_ned_message(0, *target, frame, mask, *pos, *vel,
                                                           *acc, yaw, yaw_rate)


def nan_eq(a, b, tol=1e-5):
    if isinstance(a, tuple):
        return len(a) == len(b) and all(nan_eq(x, y, tol) for x, y in zip(a, b))
    if a is None or b is None:
        return a is b
    return (math.isnan(a) and math.isnan(b)) or abs(a - b) <= tol


def check(sp, **expected):
    defaults = dict(position_ned_m=(NAN,) * 3, velocity_ned_mps=(NAN,) * 3,
                    acceleration_ned_mps2=(NAN,) * 3, yaw_rad=NAN, yaw_rate_radps=NAN,
                    attitude_q=None, body_rates_frd_radps=(NAN,) * 3, thrust=NAN)
    defaults.update(expected)
    for name, want in defaults.items():
        assert nan_eq(getattr(sp, name), want), (name, getattr(sp, name), want)


# Every MAVSDK offboard call (§5 table): (frame, type_mask) → the fields that must come through.
MAVSDK_CALLS = {
    "set_position_ned": (1, 2552, dict(position_ned_m=(1.0, 2.0, -3.0), yaw_rad=0.5)),
    "set_velocity_ned": (1, 2503, dict(velocity_ned_mps=(4.0, 5.0, -6.0), yaw_rad=0.5)),
    "set_position_velocity_ned": (1, 2496, dict(position_ned_m=(1.0, 2.0, -3.0),
                                                velocity_ned_mps=(4.0, 5.0, -6.0), yaw_rad=0.5)),
    "set_position_velocity_acceleration_ned": (
        1, 2048, dict(position_ned_m=(1.0, 2.0, -3.0), velocity_ned_mps=(4.0, 5.0, -6.0),
                      acceleration_ned_mps2=(0.1, 0.2, 0.3), yaw_rad=0.5)),
    "set_acceleration_ned": (1, 3135, dict(acceleration_ned_mps2=(0.1, 0.2, 0.3))),
    "set_velocity_body": (8, 1479, dict(velocity_ned_mps=(4.0, 5.0, -6.0), yaw_rate_radps=0.25)),
}


@pytest.mark.parametrize("call", list(MAVSDK_CALLS))
def test_mavsdk_masks(call):
    vehicle, session, client = make()
    frame, mask, expected = MAVSDK_CALLS[call]
    client.send(local_ned(frame, mask, (1, 2, -3), (4, 5, -6), (0.1, 0.2, 0.3), 0.5, 0.25))
    assert len(vehicle.setpoints) == 1 and session.stats.offboard_setpoints == 1
    now, sp = vehicle.setpoints[0]
    assert now == 0.0
    check(sp, **expected)


def test_body_ned_rotation_by_yaw_90():
    vehicle, session, client = make()
    vehicle.move_to(0, 0, -5, yaw_rad=math.pi / 2)  # facing east
    client.send(local_ned(8, 1479, vel=(2.0, 1.0, -0.5), yaw_rate=0.3))
    _, sp = vehicle.setpoints[-1]
    check(sp, velocity_ned_mps=(-1.0, 2.0, -0.5), yaw_rate_radps=0.3)  # forward = east
    # acceleration: full attitude (here yaw only) and position is ignored in the body frame
    client.send(local_ned(8, 0x0C00 | 0x038, pos=(9, 9, 9), acc=(1.0, 0.0, 0.0)))
    _, sp = vehicle.setpoints[-1]
    check(sp, acceleration_ned_mps2=(0.0, 1.0, 0.0))


def test_body_acceleration_uses_full_attitude():
    pitch = math.radians(30)  # nose up: forward acceleration tilts up (−down)
    q = (math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0)
    sp = offboard.local_setpoint(8, 0x0C00 | 0x3F, (0, 0, 0), (0, 0, 0), (1.0, 0, 0), 0, 0, q)
    check(sp, acceleration_ned_mps2=(math.cos(pitch), 0.0, -math.sin(pitch)))


def test_nan_fields_are_not_commanded_and_bad_messages_are_dropped():
    vehicle, session, client = make()
    client.heartbeat()
    client.send(local_ned(1, 2552, pos=(NAN, NAN, -3.0), yaw=NAN))  # altitude only
    check(vehicle.setpoints[-1][1], position_ned_m=(NAN, NAN, -3.0))
    bad = [
        local_ned(1, 2552, pos=(math.inf, 0, 0)),  # ±inf
        local_ned(1, 2503, vel=(0, -math.inf, 0)),
        local_ned(1, 0x0FFF),  # everything ignored
        local_ned(1, 2552, pos=(NAN, NAN, NAN)),  # used group, but all NaN
        local_ned(8, 2552, pos=(1, 2, 3)),  # position in the body frame: ignored → nothing
        local_ned(1, 3135 | 0x200, acc=(1, 1, 1)),  # FORCE_SET
        local_ned(7, 2552, pos=(1, 2, 3)),  # LOCAL_OFFSET_NED: unsupported frame
        local_ned(9, 2552, pos=(1, 2, 3)),
    ]
    for msg in bad:
        client.send(msg)
    assert len(vehicle.setpoints) == 1 and session.stats.offboard_dropped == len(bad)
    chunks = of_type(client.run_until(0.1), "STATUSTEXT")  # 61 chars: two chunks, one text/s
    assert "".join(t.text for t in chunks) == (
        "SET_POSITION_TARGET_LOCAL_NED coordinate frame 7 unsupported")
    assert {t.severity for t in chunks} == {2}


@pytest.mark.parametrize("target, accepted", [
    ((1, 1), True), ((0, 0), True), ((1, 0), True), ((2, 1), False), ((1, 190), False)])
def test_target_rules(target, accepted):
    vehicle, _, client = make()
    client.send(local_ned(1, 2552, pos=(1, 2, 3), target=target))
    assert bool(vehicle.setpoints) is accepted


@pytest.mark.parametrize("frame, alt, down", [
    (5, 498.0, -10.0),  # AMSL; origin at 488 m
    (0, 498.0, -10.0),
    (6, 10.0, -12.0),  # relative to home, home 2 m above the origin here
    (3, 10.0, -12.0),
    (11, 10.0, -12.0),  # terrain: flat ground at home altitude
])
def test_global_int_frames(frame, alt, down):
    vehicle, session, client = make()
    vehicle.become_ready()
    home_geo = vehicle.origin.offset_ned(0, 0, -2.0)
    vehicle.home = vehicle.home.__class__(home_geo, (0.0, 0.0, -2.0), 0.0)
    target = vehicle.origin.offset_ned(30.0, -20.0, 0.0)
    client.send(M.MAVLink_set_position_target_global_int_message(
        0, 1, 1, frame, 2552, int(round(target.lat_deg * 1e7)),
        int(round(target.lon_deg * 1e7)), alt, 0, 0, 0, 0, 0, 0, 1.0, 0))
    _, sp = vehicle.setpoints[-1]
    check(sp, position_ned_m=sp.position_ned_m, yaw_rad=1.0)
    assert nan_eq(sp.position_ned_m, (30.0, -20.0, down), tol=0.02)


def test_global_int_velocity_and_bad_frame():
    vehicle, session, client = make()
    client.send(M.MAVLink_set_position_target_global_int_message(
        0, 1, 1, 6, 2503, 0, 0, 0, 1.0, 2.0, 3.0, 0, 0, 0, 0, 0))
    check(vehicle.setpoints[-1][1], velocity_ned_mps=(1.0, 2.0, 3.0), yaw_rad=0.0)
    client.send(M.MAVLink_set_position_target_global_int_message(
        0, 1, 1, 1, 2552, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0))
    assert len(vehicle.setpoints) == 1 and session.stats.offboard_dropped == 1


def test_attitude_target():
    vehicle, session, client = make()
    roll = math.radians(10)
    q = [math.cos(roll / 2), math.sin(roll / 2), 0.0, 0.0]
    client.send(M.MAVLink_set_attitude_target_message(0, 1, 1, 7, q, 0, 0, 0, 0.6))
    check(vehicle.setpoints[-1][1], attitude_q=tuple(q), thrust=0.6)
    client.send(M.MAVLink_set_attitude_target_message(0, 1, 1, 128, [1, 0, 0, 0], 0.1, -0.2,
                                                      0.3, 0.5))
    check(vehicle.setpoints[-1][1], body_rates_frd_radps=(0.1, -0.2, 0.3), thrust=0.5)
    client.send(M.MAVLink_set_attitude_target_message(0, 1, 1, 7 | 64, [2, 0, 0, 0], 0, 0, 0,
                                                      0.5))  # throttle ignored, q normalized
    check(vehicle.setpoints[-1][1], attitude_q=(1.0, 0.0, 0.0, 0.0))
    client.send(M.MAVLink_set_attitude_target_message(0, 1, 1, 7 | 32, q, 0, 0, 0, 0.5))
    check(vehicle.setpoints[-1][1], attitude_q=tuple(q))  # THRUST_BODY_SET: no thrust_body here
    # PX4 takes a zero or NaN quaternion (it normalizes to NaN: the motors stop)
    for quat in ([0, 0, 0, 0], [NAN, 0, 0, 0]):
        client.send(M.MAVLink_set_attitude_target_message(0, 1, 1, 7, quat, 0, 0, 0, 0.5))
        assert all(math.isnan(c) for c in vehicle.setpoints[-1][1].attitude_q)
    n = len(vehicle.setpoints)
    for mask, quat, rates, thrust in [
        (7 | 128, q, (0, 0, 0), 0.5),  # thrust alone commands nothing
        (1 | 128, q, (0, 0, 0.3), 0.5),  # body rates need roll and pitch (PX4)
        (128, q, (math.inf, 0, 0), 0.5),
        (7, q, (0, 0, 0), math.inf),
    ]:
        client.send(M.MAVLink_set_attitude_target_message(0, 1, 1, mask, quat, *rates, thrust))
    assert len(vehicle.setpoints) == n and session.stats.offboard_dropped == 4


def test_geo_projection_matches_vehicle_origin():
    origin = GeoPoint(47.0, 8.0, 400.0)
    target = origin.offset_ned(100.0, 50.0, -20.0)
    sp = offboard.global_setpoint(5, 2552, int(round(target.lat_deg * 1e7)),
                                  int(round(target.lon_deg * 1e7)), 420.0, (0, 0, 0), (0, 0, 0),
                                  NAN, 0, origin, 400.0)
    assert nan_eq(sp.position_ned_m, (100.0, 50.0, -20.0), tol=0.02)
