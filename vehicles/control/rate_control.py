"""Pure library: body-rate PID -> normalized torque (PX4 RateControl).

Follows PX4 ``src/lib/rate_control/rate_control.cpp`` (formerly src/lib/controllib):
torque = K·(P·e + I·∫e − D·ω̇) + FF·ω_sp; the integrator is frozen while landed, does not grow into
a saturated allocator direction, is attenuated for large errors (i_factor with 400 deg/s) and is
limited to MC_*R_INT_LIM.

Rules: rates in FRD rad/s; output normalized torque per axis in [-1, 1] (what the mixer takes);
gains are PX4's MC_*RATE_* times MC_*RATE_K, unscaled (the mixer's normalization is chosen so
that they fit, see airframe.py); pure, ``update`` takes ``dt_s``. ``rate_pid`` is the one source:
``RateControl`` calls it in Python, the compiled inner loop (vehicles/inner_loop.py) inlines it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba.extending import register_jitable

from vehicles.types import Vec3

# PX4 filters the gyro derivative (IMU_DGYRO_CUTOFF, 30 Hz default; not in our param table).
D_TERM_CUTOFF_HZ = 30.0
_I_FACTOR_RATE_RADPS = math.radians(400.0)


@dataclass(frozen=True)
class RateControlGains:
    p: Vec3
    i: Vec3
    d: Vec3
    ff: Vec3
    int_lim: Vec3

    @staticmethod
    def from_params(params) -> RateControlGains:
        p = params
        k = (float(p["MC_ROLLRATE_K"]), float(p["MC_PITCHRATE_K"]), float(p["MC_YAWRATE_K"]))

        def axis(suffix: str) -> Vec3:
            vals = [float(p[f"MC_{a}RATE_{suffix}"]) for a in ("ROLL", "PITCH", "YAW")]
            return (k[0] * vals[0], k[1] * vals[1], k[2] * vals[2])

        return RateControlGains(
            p=axis("P"), i=axis("I"), d=axis("D"),
            ff=(float(p["MC_ROLLRATE_FF"]), float(p["MC_PITCHRATE_FF"]), float(p["MC_YAWRATE_FF"])),
            int_lim=(float(p["MC_RR_INT_LIM"]), float(p["MC_PR_INT_LIM"]), float(p["MC_YR_INT_LIM"])),
        )

    def vector(self) -> tuple[float, ...]:
        """The 15 numbers ``rate_pid`` takes: P, I, D, FF and integrator limit per axis."""
        return (*self.p, *self.i, *self.d, *self.ff, *self.int_lim)


# Layout of the controller's state vector (one row per vehicle in the compiled inner loop).
STATE_INTEGRAL = 0  # 3: integrator per axis
STATE_ACCEL = 3  # 3: filtered angular acceleration (D term)
STATE_PREV_RATE = 6  # 3: last measured rates
STATE_HAS_PREV = 9  # 1.0 once a rate has been seen
STATE_SIZE = 10


def d_filter_alpha(dt_s: float) -> float:
    """First-order low-pass coefficient of the D term at D_TERM_CUTOFF_HZ for step ``dt_s``."""
    return dt_s / (dt_s + 1.0 / (2.0 * math.pi * D_TERM_CUTOFF_HZ))


@register_jitable
def rate_pid(dt_s: float, alpha: float, rates: Vec3, rates_sp: Vec3, landed: bool,
             sat_pos: tuple[bool, bool, bool], sat_neg: tuple[bool, bool, bool], gains,
             state) -> Vec3:
    """One step of the rate PID (module docstring). ``gains``: the 15 numbers of
    ``RateControlGains.vector()``; ``state``: STATE_SIZE numbers, updated in place; ``alpha``:
    ``d_filter_alpha(dt_s)``. Plain Python from Python, compiled into vehicles/inner_loop.py."""
    if state[STATE_HAS_PREV] != 0.0:
        for i in range(3):
            raw = (rates[i] - state[STATE_PREV_RATE + i]) / dt_s
            state[STATE_ACCEL + i] += alpha * (raw - state[STATE_ACCEL + i])
    for i in range(3):
        state[STATE_PREV_RATE + i] = rates[i]
    state[STATE_HAS_PREV] = 1.0
    out0 = out1 = out2 = 0.0
    for i in range(3):
        sp = rates_sp[i]
        e = sp - rates[i]
        integ = state[STATE_INTEGRAL + i]
        u = gains[i] * e + integ - gains[6 + i] * state[STATE_ACCEL + i] + gains[9 + i] * sp
        u = -1.0 if u < -1.0 else (1.0 if u > 1.0 else u)
        if i == 0:
            out0 = u
        elif i == 1:
            out1 = u
        else:
            out2 = u
        if not landed:
            if sat_pos[i] and e > 0.0:
                e = 0.0
            if sat_neg[i] and e < 0.0:
                e = 0.0
            f = e / _I_FACTOR_RATE_RADPS
            i_factor = 1.0 - f * f
            if i_factor < 0.0:
                i_factor = 0.0
            v = integ + i_factor * gains[3 + i] * e * dt_s
            if math.isfinite(v):
                lim = gains[12 + i]
                state[STATE_INTEGRAL + i] = -lim if v < -lim else (lim if v > lim else v)
    return (out0, out1, out2)


class RateControl:
    """The rate PID with its own state (the World keeps one state row per vehicle instead)."""

    def __init__(self, gains: RateControlGains) -> None:
        self.gains = gains
        self._gains = np.array(gains.vector())
        self._state = np.zeros(STATE_SIZE)

    def reset(self) -> None:
        self._state[:] = 0.0

    @property
    def integral(self) -> Vec3:
        i = self._state
        return (float(i[STATE_INTEGRAL]), float(i[STATE_INTEGRAL + 1]), float(i[STATE_INTEGRAL + 2]))

    def update(self, dt_s: float, rates_frd_radps: Vec3, rates_sp_frd_radps: Vec3, landed: bool,
               saturation_positive: tuple[bool, bool, bool] = (False, False, False),
               saturation_negative: tuple[bool, bool, bool] = (False, False, False)) -> Vec3:
        u = rate_pid(dt_s, d_filter_alpha(dt_s), rates_frd_radps, rates_sp_frd_radps, landed,
                     saturation_positive, saturation_negative, self._gains, self._state)
        return (float(u[0]), float(u[1]), float(u[2]))
