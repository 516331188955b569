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


def rotor_effectiveness(rotors) -> np.ndarray:
    """ActuatorEffectivenessRotors::computeEffectivenessMatrix for rotors whose thrust points up
    (axis (0, 0, -1) FRD, CA_ROTORn_CT 1): one (roll, pitch, yaw, thrust x, y, z) column per
    rotor given as (CA_ROTORn_PX, _PY, _KM), moment = CT·(position × axis) − CT·KM·axis."""
    effectiveness = np.zeros((6, len(rotors)))
    for i, (px, py, km) in enumerate(rotors):
        effectiveness[:, i] = (-py, px, km, 0.0, 0.0, -1.0)
    return effectiveness


def pseudo_inverse_mix(effectiveness: np.ndarray, normalize: bool = True) -> np.ndarray:
    """ControlAllocationPseudoInverse::updatePseudoInverse: the allocation matrix (one row per
    actuator, one column per axis: roll, pitch, yaw, thrust x, y, z) as the pseudo-inverse of
    ``effectiveness`` (6 × actuators). ``normalize`` (a multicopter's normalize_rpy with the
    scale updated): roll and pitch columns divided by the larger of sqrt(|column|² / (non-zero
    entries / 2)), yaw by its largest entry, the thrust columns by the mean length of the
    non-zero per-actuator thrust rows; a scale that is not positive leaves its columns alone.
    Entries below 1e-3 become 0 either way."""
    mix = np.linalg.pinv(np.asarray(effectiveness, dtype=float))
    if normalize:
        scales = []
        for axis in (0, 1):
            nonzero = int((np.abs(mix[:, axis]) > 1e-3).sum())
            column = mix[:, axis]
            scales.append(math.sqrt(float(column @ column) / (nonzero / 2.0)) if nonzero else 1.0)
        rp_scale = max(scales)
        # PX4's matrix has 16 actuator rows, the unused ones zero: the largest entry is >= 0
        yaw_scale = float(mix[:, 2].max(initial=0.0))
        thrust_rows = np.linalg.norm(mix[:, 3:6], axis=1)
        nonzero_thrust = thrust_rows > np.finfo(np.float32).eps
        thrust_scale = float(thrust_rows[nonzero_thrust].mean()) if nonzero_thrust.any() else 1.0
        eps = np.finfo(np.float32).eps
        if rp_scale > eps:
            mix[:, 0:2] /= rp_scale
        if yaw_scale > eps:
            mix[:, 2] /= yaw_scale
        if thrust_scale > eps:
            mix[:, 3:6] /= thrust_scale
    mix[np.abs(mix) < 1e-3] = 0.0
    return mix


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
