"""Offboard: the latest external setpoint, its freshness, and how it maps onto the controllers.

After PX4 ``mavlink_receiver.cpp`` (every valid setpoint refreshes offboard_control_mode, in any
mode), ``commander/HealthAndArmingChecks/checks/offboardCheck.cpp`` (the mode is available while a
setpoint is younger than COM_OF_LOSS_T) and ``mc_pos_control`` (offboard trajectory setpoints go
straight to PositionControl, no smoothing; velocity and tilt limits still apply).

Rules:
- ``OffboardSetpoint`` arrives in local NED (the gateway rotated body frames). NaN = not commanded.
- Priority as PX4's control-mode flags: position / velocity / acceleration setpoints use the
  position controller (acceleration alone becomes a thrust vector directly); otherwise an attitude
  quaternion + thrust bypasses position control; otherwise body rates + thrust bypass attitude
  control too.
- Yaw: ``yaw_rad`` if given, else the present heading (PX4's PositionControl: a NaN yaw
  setpoint is the current yaw), with ``yaw_rate_radps`` as the yaw-rate feed-forward.
- Pure: time is an argument; no physics engine.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from vehicles.control.position_control import limit_tilt
from vehicles.plan_types import OffboardSetpoint
from vehicles.types import GRAVITY_MPS2, EstimatorReset, Vec3


@dataclass(frozen=True)
class OffboardCommand:
    """What the autopilot should feed its controllers this tick (exactly one kind is set)."""

    kind: str  # "position" (pos/vel/acc through PositionControl), "acceleration", "attitude", "rates"
    setpoint: OffboardSetpoint
    yaw_rad: float


def acceleration_to_thrust(acc_ned: Vec3, hover_thrust: float, tilt_max_rad: float) -> Vec3:
    """PositionControl::_accelerationControl for a pure acceleration setpoint."""
    bz = (-acc_ned[0], -acc_ned[1], GRAVITY_MPS2)
    n = math.sqrt(bz[0] ** 2 + bz[1] ** 2 + bz[2] ** 2)
    bz = limit_tilt((bz[0] / n, bz[1] / n, bz[2] / n), tilt_max_rad)
    collective = (acc_ned[2] * (hover_thrust / GRAVITY_MPS2) - hover_thrust) / bz[2]
    collective = min(collective, 0.0)
    return (bz[0] * collective, bz[1] * collective, bz[2] * collective)


class Offboard:
    def __init__(self) -> None:
        self.setpoint: OffboardSetpoint | None = None
        self.received_s = -math.inf

    def set(self, now_s: float, setpoint: OffboardSetpoint) -> None:
        self.setpoint = setpoint
        self.received_s = now_s

    def fresh(self, now_s: float, timeout_s: float) -> bool:
        return self.setpoint is not None and now_s - self.received_s <= timeout_s

    def shift(self, now_s: float, r: EstimatorReset) -> None:
        """mc_pos_control's adjustSetpointForEKFResets on the setpoint it holds, when older than
        the estimate (not received at ``now_s``): the position and the velocity move by the
        estimator's changes; a NaN component stays NaN."""
        sp = self.setpoint
        if sp is None or self.received_s >= now_s:
            return
        (px, py, pz), (vx, vy, vz) = sp.position_ned_m, sp.velocity_ned_mps
        if r.xy:
            px, py = px + r.delta_xy[0], py + r.delta_xy[1]
        if r.vxy:
            vx, vy = vx + r.delta_vxy[0], vy + r.delta_vxy[1]
        if r.vz:
            vz += r.delta_vz
        if r.z:
            pz += r.delta_z
        self.setpoint = replace(sp, position_ned_m=(px, py, pz), velocity_ned_mps=(vx, vy, vz))

    def on_entry(self, yaw_rad: float) -> None:
        """Entering Offboard (nothing to keep: the yaw setpoint is the setpoint's or the present
        heading's at every tick)."""

    def command(self, now_s: float, yaw_rad: float) -> OffboardCommand | None:
        """This tick's command; ``yaw_rad``: the present heading, the yaw setpoint when the
        setpoint gives none (PositionControl::update: a NaN ``_yaw_sp`` is the current yaw, a
        yaw rate only its feed-forward, so no yaw error ever builds up)."""
        sp = self.setpoint
        if sp is None:
            return None
        yaw = sp.yaw_rad if not math.isnan(sp.yaw_rad) else yaw_rad
        if sp.has_position or sp.has_velocity:
            kind = "position"
        elif sp.has_acceleration:
            kind = "acceleration"
        elif sp.attitude_q is not None:
            kind = "attitude"
        else:
            kind = "rates"
        return OffboardCommand(kind, sp, yaw)
