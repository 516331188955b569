"""Pure library: PX4's hover thrust estimator.

Sources: PX4 src/modules/mc_hover_thrust_estimator (zero_order_hover_thrust_ekf.cpp/.hpp, the
filter, and MulticopterHoverThrustEstimator.cpp, the module around it), the parameters of
hover_thrust_estimator_params.yaml, and mc_pos_control's use of the estimate
(PositionControl::updateHoverThrust).

- ``ZeroOrderHoverThrustEkf``: one state, the hover thrust Th, constant but for process noise
  (HTE_HT_NOISE); the measurement is the vertical acceleration (up positive) predicted as
  g·T/Th − g from the thrust T; the measurement noise R is learnt from the residuals; a
  measurement whose normalized innovation squared exceeds the gate (HTE_ACC_GATE) is rejected,
  and after a run of rejections the state variance is bumped so that a jump is followed.
- ``HoverThrustEstimator``: what PX4's module does around it at every local-position update.
  Armed and in the air (not landed, and once more than a metre above the ground): predict, then
  fuse with the measurement noise scaled up at vertical speeds above HTE_VZ_THR and horizontal
  ones above HTE_VXY_THR; the estimate stays between MPC_THR_HOVER ± HTE_THR_RANGE. It is valid
  when its variance is below 0.001 (and, to become valid, the innovation test passes) for 2 s
  on end. Disarmed it restarts from MPC_THR_HOVER with HTE_HT_ERR_INIT.
- ``hover_thrust``: what the controllers use (mc_pos_control, the land detector, the stick
  throttle curve): MPC_THR_HOVER until the estimate is first valid, then the last valid
  estimate (PX4 keeps it after landing); always MPC_THR_HOVER with MPC_USE_HTE 0.
"""

from __future__ import annotations

import math

from vehicles.types import GRAVITY_MPS2

NOISE_LEARNING_TIME_CONSTANT_S = 2.0
LPF_TIME_CONSTANT_S = 1.0
VALID_VAR = 0.001  # hover_thrust_var below this: the estimate can be used
VALID_HYSTERESIS_S = 2.0  # _valid_hysteresis.set_hysteresis_time_from(false, 2_s)
IN_AIR_HEIGHT_M = 1.0  # local_pos.dist_bottom > 1 m


def _clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else (hi if v > hi else v)


