"""MANUAL_CONTROL → the vehicle's stick input (QGC virtual joystick / joystick, MAVSDK
manual_control, pymavlink).

Source: PX4 ``mavlink_receiver.cpp`` handle_message_manual_control.
Rules:
- Taken for ``target`` 0 or this system; other targets are counted and ignored.
- x → pitch, y → roll, r → yaw, each /1000 when within [-1000, 1000]; z (throttle) is
  [0, 1000] → [-1, 1] (500 = centred, what MAVSDK's 0.5 gives). A field out of its range
  reads as 0 (centred), as PX4's zero-initialised setpoint does.
- Every valid message refreshes the input (its loss after COM_RC_LOSS_T is the vehicle's
  business: vehicles/manual_control.py). Never raises.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from vehicles.manual_control import Sticks

if TYPE_CHECKING:
    from gateway.mavlink.session import Session


def _axis(value: int) -> float:
    return value / 1000.0 if -1000 <= value <= 1000 else 0.0


def sticks_of(msg: Any) -> Sticks:
    z = msg.z
    throttle = z / 500.0 - 1.0 if 0 <= z <= 1000 else 0.0
    return Sticks(pitch=_axis(msg.x), roll=_axis(msg.y), throttle=throttle, yaw=_axis(msg.r),
                  buttons=int(msg.buttons))


class ManualControlService:
    def __init__(self, session: Session) -> None:
        self.s = session

    def on_manual_control(self, msg: Any, now_s: float) -> None:
        if msg.target not in (0, self.s.sysid):
            self.s.stats.rx_other_target += 1
            return
        hook = getattr(self.s.vehicle, "manual_control", None)
        if hook is not None:
            hook(now_s, sticks_of(msg))
