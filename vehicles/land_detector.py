"""Multicopter land detector after PX4 v1.15 ``src/modules/land_detector/MulticopterLandDetector.cpp``
and ``LandDetector.cpp``.

Four states, each a ``systemlib::Hysteresis`` that turns true only after its condition held for
LNDMC_TRIG_TIME / 3 (1/3 s) and false at once, evaluated in PX4's order within one update:
- freefall: specific force below 2 m/s² (true after 0.3 s);
- ground contact: low thrust (at most MPC_THR_MIN + 30 % of (hover - MPC_THR_MIN), 60 % while
  the hover-thrust estimate is valid), no vertical movement (|vz| below LNDMC_Z_VEL_MAX, 2.5
  times that while landed), no horizontal movement (LNDMC_XY_VEL_MAX) and, under climb-rate
  control until maybe landed, a commanded descent (velocity setpoint at least 1.1 ×
  LNDMC_Z_VEL_MAX down);
- maybe landed: minimum thrust (MPC_THR_MIN + 10 % of (hover - MPC_THR_MIN) under climb-rate
  control, else MPC_MANTHR_MIN + 0.01), no freefall, no tilt rotation above LNDMC_ROT_MAX (2.5
  times that while landed), ground contact;
- landed: maybe landed.
So a landing takes LNDMC_TRIG_TIME (three stages of 1/3 s) once ground contact's conditions
hold, and a takeoff is seen the moment the thrust leaves the minimum (or the vehicle moves).
While the position controller sees ground contact it cuts thrust (mc_pos_control
``flying_but_ground_contact``), which is what brings the thrust to its minimum. Disarmed, every
condition holds (PX4's ``!_armed ||``). There is no distance sensor, so the close-to-ground check
is skipped and the hysteresis factor is 1. LNDMC_Z_VEL_MAX above min(MPC_LAND_CRWL,
MPC_LAND_SPEED) / 1.2 is lowered to that (``_update_params``, without a PARAM_VALUE). At
disarming the time since the first takeoff is added to the total flight time (LND_FLIGHT_T_HI/_LO,
µs). Pure logic; time is an argument.
"""

from __future__ import annotations

import math

from vehicles.cnum import f32
from vehicles.hysteresis import Hysteresis
from vehicles.types import GRAVITY_MPS2, Measurement

FREEFALL_TRIGGER_S = 0.3  # MulticopterLandDetector.h FREEFALL_TRIGGER_TIME_US
FREEFALL_ACC_MPS2 = 2.0  # _get_freefall_state: specific force below this
HTE_TIMEOUT_S = 1.0  # the hover-thrust estimate counts as valid this long after its last valid one
LOW_THRUST_THRESHOLD = 0.3  # of (hover - MPC_THR_MIN) above MPC_THR_MIN: ground contact
LOW_THRUST_THRESHOLD_HTE = 0.6  # ... with a valid hover-thrust estimate
MIN_THRUST_THRESHOLD = 0.1  # ... maybe landed, under climb-rate control
LANDED_WIDENING = 2.5  # the movement thresholds while landed


