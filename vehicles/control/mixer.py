"""Pure library: collective thrust + normalized torque -> motor commands (PX4 quad-X order), and
PX4's allocation matrix.

Follows PX4 v1.15 ``src/modules/control_allocator/ControlAllocation/
ControlAllocationSequentialDesaturation.cpp`` with airmode disabled (MC_AIRMODE 0,
``mixAirmodeDisabled`` and ``mixYaw``): thrust, roll and pitch are mixed; the thrust is only ever
*reduced* to desaturate; then the roll, then the pitch setpoint is moved to desaturate; then yaw
is added and desaturated against an upper limit raised by MINIMUM_YAW_MARGIN (15 %), which the
thrust then gives back (reduced only). Each desaturation is PX4's ``desaturateActuators``: move
along the axis' column by the sum of the most negative and most positive gain that unsaturates
one output (``computeDesaturationGain``, outputs moving less than 0.2 along it left out), then by
half the gain computed again. So roll and pitch win over yaw, and yaw keeps some authority at
full thrust. ``rotor_effectiveness`` and ``pseudo_inverse_mix`` are ActuatorEffectivenessRotors'
effectiveness and ControlAllocationPseudoInverse's normalized pseudo-inverse (the rows).

Rules:
- Input thrust is normalized collective thrust (0..1); torques are normalized (-1..1); the rows
  (per-rotor thrust change per unit torque, and the rotor's normalized effectiveness) come from
  the airframe geometry.
- Output per motor: the command ``u`` in 0..1 (PX4's actuator_motors, clipped to 0..1 as
  ControlAllocator does, then at least the idle command), linear in the allocated thrust as
  PX4's with its default THR_MDL_FAC 0. The plant turns it into a rotor speed through the ESC's
  range (vehicles/airframe.py), so thrust is quadratic in ``u``, as in PX4's gz SITL.
- Also reports per-axis saturation as MulticopterRateControl reads it from ControlAllocator's
  unallocated torque (setpoint minus what the clipped outputs allocate), so the rate integrator
  can stop winding up.
- ``mix_into`` is the one source: ``Mixer`` calls it in Python, the compiled inner loop
  (vehicles/inner_loop.py) inlines it.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba.extending import register_jitable

_FLT_EPSILON = 1.1920929e-07


def rotor_effectiveness(rotors) -> np.ndarray:
    """ActuatorEffectivenessRotors::computeEffectivenessMatrix for rotors whose thrust points up
    (axis (0, 0, -1) FRD, CA_ROTORn_CT 1): one (roll, pitch, yaw, thrust x, y, z) column per
    rotor given as (CA_ROTORn_PX, _PY, _KM), moment = CT·(position × axis) − CT·KM·axis."""
    return geometry_effectiveness([(px, py, 0.0, 0.0, 0.0, -1.0, 1.0, km) for px, py, km in rotors])


def geometry_effectiveness(rotors) -> np.ndarray:
    """ActuatorEffectivenessRotors::computeEffectivenessMatrix for rotors given as
    (CA_ROTORn_PX, _PY, _PZ, _AX, _AY, _AZ, _CT, _KM): the axis normalized (a rotor whose axis is
    shorter than FLT_EPSILON, or whose CT is below it, keeps a zero column), thrust = CT·axis,
    moment = CT·(position × axis) − CT·KM·axis; one (roll, pitch, yaw, thrust x, y, z) column
    per rotor."""
    effectiveness = np.zeros((6, len(rotors)))
    for i, (px, py, pz, ax, ay, az, ct, km) in enumerate(rotors):
        norm = math.sqrt(ax * ax + ay * ay + az * az)
        if not norm > _FLT_EPSILON or not abs(ct) >= _FLT_EPSILON:
            continue
        ax, ay, az = ax / norm, ay / norm, az / norm
        moment = (py * az - pz * ay, pz * ax - px * az, px * ay - py * ax)
        column = (ct * moment[0] - ct * km * ax, ct * moment[1] - ct * km * ay,
                  ct * moment[2] - ct * km * az, ct * ax, ct * ay, ct * az)
        # A non-finite parameter (NaN, or a product past the double range) leaves the rotor out
        # rather than poisoning the whole pseudo-inverse.
        if all(math.isfinite(c) for c in column):
            effectiveness[:, i] = column
    return effectiveness


def allocation_rows(rotors) -> np.ndarray:
    """The rows ``mix_into`` takes for rotors given as ``geometry_effectiveness``'s: PX4's
    normalized pseudo-inverse (``pseudo_inverse_mix``), its roll, pitch and yaw columns and the
    thrust column (collective thrust upwards: −thrust z), with the effectiveness the allocation
    inverts (``mixer_rows_with_effectiveness``). No rotors: no rows."""
    if not len(rotors):
        return np.zeros((0, ROW_SIZE))
    with np.errstate(all="ignore"):
        mix = pseudo_inverse_mix(geometry_effectiveness(rotors))
        rows = mixer_rows_with_effectiveness(mix[:, 0], mix[:, 1], mix[:, 2], -mix[:, 5])
    return np.where(np.isfinite(rows), rows, 0.0)


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


def mixer_rows_with_effectiveness(roll, pitch, yaw, thrust=None) -> np.ndarray:
    """The rows ``mix_into`` takes, one per rotor: its roll, pitch and yaw factors (the
    normalized allocation columns), then the normalized roll, pitch and yaw effectiveness of the
    rotor, which the allocation inverts: the first three rows of the pseudo-inverse of [roll,
    pitch, yaw, thrust] (PX4 ControlAllocation::getAllocatedControl uses the scaled
    effectiveness; the same matrix up to the entries the normalization rounds to 0); last the
    rotor's share of the collective thrust (``thrust``; None: 1 each, a flat multicopter's)."""
    thrust = np.ones(len(roll)) if thrust is None else np.asarray(thrust, dtype=float)
    mix = np.column_stack([roll, pitch, yaw, thrust]).astype(float)
    effectiveness = np.linalg.pinv(mix)[:3].T
    return np.ascontiguousarray(np.hstack([mix[:, :3], effectiveness, thrust[:, None]]))


# ControlAllocationSequentialDesaturation::MINIMUM_YAW_MARGIN: yaw may use this fraction of the
# output range above the top, which the thrust then gives back.
MINIMUM_YAW_MARGIN = 0.15
# computeDesaturationGain leaves out actuators that move less than this along the vector.
_WEAK_EFFECTIVENESS = 0.2
_THRUST = 6  # ``rows`` column: the rotor's share of the collective thrust
ROW_SIZE = 7  # numbers per row of ``mixer_rows_with_effectiveness``


@register_jitable
def _along(rows, i: int, col: int) -> float:
    return rows[i][col]


@register_jitable
def _desaturation_gain(out, rows, col: int, top: float) -> float:
    """computeDesaturationGain: the sum of the most negative and the most positive multiple of
    column ``col`` that would bring one saturated output back into 0..``top``."""
    k_min = 0.0
    k_max = 0.0
    for i in range(len(out)):
        v = _along(rows, i, col)
        if abs(v) < _WEAK_EFFECTIVENESS:
            continue
        if out[i] < 0.0:
            k = -out[i] / v
            k_min = min(k_min, k)
            k_max = max(k_max, k)
        if out[i] > top:
            k = (top - out[i]) / v
            k_min = min(k_min, k)
            k_max = max(k_max, k)
    return k_min + k_max


@register_jitable
def _desaturate(out, rows, col: int, top: float, reduce_only: bool) -> None:
    """desaturateActuators: move ``out`` along column ``col`` by the desaturation gain, then by
    half the gain computed again; ``reduce_only`` (the thrust with airmode disabled): nothing if
    the first gain would add."""
    gain = _desaturation_gain(out, rows, col, top)
    if reduce_only and gain > 0.0:
        return
    for i in range(len(out)):
        out[i] += gain * _along(rows, i, col)
    half = 0.5 * _desaturation_gain(out, rows, col, top)
    for i in range(len(out)):
        out[i] += half * _along(rows, i, col)


@register_jitable
def desaturate_into(thrust: float, roll: float, pitch: float, yaw: float, rows, out) -> None:
    """ControlAllocationSequentialDesaturation::allocate (CA_METHOD 1, and 2 on a multicopter):
    PX4's mixAirmodeDisabled and mixYaw (module docstring), unclipped, into ``out``."""
    n = len(rows)
    thrust = 0.0 if thrust < 0.0 else (1.0 if thrust > 1.0 else thrust)
    for i in range(n):
        out[i] = thrust * rows[i][_THRUST] + roll * rows[i][0] + pitch * rows[i][1]
    _desaturate(out, rows, _THRUST, 1.0, True)
    _desaturate(out, rows, 0, 1.0, False)
    _desaturate(out, rows, 1, 1.0, False)
    for i in range(n):
        out[i] += yaw * rows[i][2]
    _desaturate(out, rows, 2, 1.0 + MINIMUM_YAW_MARGIN, False)
    _desaturate(out, rows, _THRUST, 1.0, True)


