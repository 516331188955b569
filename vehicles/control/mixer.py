"""Pure library: collective thrust + normalized torque -> motor commands (PX4 quad-X order).

Follows the idea of PX4 ``src/modules/control_allocator/ControlAllocation/
ControlAllocationSequentialDesaturation.cpp`` with airmode disabled (``mixAirmodeDisabled``):
roll/pitch first, thrust may only be *reduced* to make room at the top, roll/pitch are scaled down
if a motor would go below zero, then yaw is added with whatever headroom is left. So roll and
pitch always win over yaw.

Rules:
- Input thrust is normalized collective thrust (0..1); torques are normalized (-1..1); the rows
  (per-rotor thrust change per unit torque) come from the airframe geometry.
- Output per motor: the command ``u`` in 0..1 that the plant turns into rotor speed
  ``u * max_rotor_speed``. Since rotor thrust is k·ω², ``u = sqrt(normalized rotor thrust)`` makes
  the plant linear in thrust.
- Also reports per-axis saturation so the rate integrator can stop winding up.
"""

from __future__ import annotations

import math
from typing import NamedTuple


class MixerOutput(NamedTuple):
    motor_u: tuple[float, ...]  # 0..1 commands, PX4 motor order
    rotor_thrust_norm: tuple[float, ...]  # 0..1 per rotor
    saturation_positive: tuple[bool, bool, bool]
    saturation_negative: tuple[bool, bool, bool]


_NO_SATURATION = (False, False, False)


class Mixer:
    def __init__(self, rows: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]],
                 idle_thrust_norm: float = 0.0) -> None:
        self._roll, self._pitch, self._yaw = rows
        self._n = len(self._roll)
        # Per rotor (roll row, pitch row, yaw row): one tuple to unpack in the 250 Hz loop.
        self._rows = tuple(zip(self._roll, self._pitch, self._yaw))
        self.idle_thrust_norm = idle_thrust_norm

    def mix(self, thrust: float, torque: tuple[float, float, float]) -> MixerOutput:
        roll, pitch, yaw = torque
        thrust = 0.0 if thrust < 0.0 else (1.0 if thrust > 1.0 else thrust)
        rows = self._rows
        rp = [roll * r + pitch * p for r, p, _ in rows]
        sat_pos = sat_neg = _NO_SATURATION
        # Airmode disabled: only reduce thrust to unsaturate the top.
        high = max(rp)
        over = thrust + high - 1.0
        if over > 0.0:
            thrust = max(thrust - over, 0.0)
        low = min(rp)
        if thrust + low < 0.0 or thrust + high > 1.0:
            # Scale roll/pitch down so every motor stays within [0, 1].
            span_low = -low if low < 0.0 else 0.0
            k = 1.0
            if span_low > 0.0:
                k = min(k, thrust / span_low)
            if high > 0.0 and thrust + high > 1.0:
                k = min(k, (1.0 - thrust) / high)
            rp = [r * k for r in rp]
            sat_pos = (roll > 0.0, pitch > 0.0, False)
            sat_neg = (roll < 0.0, pitch < 0.0, False)
        # Yaw with the remaining headroom.
        s = 1.0
        if yaw != 0.0:
            for (_, _, yr), r in zip(rows, rp):
                y = yaw * yr
                base = thrust + r
                if y > 1e-9:
                    room = 1.0 - base
                    r = (room if room > 0.0 else 0.0) / y
                    if r < s:
                        s = r
                elif y < -1e-9:
                    r = (base if base > 0.0 else 0.0) / -y
                    if r < s:
                        s = r
            if s < 1.0:
                if yaw > 0.0:
                    sat_pos = (sat_pos[0], sat_pos[1], True)
                else:
                    sat_neg = (sat_neg[0], sat_neg[1], True)
        lo = self.idle_thrust_norm
        sy = s * yaw
        out = []
        for (_, _, yr), r in zip(rows, rp):
            t = thrust + r + sy * yr
            out.append(lo if t < lo else (1.0 if t > 1.0 else t))
        sqrt = math.sqrt
        return MixerOutput(tuple([sqrt(t) for t in out]), tuple(out), sat_pos, sat_neg)
