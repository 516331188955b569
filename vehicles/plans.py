"""Plan storage and validation: mission, geofence and rally items (PX4 dataman + mavlink_mission).

After PX4 ``src/modules/mavlink/mavlink_mission.cpp`` (``parse_mavlink_mission_item``: accepted
frames and commands, MAV_MISSION_RESULT codes) and ``src/modules/navigator/geofence.cpp``
(what a fence plan's items mean once stored).

Rules and invariants:
- One immutable tuple of ``PlanItem`` per ``PlanType``; ``set`` validates the whole list first and
  replaces the stored one only when it is ACCEPTED (atomic, like PX4 switching dataman slots)
  and differs from it (``plan_id``); an identical plan changes nothing, observers included.
- Items of every plan type go through the one parser (mavlink_mission.cpp
  parse_mavlink_mission_item): positional commands need a global frame (0, 3, 5, 6), the others
  MAV_FRAME_MISSION (2); a command in the other frame's branch, or unknown -> UNSUPPORTED; any
  other frame -> UNSUPPORTED_FRAME. Then the plan type's check (handle_mission_item_both):
  a mission refuses fence and rally commands, a fence polygon vertices with fewer than 3
  vertices (MAV_MISSION_ERROR); nothing else is checked at upload (a fence's vertex groups
  and circle radii are only read when it loads, geofence.py).
- ``plan_id`` is an opaque CRC32 of the items (0 when empty), as PX4's MISSION_ACK/CURRENT ids.
- ``item_ned`` converts an item's position to the vehicle's local NED frame: relative-altitude
  frames are relative to home, the others AMSL.
- Observers registered with ``on_change`` learn which plan changed (the navigator resets the
  mission index, the geofence rebuilds itself).
"""

from __future__ import annotations

import math
import struct
import zlib
from collections.abc import Callable, Sequence

from vehicles.cnum import f32
from vehicles.geodesy import position_fault
from vehicles.plan_types import MavCmd, MavFrame, PlanItem, PlanResult, PlanType
from vehicles.types import GeoPoint

GLOBAL_FRAMES = frozenset({MavFrame.GLOBAL, MavFrame.GLOBAL_RELATIVE_ALT, MavFrame.GLOBAL_INT,
                           MavFrame.GLOBAL_RELATIVE_ALT_INT})
RELATIVE_FRAMES = frozenset({MavFrame.GLOBAL_RELATIVE_ALT, MavFrame.GLOBAL_RELATIVE_ALT_INT})
NAV_EPSILON_POSITION_M = 0.001  # navigation.h: anything smaller is zero

# Mission commands PX4 accepts with a position (mavlink_mission.cpp, global-frame branch).
POSITIONAL_COMMANDS = frozenset({
    16, 17, 19, 21, 22, 31,  # waypoint, loiter unlim/time, land, takeoff, loiter to alt
    80, 195, 201,  # NAV_ROI, DO_SET_ROI_LOCATION, DO_SET_ROI
    84, 85,  # VTOL takeoff / land
    4501,  # CONDITION_GATE
})
# Mission commands without a position (MAV_FRAME_MISSION branch). Not among them (PX4 1.15
# answers MAV_MISSION_UNSUPPORTED): CONDITION_YAW (115), DO_SET_SERVO (183), DO_SET_ROI_SYSID
# (198), DO_AUTOTUNE_ENABLE (212), COMPONENT_ARM_DISARM (400), SET_CAMERA_ZOOM (531),
# SET_CAMERA_SOURCE (534).
NON_POSITIONAL_COMMANDS = frozenset({
    20, 93, 112, 114,  # RTL, NAV_DELAY, CONDITION_DELAY / DISTANCE
    177, 178, 179, 187, 189,  # DO_JUMP, CHANGE_SPEED, SET_HOME, SET_ACTUATOR, LAND_START
    196, 197,  # ROI wpnext offset / none
    200, 203, 204, 205, 206, 211, 214,  # camera / mount / gripper / trigger interval
    260, 530, 532,  # oblique survey, camera mode / focus
    1000, 1001, 2000, 2001, 2003, 2500, 2501, 3000, 42600,  # gimbal, capture, transition, winch
})
ROI_COMMANDS = frozenset({80, 201})  # NAV_ROI, DO_SET_ROI: param1 is the MAV_ROI mode
FENCE_COMMANDS = frozenset({MavCmd.NAV_FENCE_RETURN_POINT, MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                            MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
                            MavCmd.NAV_FENCE_CIRCLE_INCLUSION, MavCmd.NAV_FENCE_CIRCLE_EXCLUSION})
