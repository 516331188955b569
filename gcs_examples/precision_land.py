#!/usr/bin/env python3
"""Land on a landing pad — a companion computer's precision landing, with plain pymavlink.

    .venv/bin/python gcs_examples/precision_land.py                 # vehicle 1 (API port 14540)
    .venv/bin/python gcs_examples/precision_land.py --north 6 --east -4
    .venv/bin/python gcs_examples/precision_land.py --no-target     # PX4's search, then fallback

Takes off, then reports a landing pad NORTH/EAST metres from the takeoff point in LANDING_TARGET
(MAV_FRAME_LOCAL_NED, the vehicle's own local frame read from LOCAL_POSITION_NED) at 10 Hz, as a
camera pipeline on the companion computer would, and switches to Precision Land (custom mode
AUTO / PRECLAND). PX4 flies over the pad, descends onto it and disarms. Without a target it climbs
to PLD_SRCH_ALT, searches for PLD_SRCH_TOUT seconds, then lands where it is.
"""

import argparse
import math
import time

from pymavlink import mavutil

PX4_CUSTOM_MAIN_MODE_AUTO = 4
PX4_CUSTOM_SUB_MODE_AUTO_PRECLAND = 9
TARGET_RATE_HZ = 10.0


def command(conn, cmd: int, *params: float, timeout_s: float = 3.0) -> int:
    """COMMAND_LONG until its COMMAND_ACK (asked again after a second without one)."""
    p = list(params) + [0.0] * (7 - len(params))
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        conn.mav.command_long_send(conn.target_system, conn.target_component, cmd, 0, *p)
        ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=1.0)
        while ack is not None and ack.command != cmd:
            ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=1.0)
        if ack is not None:
            return ack.result
    raise TimeoutError(f"no COMMAND_ACK for command {cmd}")


def local_position(conn):
    return conn.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=5.0)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--port", type=int, default=14540,
                        help="UDP port to listen on (vehicle i talks to 14540+i)")
    parser.add_argument("--north", type=float, default=6.0, help="the pad, metres north")
    parser.add_argument("--east", type=float, default=-4.0, help="the pad, metres east")
    parser.add_argument("--no-target", action="store_true", help="report no pad")
    parser.add_argument("--timeout", type=float, default=180.0, help="seconds to land")
    args = parser.parse_args()

    conn = mavutil.mavlink_connection(f"udpin:0.0.0.0:{args.port}", source_system=245,
                                      source_component=191, dialect="development")
    conn.wait_heartbeat(timeout=30)
    print(f"-- Connected to system {conn.target_system}")
    while True:  # wait for a position estimate, as a companion computer would
        msg = conn.recv_match(type="SYS_STATUS", blocking=True, timeout=5.0)
        if msg is not None and msg.onboard_control_sensors_health & \
                mavutil.mavlink.MAV_SYS_STATUS_SENSOR_GPS:
            break
    start = local_position(conn)
    pad = (start.x + args.north, start.y + args.east, start.z)

    print("-- Arming")
    if command(conn, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) != 0:
        print("arming refused")
        return 1
    print("-- Taking off")
    command(conn, mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan,
            math.nan)
    while True:
        pos = local_position(conn)
        if pos is not None and pos.z < start.z - 2.0:
            break
    time.sleep(3.0)

    print("-- Precision Land" + (" (no target: search, then fallback)" if args.no_target else
                                 f" on the pad {args.north:.1f} m N, {args.east:.1f} m E"))
    mode = (mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, PX4_CUSTOM_MAIN_MODE_AUTO,
            PX4_CUSTOM_SUB_MODE_AUTO_PRECLAND)
    switched = False
    next_report = 0.0
    deadline = time.time() + args.timeout
    armed = True
    while armed and time.time() < deadline:
        now = time.time()
        if not args.no_target and now >= next_report:
            conn.mav.landing_target_send(int(now * 1e6), 0, mavutil.mavlink.MAV_FRAME_LOCAL_NED,
                                         0, 0, 0, 0, 0, pad[0], pad[1], pad[2],
                                         (1.0, 0.0, 0.0, 0.0), 0, 1)
            next_report = now + 1.0 / TARGET_RATE_HZ
        if not switched:
            result = command(conn, mavutil.mavlink.MAV_CMD_DO_SET_MODE, *mode)
            if result != 0:
                print(f"Precision Land refused (result {result})")
                return 1
            switched = True
        msg = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.05)
        if msg is not None and msg.get_srcSystem() == conn.target_system:
            armed = bool(msg.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
    if armed:
        print("not landed in time")
        return 1
    end = local_position(conn)
    miss = math.hypot(end.x - pad[0], end.y - pad[1])
    print(f"-- Landed and disarmed {miss:.2f} m from the pad "
          f"({end.x - start.x:.2f} m N, {end.y - start.y:.2f} m E of the takeoff point)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