class ZeroOrderHoverThrustEkf:
    def __init__(self) -> None:
        self.hover_thr = 0.5
        self.hover_thr_min = 0.1
        self.hover_thr_max = 0.9
        self.gate_size = 3.0
        self.state_var = 0.01
        self.process_var = 12.5e-6
        self.acc_var = 5.0
        self.acc_var_scale = 1.0
        self.dt = 0.02
        self.innov = self.innov_var = self.innov_test_ratio = 0.0
        self._residual_lpf = 0.0
        self._signed_innov_test_ratio_lpf = 0.0

    # --- setters, as PX4's ------------------------------------------------------------------
    def reset_accel_noise(self) -> None:
        self.acc_var = 5.0

    def set_hover_thrust(self, hover_thrust: float) -> None:
        self.hover_thr = _clamp(hover_thrust, 0.1, 0.9)

    def set_process_noise_std_dev(self, noise: float) -> None:
        self.process_var = noise * noise

    def set_measurement_noise_scale(self, scale: float) -> None:
        self.acc_var_scale = scale * scale

    def set_hover_thrust_std_dev(self, std_dev: float) -> None:
        self.state_var = std_dev * std_dev

    # --- the filter ---------------------------------------------------------------------------
    def predict(self, dt: float) -> None:
        self.state_var += self.process_var * dt * dt
        self.dt = dt

    def fuse_acc_z(self, acc_z: float, thrust: float) -> None:
        """``acc_z``: the vertical acceleration, up positive; ``thrust``: the vertical thrust
        (normalized), up positive."""
        # (Runs at 50 Hz: the predicted acceleration, g·T/Th − g, and the clamps are written
        # out.)
        hover_thr, state_var, dt = self.hover_thr, self.state_var, self.dt
        h = -GRAVITY_MPS2 * thrust / (hover_thr * hover_thr)
        r = self.acc_var * self.acc_var_scale
        innov_var = h * state_var * h + r
        if r > innov_var:  # max(·, r)
            innov_var = r
        innov = acc_z - (GRAVITY_MPS2 * thrust / hover_thr - GRAVITY_MPS2)
        k = state_var * h / innov_var
        # computeInnovTestRatio in float arithmetic: HTE_ACC_GATE = 0 (PX4 stores it as given)
        # makes the ratio inf (0/0: NaN), so every measurement is rejected, not a fault.
        gate = self.gate_size * self.gate_size * innov_var
        test_ratio = innov * innov / gate if gate != 0.0 else math.inf if innov else math.nan
        residual = innov
        if test_ratio < 1.0:
            v, lo, hi = hover_thr + k * innov, self.hover_thr_min, self.hover_thr_max
            self.hover_thr = hover_thr = lo if v < lo else (hi if v > hi else v)
            v = (1.0 - k * h) * state_var
            state_var = 1e-10 if v < 1e-10 else (1.0 if v > 1.0 else v)
            # the hover thrust moved
            residual = acc_z - (GRAVITY_MPS2 * thrust / hover_thr - GRAVITY_MPS2)
        elif abs(self._signed_innov_test_ratio_lpf) > 0.2:
            # Rejected for a while: the hover thrust jumped, or the filter diverges.
            state_var += 1e3 * self.process_var * dt * dt
        self.state_var = state_var
        signed = math.copysign(test_ratio, innov) if innov != 0.0 else test_ratio
        alpha = dt / (LPF_TIME_CONSTANT_S + dt)
        self._residual_lpf = residual_lpf = (1.0 - alpha) * self._residual_lpf + alpha * residual
        self._signed_innov_test_ratio_lpf = ((1.0 - alpha) * self._signed_innov_test_ratio_lpf
                                             + alpha * (-1.0 if signed < -1.0 else
                                                        (1.0 if signed > 1.0 else signed)))
        alpha = dt / (NOISE_LEARNING_TIME_CONSTANT_S + dt)
        res_no_bias = residual - residual_lpf
        v = (1.0 - alpha) * self.acc_var + alpha * (res_no_bias * res_no_bias
                                                     + h * state_var * h)
        self.acc_var = 1.0 if v < 1.0 else (400.0 if v > 400.0 else v)
        self.innov, self.innov_var, self.innov_test_ratio = innov, innov_var, test_ratio