class LandDetector:
    def __init__(self, params) -> None:
        self._params = params
        self._params_version = -1  # the parameters below are read on the first update
        self._z_vel_max = self._xy_vel_max = self._rot_max_rad = 0.0
        self._thr_min = self._man_thr_min = 0.0
        self._use_hte = False
        self._freefall = Hysteresis(False, FREEFALL_TRIGGER_S)
        # Each stage LNDMC_TRIG_TIME / 3 (set with the parameters, _set_hysteresis_factor(1))
        self._contact = Hysteresis(True, 0.0)
        self._maybe = Hysteresis(True, 0.0)
        self._landed = Hysteresis(True, 0.0)
        self.landed = self.ground_contact = self.maybe_landed = True
        self.freefall = False
        self.in_descend = False
        self._hte_last_valid_s = -math.inf
        self._hte_valid = False
        self._takeoff_time_s: float | None = None  # the first takeoff since arming
        self._was_armed = False

    def _update_params(self) -> None:
        p = self._params
        upper = min(float(p["MPC_LAND_CRWL"]), float(p["MPC_LAND_SPEED"])) / 1.2
        if float(p["LNDMC_Z_VEL_MAX"]) > upper:
            p.set("LNDMC_Z_VEL_MAX", upper, notify=False)  # commit_no_notification
        self._params_version = p.version
        self._z_vel_max = float(p["LNDMC_Z_VEL_MAX"])
        self._xy_vel_max = float(p["LNDMC_XY_VEL_MAX"])
        self._rot_max_rad = math.radians(float(p["LNDMC_ROT_MAX"]))
        self._thr_min = float(p["MPC_THR_MIN"])
        self._man_thr_min = float(p["MPC_MANTHR_MIN"])
        self._use_hte = int(p["MPC_USE_HTE"]) == 1
        # _set_hysteresis_factor(1): LNDMC_TRIG_TIME * 1_s / 3 in float, as whole µs; NaN or
        # a negative time converts to a huge hrt_abstime on x86: never
        stage_us = f32(f32(float(p["LNDMC_TRIG_TIME"]) * 1e6) / 3.0)
        stage_s = int(stage_us) * 1e-6 if 0.0 <= stage_us < math.inf else math.inf
        self._contact.delay_s = self._maybe.delay_s = self._landed.delay_s = stage_s

    def update(self, now_s: float, armed: bool, meas: Measurement, velocity_sp_z_mps: float,
               thrust_norm: float, hover_thrust: float, hover_valid: bool = False) -> None:
        """One local-position update. ``velocity_sp_z_mps``: the task's vertical velocity
        setpoint (NED), NaN without climb-rate control; ``hover_thrust``: the hover thrust in
        use (MPC_THR_HOVER or the estimate), ``hover_valid``: the estimate is valid now."""
        if self._params.version != self._params_version:
            self._update_params()
        if not armed and self._was_armed and self._takeoff_time_s is not None:
            self._add_flight_time(now_s - self._takeoff_time_s)
            self._takeoff_time_s = None
        self._was_armed = armed
        if hover_valid and self._use_hte:
            self._hte_last_valid_s = now_s
        thr_min = self._thr_min
        vn, ve, vd = meas.velocity_ned_mps
        ax, ay, az = meas.accel_ned_mps2
        freefall = math.sqrt(ax * ax + ay * ay + (az - GRAVITY_MPS2) ** 2) < FREEFALL_ACC_MPS2
        # (Each hysteresis is asked only when its condition or its request differs from its
        # state: otherwise its update changes nothing.)
        h = self._freefall
        self.freefall = h.state if freefall == h.state == h._requested else h.update(now_s, freefall)

        # _get_ground_contact_state
        landed_before = self._landed.state
        z_thr = self._z_vel_max * (LANDED_WIDENING if landed_before else 1.0)
        vertical = abs(vd) >= z_thr
        horizontal = math.hypot(vn, ve) > self._xy_vel_max
        hte_valid = now_s - self._hte_last_valid_s < HTE_TIMEOUT_S
        if not self.in_descend or hte_valid:  # keep a valid estimate's threshold down to the ground
            self._hte_valid = hte_valid
        share = LOW_THRUST_THRESHOLD_HTE if self._hte_valid else LOW_THRUST_THRESHOLD
        contact = thrust_norm <= thr_min + (hover_thrust - thr_min) * share
        climb_rate_control = math.isfinite(velocity_sp_z_mps)
        if climb_rate_control:
            self.in_descend = velocity_sp_z_mps >= 1.1 * self._z_vel_max
            if not self._maybe.state and not landed_before:
                contact = contact and self.in_descend
        else:
            self.in_descend = False
        contact = not armed or (contact and not horizontal and not vertical)
        h = self._contact
        self.ground_contact = (h.state if contact == h.state == h._requested
                               else h.update(now_s, contact))

        # _get_maybe_landed_state
        if climb_rate_control:
            minimum = thr_min + (hover_thrust - thr_min) * MIN_THRUST_THRESHOLD
        else:
            minimum = self._man_thr_min + 0.01
        rot_thr = self._rot_max_rad * (LANDED_WIDENING if landed_before else 1.0)
        rotating = math.hypot(meas.rates_frd_radps[0], meas.rates_frd_radps[1]) > rot_thr
        maybe = not armed or (thrust_norm <= minimum and not self.freefall and not rotating
                              and self.ground_contact)
        h = self._maybe
        self.maybe_landed = h.state if maybe == h.state == h._requested else h.update(now_s, maybe)

        maybe = not armed or self.maybe_landed
        h = self._landed
        landed = h.state if maybe == h.state == h._requested else h.update(now_s, maybe)
        if not landed and self.landed and armed and self._takeoff_time_s is None:
            self._takeoff_time_s = now_s
        self.landed = landed

    def _add_flight_time(self, seconds: float) -> None:
        """PX4's total flight time, counted at disarming (from the first takeoff since arming)
        in microseconds, kept as two int32 halves in LND_FLIGHT_T_HI and _LO."""
        p = self._params
        total = ((int(p.get("LND_FLIGHT_T_HI", 0) or 0) & 0xFFFFFFFF) << 32
                 | (int(p.get("LND_FLIGHT_T_LO", 0) or 0) & 0xFFFFFFFF))
        total = (total + int(seconds * 1e6)) & 0xFFFFFFFFFFFFFFFF
        for name, half in (("LND_FLIGHT_T_HI", total >> 32), ("LND_FLIGHT_T_LO", total)):
            half &= 0xFFFFFFFF
            # commit_no_notification: no PARAM_VALUE goes out
            p.set(name, half - (1 << 32) if half >= 1 << 31 else half, notify=False)
