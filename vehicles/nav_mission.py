"""Mission mode: executes the stored MISSION plan item by item.

After PX4 ``src/modules/navigator/mission_base.cpp`` / ``mission.cpp`` (current index, auto
takeoff when started on the ground, "Mission finished, loitering|landed", resume at the current
item after a pause) and ``mission_block.cpp`` (``is_mission_item_reached_or_completed``: horizontal
acceptance radius = param2 or NAV_ACC_RAD, vertical NAV_MC_ALT_RAD, then the hold time param1).

Rules and invariants:
- ``current`` is the index of the item being executed; leaving Mission mode keeps it (pause),
  re-entering restarts that item. ``set_current`` and a new upload restart at their item; the
  current index set again changes nothing. An upload with no item flagged current keeps the
  index (clamped to the new mission), one with several takes the last.
- As PX4's navigator runs no mode while disarmed, the mission is active only in Mission mode
  and armed: arming in Mission mode activates it. A finished mission starts over only when the
  vehicle was disarmed since it last ran (``checkMissionRestart``); otherwise re-activating it
  loiters with "No valid mission available" until an index is set or a mission uploaded.
- Items without a position are executed at once and count as reached (PX4 reports
  MISSION_ITEM_REACHED for them too); camera/gimbal/actuator items are skipped. ROI items set
  the ROI as its commands do, and the heading points at it (nav_roi.py); activating the mission,
  a new mission or current item while it runs forget it (update_mission's reset_vroi).
- Below its next position item, the mission climbs first (mission_climb.py); a takeoff item is
  then a waypoint to its own position (handleTakeoff). The landing item: mission_landing.py.
- NAV_RETURN_TO_LAUNCH switches the vehicle to Return and completes the mission. A waypoint or
  landing without autocontinue is reported reached and held there until a new current item.
- Moving on from an item is goToNextItem, and MISSION_START with an index is goToItem: DO_JUMPs
  on the way are resolved at once (mission_jumps.py). Without a next item (past the last item, a
  jump outside the mission, an exhausted jump at the end) the mission finishes at the item flown
  last; only a finish at the last item resets the jumps.
- An index set as it is (MISSION_SET_CURRENT, an upload's current item, the restart at 0) is
  loaded as it is (loadCurrentMissionItem): a DO_JUMP there becomes the current item. It is never
  reached, as PX4 measures it as a waypoint at its unset position (0°, 0°); only a new current
  item ends it. So is a CONDITION_DELAY (which the feasibility check rejects): get_time_inside
  counts NAV_DELAY's param1 only.
- Items without a position (NAV_DELAY, such a DO_JUMP) leave PX4's position setpoint
  triplet as it was (mission.cpp setActiveMissionItems): the vehicle flies on to the last item's
  setpoint. The triplet is reset on activation and on a new current index or mission while
  active (navigator_main.cpp, set_current_mission_index, onMissionUpdate); without one
  FlightTaskAuto holds at the vehicle's position (_kept_setpoint). A hold time (param1) keeps the
  waypoint's own triplet.
- Yaw: the item's (mission_heading.py; none: the auto task turns towards its target while that
  is farther than the acceptance radius and holds the heading closer, MPC_YAW_MODE 0). A position
  item with a yaw (or a ROI's) is reached only once the heading is too, within its hold time.
"""

from __future__ import annotations

import math

from vehicles import mission_landing as landing
from vehicles.events import (
    COMMANDER_RTL,
    MISSION_EXECUTE,
    MISSION_FINISHED,
    MISSION_FINISHED_LOITER,
    MISSION_NOT_VALID_LOITER,
    MISSION_NOT_VALID_REFUSE,
    Log,
)
from vehicles.mission_climb import MissionClimb
from vehicles.mission_feasibility import MissionCheck
from vehicles.mission_heading import ItemReached, forces_heading, item_yaw_rad, time_inside_s
from vehicles.mission_jumps import JumpCounts, look_ahead, non_jump_index, triplet_next
from vehicles.mission_progress import MissionProgress
from vehicles.nav_core import NavContext, NavMode, NavSetpoint, land_speed_mps
from vehicles.nav_roi import ROI_COMMANDS, Roi, RoiHeading, command_of_item
from vehicles.plan_types import (
    MavCmd,
    MissionStatus,
    PlanItem,
    PlanType,
)
from vehicles.plans import PlanStore, item_loiter_radius_m, item_ned
from vehicles.types import Changes, NavState, Vec3

