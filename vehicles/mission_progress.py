"""What a mission reports of its progress: the items reached (mission_result's seq_reached,
MISSION_ITEM_REACHED's history) and MISSION_CURRENT's view of it (mavlink_mission.cpp
update_mission_state).

Rules and invariants:
- ``reached_seq`` is the last item reached (-1: none since the mission was stored);
  ``seq_reached`` is mission_result.seq_reached, which the navigator also puts back to -1
  (``reset``: check_mission_valid, update_mission; ``reached_resets`` counts those writes, so a
  link sees them even when the value does not change).
- Each reach or reset moves the vehicle's ``mission_progress`` generation.
- mission_mode is active in Mission, Takeoff and Land; a mission the feasibility check rejected
  counts as no mission; one reached item, then another mode, is PAUSED.
"""

from __future__ import annotations

from collections import deque

from vehicles.events import MISSION_FAILURE_HEADING, Log
from vehicles.plan_types import REACHED_HISTORY, MissionState, MissionStatus, PlanType
from vehicles.plans import PlanStore
from vehicles.status_log import StatusLog
from vehicles.types import Changes, NavState

# MISSION_CURRENT.mission_mode is "active" in these (mavlink_mission.cpp update_mission_state).
MISSION_MODE_STATES = frozenset({NavState.AUTO_MISSION, NavState.AUTO_TAKEOFF, NavState.AUTO_LAND})


class MissionProgress:
    def __init__(self, changes: Changes) -> None:
        self._changes = changes
        self.reached_seq = -1
        self.reached_count = 0
        self.reached_resets = 0  # PX4 writes seq_reached = -1 (MissionStatus.reached_resets)
        self.seq_reached = -1  # mission_result.seq_reached: the last reached, -1 since a reset
        self.history: deque[int] = deque(maxlen=REACHED_HISTORY)
        self.reached_any = False
        self.failure = False  # mission_result.failure: a forced heading timed out (MIS_YAW_TMT)

    def new_mission(self) -> None:
        """A mission stored: nothing of it reached."""
        self.reached_seq = self.seq_reached = -1
        self.reached_resets += 1
        self.reached_any = False
        self.failure = False

    def reset(self) -> None:
        """The navigator puts mission_result.seq_reached back to -1 (MissionStatus), and its
        failure to false (check_mission_valid, update_mission)."""
        self.reached_resets += 1
        self.seq_reached = -1
        self.failure = False
        self._changes.mission_progress += 1

    def fail_heading(self, now_s: float, log: StatusLog) -> None:
        """Navigator::set_mission_failure_heading_timeout: the failure is set, and said, once."""
        if not self.failure:
            self.failure = True
            self._changes.mission_progress += 1
            log.critical(now_s, "unable to reach heading within timeout\t")
            log.event(now_s, MISSION_FAILURE_HEADING, Log.CRITICAL, Log.WARNING)

    def reached(self, seq: int) -> None:
        self.reached_seq = self.seq_reached = seq
        self.reached_count += 1
        self._changes.mission_progress += 1
        self.history.append(seq)
        self.reached_any = True

    def status(self, plans: PlanStore, nav_state: NavState, count: int, current: int,
               finished: bool, rejected: bool, jump: tuple[int, int]) -> MissionStatus:
        """MISSION_CURRENT's view: ``rejected`` by the feasibility check, ``jump`` the DO_JUMP
        counted last and the jumps counted so far."""
        in_mission_mode = nav_state in MISSION_MODE_STATES
        if count == 0 or rejected:
            state = MissionState.NO_MISSION
        elif finished:
            state = MissionState.COMPLETE
        elif in_mission_mode:
            state = MissionState.ACTIVE
        elif self.reached_any:
            state = MissionState.PAUSED
        else:
            state = MissionState.NOT_STARTED
        return MissionStatus(
            current_seq=min(current, max(count - 1, 0)), count=count, state=state,
            in_mission_mode=in_mission_mode, reached_seq=self.reached_seq,
            reached_count=self.reached_count, mission_id=plans.plan_id(PlanType.MISSION),
            fence_id=plans.plan_id(PlanType.FENCE), rally_id=plans.plan_id(PlanType.RALLY),
            reached_history=tuple(self.history), jump_seq=jump[0], jump_count=jump[1],
            reached_resets=self.reached_resets)
