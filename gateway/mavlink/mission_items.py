"""Mission items on the wire ↔ ``PlanItem``, and the MISSION_CURRENT / MISSION_ITEM_REACHED frames.

Source: PX4 mavlink_mission.cpp parse/format_mavlink_mission_item.
Rules:
- ``PlanItem`` stores what MISSION_ITEM_INT carries: x/y integers (degE7 in global frames), z in
  metres. A legacy float MISSION_ITEM in a global frame has x/y in degrees → rounded to degE7;
  in other frames its x/y are plain params and are rounded to integers (PX4 does the same
  when it answers such an item in int mode).
- Download answers in the mode the client asks in: MISSION_REQUEST_INT → MISSION_ITEM_INT,
  legacy MISSION_REQUEST → MISSION_ITEM (x/y back to degrees in global frames).
- pymavlink 2.4.50's MISSION_ACK / MISSION_COUNT / MISSION_CURRENT have no opaque_id /
  mission_id extension fields, so the CRC32 plan ids are not put on the wire (PX4 ≥ 1.15 sends
  them; MAVSDK 3 and QGC work without).
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.codec import Encoder
from gateway.mavlink.vehicle_port import VehiclePort
from vehicles.plan_types import MissionState, MissionStatus, PlanItem, PlanType

# Frames whose x/y are latitude/longitude (MAV_FRAME numbers).
GLOBAL_FRAMES = frozenset({0, 3, 5, 6, 10, 11})
MISSION_TOTAL_NONE = 65535  # MISSION_CURRENT.total while no mission is stored
MISSION_MODE_ACTIVE = 1  # MISSION_CURRENT.mission_mode: in Mission/Takeoff/Land
MISSION_MODE_SUSPENDED = 2

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


def pack_item(enc: Encoder, item: PlanItem, seq: int, mission_type: int, target: tuple[int, int],
              int_mode: bool) -> bytes:
    """MISSION_ITEM_INT (int_mode) or legacy MISSION_ITEM for one stored item."""
    common = (target[0], target[1], seq, item.frame, item.command, item.current,
              item.autocontinue, item.param1, item.param2, item.param3, item.param4)
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


def pack_mission_current(enc: Encoder, st: MissionStatus) -> bytes:
    total = st.count if st.count > 0 else MISSION_TOTAL_NONE
    mode = MISSION_MODE_ACTIVE if st.in_mission_mode else MISSION_MODE_SUSPENDED
    return enc.pack(M.MAVLink_mission_current_message, max(0, st.current_seq) & 0xFFFF, total,
                    int(st.state), mode)


def pack_item_reached(enc: Encoder, seq: int) -> bytes:
    return enc.pack(M.MAVLink_mission_item_reached_message, seq & 0xFFFF)


def plan_type_of(mission_type: int) -> PlanType | None:
    try:
        return PlanType(mission_type)
    except ValueError:
        return None
