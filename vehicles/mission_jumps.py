"""DO_JUMP resolution of the mission (PX4 ``src/modules/navigator/mission_base.cpp``
getNonJumpItem / getNextPositionItems, v1.15) and the triplet's next item (mission.cpp
setActiveMissionItems).

Rules and invariants:
- A DO_JUMP (param1 target index, param2 repeats) is taken while its count is below its
  repeats; taking it counts once when ``write_jumps`` (the mission moving on), never when only
  looking ahead. mavlink_mission.cpp stores param1 in mission_item_s's int16_t
  do_jump_mission_index and param2 in its uint16_t do_jump_repeat_count (``jump_target`` /
  ``jump_repeats``), and a download sends those back: -1 repeats are 65535.
- Only the index a resolution starts from is checked against the mission. Stepping past an
  exhausted DO_JUMP that is the last item reads the item after the last, which the dataman does
  not have: "Waypoint could not be read." (critical, event mission_failed_to_read_wp), and
  there is no next item. A jump to an index outside the mission has no next item either, said
  only on PX4's console ("Do Jump mission index is out of bounds.").
- The triplet's next (``triplet_next``) is the first position item after the current one as
  getNextPositionItems finds it: items without a position (NAV_DELAY, ROI, speed, camera, ...)
  are skipped, DO_JUMPs followed without counting, and a takeoff or landing counts. There is
  none when the current item does not autocontinue or a multicopter brakes for its hold time
  (brake_for_hold: get_time_inside), e.g. a waypoint, a NAV_DELAY, a waypoint: the second is
  the next of the first, whose corner is then planned towards it.
- ``jumps_done`` (JumpCounts) maps a DO_JUMP's index to the jumps taken (PX4 writes the count
  back into the stored item) and keeps, across resets, how many were counted and the last one
  (report_do_jump_mission_changed).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from vehicles.events import MISSION_READ_FAILED, Log
from vehicles.mission_heading import FLT_EPSILON, time_inside_s
from vehicles.plan_types import MavCmd, PlanItem
from vehicles.status_log import StatusLog

MAX_JUMP_ITERATION = 10  # mission_base.h: jumps one resolution follows at most
NEXT_POSITION_ITEMS = 2  # mission.cpp setActiveMissionItems: the position items looked ahead
# MissionBlock::item_contains_position (multicopter and VTOL commands)
POSITION_COMMANDS = frozenset({MavCmd.NAV_WAYPOINT, MavCmd.NAV_LOITER_UNLIM,
                               MavCmd.NAV_LOITER_TIME, MavCmd.NAV_LOITER_TO_ALT,
                               MavCmd.NAV_TAKEOFF, MavCmd.NAV_LAND, 84, 85})


def _low16(value: float) -> int:
    """The low 16 bits of a float converted to a C 16-bit integer on x86-64 SITL: the
    conversion goes through an int32 (cvttss2si), which gives INT32_MIN for NaN, ±inf and
    values outside int32."""
    i = math.trunc(value) if math.isfinite(value) and -(2**31) < value < 2**31 else -(2**31)
    return i & 0xFFFF


def jump_target(item: PlanItem) -> int:
    """do_jump_mission_index: param1 as an int16_t."""
    low = _low16(item.param1)
    return low - 0x10000 if low >= 0x8000 else low


def jump_repeats(item: PlanItem) -> int:
    """do_jump_repeat_count: param2 as a uint16_t (-1 → 65535)."""
    return _low16(item.param2)


class JumpCounts(dict[int, int]):
    """Jumps taken per DO_JUMP index; ``reports`` (never reset) and ``last`` say which jump was
    counted last."""

    def __init__(self) -> None:
        super().__init__()
        self.reports = 0
        self.last = -1

    def take(self, index: int) -> None:
        self[index] = self.get(index, 0) + 1
        self.reports += 1
        self.last = index


def non_jump_index(log: StatusLog, now_s: float, items: Sequence[PlanItem], index: int,
                   jumps_done: JumpCounts, write_jumps: bool) -> int | None:
    """getNonJumpItem: the first item from ``index`` on that is not a DO_JUMP, following the
    jumps with repeats left; None when there is none."""
    count = len(items)
    if not 0 <= index < count:
        return None
    for _ in range(MAX_JUMP_ITERATION):
        if index >= count:
            log.critical(now_s, "Waypoint could not be read.\t")
            log.event(now_s, MISSION_READ_FAILED, Log.ERROR, None, "H", index)
            return None
        item = items[index]
        if item.command != MavCmd.DO_JUMP:
            return index
        target = jump_target(item)
        if not 0 <= target < count:
            return None
        if jumps_done.get(index, 0) < jump_repeats(item):
            if write_jumps:
                jumps_done.take(index)
            index = target
        else:
            index += 1
    return index  # MAX_JUMP_ITERATION jumps in a row: PX4 stops where it got to


def look_ahead(log: StatusLog, now_s: float, items: Sequence[PlanItem], start: int,
               jumps_done: JumpCounts, max_items: int = NEXT_POSITION_ITEMS) -> list[int]:
    """getNextPositionItems(start, max_items), as setActiveMissionItems runs it for each new
    current item (``start`` = current + 1): the next position items, jumps followed
    but not counted. Its reads are what matter (the failed read past an exhausted last jump).
    PX4 loops for ever on a jump back to items without a position; this stops after one pass
    over the mission."""
    found: list[int] = []
    index = start
    steps = len(items) + 1
    for _ in range(max_items):
        while True:
            if index >= len(items) or steps == 0:
                return found
            steps -= 1
            item_index = non_jump_index(log, now_s, items, index, jumps_done, write_jumps=False)
            if item_index is None:
                return found
            index = item_index + 1
            if items[item_index].command in POSITION_COMMANDS:
                found.append(item_index)
                break
    return found


def triplet_next(items: Sequence[PlanItem], current: int, ahead: Sequence[int]) -> int | None:
    """The index of the triplet's next item for the current position item, ``ahead`` being
    look_ahead's from the item after it: PX4's navigator publishes it and FlightTaskAuto plans
    the corner at the current item towards it."""
    item = items[current]
    if not item.autocontinue or time_inside_s(item) > FLT_EPSILON or not ahead:
        return None
    return ahead[0]
