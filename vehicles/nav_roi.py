"""The region of interest (ROI): the navigator's ``vehicle_roi`` and the mission's heading at it.

After PX4 v1.15.2 ``src/modules/navigator``: navigator_main.cpp (the ROI vehicle commands
replace ``_vroi``), mission_block.cpp (``issue_command``: a mission's ROI items publish the
equivalent vehicle command) and mission_base.cpp (``on_active`` / ``heading_sp_update``: a
multicopter's mission points its heading at the ROI; ``update_mission`` and
``checkMissionRestart`` reset it).

Rules and invariants:
- One ``Roi`` per navigator, shared by every mode; only Mission reads it (Loiter, RTL, Takeoff
  and Land do not look at ``_vroi`` in v1.15.2). ``command`` replaces it whole, as
  ``_vroi = {}`` followed by the command's fields does: DO_SET_ROI / NAV_ROI set only the mode
  (param1), so a DO_SET_ROI in MAV_ROI_LOCATION mode points at 0°N 0°E; DO_SET_ROI_LOCATION
  sets the location (param5/6/7), DO_SET_ROI_WPNEXT_OFFSET the offsets (param5/6/7, degrees),
  DO_SET_ROI_NONE clears it.
- A mission item is turned into its command as issue_command does: DO_SET_ROI_LOCATION with
  the item's position (a relative altitude plus home's); NAV_ROI is stored as DO_SET_ROI, whose
  param5/6 are the item's unused float slots (0) in a global frame, and x/y in
  MAV_FRAME_MISSION.
- The heading (``heading_at``) is the bearing from the vehicle to the ROI location (LOCATION)
  or to the current setpoint plus the yaw offset (WPNEXT), only farther than NAV_ACC_RAD from
  that point; other modes give none. Great-circle distance and bearing, as PX4's
  get_distance_to_next_waypoint / get_bearing_to_next_waypoint.
- Mission (``RoiHeading``) writes that heading into its current item's yaw, so it stays once
  the vehicle is within the radius, or the ROI is gone, until the next item; it does so
  while MIS_MNT_YAW_CTL is 0 (the vehicle, not a mount, points at the ROI) and the item is not
  a takeoff (the climb from the ground included) or a landing.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from vehicles.geodesy import bearing_rad, distance_m, reproject
from vehicles.nav_core import NavContext, NavSetpoint
from vehicles.plan_types import MavFrame, PlanItem
from vehicles.plans import RELATIVE_FRAMES
from vehicles.types import GeoPoint, Vec3

# vehicle_roi_s modes (MAV_ROI)
ROI_NONE, ROI_WPNEXT, ROI_WPINDEX, ROI_LOCATION, ROI_TARGET = 0, 1, 2, 3, 4
# The commands (MAV_CMD) and mission items that set it
NAV_ROI = 80
DO_SET_ROI_LOCATION = 195
DO_SET_ROI_WPNEXT_OFFSET = 196
DO_SET_ROI_NONE = 197
DO_SET_ROI = 201
ROI_COMMANDS = frozenset({NAV_ROI, DO_SET_ROI_LOCATION, DO_SET_ROI_WPNEXT_OFFSET,
                          DO_SET_ROI_NONE, DO_SET_ROI})

Params7 = tuple[float, float, float, float, float, float, float]


class VehicleRoi(NamedTuple):
    """vehicle_roi_s: the mode, a location (degrees, AMSL) and the offsets (radians)."""

    mode: int = ROI_NONE
    lat_deg: float = 0.0
    lon_deg: float = 0.0
    alt_amsl_m: float = 0.0
    pitch_offset_rad: float = 0.0
    roll_offset_rad: float = 0.0
    yaw_offset_rad: float = 0.0


NO_ROI = VehicleRoi()


def _uint8(value: float) -> int:
    """``_vroi.mode = cmd.param1``: a float stored in a uint8_t as x86 converts it (truncated
    through int32; NaN, ±inf and values beyond int32 give 0x80000000, whose low byte is 0)."""
    if not math.isfinite(value) or abs(value) >= 2**31:
        return 0
    return math.trunc(value) & 0xFF


def roi_of_command(command: int, params: Params7) -> VehicleRoi:
    """navigator_main.cpp: the ``_vroi`` a ROI vehicle command leaves (anything else: none)."""
    if command in (DO_SET_ROI, NAV_ROI):
        return VehicleRoi(mode=_uint8(params[0]))
    if command == DO_SET_ROI_LOCATION:
        return VehicleRoi(ROI_LOCATION, params[4], params[5], params[6])
    if command == DO_SET_ROI_WPNEXT_OFFSET:
        return VehicleRoi(ROI_WPNEXT, pitch_offset_rad=math.radians(params[4]),
                          roll_offset_rad=math.radians(params[5]),
                          yaw_offset_rad=math.radians(params[6]))
    return NO_ROI


def command_of_item(item: PlanItem, home_alt_amsl_m: float) -> tuple[int, Params7]:
    """MissionBlock::issue_command for a ROI item: (command, param1..7) as the navigator then
    receives it. parse_mavlink_mission_item keeps a global-frame NAV_ROI / DO_SET_ROI as
    DO_SET_ROI with only its mode and altitude (param5/6 stay 0); DO_SET_ROI_LOCATION sends
    the item's latitude and longitude, and its altitude plus home's when relative; the
    MAV_FRAME_MISSION items send their params and x/y/z as they are."""
    p1, p2, p3, p4 = item.param1, item.param2, item.param3, item.param4
    command = DO_SET_ROI if item.command == NAV_ROI else item.command
    if item.command == DO_SET_ROI_LOCATION:
        alt = item.z + home_alt_amsl_m if item.frame in RELATIVE_FRAMES else item.z
        return command, (p1, p2, p3, p4, item.lat_deg, item.lon_deg, alt)
    if command == DO_SET_ROI and item.frame != MavFrame.MISSION:  # a global frame: MAV_ROI_LOCATION or NONE
        return command, (p1, 0.0, 0.0, 0.0, 0.0, 0.0, item.z)
    return command, (p1, p2, p3, p4, float(item.x), float(item.y), item.z)


class Roi:
    """The navigator's ``_vroi`` (``current``): set by commands and mission items, reset by
    the mission (Navigator::reset_vroi). ``published``: the vehicle_roi the navigator published
    last (None: never), at each command (``published_at_s``: its timestamp); a reset publishes
    nothing."""

    def __init__(self) -> None:
        self.current = NO_ROI
        self.published: VehicleRoi | None = None
        self.published_at_s = math.nan

    def command(self, command: int, params: Params7, now_s: float) -> None:
        self.current = self.published = roi_of_command(command, params)
        self.published_at_s = now_s

    def reset(self) -> None:
        self.current = NO_ROI


def heading_at(roi: VehicleRoi, origin: GeoPoint, position_ned_m: Vec3, setpoint_ned_m: Vec3,
               acceptance_radius_m: float) -> float:
    """MissionBase::heading_sp_update: the heading towards the ROI from the vehicle (both local
    NED points of ``origin``), or NaN when there is none: a mode other than LOCATION and WPNEXT
    (the current setpoint, plus the yaw offset), or the point within the acceptance radius."""
    lat, lon = reproject(origin.lat_deg, origin.lon_deg, position_ned_m[0], position_ned_m[1])
    if roi.mode == ROI_LOCATION:
        to_lat, to_lon, offset = roi.lat_deg, roi.lon_deg, 0.0
    elif roi.mode == ROI_WPNEXT:
        to_lat, to_lon = reproject(origin.lat_deg, origin.lon_deg, setpoint_ned_m[0],
                                   setpoint_ned_m[1])
        offset = roi.yaw_offset_rad
    else:
        return math.nan
    if not distance_m(lat, lon, to_lat, to_lon) > acceptance_radius_m:
        return math.nan
    return math.remainder(bearing_rad(lat, lon, to_lat, to_lon) + offset, math.tau)


class RoiHeading:
    """Mission's part of heading_sp_update: the heading it wrote into the current item
    (``yaw_rad``, NaN: none), which ``new_item`` forgets (set_mission_items loads the item's own)."""

    def __init__(self, roi: Roi) -> None:
        self.roi = roi
        self.yaw_rad = math.nan

    def new_item(self) -> None:
        self.yaw_rad = math.nan

    def apply(self, ctx: NavContext, sp: NavSetpoint, item_applies: bool) -> NavSetpoint:
        """This tick's setpoint with the current item's heading: updated towards the ROI (a
        ROI set, MIS_MNT_YAW_CTL 0, ``item_applies``: not a takeoff or a landing), else the one
        written earlier, else the item's own. Not while idle (no valid setpoint)."""
        roi = self.roi.current
        if sp.idle or not item_applies:
            return sp
        if roi.mode != ROI_NONE and not int(ctx.params["MIS_MNT_YAW_CTL"]):
            yaw = heading_at(roi, ctx.origin, ctx.position_ned_m, sp.target_ned_m,
                             float(ctx.params["NAV_ACC_RAD"]))
            if not math.isnan(yaw):
                self.yaw_rad = yaw
        if math.isnan(self.yaw_rad):
            return sp
        return sp._replace(yaw_rad=self.yaw_rad)