POLYGON_COMMANDS = frozenset({MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                              MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION})
# handle_mission_item_both's check of a mission item ("hardening against wrong client
# implementations"): these parse, but a mission refuses them with MAV_MISSION_ERROR. Not
# NAV_FENCE_RETURN_POINT: a mission stores it (and its feasibility check refuses it).
MISSION_HARDENING = (FENCE_COMMANDS - {MavCmd.NAV_FENCE_RETURN_POINT}) | {MavCmd.NAV_RALLY_POINT}

# PX4 dataman capacities (the mission one is large in SITL); the gateway refuses bigger
# uploads with MAV_MISSION_NO_SPACE before any item is transferred.
CAPACITY = {PlanType.MISSION: 2000, PlanType.FENCE: 64, PlanType.RALLY: 32}


def validate_plan(plan_type: PlanType, items: Sequence[PlanItem]) -> PlanResult:
    if len(items) > CAPACITY[plan_type]:
        return PlanResult.NO_SPACE
    for i, item in enumerate(items):
        if item.seq != i:
            return PlanResult.INVALID_SEQUENCE
        result = validate_item(plan_type, item)
        if result is not PlanResult.ACCEPTED:
            return result
    return PlanResult.ACCEPTED


_FAULT_RESULT = {"lat": PlanResult.INVALID_PARAM5_X, "lon": PlanResult.INVALID_PARAM6_Y,
                 "alt": PlanResult.INVALID_PARAM7}


def _validate_position(item: PlanItem, check_alt: bool = True) -> PlanResult:
    """A place the vehicle can fly to and report (geodesy.position_fault); the altitude of a
    relative frame is checked as it is, home being near sea level next to MAX_ALT_M."""
    fault = position_fault(item.lat_deg, item.lon_deg, item.z if check_alt else 0.0)
    return PlanResult.ACCEPTED if fault is None else _FAULT_RESULT[fault]


def vertex_count(param1: float) -> int:
    """A polygon vertex's count as PX4 keeps it: ``(uint16_t)(param1 + 0.5f)``
    (parse_mavlink_mission_item), the conversion x86 SITL does (through int32: NaN, ±inf and
    values beyond int32 give 0x80000000, whose low 16 bits are 0)."""
    v = f32(f32(param1) + 0.5)
    if not math.isfinite(v) or abs(v) >= 2**31:
        return 0
    return math.trunc(v) & 0xFFFF


def validate_item(plan_type: PlanType, item: PlanItem) -> PlanResult:
    """One uploaded item's verdict, as handle_mission_item_both gives it at that item: first
    parse_mavlink_mission_item (the same parser for every plan type), then the plan type's own
    check (MAV_MISSION_ERROR: a fence or rally command in a mission, a fence polygon vertex
    with fewer than 3 vertices). A fence or rally plan stores whatever parses: a waypoint in a
    fence is "unhandled" when the fence loads (geofence.py), one in a rally plan is no rally
    point for RTL (nav_rtl.py). Positions outside the globe are refused as the parser's
    INVALID_PARAM5_X/6_Y/7 (a fence point's altitude is unused, so not checked)."""
    result = _parse(item)
    if result is not PlanResult.ACCEPTED:
        return result
    if plan_type is PlanType.MISSION and item.command in MISSION_HARDENING:
        return PlanResult.ERROR
    if (plan_type is PlanType.FENCE and item.command in POLYGON_COMMANDS
            and vertex_count(item.param1) < 3):
        return PlanResult.ERROR  # "Fence: too few vertices" (console only)
    if item.frame in GLOBAL_FRAMES:  # last: only what PX4 would store is refused here
        return _validate_position(item, check_alt=plan_type is not PlanType.FENCE)
    return PlanResult.ACCEPTED


