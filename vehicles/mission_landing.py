"""A mission's landing item, as PX4 1.15 flies a multicopter's (navigator mission_base.cpp
handleLanding, mission_block.cpp is_mission_item_reached_or_completed).

- In the air and farther than NAV_ACC_RAD from the landing point (do_need_move_to_item), the
  landing starts with a waypoint work item (WORK_ITEM_TYPE_MOVE_TO_LAND) to it: at the altitude
  of the current position setpoint if that is a SETPOINT_TYPE_POSITION (a waypoint's), else at
  the vehicle's, from the current setpoint as its previous one. It is reached within
  NAV_ACC_RAD horizontally and NAV_MC_ALT_RAD vertically, and the heading as any item's.
- Closer, or on the ground, the descent starts at once: a SETPOINT_TYPE_LAND at the item's
  position, descending at the land speed (nav_core.land_speed_mps).
"""

from __future__ import annotations

import math

from vehicles.nav_core import NavContext, NavSetpoint, land_speed_mps
from vehicles.plan_types import MavCmd, PlanItem
from vehicles.plans import item_ned
from vehicles.types import Vec3

LAND_COMMANDS = frozenset({MavCmd.NAV_LAND, 85})  # + NAV_VTOL_LAND
# Below this horizontal distance the move to the landing point no longer updates the heading.
YAW_LOCK_DIST_M = 1.0


def landing_start(ctx: NavContext, item: PlanItem, triplet: NavSetpoint | None,
                  climb: NavSetpoint | None) -> tuple[Vec3, bool, Vec3 | None]:
    """(the target, whether the move to the landing point comes first, the move's previous
    setpoint). ``triplet``: the current position setpoint as set last (None: reset); ``climb``:
    the mission's climb work item's last setpoint, a SETPOINT_TYPE_LOITER in the air
    (LOITER_TO_ALT)."""
    n, e, _ = item_ned(item, ctx.origin, ctx.home_alt_amsl_m)
    x, y, z = ctx.position_ned_m
    if ctx.landed or not math.hypot(n - x, e - y) > float(ctx.params["NAV_ACC_RAD"]):
        return (n, e, z), False, None
    previous = None
    if triplet is not None:
        # setActiveMissionItems resets the previous setpoint, then sets it to the current one
        # all the same (the work item type it tests is still the one before the move)
        if all(map(math.isfinite, triplet.target_ned_m)):
            previous = triplet.target_ned_m
        if triplet is not climb and not (
                triplet.loiter or triplet.landing or triplet.taking_off or triplet.idle):
            z = triplet.target_ned_m[2]
    return (n, e, z), True, previous


def approach_near(ctx: NavContext, target: Vec3) -> bool:
    """The move to the landing point is within its acceptance radius (NAV_ACC_RAD) and
    altitude (NAV_MC_ALT_RAD)."""
    x, y, z = ctx.position_ned_m
    p = ctx.params
    return (math.hypot(target[0] - x, target[1] - y) < float(p["NAV_ACC_RAD"])
            and abs(z - target[2]) < float(p["NAV_MC_ALT_RAD"]))


def approach_yaw(ctx: NavContext, target: Vec3, fixed_yaw: float, yaw: float) -> float:
    """The move's heading: the item's (param4), else towards the landing point while farther
    than YAW_LOCK_DIST_M, else ``yaw`` (held)."""
    if not math.isnan(fixed_yaw):
        return fixed_yaw
    x, y, _ = ctx.position_ned_m
    if math.hypot(target[0] - x, target[1] - y) > YAW_LOCK_DIST_M:
        return math.atan2(target[1] - y, target[0] - x)
    return yaw


def land_setpoint(ctx: NavContext, target: Vec3, yaw: float, item: PlanItem | None = None
                  ) -> NavSetpoint:
    """The descent at the landing point's horizontal position; a land item whose param2 asks
    for a precision landing (1 opportunistic, 2 required: ``land_precision``) runs the
    navigator's Precision Land block instead (MissionBlock::startPrecLand)."""
    precision = item.param2 if item is not None and item.command == MavCmd.NAV_LAND else 0.0
    if ctx.precland is not None and precision in (1.0, 2.0):
        return ctx.precland.land(ctx, item, target, yaw, int(precision))
    speed = land_speed_mps(ctx.params, -ctx.position_ned_m[2])
    return NavSetpoint((target[0], target[1], math.nan), yaw,
                       ctx.limits(speed_down_mps=speed), vz_cmd_mps=speed, landing=True)