class HoverThrustEstimator:
    """mc_hover_thrust_estimator around ``ZeroOrderHoverThrustEkf``, and the hover thrust the
    controllers take from it (module docstring)."""

    def __init__(self, params) -> None:
        self.params = params
        self.ekf = ZeroOrderHoverThrustEkf()
        self._params_version = -1
        self._use = True
        self._param_hover = 0.5
        self._err_init = 0.1
        self._vz_thr = self._vxy_thr = 0.0
        self.valid = False
        self._valid_since_s: float | None = None  # when the condition for valid began to hold
        self._in_air = False
        self._last_s: float | None = None
        self._update_params()
        self.reset()
        self.hover_thrust = self._param_hover  # what the controllers use

    def _update_params(self) -> None:
        p = self.params
        self._params_version = p.version
        err_init = float(p["HTE_HT_ERR_INIT"])
        hover = float(p["MPC_THR_HOVER"])
        self.ekf.set_process_noise_std_dev(float(p["HTE_HT_NOISE"]))
        if abs(err_init - self._err_init) > 1.2e-7:
            self.ekf.set_hover_thrust_std_dev(err_init)
        self._err_init = err_init
        self.ekf.gate_size = float(p["HTE_ACC_GATE"])
        rng = float(p["HTE_THR_RANGE"])
        self.ekf.hover_thr_min = _clamp(hover - rng, 0.0, 0.8)
        self.ekf.hover_thr_max = _clamp(hover + rng, 0.2, 0.9)
        self._vz_thr, self._vxy_thr = float(p["HTE_VZ_THR"]), float(p["HTE_VXY_THR"])
        use = int(p["MPC_USE_HTE"]) != 0
        if hover != self._param_hover or not use:
            # mc_pos_control takes MPC_THR_HOVER when it changes, and always without the HTE.
            self.hover_thrust = hover
        self._param_hover, self._use = hover, use

    def reset(self) -> None:
        # (Every 50 Hz tick while disarmed: the three setters written out.)
        ekf, hover, err = self.ekf, self._param_hover, self._err_init
        ekf.hover_thr = 0.1 if hover < 0.1 else (0.9 if hover > 0.9 else hover)  # set_hover_thrust
        ekf.state_var = err * err  # set_hover_thrust_std_dev
        ekf.acc_var = 5.0  # reset_accel_noise

    def update(self, now_s: float, armed: bool, landed: bool, height_m: float,
               velocity_ned_mps: tuple[float, float, float], accel_z_ned_mps2: float,
               thrust_z_ned: float) -> float:
        """One local-position update: ``height_m`` above the ground, ``accel_z_ned_mps2`` the
        vertical acceleration (NED), ``thrust_z_ned`` the position controller's last thrust
        setpoint's z (NED, NaN without one). Returns ``hover_thrust``."""
        if self.params.version != self._params_version:
            self._update_params()
        if landed:
            self._in_air = False
        elif height_m > IN_AIR_HEIGHT_M:
            self._in_air = True
        dt = 0.0 if self._last_s is None else now_s - self._last_s
        self._last_s = now_s
        if armed and self._in_air and 0.001 < dt < 1.0 and math.isfinite(accel_z_ned_mps2):
            ekf = self.ekf
            ekf.state_var += ekf.process_var * dt * dt  # ekf.predict(dt)
            ekf.dt = dt
            if math.isfinite(thrust_z_ned):
                vn, ve, vd = velocity_ned_mps
                # (the max() calls as comparisons, the same values, NaN included)
                coeff_z = abs(vd) - self._vz_thr + 1.0
                coeff_z = 1.0 if 1.0 > coeff_z else coeff_z
                coeff_xy = math.hypot(vn, ve) - self._vxy_thr + 1.0
                coeff_xy = 1.0 if 1.0 > coeff_xy else coeff_xy
                scale = coeff_z if coeff_z > coeff_xy else coeff_xy
                ekf.acc_var_scale = scale * scale  # set_measurement_noise_scale
                ekf.fuse_acc_z(-accel_z_ned_mps2, -thrust_z_ned)
                ok = ekf.state_var < VALID_VAR
                if not self.valid:
                    ok = ok and ekf.innov_test_ratio < 1.0
                if not (ok and self.valid):  # (valid stays valid while ok)
                    self._set_valid(ok, now_s)
        else:
            self.valid, self._valid_since_s = False, None  # _set_valid(False)
            if not armed:
                self.reset()
        if self.valid and self._use:
            v = self.ekf.hover_thr  # setHoverThrust
            self.hover_thrust = 0.05 if v < 0.05 else (0.9 if v > 0.9 else v)
        return self.hover_thrust

    def _set_valid(self, ok: bool, now_s: float) -> None:
        """systemlib::Hysteresis: true only after ``ok`` held VALID_HYSTERESIS_S, false at once."""
        if not ok:
            self.valid = False
            self._valid_since_s = None
            return
        if self._valid_since_s is None:
            self._valid_since_s = now_s
        if now_s - self._valid_since_s >= VALID_HYSTERESIS_S - 1e-9:
            self.valid = True
