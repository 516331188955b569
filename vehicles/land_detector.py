"""Multicopter land detector after PX4 ``src/modules/land_detector/MulticopterLandDetector.cpp``.

Stages (each with PX4's hysteresis from LandDetector.h): ground contact (commanded descent at
>= 90 % of MPC_LAND_SPEED but no vertical movement above LNDMC_Z_VEL_MAX and no horizontal movement
above LNDMC_XY_VEL_MAX, 0.35 s) -> maybe landed (ground contact and thrust below
MPC_THR_MIN + 30 % of (hover - MPC_THR_MIN), 0.25 s) -> landed (0.3 s). While the position
controller sees ground contact it cuts thrust (PX4 ``limit_thrust_during_landing``), which is what
makes the thrust low. Takeoff: a landed, armed vehicle is in the air once, for TAKEOFF_TRIGGER_S,
its thrust is no longer minimal (PX4: landed needs maybe-landed, which needs thrust below
MPC_THR_MIN + 30 % of (hover - MPC_THR_MIN)) or it climbs faster than LNDMC_Z_VEL_MAX; the takeoff
ramp (control/takeoff.py) reaches its flight state on that. Disarmed means landed. At disarming
the time since the first takeoff is added to the total flight time (LND_FLIGHT_T_HI/_LO, µs), as
PX4's LandDetector counts it. Pure logic; time is an argument.
"""

from __future__ import annotations

import math

GROUND_CONTACT_TRIGGER_S = 0.35
MAYBE_LANDED_TRIGGER_S = 0.25
LANDED_TRIGGER_S = 0.3
TAKEOFF_TRIGGER_S = 0.1
LOW_THRUST_THRESHOLD = 0.3


class _Hysteresis:
    """True only after the condition has held for ``delay_s``; drops at once."""

    def __init__(self, delay_s: float) -> None:
        self.delay_s = delay_s
        self.state = False
        self._since: float | None = None

    def update(self, now_s: float, condition: bool) -> bool:
        if not condition:
            self._since = None
            self.state = False
        else:
            if self._since is None:
                self._since = now_s
            self.state = now_s - self._since >= self.delay_s - 1e-9
        return self.state

    def reset(self) -> None:
        self.state = False
        self._since = None


class LandDetector:
    def __init__(self, params) -> None:
        self._params = params
        self._params_version = -1  # the parameters below are read on the first update
        self._z_vel_max = self._thr_min = self._land_speed_thr = 0.0
        self._max_climb = self._xy_vel_max = 0.0
        self.landed = True
        self.ground_contact = False
        self.maybe_landed = False
        self._contact = _Hysteresis(GROUND_CONTACT_TRIGGER_S)
        self._maybe = _Hysteresis(MAYBE_LANDED_TRIGGER_S)
        self._landed = _Hysteresis(LANDED_TRIGGER_S)
        self._takeoff = _Hysteresis(TAKEOFF_TRIGGER_S)
        self._takeoff_time_s: float | None = None  # the first takeoff since arming
        self._was_armed = False

    def _update_params(self) -> None:
        p = self._params
        self._params_version = p.version
        self._z_vel_max = float(p["LNDMC_Z_VEL_MAX"])
        self._thr_min = float(p["MPC_THR_MIN"])
        self._land_speed_thr = 0.9 * max(float(p["MPC_LAND_SPEED"]), 0.1)
        self._max_climb = min(0.5 * self._land_speed_thr, self._z_vel_max)
        self._xy_vel_max = float(p["LNDMC_XY_VEL_MAX"])

    def update(self, now_s: float, armed: bool, velocity_ned_mps: tuple[float, float, float],
               velocity_sp_z_mps: float, thrust_norm: float, hover_thrust: float) -> None:
        if self._params.version != self._params_version:
            self._update_params()
        if not armed and self._was_armed and self._takeoff_time_s is not None:
            self._add_flight_time(now_s - self._takeoff_time_s)
            self._takeoff_time_s = None
        self._was_armed = armed
        if not armed:
            self.landed, self.ground_contact, self.maybe_landed = True, False, False
            for h in (self._contact, self._maybe, self._landed, self._takeoff):
                h.reset()
            return
        z_vel_max, thr_min = self._z_vel_max, self._thr_min
        low_thrust = thrust_norm <= thr_min + (hover_thrust - thr_min) * LOW_THRUST_THRESHOLD
        if self.landed:
            if self._takeoff.update(now_s, -velocity_ned_mps[2] > z_vel_max or not low_thrust):
                self.landed = False
                if self._takeoff_time_s is None:
                    self._takeoff_time_s = now_s
                for h in (self._contact, self._maybe, self._landed):
                    h.reset()
            return
        land_speed_thr = self._land_speed_thr
        vertical = abs(velocity_ned_mps[2]) > self._max_climb
        horizontal = math.hypot(velocity_ned_mps[0], velocity_ned_mps[1]) > self._xy_vel_max
        # Without a climb-rate setpoint (Stabilized, Acro, offboard attitude/rates) PX4 judges
        # ground contact by the missing movement alone; low thrust still has to follow.
        in_descend = (velocity_sp_z_mps >= land_speed_thr if math.isfinite(velocity_sp_z_mps)
                      else True)
        self.ground_contact = self._contact.update(now_s, not vertical and not horizontal and in_descend)
        self.maybe_landed = self._maybe.update(now_s, self.ground_contact and low_thrust)
        if self._landed.update(now_s, self.maybe_landed):
            self.landed = True
            self.ground_contact = self.maybe_landed = False
            self._takeoff.reset()

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
