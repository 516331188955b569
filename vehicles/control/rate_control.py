"""Pure library: body-rate PID -> normalized torque (PX4 RateControl).

Follows PX4 ``src/lib/rate_control/rate_control.cpp`` (formerly src/lib/controllib):
torque = K·(P·e + I·∫e − D·ω̇) + FF·ω_sp; the integrator is frozen while landed, does not grow into
a saturated allocator direction, is attenuated for large errors (i_factor with 400 deg/s) and is
limited to MC_*R_INT_LIM.

Rules: rates in FRD rad/s; output normalized torque per axis in [-1, 1] (what the mixer takes);
gains are PX4's MC_*RATE_* times MC_*RATE_K, unscaled (the mixer's normalization is chosen so
that they fit, see airframe.py); pure, ``update`` takes ``dt_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

Vec3 = tuple[float, float, float]

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


class RateControl:
    def __init__(self, gains: RateControlGains) -> None:
        self.gains = gains
        self._int = [0.0, 0.0, 0.0]
        self._prev_rate: Vec3 | None = None
        self._accel = [0.0, 0.0, 0.0]
        # Per axis (P, I, D, FF, integrator limit), unpacked once per axis in the 250 Hz loop.
        self._axes = tuple(zip(gains.p, gains.i, gains.d, gains.ff, gains.int_lim))
        self._alpha_dt = math.nan  # the derivative filter's alpha for _alpha_dt
        self._alpha = 0.0

    def reset(self) -> None:
        self._int = [0.0, 0.0, 0.0]
        self._prev_rate = None
        self._accel = [0.0, 0.0, 0.0]

    def update(self, dt_s: float, rates_frd_radps: Vec3, rates_sp_frd_radps: Vec3, landed: bool,
               saturation_positive: tuple[bool, bool, bool] = (False, False, False),
               saturation_negative: tuple[bool, bool, bool] = (False, False, False)) -> Vec3:
        accel = self._accel
        integ = self._int
        # Low-passed derivative of the measured rate (D on measurement, PX4 style).
        prev = self._prev_rate
        if prev is not None:
            if dt_s != self._alpha_dt:
                self._alpha = dt_s / (dt_s + 1.0 / (2.0 * math.pi * D_TERM_CUTOFF_HZ))
                self._alpha_dt = dt_s
            alpha = self._alpha
            for i in range(3):
                raw = (rates_frd_radps[i] - prev[i]) / dt_s
                accel[i] += alpha * (raw - accel[i])
        self._prev_rate = rates_frd_radps
        out = [0.0, 0.0, 0.0]
        for i, (kp, ki, kd, kff, lim) in enumerate(self._axes):
            sp = rates_sp_frd_radps[i]
            e = sp - rates_frd_radps[i]
            u = kp * e + integ[i] - kd * accel[i] + kff * sp
            out[i] = -1.0 if u < -1.0 else (1.0 if u > 1.0 else u)
            if not landed:
                if saturation_positive[i] and e > 0.0:
                    e = 0.0
                if saturation_negative[i] and e < 0.0:
                    e = 0.0
                f = e / _I_FACTOR_RATE_RADPS
                i_factor = 1.0 - f * f
                if i_factor < 0.0:
                    i_factor = 0.0
                v = integ[i] + i_factor * ki * e * dt_s
                if math.isfinite(v):
                    integ[i] = -lim if v < -lim else (lim if v > lim else v)
        return (out[0], out[1], out[2])
