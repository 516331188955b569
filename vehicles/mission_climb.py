"""The mission's climb before its first position item: the takeoff PX4 inserts when a mission
starts on the ground, and the climb in place when it starts in the air below its next item.

After PX4 v1.15 ``src/modules/navigator/mission_base.cpp`` (``checkClimbRequired``),
``mission.cpp`` (``handleTakeoff``: WORK_ITEM_TYPE_CLIMB) and ``mission_block.cpp``
(``mission_item_to_position_setpoint``, ``is_mission_item_reached_or_completed``).

Rules and invariants:
- Whether to climb is decided once, when the mission is activated (``check``): when the next
  position item (DO_JUMPs followed) is more than NAV_MC_ALT_RAD above the vehicle, the climb to
  its altitude comes before it, on the ground as in the air. The first position item started
  afterwards takes it (``start``); nothing else inserts a climb (a waypoint started on the
  ground without one is flown from the ground, as PX4 flies it).
- On the ground the climb is a NAV_CMD_TAKEOFF, i.e. a SETPOINT_TYPE_TAKEOFF setpoint: flown as
  Takeoff mode flies one (nav_core.takeoff_limits: MPC_TKO_SPEED and the MPC_TKO_RAMP_T
  acceleration below MPC_LAND_ALT1; the auto task keeps the trajectory's altitude at the
  vehicle's), reported as LandedState.TAKEOFF, and accepted by the multicopter takeoff test
  (nav_core.takeoff_reached). In the air it is a NAV_CMD_LOITER_TO_ALT: a loiter setpoint with
  the ordinary limits, accepted within NAV_MC_ALT_RAD of the altitude.
- Both climb straight up from where the vehicle is, without a yaw setpoint: FlightTaskAuto
  (MPC_YAW_MODE 0) keeps the heading while the target is within the acceptance radius.
- The climb is a work item: never reported as reached, and the mission's current item stays
  the item it precedes (a takeoff item is then flown as a waypoint to its own position).
- PX4's triplet carries the item the climb precedes as ``next``; it is left out here: before the
  climb's altitude is reached computeStartXYSpeedFromWaypoints plans no corner towards it, and
  the climb is accepted before that altitude.
"""

from __future__ import annotations

from collections.abc import Sequence

from vehicles.events import MISSION_CLIMB, Log
from vehicles.mission_jumps import JumpCounts, look_ahead
from vehicles.nav_core import NavContext, NavSetpoint, takeoff_limits, takeoff_reached
from vehicles.plan_types import PlanItem
from vehicles.plans import item_ned
from vehicles.types import Vec3


class MissionClimb:
    def __init__(self) -> None:
        self.required_z: float | None = None  # PX4 _mission_init_climb_altitude_amsl (NED z)
        self.takeoff = False  # NAV_CMD_TAKEOFF (started landed), else NAV_CMD_LOITER_TO_ALT
        self.target: Vec3 = (0.0, 0.0, 0.0)
        self.yaw_rad = 0.0

    def check(self, ctx: NavContext, items: Sequence[PlanItem], current: int,
              jumps_done: JumpCounts) -> None:
        """checkClimbRequired(current): the next position item's altitude when it is more than
        the altitude acceptance radius (NAV_MC_ALT_RAD) above the vehicle."""
        self.required_z = None
        found = look_ahead(ctx.log, ctx.now_s, items, current, jumps_done, 1)
        if not found:
            return
        z = item_ned(items[found[0]], ctx.origin, ctx.home_alt_amsl_m)[2]
        if ctx.position_ned_m[2] - z > float(ctx.params["NAV_MC_ALT_RAD"]):
            self.required_z = z

    def start(self, ctx: NavContext) -> bool:
        """handleTakeoff for a position item: the climb work item, when one is pending ("Climb
        to %.1f meters above home", tab, event); False when none is."""
        if self.required_z is None:
            return False
        home_z = ctx.home.position_ned_m[2] if ctx.home is not None else 0.0
        alt_above_home_m = home_z - self.required_z
        ctx.log.info(ctx.now_s, f"Climb to {alt_above_home_m:.1f} meters above home\t")
        ctx.log.event(ctx.now_s, MISSION_CLIMB, Log.INFO, None, "f", alt_above_home_m)
        x, y, _ = ctx.position_ned_m
        self.target, self.required_z = (x, y, self.required_z), None
        self.takeoff = ctx.landed
        self.yaw_rad = ctx.yaw_rad
        return True

    def setpoint(self, ctx: NavContext) -> NavSetpoint | None:
        """This tick's setpoint, or None once is_mission_item_reached_or_completed accepts the
        climb (in the air in both cases)."""
        if self.takeoff:
            if not ctx.landed and takeoff_reached(ctx, self.target[2]):
                return None
            return NavSetpoint(self.target, self.yaw_rad, takeoff_limits(ctx.params, ctx),
                               taking_off=True)
        # LOITER_TO_ALT: within NAV_ACC_RAD plus the loiter radius horizontally (it climbs
        # where it is) and within NAV_MC_ALT_RAD of the altitude.
        rad = float(ctx.params["NAV_MC_ALT_RAD"])
        if not ctx.landed and abs(ctx.position_ned_m[2] - self.target[2]) <= rad:
            return None
        return NavSetpoint(self.target, self.yaw_rad, ctx.limits())

