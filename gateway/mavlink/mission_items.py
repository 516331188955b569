"""Mission items on the wire ↔ ``PlanItem``, and the MISSION_CURRENT / MISSION_ITEM_REACHED frames.

Source: PX4 mavlink_mission.cpp parse/format_mavlink_mission_item.
Rules:
- ``PlanItem`` stores what MISSION_ITEM_INT carries: x/y integers (degE7 in global frames), z in
  metres. A legacy float MISSION_ITEM in a global frame has x/y in degrees → rounded to degE7;
  in other frames its x/y are plain params and are rounded to integers (PX4 does the same
  when it answers such an item in int mode).
- Download answers in the mode the client asks in: MISSION_REQUEST_INT → MISSION_ITEM_INT,
  legacy MISSION_REQUEST → MISSION_ITEM (x/y back to degrees in global frames), each item as
  PX4 formats what it stored (``download_form``: frame and params of positional items).
- pymavlink 2.4.50's MISSION_ACK / MISSION_COUNT / MISSION_CURRENT have no opaque_id /
  mission_id extension fields, so the CRC32 plan ids are not put on the wire (PX4 ≥ 1.15 sends
  them; MAVSDK 3 and QGC work without).
"""

from __future__ import annotations

import dataclasses
import math

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.codec import Encoder, payload_of
from gateway.mavlink.vehicle_port import VehiclePort
from vehicles.mission_jumps import jump_repeats, jump_target
from vehicles.plan_types import MavCmd, MissionState, MissionStatus, PlanItem, PlanType
from vehicles.plans import vertex_count

# Frames whose x/y are latitude/longitude (MAV_FRAME numbers).
GLOBAL_FRAMES = frozenset({0, 3, 5, 6, 10, 11})
RELATIVE_FRAMES = frozenset({3, 6})
MISSION_TOTAL_NONE = 65535  # MISSION_CURRENT.total while no mission is stored

NO_MISSION = MissionStatus(current_seq=0, count=0, state=MissionState.NO_MISSION,
                           in_mission_mode=False, reached_seq=-1, reached_count=0,
                           mission_id=0, fence_id=0, rally_id=0)


def item_from_int(msg: M.MAVLink_mission_item_int_message) -> PlanItem:
    return PlanItem(seq=msg.seq, frame=msg.frame, command=msg.command, current=msg.current,
                    autocontinue=msg.autocontinue, param1=msg.param1, param2=msg.param2,
                    param3=msg.param3, param4=msg.param4, x=msg.x, y=msg.y, z=msg.z,
                    mission_type=msg.mission_type)


def _to_int(value: float, scale: float) -> int:
    """A float param as the int32 MISSION_ITEM_INT would carry (NaN/inf → 0, clamped)."""
    if not math.isfinite(value):
        return 0
    return max(-(2**31), min(2**31 - 1, int(round(value * scale))))


def item_from_float(msg: M.MAVLink_mission_item_message) -> PlanItem:
    scale = 1e7 if msg.frame in GLOBAL_FRAMES else 1.0
    return PlanItem(seq=msg.seq, frame=msg.frame, command=msg.command, current=msg.current,
                    autocontinue=msg.autocontinue, param1=msg.param1, param2=msg.param2,
                    param3=msg.param3, param4=msg.param4, x=_to_int(msg.x, scale),
                    y=_to_int(msg.y, scale), z=msg.z, mission_type=msg.mission_type)


def _yaw_deg(deg: float) -> float:
    """A yaw param as PX4 stores and returns it: wrap_2pi(radians(deg)) back in degrees."""
    return math.degrees(math.radians(deg) % math.tau) if math.isfinite(deg) else deg


def _flag(value: float) -> float:
    return 1.0 if value > 0 else 0.0


