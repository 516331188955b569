"""Value types for missions, geofences, rally points and offboard setpoints.

These are what the gateway hands the vehicle once it has decoded the wire (PX4 keeps the same
split: mavlink_mission.cpp stores items in dataman, navigator interprets them).

Rules:
- ``PlanItem`` is one MISSION_ITEM_INT as stored: raw MAV_CMD number, MAV_FRAME number, params,
  x/y in degE7 for global frames, z in metres (relative or AMSL depending on the frame). The
  vehicle interprets commands; it does not need pymavlink for that, so the few MAV_CMD / MAV_FRAME
  numbers it understands are named here.
- ``OffboardSetpoint`` is already in the vehicle's local NED frame (the gateway rotates BODY_NED
  and projects global setpoints with ``Vehicle.origin``). NaN means "not commanded". At least one
  of position / velocity / acceleration / attitude / body rates is commanded, checked in
  ``__post_init__``; no field is ±inf.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from vehicles.types import Vec3

NAN = math.nan
NAN3: Vec3 = (NAN, NAN, NAN)


class PlanType(enum.IntEnum):
    """MAV_MISSION_TYPE."""

    MISSION = 0
    FENCE = 1
    RALLY = 2


class MavCmd(enum.IntEnum):
    """The MAV_CMD numbers the navigator interprets (common.xml)."""

    NAV_WAYPOINT = 16
    NAV_LOITER_UNLIM = 17
    NAV_LOITER_TURNS = 18
    NAV_LOITER_TIME = 19
    NAV_RETURN_TO_LAUNCH = 20
    NAV_LAND = 21
    NAV_TAKEOFF = 22
    NAV_LOITER_TO_ALT = 31
    NAV_DELAY = 93
    DO_JUMP = 177
    DO_CHANGE_SPEED = 178
    DO_SET_HOME = 179
    DO_LAND_START = 189
    CONDITION_DELAY = 112
    CONDITION_YAW = 115
    NAV_FENCE_RETURN_POINT = 5000
    NAV_FENCE_POLYGON_VERTEX_INCLUSION = 5001
    NAV_FENCE_POLYGON_VERTEX_EXCLUSION = 5002
    NAV_FENCE_CIRCLE_INCLUSION = 5003
    NAV_FENCE_CIRCLE_EXCLUSION = 5004
    NAV_RALLY_POINT = 5100


class MavFrame(enum.IntEnum):
    """MAV_FRAME numbers used by plan items."""

    GLOBAL = 0  # AMSL, lat/lon
    MISSION = 2  # not a position
    GLOBAL_RELATIVE_ALT = 3  # altitude relative to home
    GLOBAL_INT = 5
    GLOBAL_RELATIVE_ALT_INT = 6
    GLOBAL_TERRAIN_ALT = 10
    GLOBAL_TERRAIN_ALT_INT = 11


class MissionState(enum.IntEnum):
    """MISSION_STATE (MISSION_CURRENT.mission_state)."""

    UNKNOWN = 0
    NO_MISSION = 1
    NOT_STARTED = 2
    ACTIVE = 3
    PAUSED = 4
    COMPLETE = 5


class PlanResult(enum.IntEnum):
    """MAV_MISSION_RESULT values the vehicle may return when a plan is stored."""

    ACCEPTED = 0
    ERROR = 1
    UNSUPPORTED_FRAME = 2
    UNSUPPORTED = 3
    NO_SPACE = 4
    INVALID = 5
    INVALID_PARAM1 = 6
    INVALID_PARAM5_X = 10
    INVALID_PARAM6_Y = 11
    INVALID_PARAM7 = 12
    INVALID_SEQUENCE = 13
    DENIED = 14


@dataclass(frozen=True)
class PlanItem:
    seq: int
    frame: int
    command: int
    current: int
    autocontinue: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float
    mission_type: int = PlanType.MISSION

    @property
    def lat_deg(self) -> float:
        return self.x * 1e-7

    @property
    def lon_deg(self) -> float:
        return self.y * 1e-7


@dataclass(frozen=True)
class MissionStatus:
    """What MISSION_CURRENT / MISSION_ITEM_REACHED report (PX4 mavlink_mission.cpp)."""

    current_seq: int
    count: int
    state: MissionState
    in_mission_mode: bool  # mission_mode 1 (in Mission/Takeoff/Land) vs 2 (suspended)
    reached_seq: int  # last MISSION_ITEM_REACHED seq, -1 if none
    reached_count: int  # increments on every reach event (a repeat of the same seq too)
    mission_id: int  # CRC32 opaque ids
    fence_id: int
    rally_id: int
    # The newest reached seqs, oldest first (up to REACHED_HISTORY). Several items can be reached
    # in one tick (a waypoint followed by DO_* items): a reader that saw reached_count k takes the
    # last (reached_count - k) entries as the new MISSION_ITEM_REACHED events.
    reached_history: tuple[int, ...] = ()
    # The DO_JUMP taken last and how many jumps were taken so far (moves with each): PX4's
    # mission_result item_do_jump_changed / item_changed_index, which mavlink answers with that
    # item (mavlink_mission.cpp send).
    jump_seq: int = -1
    jump_count: int = 0
    # Moves each time PX4's navigator puts mission_result.seq_reached back to -1 (activation, a
    # new current item while active, a new mission): the next reach is news even for the same
    # seq, as mavlink_mission.cpp sends MISSION_ITEM_REACHED only when seq_reached changes.
    reached_resets: int = 0


REACHED_HISTORY = 32


def _finite_or_nan(values: tuple[float, ...], what: str) -> None:
    for v in values:
        if math.isinf(v):
            raise ValueError(f"{what} must be finite or NaN, got {v}")


@dataclass(frozen=True)
class OffboardSetpoint:
    position_ned_m: Vec3 = NAN3
    velocity_ned_mps: Vec3 = NAN3
    acceleration_ned_mps2: Vec3 = NAN3
    yaw_rad: float = NAN
    yaw_rate_radps: float = NAN
    attitude_q: tuple[float, float, float, float] | None = None  # (w,x,y,z) FRD->NED
    body_rates_frd_radps: Vec3 = NAN3
    thrust: float = NAN  # 0..1 collective, with attitude / body-rate setpoints

    def __post_init__(self) -> None:
        _finite_or_nan(self.position_ned_m, "position")
        _finite_or_nan(self.velocity_ned_mps, "velocity")
        _finite_or_nan(self.acceleration_ned_mps2, "acceleration")
        _finite_or_nan((self.yaw_rad, self.yaw_rate_radps, self.thrust), "yaw/thrust")
        _finite_or_nan(self.body_rates_frd_radps, "body rates")
        if self.attitude_q is not None:
            _finite_or_nan(self.attitude_q, "attitude")
            nans = sum(math.isnan(v) for v in self.attitude_q)
            if nans not in (0, 4):  # all NaN: a degenerate quaternion (the motors stop)
                raise ValueError("attitude quaternion has NaN")
        if not (self.has_position or self.has_velocity or self.has_acceleration
                or self.attitude_q is not None or self.has_body_rates):
            raise ValueError("setpoint commands nothing")

    @property
    def has_position(self) -> bool:
        return not any(math.isnan(v) for v in self.position_ned_m[:2]) or \
            not math.isnan(self.position_ned_m[2])

    @property
    def has_velocity(self) -> bool:
        return not all(math.isnan(v) for v in self.velocity_ned_mps)

    @property
    def has_acceleration(self) -> bool:
        return not all(math.isnan(v) for v in self.acceleration_ned_mps2)

    @property
    def has_body_rates(self) -> bool:
        return not all(math.isnan(v) for v in self.body_rates_frd_radps)