def _parse(item: PlanItem) -> PlanResult:
    """parse_mavlink_mission_item: the frame picks the branch (global 0/3/5/6, or
    MAV_FRAME_MISSION), then the branch knows the command or answers UNSUPPORTED (so
    DO_CHANGE_SPEED in a global frame and a waypoint or rally point in MAV_FRAME_MISSION are
    refused); any other frame is UNSUPPORTED_FRAME. (The *_INT frames only in int mode: the
    gateway refuses them in a float MISSION_ITEM.)"""
    cmd, frame = item.command, item.frame
    if frame in GLOBAL_FRAMES:
        if cmd in ROI_COMMANDS and _roi_mode(item) not in (0, 3):  # NONE, LOCATION
            return PlanResult.INVALID_PARAM1
        ok = cmd in POSITIONAL_COMMANDS or cmd in FENCE_COMMANDS or cmd == MavCmd.NAV_RALLY_POINT
        return PlanResult.ACCEPTED if ok else PlanResult.UNSUPPORTED
    if frame == MavFrame.MISSION:
        if cmd in ROI_COMMANDS:  # MAV_ROI NONE, WPNEXT, WPINDEX
            return PlanResult.ACCEPTED if _roi_mode(item) in (0, 1, 2) else PlanResult.INVALID_PARAM1
        return PlanResult.ACCEPTED if cmd in NON_POSITIONAL_COMMANDS else PlanResult.UNSUPPORTED
    return PlanResult.UNSUPPORTED_FRAME


def _roi_mode(item: PlanItem) -> int:
    return int(item.param1) if math.isfinite(item.param1) else -1


def plan_crc32(items: Sequence[PlanItem]) -> int:
    """Opaque id of a plan: CRC32 over the packed items (0 for an empty plan). Like PX4's
    crc32_for_mission_item it covers what each item asks for (frame, command, autocontinue,
    params, x/y/z), not its seq or ``current`` flag: the same plan sent again has the same id."""
    if not items:
        return 0
    crc = 0
    for it in items:
        crc = zlib.crc32(struct.pack("<BHBffffiif", it.frame, it.command, it.autocontinue & 0xFF,
                                     it.param1, it.param2, it.param3, it.param4, it.x, it.y,
                                     it.z), crc)
    return crc or 1


def item_geo(item: PlanItem, home_alt_amsl_m: float) -> GeoPoint:
    alt = item.z + home_alt_amsl_m if item.frame in RELATIVE_FRAMES else item.z
    return GeoPoint(item.lat_deg, item.lon_deg, alt)


def item_ned(item: PlanItem, origin: GeoPoint, home_alt_amsl_m: float) -> tuple[float, float, float]:
    """The item's position in the local NED frame of ``origin``."""
    return origin.ned_of(item_geo(item, home_alt_amsl_m))


def item_loiter_radius_m(item: PlanItem) -> float:
    """The loiter radius of the item's position setpoint, NaN for NAV_LOITER_RAD: param2 of a
    LOITER_TO_ALT, param3 of the others (mavlink_mission.cpp), its size, none when about zero
    (mission_item_to_position_setpoint, NAV_EPSILON_POSITION)."""
    radius = abs(item.param2 if item.command == MavCmd.NAV_LOITER_TO_ALT else item.param3)
    return radius if radius > NAV_EPSILON_POSITION_M else math.nan


class PlanStore:
    def __init__(self) -> None:
        self._plans: dict[PlanType, tuple[PlanItem, ...]] = {t: () for t in PlanType}
        self._ids: dict[PlanType, int] = {t: 0 for t in PlanType}
        self._observers: list[Callable[[PlanType], None]] = []

    def on_change(self, callback: Callable[[PlanType], None]) -> None:
        self._observers.append(callback)

    def get(self, plan_type: PlanType) -> tuple[PlanItem, ...]:
        plans = self._plans
        # PlanType is an IntEnum: members and their values find the same key; the enum call
        # (slow, and polled by every session wake-up through mission progress) only validates.
        return plans[plan_type] if plan_type in plans else plans[PlanType(plan_type)]

    def plan_id(self, plan_type: PlanType) -> int:
        ids = self._ids  # (as ``get``: the enum call only validates a value that is no key)
        return ids[plan_type] if plan_type in ids else ids[PlanType(plan_type)]

    def set(self, plan_type: PlanType, items: Sequence[PlanItem]) -> PlanResult:
        plan_type = PlanType(plan_type)
        items = tuple(items)
        result = validate_plan(plan_type, items)
        # mavlink_mission.cpp publishes a completed upload only when its CRC32 differs from the
        # stored plan's: the same plan again is ACCEPTED and changes nothing (not the mission's
        # current item, even if another item is flagged current).
        if result is PlanResult.ACCEPTED and not (items and plan_crc32(items) == self._ids[plan_type]):
            self._plans[plan_type] = items
            self._ids[plan_type] = plan_crc32(items)
            for cb in self._observers:
                cb(plan_type)
        return result

    def clear(self, plan_type: PlanType) -> PlanResult:
        return self.set(plan_type, ())