def download_form(item: PlanItem, mission_type: int, int_mode: bool
                  ) -> tuple[int, float, float, float, float]:
    """(frame, param1..4) of a stored item as PX4 sends it back (mavlink_mission.cpp
    format_mavlink_mission_item from what parse_mavlink_mission_item kept): items without a
    position keep their params; positional ones get the frame of their altitude reference in
    the flavour asked for (relative: 6 or 3, absolute: 5 or 0; a fence point is always
    absolute, as PX4 keeps no reference for it) and only the params PX4 stores, yaw wrapped to
    [0, 360). A DO_JUMP's index and repeats come back as the int16 / uint16 PX4 keeps."""
    if item.command == MavCmd.DO_JUMP and item.frame not in GLOBAL_FRAMES:  # int16 / uint16
        return item.frame, float(jump_target(item)), float(jump_repeats(item)), item.param3, \
            item.param4
    if item.frame not in GLOBAL_FRAMES:
        return item.frame, item.param1, item.param2, item.param3, item.param4
    relative = item.frame in RELATIVE_FRAMES and mission_type != int(PlanType.FENCE)
    frame = (6 if int_mode else 3) if relative else (5 if int_mode else 0)
    cmd, p1, p2, p3, p4 = item.command, item.param1, item.param2, item.param3, item.param4
    if cmd == MavCmd.NAV_WAYPOINT:
        return frame, p1, p2, 0.0, _yaw_deg(p4)
    if cmd == MavCmd.NAV_LOITER_UNLIM:
        return frame, 0.0, 0.0, p3, _yaw_deg(p4)
    if cmd == MavCmd.NAV_LOITER_TIME:  # time, force heading, radius, exit on the tangent
        return frame, p1, _flag(p2), p3, _flag(p4)
    if cmd == MavCmd.NAV_LOITER_TO_ALT:
        return frame, _flag(p1), p2, 0.0, _flag(p4)
    if cmd == MavCmd.NAV_LAND:  # land_precision is a uint8_t
        precision = float(int(p2) & 0xFF) if math.isfinite(p2) and p2 >= 0 else 0.0
        return frame, 0.0, precision, 0.0, _yaw_deg(p4)
    if cmd in (MavCmd.NAV_TAKEOFF, 84, 85):  # + VTOL takeoff / land
        return frame, 0.0, 0.0, 0.0, _yaw_deg(p4)
    if cmd in (MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION):
        return frame, float(vertex_count(p1)), 0.0, 0.0, 0.0
    if cmd in (MavCmd.NAV_FENCE_CIRCLE_INCLUSION, MavCmd.NAV_FENCE_CIRCLE_EXCLUSION):
        return frame, p1, 0.0, 0.0, 0.0
    return frame, 0.0, 0.0, 0.0, 0.0


def fence_point(item: PlanItem) -> PlanItem:
    """A fence plan's item as PX4 reads it back (send_mission_item): dataman keeps a
    mission_fence_point_s (command, frame, lat/lon, alt and either the vertex count or a float
    sharing its place with mission_item_s's first param), so autocontinue comes back 0 and
    param2..4 as 0; a MAV_FRAME_MISSION item keeps param1 (a DO_JUMP not even that) and z, its
    x/y were never stored."""
    if item.frame in GLOBAL_FRAMES:
        return dataclasses.replace(item, autocontinue=0, param2=0.0, param3=0.0, param4=0.0)
    p1 = 0.0 if item.command == MavCmd.DO_JUMP else item.param1
    return dataclasses.replace(item, autocontinue=0, param1=p1, param2=0.0, param3=0.0,
                               param4=0.0, x=0, y=0)


def pack_item(enc: Encoder, item: PlanItem, seq: int, mission_type: int, target: tuple[int, int],
              int_mode: bool) -> bytes:
    """MISSION_ITEM_INT (int_mode) or legacy MISSION_ITEM for one stored item."""
    if mission_type == PlanType.FENCE:
        item = fence_point(item)
    frame, p1, p2, p3, p4 = download_form(item, mission_type, int_mode)
    common = (target[0], target[1], seq, frame, item.command, item.current,
              item.autocontinue, p1, p2, p3, p4)
    if int_mode:
        return enc.pack(M.MAVLink_mission_item_int_message, *common, item.x, item.y, item.z,
                        mission_type)
    scale = 1e-7 if item.frame in GLOBAL_FRAMES else 1.0
    return enc.pack(M.MAVLink_mission_item_message, *common, item.x * scale, item.y * scale,
                    item.z, mission_type)


def mission_status_of(vehicle: VehiclePort) -> MissionStatus:
    """``vehicle.mission_status``, or "no mission" for a vehicle without mission support."""
    status = getattr(vehicle, "mission_status", None)
    return NO_MISSION if status is None else status


_MISSION_CURRENT = payload_of(M.MAVLink_mission_current_message)


def mission_current_payload(st: MissionStatus) -> bytes:
    """MavlinkMissionManager::send_mission_current (v1.15): seq and total (UINT16_MAX without a
    mission); mission_state and mission_mode stay 0 (UNKNOWN: v1.15 does not fill them in, so
    MAVSDK judges a mission finished by MISSION_ITEM_REACHED, as with PX4)."""
    total = st.count if st.count > 0 else MISSION_TOTAL_NONE
    return _MISSION_CURRENT(max(0, st.current_seq) & 0xFFFF, total, 0, 0)


def pack_mission_current(enc: Encoder, st: MissionStatus) -> bytes:
    return enc.frame(M.MAVLINK_MSG_ID_MISSION_CURRENT, M.MAVLink_mission_current_message.crc_extra,
                     mission_current_payload(st))


def pack_item_reached(enc: Encoder, seq: int) -> bytes:
    return enc.pack(M.MAVLink_mission_item_reached_message, seq & 0xFFFF)


def plan_type_of(mission_type: int) -> PlanType | None:
    try:
        return PlanType(mission_type)
    except ValueError:
        return None
