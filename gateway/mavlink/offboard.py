"""Offboard setpoints: SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT, SET_ATTITUDE_TARGET → vehicle.

Source: PX4 mavlink_receiver.cpp handle_message_set_position_target_local_ned,
_global_int, _set_attitude_target; MAVSDK offboard_impl.cpp masks.
Rules:
- Handled only for target (own|0, 1|0); anything else is counted as another target.
- A type_mask bit set means "ignore". Position / velocity / acceleration are taken as groups: one
  ignore bit in a group ignores the group (PX4). Inside a used group NaN = not commanded.
- Every message becomes one ``OffboardSetpoint`` in the vehicle's local NED frame and goes to
  ``vehicle.set_offboard_setpoint(now_s, sp)`` in any mode (it refreshes the offboard stream; the
  vehicle uses it only in OFFBOARD).
- LOCAL_NED (1) as is. BODY_NED (8): position is ignored, velocity rotated by the current yaw
  only, acceleration by the full attitude; yaw / yaw_rate are absolute as in PX4. Other frames
  → critical text "… coordinate frame N unsupported", dropped. FORCE_SET with acceleration →
  dropped (PX4 has no force setpoints).
- GLOBAL_INT frames: 5 (and 0) AMSL, 6 (and 3) relative to home, 11 (and 10) terrain, taken as
  relative to home (flat ground at home altitude). Projected with ``vehicle.origin``.
- SET_ATTITUDE_TARGET: attitude unless ATTITUDE_IGNORE (128); body rates per axis unless their
  ignore bit; thrust unless THROTTLE_IGNORE (64). THRUST_BODY_SET (32) needs the thrust_body
  extension, which pymavlink 2.4.50 does not decode → thrust not commanded.
- A message that is ±inf anywhere, commands nothing, or has a degenerate quaternion is dropped
  and counted (``offboard_dropped``); it never raises.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.link import LinkContext, Say
from vehicles.plan_types import NAN3, OffboardSetpoint, Vec3
from vehicles.types import GeoPoint, Severity

NAN = math.nan

FRAME_LOCAL_NED = 1
FRAME_BODY_NED = 8
GLOBAL_AMSL_FRAMES = frozenset({0, 5})  # GLOBAL, GLOBAL_INT
GLOBAL_RELATIVE_FRAMES = frozenset({3, 6})  # GLOBAL_RELATIVE_ALT(_INT)
GLOBAL_TERRAIN_FRAMES = frozenset({10, 11})  # GLOBAL_TERRAIN_ALT(_INT)

# POSITION_TARGET_TYPEMASK
POSITION_IGNORE = 0x007
VELOCITY_IGNORE = 0x038
ACCELERATION_IGNORE = 0x1C0
FORCE_SET = 0x200
YAW_IGNORE = 0x400
YAW_RATE_IGNORE = 0x800
# ATTITUDE_TARGET_TYPEMASK
BODY_RATE_IGNORE = (0x01, 0x02, 0x04)  # roll, pitch, yaw
THRUST_BODY_SET = 0x20
THROTTLE_IGNORE = 0x40
ATTITUDE_IGNORE = 0x80

TEXT_INTERVAL_S = 1.0  # at most one "unsupported frame" text per second per link


def _finite(*values: float) -> None:
    if any(math.isinf(v) for v in values):
        raise ValueError("infinite value in setpoint")


def _yaw_fields(mask: int, yaw: float, yaw_rate: float) -> tuple[float, float]:
    _finite(yaw, yaw_rate)
    return (NAN if mask & YAW_IGNORE else yaw), (NAN if mask & YAW_RATE_IGNORE else yaw_rate)


def _rotate_yaw(v: Vec3, yaw: float) -> Vec3:
    """Body (forward, right, down) → NED by heading only; NaN in x or y drops the pair."""
    c, s = math.cos(yaw), math.sin(yaw)
    n, e = c * v[0] - s * v[1], s * v[0] + c * v[1]
    return n, e, v[2]


def _rotate_q(v: Vec3, q: Any) -> Vec3:
    """FRD → NED with the full attitude quaternion (w, x, y, z)."""
    w, x, y, z = (float(c) for c in q)
    vx, vy, vz = v
    return (
        (1 - 2 * (y * y + z * z)) * vx + 2 * (x * y - w * z) * vy + 2 * (x * z + w * y) * vz,
        2 * (x * y + w * z) * vx + (1 - 2 * (x * x + z * z)) * vy + 2 * (y * z - w * x) * vz,
        2 * (x * z - w * y) * vx + 2 * (y * z + w * x) * vy + (1 - 2 * (x * x + y * y)) * vz,
    )


def local_setpoint(frame: int, mask: int, pos: Vec3, vel: Vec3, acc: Vec3, yaw: float,
                   yaw_rate: float, attitude_q: Any) -> OffboardSetpoint:
    """SET_POSITION_TARGET_LOCAL_NED fields → setpoint (raises ValueError when unusable)."""
    _finite(*pos, *vel, *acc)
    use_acc = not mask & ACCELERATION_IGNORE
    if use_acc and mask & FORCE_SET:
        raise ValueError("force setpoints are not supported")
    position = pos if not mask & POSITION_IGNORE else NAN3
    velocity = vel if not mask & VELOCITY_IGNORE else NAN3
    acceleration = acc if use_acc else NAN3
    if frame == FRAME_BODY_NED:
        position = NAN3
        velocity = _rotate_yaw(velocity, _heading(attitude_q))
        acceleration = _rotate_q(acceleration, attitude_q)
    elif frame != FRAME_LOCAL_NED:
        raise ValueError(f"frame {frame}")
    yaw_sp, yaw_rate_sp = _yaw_fields(mask, yaw, yaw_rate)
    return OffboardSetpoint(position_ned_m=position, velocity_ned_mps=velocity,
                            acceleration_ned_mps2=acceleration, yaw_rad=yaw_sp,
                            yaw_rate_radps=yaw_rate_sp)


def _heading(q: Any) -> float:
    w, x, y, z = (float(c) for c in q)
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def global_setpoint(frame: int, mask: int, lat_int: int, lon_int: int, alt_m: float, vel: Vec3,
                    acc: Vec3, yaw: float, yaw_rate: float, origin: GeoPoint,
                    home_alt_m: float) -> OffboardSetpoint:
    """SET_POSITION_TARGET_GLOBAL_INT fields → local-NED setpoint (raises ValueError)."""
    _finite(alt_m, *vel, *acc)
    if frame in GLOBAL_AMSL_FRAMES:
        alt_amsl = alt_m
    elif frame in GLOBAL_RELATIVE_FRAMES or frame in GLOBAL_TERRAIN_FRAMES:
        alt_amsl = alt_m + home_alt_m
    else:
        raise ValueError(f"frame {frame}")
    position = NAN3
    if not mask & POSITION_IGNORE:
        position = origin.ned_of(GeoPoint(lat_int * 1e-7, lon_int * 1e-7, alt_amsl))
    if mask & FORCE_SET and not mask & ACCELERATION_IGNORE:
        raise ValueError("force setpoints are not supported")
    yaw_sp, yaw_rate_sp = _yaw_fields(mask, yaw, yaw_rate)
    return OffboardSetpoint(
        position_ned_m=position,
        velocity_ned_mps=vel if not mask & VELOCITY_IGNORE else NAN3,
        acceleration_ned_mps2=acc if not mask & ACCELERATION_IGNORE else NAN3,
        yaw_rad=yaw_sp, yaw_rate_radps=yaw_rate_sp)


def attitude_setpoint(mask: int, q: Any, rates: Vec3, thrust: float) -> OffboardSetpoint:
    """SET_ATTITUDE_TARGET fields → setpoint (raises ValueError)."""
    _finite(*rates, thrust)
    attitude = None
    if not mask & ATTITUDE_IGNORE:
        # PX4 takes any quaternion (mavlink_receiver.cpp: the offboard heartbeat is published
        # and AttitudeControl normalizes q_d): a zero, NaN or infinite one normalizes to NaN, and
        # the non-finite motor commands it gives stop the motors (MixingOutput).
        norm = math.sqrt(sum(float(c) * float(c) for c in q))
        attitude = tuple(float(c) / norm for c in q) if 0.0 < norm < math.inf \
            else (NAN, NAN, NAN, NAN)
    body_rates = tuple(NAN if mask & bit else r for r, bit in zip(rates, BODY_RATE_IGNORE))
    if attitude is None and mask & (BODY_RATE_IGNORE[0] | BODY_RATE_IGNORE[1]):
        # mavlink_receiver.cpp: body rates need roll and pitch (a yaw rate alone is none)
        raise ValueError("no attitude and no roll and pitch rates")
    use_thrust = not mask & (THROTTLE_IGNORE | THRUST_BODY_SET) and not math.isnan(thrust)
    return OffboardSetpoint(attitude_q=attitude, body_rates_frd_radps=body_rates,  # type: ignore[arg-type]
                            thrust=min(1.0, max(0.0, thrust)) if use_thrust else NAN)


class OffboardService:
    """Uses the vehicle, sysid, the stats (setpoints handed over or dropped), other_target,
    and ``say`` (STATUSTEXT on this link) for the unsupported-frame text."""

    def __init__(self, ctx: LinkContext, say: Say) -> None:
        self.vehicle = ctx.vehicle
        self.sysid = ctx.sysid
        self.stats = ctx.stats
        self.other_target = ctx.other_target
        self.say = say
        self._next_text_s = -math.inf

    def _for_us(self, msg: Any) -> bool:
        if msg.target_system in (0, self.sysid) and msg.target_component in (0, 1):
            return True
        self.other_target()
        return False

    def _deliver(self, now_s: float, build: Callable[..., OffboardSetpoint], *args: Any) -> None:
        setter = getattr(self.vehicle, "set_offboard_setpoint", None)
        sp: OffboardSetpoint | None
        try:
            sp = build(*args)
        except ValueError:
            sp = None
        if sp is None or setter is None:
            self.stats.offboard_dropped += 1
            return
        self.stats.offboard_setpoints += 1
        setter(now_s, sp)

    def _bad_frame(self, now_s: float, what: str, frame: int) -> None:
        self.stats.offboard_dropped += 1
        if now_s >= self._next_text_s:
            self._next_text_s = now_s + TEXT_INTERVAL_S
            self.say(now_s, Severity.CRITICAL, f"{what} coordinate frame {frame} unsupported")

    def on_local_ned(self, msg: M.MAVLink_set_position_target_local_ned_message,
                     now_s: float) -> None:
        if not self._for_us(msg):
            return
        if msg.coordinate_frame not in (FRAME_LOCAL_NED, FRAME_BODY_NED):
            self._bad_frame(now_s, "SET_POSITION_TARGET_LOCAL_NED", msg.coordinate_frame)
            return
        self._deliver(now_s, local_setpoint, msg.coordinate_frame, msg.type_mask,
                      (msg.x, msg.y, msg.z), (msg.vx, msg.vy, msg.vz), (msg.afx, msg.afy, msg.afz),
                      msg.yaw, msg.yaw_rate, self.vehicle.state.attitude_q)

    def on_global_int(self, msg: M.MAVLink_set_position_target_global_int_message,
                      now_s: float) -> None:
        if not self._for_us(msg):
            return
        frame = msg.coordinate_frame
        if frame not in GLOBAL_AMSL_FRAMES | GLOBAL_RELATIVE_FRAMES | GLOBAL_TERRAIN_FRAMES:
            self._bad_frame(now_s, "SET_POSITION_TARGET_GLOBAL_INT", frame)
            return
        v = self.vehicle
        home = v.status.home
        home_alt = home.geo.alt_amsl_m if home is not None else v.origin.alt_amsl_m
        self._deliver(now_s, global_setpoint, frame, msg.type_mask, msg.lat_int, msg.lon_int,
                      msg.alt, (msg.vx, msg.vy, msg.vz), (msg.afx, msg.afy, msg.afz), msg.yaw,
                      msg.yaw_rate, v.origin, home_alt)

    def on_attitude_target(self, msg: M.MAVLink_set_attitude_target_message,
                           now_s: float) -> None:
        if not self._for_us(msg):
            return
        self._deliver(now_s, attitude_setpoint, msg.type_mask, tuple(msg.q),
                      (msg.body_roll_rate, msg.body_pitch_rate, msg.body_yaw_rate), msg.thrust)