@register_jitable
def pseudo_inverse_into(thrust: float, roll: float, pitch: float, yaw: float, rows, out) -> None:
    """ControlAllocationPseudoInverse::allocate (CA_METHOD 0): the allocation matrix times the
    setpoint, unclipped, into ``out``."""
    thrust = 0.0 if thrust < 0.0 else (1.0 if thrust > 1.0 else thrust)
    for i in range(len(rows)):
        out[i] = (thrust * rows[i][_THRUST] + roll * rows[i][0] + pitch * rows[i][1]
                  + yaw * rows[i][2])


@register_jitable
def clip_into(roll: float, pitch: float, yaw: float, rows, idle: float, out
              ) -> tuple[bool, bool, bool, bool, bool, bool]:
    """ControlAllocator after the allocation: ``out`` clipped to 0..1 (clipActuatorSetpoint),
    then at least ``idle``; returns MulticopterRateControl's saturation flags (roll+, pitch+,
    yaw+, roll−, pitch−, yaw−) from the unallocated torque (the setpoint less the torque the
    clipped outputs allocate, effectiveness · outputs), none while the torque is met
    (|unallocated|² < 1e-6)."""
    e_roll, e_pitch, e_yaw = roll, pitch, yaw
    for i in range(len(rows)):
        t = out[i]
        t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
        e_roll -= rows[i][3] * t
        e_pitch -= rows[i][4] * t
        e_yaw -= rows[i][5] * t
        out[i] = idle if t < idle else t
    if e_roll * e_roll + e_pitch * e_pitch + e_yaw * e_yaw < 1e-6:
        return (False, False, False, False, False, False)
    return (e_roll > _FLT_EPSILON, e_pitch > _FLT_EPSILON, e_yaw > _FLT_EPSILON,
            e_roll < -_FLT_EPSILON, e_pitch < -_FLT_EPSILON, e_yaw < -_FLT_EPSILON)


