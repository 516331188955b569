"""What a pilot or a GCS feeds continuously: MANUAL_CONTROL → the vehicle's stick input (QGC
virtual joystick / joystick, MAVSDK manual_control, pymavlink); FOLLOW_TARGET → the target of
Follow Me (MAVSDK follow_me, QGC's Follow Me with the GCS's position); SET_VELOCITY_LIMITS → the
limits of Position Slow (vehicles/position_slow.py); LANDING_TARGET → Precision Land's target
(vehicles/nav_precland.py).

Source: PX4 ``mavlink_receiver.cpp`` handle_message_manual_control, handle_message_follow_target
(no target field: every FOLLOW_TARGET on the link counts; lat/lon 1e7 deg, alt AMSL m, vel NED;
passed on as PX4 publishes it: the vehicle's target estimator fuses only what is finite),
handle_message_set_velocity_limits (its target fields unread: every one on the link counts;
passed on as published, NaN where a limit is not set), handle_message_landing_target (its
time_usec through the link's timesync: gateway/mavlink/timesync.py).
Rules:
- Taken for ``target`` 0 or this system; other targets are counted and ignored.
- x → pitch, y → roll, r → yaw, each /1000 when within [-1000, 1000]; z (throttle) is
  [0, 1000] → [-1, 1] (500 = centred, what MAVSDK's 0.5 gives), each in float32 arithmetic as
  PX4 computes it (MANUAL_CONTROL's echo shows them). A field out of its range
  reads as 0 (centred): PX4's receiver range-checks each field since after v1.15 (v1.15.2
  passed them on unchecked, e.g. pitch 32.767) and leaves the zero-initialised setpoint's.
- Every valid message refreshes the input (its loss after COM_RC_LOSS_T is the vehicle's
  business: vehicles/manual_control.py); its source is the link (PX4's data_source
  SOURCE_MAVLINK_0 + the MAVLink instance), so a joystick on another link (QGC on the GCS link,
  a MAVSDK app on the API link) cannot take over while the first is fresh, and two senders on
  one link are one source, their samples interleaved, as in PX4. Never raises.
"""

from __future__ import annotations

from typing import Any

from gateway.mavlink.codec import f32
from gateway.mavlink.link import LinkContext
from gateway.mavlink.timesync import Timesync
from vehicles.manual_control import Sticks


def _axis(value: int) -> float:
    return f32(value / 1000.0) if -1000 <= value <= 1000 else 0.0  # x / 1000.f


def sticks_of(msg: Any) -> Sticks:
    """The float32 values PX4 computes: x / 1000.f, and the throttle (z / 1000.f) * 2.f - 1.f."""
    z = msg.z
    throttle = f32(f32(z / 1000.0) * 2.0 - 1.0) if 0 <= z <= 1000 else 0.0
    return Sticks(pitch=_axis(msg.x), roll=_axis(msg.y), throttle=throttle, yaw=_axis(msg.r),
                  buttons=int(msg.buttons))


class ManualControlService:
    """MANUAL_CONTROL, FOLLOW_TARGET, SET_VELOCITY_LIMITS and LANDING_TARGET (module docstring).
    Uses the vehicle, the link kind (the stick source), sysid and other_target."""

    def __init__(self, ctx: LinkContext, timesync: Timesync | None = None) -> None:
        """``timesync``: the link's (LANDING_TARGET's time_usec goes through it; None: none,
        the arrival stamps it)."""
        self.vehicle = ctx.vehicle
        self.kind = ctx.kind
        self.sysid = ctx.sysid
        self.other_target = ctx.other_target
        self.timesync = timesync

    def on_manual_control(self, msg: Any, now_s: float) -> None:
        if msg.target not in (0, self.sysid):
            self.other_target()
            return
        hook = getattr(self.vehicle, "manual_control", None)
        if hook is not None:  # the source: this link (PX4: one per MAVLink instance)
            hook(now_s, sticks_of(msg), self.kind.value)

    def on_follow_target(self, msg: Any, now_s: float) -> None:
        hook = getattr(self.vehicle, "set_follow_target", None)
        if hook is None:
            return
        # as PX4 publishes it: the target's estimator fuses only what is finite
        hook(now_s, msg.lat * 1e-7, msg.lon * 1e-7, float(msg.alt),
             tuple(float(v) for v in msg.vel[:3]))

    def on_landing_target(self, msg: Any, now_s: float) -> None:
        hook = getattr(self.vehicle, "landing_target", None)
        if hook is not None:  # stamped as MavlinkReceiver stamps it (_mavlink_timesync)
            ts = self.timesync
            stamp = None if ts is None else ts.sync_stamp(msg.time_usec, round(now_s * 1e6))
            hook(now_s, bool(msg.position_valid), int(msg.frame),
                 (float(msg.x), float(msg.y), float(msg.z)), stamp)

    def on_set_velocity_limits(self, msg: Any, now_s: float) -> None:
        hook = getattr(self.vehicle, "set_velocity_limits", None)
        if hook is not None:
            hook(msg.horizontal_speed_limit, msg.vertical_speed_limit, msg.yaw_rate_limit)
