#!/usr/bin/env python3
"""List every parameter of every vehicle on the GCS port, then set one — with plain pymavlink.

    .venv/bin/python gcs_examples/params.py                         # listen on 14550
    .venv/bin/python gcs_examples/params.py --set MIS_TAKEOFF_ALT 5 --sysid 1
"""

import argparse
import struct
import time

from pymavlink import mavutil


def as_value(msg) -> float | int:
    if msg.param_type == mavutil.mavlink.MAV_PARAM_TYPE_INT32:
        # PX4 sends INT32 parameters byte-wise in the float field.
        return struct.unpack("<i", struct.pack("<f", msg.param_value))[0]
    return msg.param_value


def read_all(conn, sysid: int, timeout_s: float = 60.0) -> dict[str, object]:
    """Every parameter of ``sysid``, as QGC reads them: PARAM_REQUEST_LIST (asked again while
    nothing answers), then PARAM_REQUEST_READ for each index still missing once the stream goes
    quiet. Over a lossy link some answers are lost; what never came is simply not in the result."""
    conn.mav.param_request_list_send(sysid, 1)
    by_index, count = {}, None
    deadline = time.time() + timeout_s
    quiet_since = time.time()
    while time.time() < deadline and (count is None or len(by_index) < count):
        msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.3)
        if msg is not None and msg.get_srcSystem() == sysid and msg.param_id != "_HASH_CHECK":
            count = msg.param_count
            by_index[msg.param_index] = msg
            quiet_since = time.time()
        elif time.time() - quiet_since > 1.0 and count is None:
            conn.mav.param_request_list_send(sysid, 1)  # the request (or every answer) was lost
            quiet_since = time.time()
        elif count is not None and time.time() - quiet_since > 0.5:
            for i in [i for i in range(count) if i not in by_index][:10]:
                conn.mav.param_request_read_send(sysid, 1, b"", i)  # re-request, as QGC does
            quiet_since = time.time()
    return {m.param_id: m for m in by_index.values()}


def shown(params: dict, name: str) -> str:
    return str(as_value(params[name])) if name in params else "(not received)"


def set_param(conn, sysid: int, msg, text: str, attempts: int = 5):
    """PARAM_SET until the vehicle echoes the parameter (QGC retries a PARAM_SET too)."""
    name, ptype = msg.param_id, msg.param_type
    if ptype == mavutil.mavlink.MAV_PARAM_TYPE_INT32:
        wire = struct.unpack("<f", struct.pack("<i", int(text)))[0]
    else:
        wire = float(text)
    for _ in range(attempts):
        conn.mav.param_set_send(sysid, 1, name.encode(), wire, ptype)
        deadline = time.time() + 1.0
        while time.time() < deadline:
            echo = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.2)
            if echo is not None and echo.get_srcSystem() == sysid and echo.param_id == name:
                return echo
    return None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--port", type=int, default=14550)
    parser.add_argument("--sysid", type=int, default=None, help="only this vehicle")
    parser.add_argument("--set", nargs=2, metavar=("NAME", "VALUE"))
    args = parser.parse_args()

    conn = mavutil.mavlink_connection(f"udpin:0.0.0.0:{args.port}", source_system=255,
                                      source_component=190)
    print(f"Listening on {args.port} for vehicles...")
    conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID,
                            0, 0, 0)
    # Listen 3 s for every vehicle's HEARTBEAT (1 Hz); longer (up to 15 s) while the one
    # asked for, or any, is still unheard: over a lossy link a few can be lost in a row.
    vehicles = set()
    start = time.time()
    while time.time() < start + 15:
        hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
        if hb is not None and hb.get_srcComponent() == 1:
            vehicles.add(hb.get_srcSystem())
        wanted = vehicles if args.sysid is None else vehicles & {args.sysid}
        if wanted and time.time() > start + 3:
            break
    if args.sysid is not None:
        vehicles &= {args.sysid}
    if not vehicles:
        print("no vehicle heard: is `make run` running?")
    for sysid in sorted(vehicles):
        params = read_all(conn, sysid)
        print(f"vehicle {sysid}: {len(params)} parameters, e.g. MIS_TAKEOFF_ALT="
              f"{shown(params, 'MIS_TAKEOFF_ALT')} MAV_SYS_ID={shown(params, 'MAV_SYS_ID')}")
        if args.set:
            name, text = args.set
            if name not in params:
                conn.mav.param_request_read_send(sysid, 1, name.encode(), -1)
                msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=2,
                                      condition=f"PARAM_VALUE.param_id=='{name}'")
                if msg is None:
                    print(f"vehicle {sysid}: no parameter {name} (or no answer)")
                    continue
                params[name] = msg
            echo = set_param(conn, sysid, params[name], text)
            print(f"vehicle {sysid}: {name} is now {as_value(echo) if echo else '(no answer)'}")

if __name__ == "__main__":
    main()
