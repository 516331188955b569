"""Pure library: collective thrust + normalized torque -> motor commands (PX4 quad-X order).

Follows the idea of PX4 ``src/modules/control_allocator/ControlAllocation/
ControlAllocationSequentialDesaturation.cpp`` with airmode disabled (``mixAirmodeDisabled``):
roll/pitch first, thrust may only be *reduced* to make room at the top, roll/pitch are scaled down
if a motor would go below zero, then yaw is added with whatever headroom is left. So roll and
pitch always win over yaw.

Rules:
- Input thrust is normalized collective thrust (0..1); torques are normalized (-1..1); the rows
  (per-rotor thrust change per unit torque) come from the airframe geometry.
- Output per motor: the command ``u`` in 0..1 (PX4's actuator_motors), linear in the allocated
  thrust as PX4's with its default THR_MDL_FAC 0. The plant turns it into a rotor speed through
  the ESC's range (vehicles/airframe.py), so thrust is quadratic in ``u``, as in PX4's gz SITL.
- Also reports per-axis saturation so the rate integrator can stop winding up.
- ``mix_into`` is the one source: ``Mixer`` calls it in Python, the compiled inner loop
  (vehicles/inner_loop.py) inlines it.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba.extending import register_jitable


class MixerOutput(NamedTuple):
    motor_u: tuple[float, ...]  # 0..1 commands, PX4 motor order
    saturation_positive: tuple[bool, bool, bool]
    saturation_negative: tuple[bool, bool, bool]


@register_jitable
def mix_into(thrust: float, roll: float, pitch: float, yaw: float, rows, idle: float, out
             ) -> tuple[bool, bool, bool, bool, bool, bool]:
    """Sequential desaturation (module docstring): normalized rotor thrusts into ``out``;
    returns the saturation flags (roll+, pitch+, yaw+, roll−, pitch−, yaw−). ``rows``: one
    (roll, pitch, yaw) row per rotor. Plain Python from Python, compiled into
    vehicles/inner_loop.py."""
    n = len(rows)
    thrust = 0.0 if thrust < 0.0 else (1.0 if thrust > 1.0 else thrust)
    high = -math.inf
    low = math.inf
    for i in range(n):
        r = roll * rows[i][0] + pitch * rows[i][1]
        out[i] = r
        if r > high:
            high = r
        if r < low:
            low = r
    sp0 = sp1 = sp2 = sn0 = sn1 = sn2 = False
    over = thrust + high - 1.0
    if over > 0.0:
        thrust = max(thrust - over, 0.0)
    if thrust + low < 0.0 or thrust + high > 1.0:
        span_low = -low if low < 0.0 else 0.0
        k = 1.0
        if span_low > 0.0:
            k = min(k, thrust / span_low)
        if high > 0.0 and thrust + high > 1.0:
            k = min(k, (1.0 - thrust) / high)
        for i in range(n):
            out[i] = out[i] * k
        sp0, sp1 = roll > 0.0, pitch > 0.0
        sn0, sn1 = roll < 0.0, pitch < 0.0
    s = 1.0
    if yaw != 0.0:
        for i in range(n):
            y = yaw * rows[i][2]
            base = thrust + out[i]
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
                sp2 = True
            else:
                sn2 = True
    sy = s * yaw
    for i in range(n):
        t = thrust + out[i] + sy * rows[i][2]
        out[i] = idle if t < idle else (1.0 if t > 1.0 else t)
    return (sp0, sp1, sp2, sn0, sn1, sn2)


class Mixer:
    def __init__(self, rows: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]],
                 idle_thrust_norm: float = 0.0) -> None:
        self.rows = np.array(rows, dtype=float).T.copy()  # one (roll, pitch, yaw) row per rotor
        self.idle_thrust_norm = idle_thrust_norm

    def mix(self, thrust: float, torque: tuple[float, float, float]) -> MixerOutput:
        out = np.zeros(len(self.rows))
        sat = mix_into(thrust, torque[0], torque[1], torque[2], self.rows, self.idle_thrust_norm,
                       out)
        return MixerOutput(tuple(float(t) for t in out), sat[:3], sat[3:])