# Items that move the vehicle (the rest is executed instantly).
GOTO_COMMANDS = frozenset({MavCmd.NAV_WAYPOINT, MavCmd.NAV_LOITER_TIME, MavCmd.NAV_LOITER_UNLIM,
                           MavCmd.NAV_LOITER_TO_ALT})
TAKEOFF_COMMANDS = frozenset({MavCmd.NAV_TAKEOFF, 84})  # + NAV_VTOL_TAKEOFF
LOITER_COMMANDS = GOTO_COMMANDS - {MavCmd.NAV_WAYPOINT}  # SETPOINT_TYPE_LOITER


class Mission(NavMode):
    def __init__(self, plans: PlanStore, changes: Changes | None = None,
                 roi: Roi | None = None) -> None:
        """``changes``: the vehicle's generations (``mission_progress`` moves with ``current``,
        the item count and ``reached_count``); ``roi``: the navigator's."""
        self.plans = plans
        self.roi = roi if roi is not None else Roi()
        self._roi_heading = RoiHeading(self.roi)
        self._sp_yaw = math.nan  # the last setpoint's heading (PX4's current.yaw)
        self._changes = changes if changes is not None else Changes()
        self.progress = MissionProgress(self._changes)  # items reached, MISSION_CURRENT's view
        self.check = MissionCheck(self.progress.reset)  # PX4's feasibility verdict
        self._current = 0
        self.finished = False
        self._jumps_done = JumpCounts()
        self._phase = "start"  # start | takeoff | goto | delay | approach | land | jump | done
        self._reached = ItemReached()  # the current position item's reached flags
        self._resolve_jump = False  # the current index came from goToItem (MISSION_START)
        self._target: Vec3 = (0.0, 0.0, 0.0)
        self._yaw = 0.0
        self._fixed_yaw = math.nan
        self._wait_until = 0.0
        self._acc_rad = 2.0
        self._loiter_target: Vec3 | None = None  # a loiter item's setpoint, while it is the target
        self._loiter_radius = math.nan  # its loiter radius (NaN: NAV_LOITER_RAD)
        self._previous: Vec3 | None = None  # the triplet around a goto (PX4 position_setpoint)
        self._next: Vec3 | None = None
        self._came_from: Vec3 | None = None  # the waypoint just reached (the next previous)
        self._triplet: NavSetpoint | None = None  # PX4's triplet as set last; None: reset
        self._climb = MissionClimb()  # the climb work item before the first position item
        self._climb_setpoint: NavSetpoint | None = None  # its last (in the air: LOITER_TO_ALT)
        self._running = False  # active: in Mission mode and armed (PX4 isActive())
        self._has_run = False  # PX4 _mission_has_been_activated
        self.disarmed_while_inactive = False  # PX4 _system_disarmed_while_inactive
        self._announce = False  # say "Executing Mission" at the next tick
        plans.on_change(self._plan_changed)
        self._plan_changed(PlanType.MISSION)

    # --- bookkeeping ---------------------------------------------------------------------------
    @property
    def current(self) -> int:
        return self._current

    @current.setter
    def current(self, seq: int) -> None:
        # Every write moves the generation, so no path that moves the mission can miss it (a new
        # plan, the item count's only source of change, sets it too).
        self._current = seq
        self._changes.mission_progress += 1

    @property
    def items(self) -> tuple[PlanItem, ...]:
        return self.plans.get(PlanType.MISSION)

    def _plan_changed(self, plan_type: PlanType) -> None:
        if plan_type is not PlanType.MISSION:
            return
        # The upload's current item is the last one flagged (mavlink_mission.cpp
        # _transfer_current_seq); without one it is -1 and updateMavlinkMission keeps the
        # previous index, clamped to the new mission. A clear publishes 0.
        flagged = [i for i, it in enumerate(self.items) if it.current]
        count = len(self.items)
        self.current = flagged[-1] if flagged else max(0, min(self._current, count - 1))
        self._revive()
        self._has_run = self._running  # onMissionUpdate: new items while inactive
        if self._running:  # onMissionUpdate → update_mission
            self.roi.reset()
        self.progress.new_mission()
        self._jumps_done.clear()
        self._phase = "start"
        self._resolve_jump = False
        self._triplet = None  # onMissionUpdate: reset_triplets

    @property
    def last_jump(self) -> tuple[int, int]:
        """(the DO_JUMP counted last or -1, how many jumps were counted so far)."""
        return self._jumps_done.last, self._jumps_done.reports

    def jumps_taken(self, index: int) -> int:
        """The jumps the DO_JUMP at ``index`` has taken (do_jump_current_count)."""
        return self._jumps_done.get(index, 0)

    def valid(self) -> bool:
        """Items stored and found feasible (mission_feasibility.py: ``check``)."""
        return len(self.items) > 0 and self.check.valid

    def set_current(self, seq: int, resolve_jump: bool = False) -> bool:
        """A new current item: as it is (MISSION_SET_CURRENT), or with a DO_JUMP there resolved
        when the item starts (``resolve_jump``: MISSION_START's goToItem)."""
        if not 0 <= seq < len(self.items):
            return False
        if seq == self._current:  # set_current_mission_index / checkMissionDataChanged: no news
            return True
        self.current = seq
        self._resolve_jump = resolve_jump
        self._revive()
        self._phase = "start"
        self._triplet = None  # set_current_mission_index: reset_triplets
        self.progress.reached_resets += self._running  # onMissionUpdate → update_mission
        if self._running:  # while active
            self.progress.seq_reached = -1
            self.roi.reset()
        return True

    def _revive(self) -> None:
        """A new current item (set, or a new mission): a finished mission runs again, and when
        that happens in Mission mode update_mission says "Executing Mission" once more."""
        self._announce = self._running and self.finished
        self.finished = False

    def status(self, nav_state: NavState) -> MissionStatus:
        """MISSION_CURRENT's view (mission_progress.py)."""
        return self.progress.status(
            self.plans, nav_state, len(self.items), self.current, self.finished,
            self.check.rejected(self.plans.plan_id(PlanType.MISSION)), self.last_jump)

    # --- NavMode hooks -------------------------------------------------------------------------
    def on_activation(self, ctx: NavContext) -> None:
        self._running = False
        if ctx.armed:
            self._activate(ctx)

    def on_inactive(self, ctx: NavContext) -> None:
        self._running = False

    def _activate(self, ctx: NavContext) -> None:
        """mission_base.cpp on_activation: checkMissionRestart, then update_mission's verdict."""
        count = len(self.items)
        if self.disarmed_while_inactive and self._has_run and count and self.current + 1 == count:
            self.current, self.finished = 0, False
            self._jumps_done.clear()
            ctx.set_cruise_mps(math.nan)
        self._running = self._has_run = True
        self.disarmed_while_inactive = False
        self._triplet = None  # navigator_main.cpp: a new navigation mode resets the triplet
        self.check.force()  # Mission::on_activation: check_mission_valid(true)
        self.progress.reset()  # update_mission, which forgets the ROI
        self.roi.reset()
        self._yaw = ctx.yaw_rad
        if self.finished:
            # The last item was done and nothing set a new one: PX4 finds no valid current
            # item and keeps the end-of-mission loiter (idle on the ground).
            self._phase = "done"
            self._target = ctx.position_ned_m if ctx.landed else ctx.setpoint_ned_m
            if ctx.landed:
                ctx.log.critical(ctx.now_s, "No valid mission available, refusing takeoff\t")
                ctx.log.event(ctx.now_s, MISSION_NOT_VALID_REFUSE, Log.ERROR, Log.DISABLED)
            else:
                ctx.log.critical(ctx.now_s, "No valid mission available, loitering\t")
                ctx.log.event(ctx.now_s, MISSION_NOT_VALID_LOITER, Log.ERROR, Log.DISABLED)
            return
        ctx.log.info(ctx.now_s, "Executing Mission\t")
        ctx.log.event(ctx.now_s, MISSION_EXECUTE)
        self._phase = "start"
        self._climb.check(ctx, self.items, self.current, self._jumps_done)

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        sp = self._roi_heading.apply(ctx, self._on_active(ctx), self._roi_item())
        self._sp_yaw = sp.yaw_rad
        return sp

    def _roi_item(self) -> bool:
        """MissionBase::on_active: no heading_sp_update on a takeoff (the climb from the ground,
        a VTOL takeoff) or a landing (but on its approach: a waypoint work item)."""
        phase = self._phase
        if phase == "takeoff":
            return not self._climb.takeoff
        if phase == "goto":
            return self.items[self.current].command != 84  # NAV_VTOL_TAKEOFF
        return phase != "land"

    def _on_active(self, ctx: NavContext) -> NavSetpoint:
        if not ctx.armed:  # PX4's navigator runs no mode while disarmed
            self._running = False
            self.disarmed_while_inactive = True
        elif not self._running:
            self._activate(ctx)  # armed in Mission mode
        elif self._announce:
            ctx.log.info(ctx.now_s, "Executing Mission\t")
            ctx.log.event(ctx.now_s, MISSION_EXECUTE)
        self._announce = False
        if not ctx.armed or (ctx.landed and self.finished):
            self._phase = "start" if not self.finished else "done"
            self._target = ctx.position_ned_m
            return NavSetpoint(ctx.position_ned_m, ctx.yaw_rad, ctx.limits(), idle=True)
        if self._phase == "start":
            self._start_item(ctx)
        sp = self._run_phase(ctx)
        if self._phase not in ("delay", "jump"):
            self._triplet = sp
        return sp

    # --- item handling ------------------------------------------------------------------------
    def _start_item(self, ctx: NavContext) -> None:
        items = self.items
        resolve, self._resolve_jump = self._resolve_jump, False
        self._roi_heading.new_item()
        self._reached.reset()
        for _ in range(len(items) + 1):  # bounded: DO_JUMP loops cannot hang a tick
            if self.current >= len(items):
                self._finish(ctx)
                return
            item = items[self.current]
            cmd = item.command
            if cmd == MavCmd.DO_JUMP and not resolve or cmd == MavCmd.CONDITION_DELAY:  # never reached
                look_ahead(ctx.log, ctx.now_s, items, self.current + 1, self._jumps_done)
                self._phase = "jump"  # no setpoint of its own (_kept_setpoint)
                return
            if cmd == MavCmd.DO_JUMP:  # MISSION_START on a DO_JUMP: goToItem resolves it
                index = non_jump_index(ctx.log, ctx.now_s, self.items, self.current,
                                       self._jumps_done, write_jumps=True)
                if index is None:
                    self._finish(ctx)
                    return
                self.current = index
                continue
            ahead = look_ahead(ctx.log, ctx.now_s, items, self.current + 1, self._jumps_done)
            positional = cmd in GOTO_COMMANDS or cmd in TAKEOFF_COMMANDS or cmd in landing.LAND_COMMANDS
            if positional and self._climb.start(ctx):  # handleTakeoff's climb work item
                self._target, self._yaw = self._climb.target, self._climb.yaw_rad
                self._phase = "takeoff"
                return
            if cmd in GOTO_COMMANDS or cmd in TAKEOFF_COMMANDS:
                self._begin_goto(ctx, item, triplet_next(items, self.current, ahead))
                return
            if cmd in landing.LAND_COMMANDS:
                self._fixed_yaw = item_yaw_rad(item)  # the move's waypoint keeps param4
                self._target, approach, self._previous = landing.landing_start(
                    ctx, item, self._triplet, self._climb_setpoint)
                self._phase = "approach" if approach else "land"
                return
            if cmd == MavCmd.NAV_DELAY and item.param1 > 0:
                # no setpoint of its own (_kept_setpoint); NAV_CMD_DELAY is "reached" at once
                self._wait_until = ctx.now_s + item.param1
                self._phase = "delay"
                return
            if cmd == MavCmd.NAV_RETURN_TO_LAUNCH:
                # issue_command: PX4's mission sends NAV_RETURN_TO_LAUNCH and stays on the item,
                # never reached (is_mission_item_reached_or_completed waits for its position)
                # nor finished; MAVSDK counts on that (is_mission_finished's rtl_correction).
                self._phase = "done"
                # Commander's answer
                ctx.log.info(ctx.now_s, "Returning to launch\t")
                ctx.log.event(ctx.now_s, COMMANDER_RTL)
                ctx.switch_to(NavState.AUTO_RTL, None)
                return
            if cmd == MavCmd.DO_CHANGE_SPEED and int(item.param1) in (0, 1):
                # param1 speed type: 0 air / 1 ground (horizontal); 2 climb / 3 descent ignored
                ctx.set_cruise_mps(item.param2 if item.param2 > 0 else math.nan)
            if cmd in ROI_COMMANDS:  # issue_command: the navigator takes it as the command
                self.roi.command(*command_of_item(item, ctx.home_alt_amsl_m), ctx.now_s)
            # Everything else (camera, gimbal, actuator, DO_SET_HOME, DO_LAND_START, ...) is
            # accepted and skipped.
            self.progress.reached(self.current)
            if not self._next_item(ctx):
                return
        self._finish(ctx)

    def _next_item(self, ctx: NavContext) -> bool:
        """advance_mission / goToNextItem: the item after the current one, jumps resolved (and
        counted); without one the mission finishes where it is (False)."""
        count = len(self.items)
        nxt = self.current + 1
        index = non_jump_index(ctx.log, ctx.now_s, self.items, nxt, self._jumps_done,
                               write_jumps=True) if nxt < count else None
        if index is None:
            if nxt == count:  # completed: "Reset jump counter if the mission was completed"
                self._jumps_done.clear()
            self._finish(ctx)
            return False
        self.current = index
        return True

    def _begin_goto(self, ctx: NavContext, item: PlanItem, later: int | None) -> None:
        self._previous = self._came_from if self._came_from is not None else ctx.setpoint_ned_m
        self._came_from = None
        self._target = item_ned(item, ctx.origin, ctx.home_alt_amsl_m)
        # mission_item_to_position_setpoint: the loiter items' setpoints are SETPOINT_TYPE_LOITER
        # (a takeoff item is a NAV_CMD_WAYPOINT once handleTakeoff has seen it)
        self._loiter_target = self._target if item.command in LOITER_COMMANDS else None
        self._loiter_radius = item_loiter_radius_m(item)
        acc = item.param2 if item.command == MavCmd.NAV_WAYPOINT else 0.0
        self._acc_rad = acc if acc > 0 else float(ctx.params["NAV_ACC_RAD"])
        nxt = None  # the triplet's next (setActiveMissionItems)
        if later is not None:
            nxt = item_ned(self.items[later], ctx.origin, ctx.home_alt_amsl_m)
            if self.items[later].command == MavCmd.NAV_LOITER_TO_ALT:  # at the vehicle's altitude
                nxt = (nxt[0], nxt[1], ctx.position_ned_m[2])
        # FlightTaskAuto::_evaluateTriplets plans no corner at a loiter setpoint (it ignores next)
        self._next = None if item.command in LOITER_COMMANDS else nxt
        self._fixed_yaw = item_yaw_rad(item)
        self._phase = "goto"
        self._yaw = self._fixed_yaw
        self._triplet = self._goto_setpoint(ctx)  # set now, before this tick's reached check

    def _goto_setpoint(self, ctx: NavContext) -> NavSetpoint:
        return NavSetpoint(self._target, self._yaw, ctx.limits(), previous_ned_m=self._previous,
                           next_ned_m=self._next, acceptance_radius_m=self._acc_rad,
                           loiter=self._loiter_target is self._target,
                           loiter_radius_m=self._loiter_radius)

    def _run_phase(self, ctx: NavContext) -> NavSetpoint:
        p = ctx.params
        x, y, z = ctx.position_ned_m
        tx, ty, tz = self._target
        if self._phase == "done":
            return self._hold(ctx)
        if self._phase == "jump":
            return self._kept_setpoint(ctx)
        if self._phase == "takeoff":
            climb = self._climb_setpoint = self._climb.setpoint(ctx)
            if climb is not None:
                return climb
            # accepted: the item it preceded comes, the climb's setpoint as its previous
            self._came_from, self._phase = self._target, "start"
            self._start_item(ctx)
            return self._run_phase(ctx)
        if self._phase == "goto":
            dist = math.hypot(tx - x, ty - y)
            # without a yaw of its own "FlightTaskAuto handles yaw directly" (mission.cpp): towards
            # its target while farther than the acceptance radius, else held (auto_heading.py)
            self._yaw = self._fixed_yaw
            at = (not ctx.landed and dist < self._acc_rad
                  and abs(z - tz) < float(p["NAV_MC_ALT_RAD"]))
            if at or self._reached.position:  # (else the reached check says no)
                item = self.items[self.current]
                if at and item.command == MavCmd.NAV_LOITER_UNLIM:
                    # is_mission_item_reached_or_completed: never for LOITER_UNLIMITED, so no
                    # MISSION_ITEM_REACHED either; only a new current item ends it.
                    return NavSetpoint(self._target, self._yaw, ctx.limits(), loiter=True,
                                       loiter_radius_m=self._loiter_radius)
                # position, then yaw, then the hold time (its own triplet, unchanged meanwhile)
                reached = self._reached.update(ctx.now_s, at, self._item_yaw(), ctx.yaw_rad, p,
                                               forces_heading(item), time_inside_s(item))
                if self._reached.heading_timeout:
                    self.progress.fail_heading(ctx.now_s, ctx.log)
                if reached:
                    if item.autocontinue:
                        return self._advance(ctx)
                    # MissionBase::on_active: reached, not advanced; held till a new current item
                    if not self._reached.reported:
                        self._reached.reported = True
                        self.progress.reached(self.current)
            return self._goto_setpoint(ctx)
        if self._phase == "delay":
            if ctx.now_s >= self._wait_until:
                return self._advance(ctx)
            return self._kept_setpoint(ctx)
        if self._phase == "approach":
            if ctx.landed or self._reached.update(ctx.now_s, landing.approach_near(ctx, self._target),
                                                  self._item_yaw(), ctx.yaw_rad, p):
                self._phase = "land"
                self._roi_heading.new_item()  # the land item after its approach work item
            else:
                self._yaw = landing.approach_yaw(ctx, self._target, self._fixed_yaw, self._yaw)
                return NavSetpoint(self._target, self._yaw, ctx.limits(), previous_ned_m=self._previous)
        # land
        if ctx.landed:
            if not self._reached.reported:  # reached; advanced only with autocontinue
                self._reached.reported = True
                self.progress.reached(self.current)
                if self.items[self.current].autocontinue and self._next_item(ctx):
                    self._start_item(ctx)
            return NavSetpoint(ctx.position_ned_m, ctx.yaw_rad, ctx.limits(), idle=True)
        return landing.land_setpoint(ctx, self._target, self._yaw, self.items[self.current])

    def _advance(self, ctx: NavContext) -> NavSetpoint:
        self._came_from = self._target
        self.progress.reached(self.current)
        if not self._next_item(ctx):
            return self._hold(ctx)
        self._phase = "start"
        self._start_item(ctx)
        if self._phase in ("goto", "approach", "delay", "takeoff", "jump"):
            return self._run_phase(ctx)
        return self._hold(ctx)

    def _item_yaw(self) -> float:
        """The yaw the item is measured against: a ROI's heading written into it, else its own."""
        roi = self._roi_heading.yaw_rad
        return self._fixed_yaw if math.isnan(roi) else roi

    def _kept_setpoint(self, ctx: NavContext) -> NavSetpoint:
        """An item without a position (NAV_DELAY, a DO_JUMP loaded as it is): the triplet set
        last, as it was (setActiveMissionItems sets none; a landing's descent speed follows the
        height). Reset or on the ground: FlightTaskAuto::_evaluateTriplets without a valid
        setpoint, at the vehicle's position and yaw every update (not a loiter setpoint)."""
        sp = self._triplet
        if sp is None or ctx.landed:
            self._target, self._loiter_target = ctx.position_ned_m, None
            return NavSetpoint(self._target, ctx.yaw_rad, ctx.limits(), idle=ctx.landed)
        if sp.landing:
            speed = land_speed_mps(ctx.params, -ctx.position_ned_m[2])
            return sp._replace(limits=ctx.limits(speed_down_mps=speed), vz_cmd_mps=speed)
        return sp

    def _hold(self, ctx: NavContext) -> NavSetpoint:
        # the end of the mission is a loiter item (setEndOfMissionItems)
        kept = self._loiter_target is self._target  # setLoiterItemFromCurrentPositionSetpoint
        return NavSetpoint(self._target, self._yaw, ctx.limits(), idle=ctx.landed,
                           loiter=self.finished,
                           loiter_radius_m=self._loiter_radius if kept else math.nan)

    def _finish(self, ctx: NavContext) -> None:
        self.finished = True
        self._phase = "done"
        if ctx.landed:
            ctx.log.info(ctx.now_s, "Mission finished, landed\t")
            ctx.log.event(ctx.now_s, MISSION_FINISHED)
            self._target = ctx.position_ned_m
        else:
            ctx.log.info(ctx.now_s, "Mission finished, loitering\t")
            ctx.log.event(ctx.now_s, MISSION_FINISHED_LOITER)
            # MissionBase::setEndOfMissionItems: a loiter item's setpoint is kept, else the
            # vehicle loiters where it is (setLoiterItemFromCurrentPosition)
            if self._loiter_target is None or self._loiter_target != self._target:
                self._target = ctx.position_ned_m
            else:  # setLoiterItemFromCurrentPositionSetpoint: the setpoint's heading too
                self._yaw = self._sp_yaw