@register_jitable
def mix_into(thrust: float, roll: float, pitch: float, yaw: float, rows, idle: float, out
             ) -> tuple[bool, bool, bool, bool, bool, bool]:
    """The sequential desaturation and the clipping: normalized rotor thrusts into ``out``, at
    least ``idle``; returns the saturation flags (``clip_into``). ``rows``:
    ``mixer_rows_with_effectiveness``'s, one per rotor. Plain Python from Python, compiled into
    vehicles/inner_loop.py."""
    desaturate_into(thrust, roll, pitch, yaw, rows, out)
    return clip_into(roll, pitch, yaw, rows, idle, out)


class Mixer:
    def __init__(self, rows: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]],
                 idle_thrust_norm: float = 0.0) -> None:
        """``rows``: the roll, pitch and yaw columns (``Airframe.mixer_rows``)."""
        self.rows = mixer_rows_with_effectiveness(*rows)
        self.idle_thrust_norm = idle_thrust_norm

    def mix(self, thrust: float, torque: tuple[float, float, float]) -> MixerOutput:
        out = np.zeros(len(self.rows))
        sat = mix_into(thrust, torque[0], torque[1], torque[2], self.rows, self.idle_thrust_norm,
                       out)
        return MixerOutput(tuple(float(t) for t in out),
                           (bool(sat[0]), bool(sat[1]), bool(sat[2])),
                           (bool(sat[3]), bool(sat[4]), bool(sat[5])))
