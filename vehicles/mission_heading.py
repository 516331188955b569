"""A mission item's heading and when a position item counts as reached (PX4 v1.15.2).

After PX4 ``src/modules/mavlink/mavlink_mission.cpp`` (parse_mavlink_mission_item: the item's
yaw and force_heading), ``src/modules/navigator/mission.cpp`` / ``mission_base.cpp``
(handleTakeoff and handleLanding clear the yaw of a takeoff and of a landing's descent),
``mission_block.cpp`` (is_mission_item_reached_or_completed, get_time_inside) and
``navigator_main.cpp`` (get_yaw_to_be_accepted, MIS_YAW_ERR / MIS_YAW_TMT).

Rules and invariants:
- An item's yaw (``item_yaw_rad``): NAV_WAYPOINT, LOITER_UNLIM and LOITER_TIME carry param4 in
  degrees (NaN: none; the auto task then turns as MPC_YAW_MODE says). LOITER_TO_ALT's parser
  sets none, so it keeps the zeroed mission_item_s's 0: north. A multicopter flies a takeoff
  without one. A landing keeps its param4 while it moves to the landing point (handleLanding's
  waypoint copy of the item), and has none for the descent.
- ``ItemReached`` is the item's reached state (_waypoint_position_reached, _waypoint_yaw_reached,
  _time_wp_reached): each flag latches until the next item. Once the position is reached, a
  rotary wing waits for the yaw: the heading within MIS_YAW_ERR of it (wrap_pi). No yaw (NaN),
  no wait. MIS_YAW_TMT at or above FLT_EPSILON accepts at once an item that does not force its
  heading (force_heading: LOITER_TIME param2 > 0, LOITER_TO_ALT param1 > 0); a forced one keeps
  waiting, and after MIS_YAW_TMT from the position's arrival ``heading_timeout`` is set: the
  mission fails ("unable to reach heading within timeout", mission_result.failure), and the
  failsafe's mission_failure check answers with RTL.
- The yaw waited for is the item's as heading_sp_update left it the tick before: a ROI's bearing
  replaces it (nav_roi.py).
- A multicopter always waits: get_yaw_to_be_accepted waives the yaw only when
  position_controller_status says NaN, and for a multicopter only the obstacle avoidance
  interface (COM_OBS_AVOID, not modelled) publishes it.
- The hold time (get_time_inside: a waypoint's or LOITER_TIME's param1, never negative) counts
  from the moment the position was reached, so the wait for the yaw runs inside it.
"""

from __future__ import annotations

import math

from vehicles.params import ParamStore
from vehicles.plan_types import MavCmd, PlanItem

FLT_EPSILON = 1.1920929e-07
# parse_mavlink_mission_item: the position items that take param4 as their yaw
YAW_COMMANDS = frozenset({MavCmd.NAV_WAYPOINT, MavCmd.NAV_LOITER_UNLIM, MavCmd.NAV_LOITER_TIME,
                          MavCmd.NAV_LAND})


def item_yaw_rad(item: PlanItem) -> float:
    """The item's yaw as the navigator flies it (radians, [0, 2π); NaN: none). A landing's is
    the one of its move to the landing point."""
    if item.command in YAW_COMMANDS:
        return math.radians(item.param4) % math.tau if math.isfinite(item.param4) else math.nan
    if item.command == MavCmd.NAV_LOITER_TO_ALT:
        return 0.0  # not parsed: mission_item_s{}'s zero
    return math.nan


def forces_heading(item: PlanItem) -> bool:
    """mission_item_s force_heading: LOITER_TIME's param2, LOITER_TO_ALT's param1."""
    if item.command == MavCmd.NAV_LOITER_TIME:
        return item.param2 > 0
    return item.command == MavCmd.NAV_LOITER_TO_ALT and item.param1 > 0


def time_inside_s(item: PlanItem) -> float:
    """get_time_inside for a multicopter: a waypoint's or LOITER_TIME's param1, at least 0."""
    if item.command in (MavCmd.NAV_WAYPOINT, MavCmd.NAV_LOITER_TIME):
        return max(item.param1, 0.0)
    return 0.0


def yaw_accepted(yaw_rad: float, heading_rad: float, params: ParamStore, force: bool) -> bool:
    """is_mission_item_reached_or_completed's yaw check of a rotary wing."""
    if math.isnan(yaw_rad):
        return True
    err = abs(math.remainder(yaw_rad - heading_rad, math.tau))
    return err < math.radians(float(params["MIS_YAW_ERR"])) \
        or (float(params["MIS_YAW_TMT"]) >= FLT_EPSILON and not force)


class ItemReached:
    """The current item's reached flags; ``reset`` for each new item (reset_mission_item_reached)."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.position_at_s = math.nan  # _time_wp_reached (NaN: the position not reached yet)
        self.yaw = False
        self.reported = False  # reported reached without autocontinue (the item goes on)
        self.heading_timeout = False  # a forced heading not reached within MIS_YAW_TMT

    @property
    def position(self) -> bool:
        return not math.isnan(self.position_at_s)

    def update(self, now_s: float, at_position: bool, yaw_rad: float, heading_rad: float,
               params: ParamStore, force: bool = False, hold_s: float = 0.0) -> bool:
        """True once the position (``at_position`` this tick, latched), then the yaw, then the
        hold time were reached."""
        if not self.position:
            if not at_position:
                return False
            self.position_at_s = now_s
        if not self.yaw:
            self.yaw = yaw_accepted(yaw_rad, heading_rad, params, force)
            if not self.yaw:
                timeout_s = float(params["MIS_YAW_TMT"])
                if force and timeout_s >= FLT_EPSILON and now_s - self.position_at_s >= timeout_s:
                    self.heading_timeout = True  # set_mission_failure_heading_timeout
                return False
        return hold_s < FLT_EPSILON or now_s >= self.position_at_s + hold_s
