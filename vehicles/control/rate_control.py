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

    def reset(self) -> None:
        self._int = [0.0, 0.0, 0.0]
        self._prev_rate = None
        self._accel = [0.0, 0.0, 0.0]

    def update(self, dt_s: float, rates_frd_radps: Vec3, rates_sp_frd_radps: Vec3, landed: bool,
               saturation_positive: tuple[bool, bool, bool] = (False, False, False),
               saturation_negative: tuple[bool, bool, bool] = (False, False, False)) -> Vec3:
        g = self.gains
        # Low-passed derivative of the measured rate (D on measurement, PX4 style).
        if self._prev_rate is not None:
            alpha = dt_s / (dt_s + 1.0 / (2.0 * math.pi * D_TERM_CUTOFF_HZ))
            for i in range(3):
                raw = (rates_frd_radps[i] - self._prev_rate[i]) / dt_s
                self._accel[i] += alpha * (raw - self._accel[i])
        self._prev_rate = rates_frd_radps
        out = []
        for i in range(3):
            e = rates_sp_frd_radps[i] - rates_frd_radps[i]
            u = g.p[i] * e + self._int[i] - g.d[i] * self._accel[i] + g.ff[i] * rates_sp_frd_radps[i]
            out.append(min(max(u, -1.0), 1.0))
            if not landed:
                if saturation_positive[i]:
                    e = min(e, 0.0)
                if saturation_negative[i]:
                    e = max(e, 0.0)
                f = e / _I_FACTOR_RATE_RADPS
                i_factor = max(0.0, 1.0 - f * f)
                v = self._int[i] + i_factor * g.i[i] * e * dt_s
                if math.isfinite(v):
                    self._int[i] = min(max(v, -g.int_lim[i]), g.int_lim[i])
        return (out[0], out[1], out[2])
