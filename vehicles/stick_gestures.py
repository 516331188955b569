"""Stick gestures: arming and disarming with the sticks alone (PX4 ``modules/manual_control``,
ManualControl::processStickArming).

- Arm: the left stick to the lower right (throttle below -0.8, yaw above 0.9) with the right
  stick centred (roll and pitch within 0.1), held COM_RC_ARM_HYST milliseconds; disarm: the same
  to the lower left (yaw below -0.9). Each asks once per hold, when its hysteresis turns true.
- MAN_ARM_GESTURE 0 keeps the hystereses running and asks nothing.
- Evaluated at each sample of the stick input that has control; input lost (older than
  COM_RC_LOSS_T) resets both, as PX4 does while its selector has no valid input. PX4 also runs
  every 200 ms without a sample, which changes nothing for inputs at 5 Hz or more.
- The commander answers the request (commander.py: Commander::arm / disarm with reason RC).

PX4's kill gesture (MAN_KILL_GEST_T, off by default) and its RC switches are not modelled.
"""

from __future__ import annotations

from vehicles.hysteresis import Hysteresis
from vehicles.mode_table import ArmEvent

CENTRED = 0.1  # |pitch|, |roll| below this: the right stick is centred
THROTTLE_DOWN = -0.8
YAW_OUT = 0.9


class StickGestures:
    def __init__(self, params) -> None:
        self._params = params
        self._version = -1
        self._enabled = True
        self._arm = Hysteresis(False, 1.0)
        self._disarm = Hysteresis(False, 1.0)

    def reset(self, now_s: float) -> None:
        """No valid input: both gestures start again."""
        self._arm.update(now_s, False)
        self._disarm.update(now_s, False)

    def update(self, now_s: float, pitch: float, roll: float, throttle: float, yaw: float
               ) -> ArmEvent | None:
        """A valid sample (manual_control_setpoint ranges): the request it completes, if any."""
        p = self._params
        if p.version != self._version:
            self._version = p.version
            self._arm.delay_s = self._disarm.delay_s = int(p["COM_RC_ARM_HYST"]) * 1e-3
            self._enabled = bool(int(p["MAN_ARM_GESTURE"]))
        centred = abs(pitch) < CENTRED and abs(roll) < CENTRED
        low = throttle < THROTTLE_DOWN
        was_arm, was_disarm = self._arm.state, self._disarm.state
        arm = self._arm.update(now_s, low and yaw > YAW_OUT and centred)
        disarm = self._disarm.update(now_s, low and yaw < -YAW_OUT and centred)
        if not self._enabled:
            return None
        if arm and not was_arm:
            return ArmEvent.ARM
        if disarm and not was_disarm:
            return ArmEvent.DISARM
        return None
