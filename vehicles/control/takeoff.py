"""Pure library: PX4's smooth takeoff (src/modules/mc_pos_control/Takeoff, TakeoffHandling).

After arming the motors spin at idle for COM_SPOOLUP_TIME; once a flight task wants to take off
the upward velocity limit ramps over MPC_TKO_RAMP_T from -g / MPC_Z_VEL_P_ACC (a limit that asks
for no thrust at all) to the task's climb speed, so the thrust rises smoothly from zero and the
vehicle leaves the ground part-way through the ramp. Until the ramp starts the position
controller gets no setpoint (no thrust, no integration); until the flight state the tilt is
limited to MPC_TILTMAX_LND and the minimum thrust is 0 instead of MPC_THR_MIN (the module's use,
position_stage.py).

Rules: time is an argument (seconds); no clock, no physics. States and transitions as PX4's
``updateTakeoffState`` (one update may pass through several states); ``update_ramp`` as PX4's
``updateRamp``. Modes without climb-rate control (Stabilized, Acro, attitude offboard) skip the
takeoff: the state is flight at once, so a switch to a position mode in the air does not ramp.
"""

from __future__ import annotations

import enum
import math

from vehicles.types import GRAVITY_MPS2


class TakeoffState(enum.IntEnum):
    DISARMED = 0
    SPOOLUP = 1
    READY_FOR_TAKEOFF = 2
    RAMPUP = 3
    FLIGHT = 4


# The states by their own names for the state machine, which runs at every 50 Hz tick: in Python
# 3.11 reading a member off its class (``TakeoffState.FLIGHT``) goes through EnumType.__getattr__
# and costs ~0.2 us.
DISARMED, SPOOLUP, READY_FOR_TAKEOFF, RAMPUP, FLIGHT = (
    TakeoffState.DISARMED, TakeoffState.SPOOLUP, TakeoffState.READY_FOR_TAKEOFF,
    TakeoffState.RAMPUP, TakeoffState.FLIGHT)


class TakeoffHandling:
    def __init__(self, spoolup_time_s: float = 1.0, ramp_time_s: float = 3.0,
                 velocity_p_gain: float = 4.0) -> None:
        self.spoolup_time_s = spoolup_time_s
        self.ramp_time_s = ramp_time_s
        self.ramp_vz_init = -GRAVITY_MPS2 / max(velocity_p_gain, 0.01)
        self.state = TakeoffState.DISARMED
        self.ramp_progress = 0.0
        self._armed_since = math.inf  # when ``armed`` last became true (the spool-up hysteresis)

    def set_velocity_p_gain(self, velocity_p_gain: float) -> None:
        """PX4 generateInitialRampValue: the ramp starts at -g / gain (MPC_Z_VEL_P_ACC)."""
        self.ramp_vz_init = -GRAVITY_MPS2 / max(velocity_p_gain, 0.01)

    def update_state(self, armed: bool, landed: bool, want_takeoff: bool, now_s: float,
                     skip_takeoff: bool = False) -> TakeoffState:
        if not armed:
            self._armed_since = math.inf
        elif self._armed_since == math.inf:
            self._armed_since = now_s
        spooled_up = armed and now_s - self._armed_since >= self.spoolup_time_s
        s = self.state
        if s is DISARMED and armed:
            s = SPOOLUP
        if s is SPOOLUP and spooled_up:
            s = READY_FOR_TAKEOFF
        if s is READY_FOR_TAKEOFF and want_takeoff:
            s = RAMPUP
            self.ramp_progress = 0.0
        if s is RAMPUP and self.ramp_progress >= 1.0:
            s = FLIGHT
        if s is FLIGHT and landed:
            s = READY_FOR_TAKEOFF
        if armed and skip_takeoff:
            s = FLIGHT
        if not armed:
            s = DISARMED
        self.state = s
        return s

    def update_ramp(self, dt_s: float, desired_vz_up_mps: float) -> float:
        """The upward velocity limit (m/s, positive up) for this tick."""
        limit = desired_vz_up_mps
        if self.state < RAMPUP:
            limit = self.ramp_vz_init
        if self.state is RAMPUP:
            if self.ramp_time_s > dt_s:
                self.ramp_progress += dt_s / self.ramp_time_s
            else:
                self.ramp_progress = 1.0
            if self.ramp_progress < 1.0:
                limit = self.ramp_vz_init + self.ramp_progress * (desired_vz_up_mps
                                                                  - self.ramp_vz_init)
        return limit
