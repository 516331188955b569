"""The 250 Hz inner loop of every vehicle of a World, compiled: one call per physics step runs,
for each vehicle, attitude P → rate PID → mixer → motor lag → body force and torque; ``measure``
turns the raw PyBullet states read after the step into NED/FRD measurements (physics.py runs it
inside its one compiled call after PyBullet's step).

Why compiled: these few hundred floating-point operations per vehicle and step were most of a
vehicle's cost in CPython (~25 µs, 250 times a simulated second); compiled they cost well under a
microsecond, and the per-body PyBullet calls become the floor. The controllers are not repeated
here: ``attitude_rates``, ``rate_pid`` and ``mix_into`` are ``register_jitable`` functions of
vehicles/control — the same source the Python classes run — inlined into these kernels.

Rules and invariants:
- One row per vehicle in every array (``InnerLoop.add`` grows them); row k is the World's k-th
  vehicle. The autopilot (Python, 50 Hz) decides a row's mode, setpoints, gains and resets as an
  ``InnerCommand``; ``InnerLoop.load`` copies it into the row; nothing else writes them.
- Modes per vehicle and step: OFF (disarmed or terminated: the motors spin down, the controller
  state is left alone), IDLE (rate controller reset, zero torque → motors at idle thrust, the
  saturation flags kept), FLY (attitude, or a body-rate setpoint when one is given).
- Frames: PyBullet is ENU/FLU; forces come out in ENU (what ``applyExternalForce`` takes in
  WORLD_FRAME), measurements in NED/FRD relative to the vehicle's spawn point (physics.py rules).
- numba caches the compiled kernels (vehicles/control/compiled.py): the first run on a machine
  compiles them (seconds), later runs load them.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from vehicles.airframe import Airframe
from vehicles.control.attitude_control import attitude_rates
from vehicles.control.compiled import njit_cached
from vehicles.control.mixer import mix_into, mixer_rows_with_effectiveness
from vehicles.control.rate_control import STATE_INTEGRAL, STATE_SIZE, d_filter_alpha, rate_pid
from vehicles.control.rotation import dcm

MODE_OFF = 0
MODE_IDLE = 1
MODE_FLY = 2
# Disarmed, with PX4's actuator test (MAV_CMD_ACTUATOR_TEST) driving motors: ``setpoint``'s first
# columns hold each rotor's test value (0..1 over the ESC range; NaN: the motor stays stopped).
MODE_TEST = 3
# The mixer's lowest motor command when armed: PX4's allocation gives 0 (actuator_motors); the
# armed motor still spins, at the ESC's minimum (Airframe.esc_min_radps).
IDLE_THRUST_NORM = 0.0

# Columns of ``InnerLoop.measured``: position NED (m), velocity NED (m/s), attitude q (w, x, y, z)
# FRD → NED, body rates FRD (rad/s), acceleration NED (m/s², finite difference of velocity).
M_POS, M_VEL, M_Q, M_RATES, M_ACCEL, M_SIZE = 0, 3, 6, 10, 13, 16
# Columns of ``InnerLoop.forces``: force ENU (N), torque ENU (N m), 1.0 when there is anything
# to apply (PyBullet clears external forces after every step).
F_SIZE = 7
# Columns of ``InnerLoop.commanded``: the rate setpoint FRD (rad/s), the rate controller's
# normalized torque and its integrator (PX4 vehicle_torque_setpoint, rate_ctrl_status), then one
# commanded rotor speed (rad/s) per rotor.
C_RATES_SP, C_TORQUE_SP, C_RATE_INT, C_OUTPUTS = 0, 3, 6, 9
# Columns of ``InnerLoop.setpoint``: attitude q (w, x, y, z), heading rate (rad/s), collective
# thrust (0..1), body rates FRD (rad/s; flown instead of the attitude when ``use_rates_sp``).
SP_Q, SP_YAWSPEED, SP_THRUST, SP_RATES, SP_SIZE = 0, 4, 5, 6, 9
# Columns of ``InnerLoop.gains``: ``attitude_rates``' seven coefficients, then ``rate_pid``'s 15,
# then THR_MDL_FAC (the motors' thrust model).
G_ATT, G_RATE, G_THR_MDL_FAC, G_SIZE = 0, 7, 22, 23
# Columns of ``InnerLoop.rotors`` (one row per rotor): the mixer's six numbers (roll, pitch and
# yaw factors, then the rotor's normalized effectiveness: mixer.mixer_rows_with_effectiveness),
# the rotor's x and y (FRD, m), its reaction torque per newton of thrust (signed, m).
R_MIX, R_X, R_Y, R_YAW_K, R_SIZE = 0, 6, 7, 8, 9
# Numbers per body of a raw PyBullet state (``measure``): position, orientation xyzw, linear and
# angular velocity, ENU.
RAW_SIZE = 13
_SQRT_HALF = math.sqrt(0.5)


class InnerCommand(NamedTuple):
    """What the autopilot hands its row of the inner loop (``Autopilot.step``): the mode, the
    attitude (or body-rate) setpoint and thrust, the land detector's verdict, new gains when the
    parameters changed (the rate integrator then restarts, as PX4 builds a new controller) and
    whether the rate controller restarts (the motors went idle). A NamedTuple: one is built at
    every 50 Hz tick of every vehicle."""

    mode: int  # MODE_OFF, MODE_IDLE, MODE_FLY or MODE_TEST
    attitude_q: tuple[float, float, float, float]
    yawspeed_radps: float
    thrust_norm: float
    rates_frd_radps: tuple[float, float, float] | None  # replaces the attitude controller
    landed: bool
    # (attitude, rate) coefficients and THR_MDL_FAC
    gains: tuple[tuple[float, ...], tuple[float, ...], float] | None
    reset_rates: bool
    motor_test: tuple[float, ...] = ()  # MODE_TEST: each rotor's test value (NaN: stopped)


@njit_cached
def thrust_model(control: float, factor: float) -> float:  # pragma: no cover
    """FunctionMotors::updateValues: with THR_MDL_FAC ``factor`` in (0, 1] the motor command
    whose thrust factor·x² + (1 − factor)·x is ``control`` (the inverse of PX4's thrust model);
    otherwise ``control`` unchanged."""
    if not 0.0 < factor <= 1.0:
        return control
    a, b = factor, 1.0 - factor
    tmp1 = b / (2.0 * a)
    tmp2 = b * b / (4.0 * a * a)
    if control > 0.0:
        return -tmp1 + math.sqrt(tmp2 + control / a)
    if control < 0.0:
        return tmp1 - math.sqrt(tmp2 - control / a)
    return 0.0


@njit_cached
def control_and_forces(mode, setpoint, use_rates_sp, landed, gains, rate_state, saturation,
                       rotors, plant, measured, estimated, rotor_speed, wind, forces,
                       motor_ok, commanded):  # pragma: no cover
    """One physics step of every vehicle's inner loop (module rules). The controllers fly on
    ``estimated`` (attitude, gyro rates less their bias); the physics acts on ``measured``, the
    truth. ``plant``: max rotor speed, motor constant, lag coefficient up, lag coefficient down,
    linear drag, idle thrust, the D term's filter coefficient, the step (s); ``wind``: the air's
    velocity (NED), which the drag acts against; ``motor_ok``: 0 for a rotor whose motor has
    failed (failure injection: it spins down). ``commanded`` (out): per row the rate controller's
    setpoint (C_RATES_SP, PX4 vehicle_rates_setpoint; 0 when it does not run), its torque and
    integrator (C_TORQUE_SP, C_RATE_INT; 0 when it does not run) and each rotor's
    commanded speed (C_OUTPUTS, rad/s: PX4's actuator_outputs as the gz bridge's ESC outputs
    carry them, before the motor's lag and whatever failure injection did to the motor)."""
    w_max, k_motor, alpha_up, alpha_down, drag = plant[0], plant[1], plant[2], plant[3], plant[4]
    idle, alpha, dt_s, esc_min, esc_span = plant[5], plant[6], plant[7], plant[8], plant[9]
    n_rotors = len(rotors)
    u = np.zeros(n_rotors)
    for v in range(len(mode)):
        m = measured[v]
        q = (m[M_Q], m[M_Q + 1], m[M_Q + 2], m[M_Q + 3])
        est = estimated[v]
        q_est = (est[M_Q], est[M_Q + 1], est[M_Q + 2], est[M_Q + 3])
        out_cmd = commanded[v]
        for i in range(C_OUTPUTS):
            out_cmd[i] = 0.0
        armed = mode[v] != MODE_OFF
        if not armed:
            for i in range(n_rotors):
                u[i] = 0.0
        elif mode[v] == MODE_TEST:
            rate_state[v, :] = 0.0
            for i in range(n_rotors):
                x = setpoint[v, i]
                # NaN (or below 0): stopped; the test value goes through the thrust model too
                u[i] = thrust_model(min(x, 1.0), gains[v, G_THR_MDL_FAC]) if x >= 0.0 else -1.0
        else:
            if mode[v] == MODE_IDLE:
                rate_state[v, :] = 0.0
                mix_into(0.0, 0.0, 0.0, 0.0, rotors, idle, u)
            else:
                c = setpoint[v]
                g = gains[v]
                if use_rates_sp[v]:
                    sp = (c[SP_RATES], c[SP_RATES + 1], c[SP_RATES + 2])
                else:
                    sp = attitude_rates(q_est, (c[SP_Q], c[SP_Q + 1], c[SP_Q + 2], c[SP_Q + 3]),
                                        g[0], g[1], g[2], g[3], g[4], g[5], g[6], c[SP_YAWSPEED])
                out_cmd[C_RATES_SP], out_cmd[C_RATES_SP + 1], out_cmd[C_RATES_SP + 2] = sp
                s = saturation[v]
                torque = rate_pid(dt_s, alpha, (est[M_RATES], est[M_RATES + 1], est[M_RATES + 2]), sp,
                                  landed[v], (s[0], s[1], s[2]), (s[3], s[4], s[5]), g[G_RATE:],
                                  rate_state[v])
                flags = mix_into(c[SP_THRUST], torque[0], torque[1], torque[2], rotors, idle, u)
                for i in range(3):
                    out_cmd[C_TORQUE_SP + i] = torque[i]
                    out_cmd[C_RATE_INT + i] = rate_state[v, STATE_INTEGRAL + i]
                for i in range(6):
                    s[i] = flags[i]
            factor = gains[v, G_THR_MDL_FAC]
            if factor > 0.0:
                for i in range(n_rotors):
                    u[i] = thrust_model(u[i], factor)
        # Motor lag (first order, faster up than down) and the rotors' thrust and torque.
        speeds = rotor_speed[v]
        total = tx = ty = tz = 0.0
        for i in range(n_rotors):
            # MixingOutput::output_limit_calc_single: the ESC output is a whole number (lroundf).
            cmd = (min(math.floor(esc_min + esc_span * u[i] + 0.5), w_max)
                   if armed and u[i] >= 0.0 else 0.0)
            out_cmd[C_OUTPUTS + i] = cmd
            cmd *= motor_ok[v, i]
            w = speeds[i]
            w += (cmd - w) * (alpha_up if cmd > w else alpha_down)
            speeds[i] = w
            t = k_motor * w * w
            total += t
            tx -= rotors[i, R_Y] * t
            ty += rotors[i, R_X] * t
            tz += rotors[i, R_YAW_K] * t
        out = forces[v]
        vn, ve, vd = m[M_VEL] - wind[0], m[M_VEL + 1] - wind[1], m[M_VEL + 2] - wind[2]
        if total == 0.0 and vn == 0.0 and ve == 0.0 and vd == 0.0:
            out[6] = 0.0
            continue
        qw, qx, qy, qz = q
        # Body force (0, 0, -total) in NED = -total · third column of R; plus linear drag.
        fn = -total * 2 * (qx * qz + qw * qy) - drag * vn
        fe = -total * 2 * (qy * qz - qw * qx) - drag * ve
        fd = -total * (1 - 2 * (qx * qx + qy * qy)) - drag * vd
        # Body torque into NED: R · τ.
        mn = ((1 - 2 * (qy * qy + qz * qz)) * tx + 2 * (qx * qy - qw * qz) * ty
              + 2 * (qx * qz + qw * qy) * tz)
        me = (2 * (qx * qy + qw * qz) * tx + (1 - 2 * (qx * qx + qz * qz)) * ty
              + 2 * (qy * qz - qw * qx) * tz)
        md = (2 * (qx * qz - qw * qy) * tx + 2 * (qy * qz + qw * qx) * ty
              + (1 - 2 * (qx * qx + qy * qy)) * tz)
        out[0], out[1], out[2] = fe, fn, -fd
        out[3], out[4], out[5] = me, mn, -md
        out[6] = 1.0


@njit_cached
def measure(raw, spawn_enu, dt_s, measured):  # pragma: no cover - compiled
    """PyBullet states (rows: position, orientation xyzw, linear and angular velocity, all ENU)
    into ``measured`` rows (NED/FRD, see M_*); acceleration from the previous velocity over
    ``dt_s`` (0 when ``dt_s`` is not positive)."""
    s = _SQRT_HALF
    for v in range(len(raw)):
        r = raw[v]
        m = measured[v]
        # ENU/FLU quaternion (x, y, z, w) -> NED/FRD (w, x, y, z): q_ned_enu ⊗ q ⊗ q_flu_frd.
        x, y, z, w = r[3], r[4], r[5], r[6]
        qw, qx, qy, qz = s * (w + z), s * (x + y), s * (x - y), s * (w - z)
        if qw < 0.0:
            qw, qx, qy, qz = -qw, -qx, -qy, -qz
        vn, ve, vd = r[8], r[7], -r[9]
        if dt_s > 0.0:
            m[M_ACCEL] = (vn - m[M_VEL]) / dt_s
            m[M_ACCEL + 1] = (ve - m[M_VEL + 1]) / dt_s
            m[M_ACCEL + 2] = (vd - m[M_VEL + 2]) / dt_s
        m[M_POS], m[M_POS + 1], m[M_POS + 2] = r[1] - spawn_enu[v, 1], r[0] - spawn_enu[v, 0], \
            spawn_enu[v, 2] - r[2]
        m[M_VEL], m[M_VEL + 1], m[M_VEL + 2] = vn, ve, vd
        m[M_Q], m[M_Q + 1], m[M_Q + 2], m[M_Q + 3] = qw, qx, qy, qz
        # Body rates: R^T · ω_ned.
        wn, we, wd = r[11], r[10], -r[12]
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = dcm(qw, qx, qy, qz)
        m[M_RATES] = r00 * wn + r10 * we + r20 * wd
        m[M_RATES + 1] = r01 * wn + r11 * we + r21 * wd
        m[M_RATES + 2] = r02 * wn + r12 * we + r22 * wd


class InnerLoop:
    """The arrays of every vehicle's inner loop and the two kernels over them (module rules)."""

    def __init__(self, airframe: Airframe, dt_s: float, idle_thrust_norm: float) -> None:
        self.dt_s = dt_s
        self.idle_thrust_norm = idle_thrust_norm
        self.alpha = d_filter_alpha(dt_s)
        mixer = mixer_rows_with_effectiveness(*airframe.mixer_rows())
        self.rotors = np.array([
            (*mixer[i], r.position_frd_m[0], r.position_frd_m[1],
             r.yaw_sign * airframe.moment_constant_m) for i, r in enumerate(airframe.rotors)],
            dtype=float)
        self.plant = np.array([
            airframe.max_rotor_speed_radps, airframe.motor_constant_n_per_radps2,
            1.0 - math.exp(-dt_s / airframe.motor_time_constant_up_s),
            1.0 - math.exp(-dt_s / airframe.motor_time_constant_down_s),
            airframe.linear_drag_n_per_mps, idle_thrust_norm, self.alpha, dt_s,
            airframe.esc_min_radps, airframe.esc_max_radps - airframe.esc_min_radps,
        ])
        self._rotors = airframe.rotor_count
        self.wind = np.zeros(3)  # the air's velocity, NED (wind.py); World.step sets it
        self.count = 0
        self._resize(0)
        # Compile (or load from numba's cache) both kernels now, with no rows: a World is ready
        # to step when it is built, so the daemon never stalls on its first physics step.
        self.control()
        measure(np.zeros((0, RAW_SIZE)), self.spawn_enu, 0.0, self.measured)

    def _resize(self, n: int) -> None:
        def grow(old, shape, dtype=float):
            new = np.zeros(shape, dtype=dtype)
            if old is not None and len(old):
                new[:len(old)] = old
            return new

        get = self.__dict__.get
        self.mode = grow(get("mode"), n, np.int8)
        self.setpoint = grow(get("setpoint"), (n, SP_SIZE))
        self.use_rates_sp = grow(get("use_rates_sp"), n, np.bool_)
        self.landed = grow(get("landed"), n, np.bool_)
        self.gains = grow(get("gains"), (n, G_SIZE))
        self.rate_state = grow(get("rate_state"), (n, STATE_SIZE))
        self.saturation = grow(get("saturation"), (n, 6), np.bool_)
        self.measured = grow(get("measured"), (n, M_SIZE))
        self.estimated = grow(get("estimated"), (n, M_SIZE))
        self.rotor_speed = grow(get("rotor_speed"), (n, self._rotors))
        old_ok = get("motor_ok")
        self.motor_ok = np.ones((n, self._rotors))
        if old_ok is not None and len(old_ok):
            self.motor_ok[:len(old_ok)] = old_ok
        self.spawn_enu = grow(get("spawn_enu"), (n, 3))
        self.forces = grow(get("forces"), (n, F_SIZE))
        self.commanded = grow(get("commanded"), (n, C_OUTPUTS + self._rotors))
        # ``control_and_forces``' arguments, gathered once per resize rather than looked up
        # attribute by attribute at every step (the arrays are only ever written in place), and
        # few: numba checks the type of every argument at every call.
        self._control_args = (
            self.mode, self.setpoint, self.use_rates_sp, self.landed, self.gains,
            self.rate_state, self.saturation, self.rotors, self.plant, self.measured,
            self.estimated, self.rotor_speed, self.wind, self.forces, self.motor_ok,
            self.commanded)
        # The rows ``load`` writes, as views: indexing a list is cheaper than a 2-D array.
        self._setpoint_rows = list(self.setpoint)
        self._rate_state_rows = list(self.rate_state)

    def add(self, spawn_enu_m: tuple[float, float, float], raw_state: tuple[float, ...]) -> int:
        """A new row for a vehicle spawned at ``spawn_enu_m`` whose PyBullet state is
        ``raw_state`` (see ``measure``); its acceleration starts at zero. Returns the row."""
        k = self.count
        self._resize(k + 1)
        self.count = k + 1
        self.setpoint[k, SP_Q] = 1.0
        self.spawn_enu[k] = spawn_enu_m
        measure(np.array([raw_state]), self.spawn_enu[k:k + 1], 0.0, self.measured[k:k + 1])
        self.estimated[k] = self.measured[k]
        return k

    def load(self, k: int, command: InnerCommand) -> None:
        """Row ``k`` takes the autopilot's ``command`` (every 50 Hz tick of every vehicle: the
        setpoint goes in element by element, cheaper than numpy's conversion of a sequence)."""
        mode, attitude_q, yawspeed, thrust, rates, landed, gains, reset_rates, motor_test = command
        self.mode[k] = mode
        if gains is not None:
            attitude, rate, thrust_model = gains
            self.gains[k] = (*attitude, *rate, thrust_model)
            reset_rates = True
        if reset_rates:
            self._rate_state_rows[k].fill(0.0)
        sp = self._setpoint_rows[k]
        sp[SP_Q], sp[SP_Q + 1], sp[SP_Q + 2], sp[SP_Q + 3] = attitude_q
        sp[SP_YAWSPEED] = yawspeed
        sp[SP_THRUST] = thrust
        self.use_rates_sp[k] = rates is not None
        if rates is not None:
            sp[SP_RATES], sp[SP_RATES + 1], sp[SP_RATES + 2] = rates
        self.landed[k] = landed
        if mode == MODE_TEST:
            n = min(len(motor_test), self._rotors)
            sp[:self._rotors] = math.nan
            sp[:n] = motor_test[:n]

    def commanded_row(self, k: int) -> list[float]:
        """Row ``k``'s last rate setpoint and commanded rotor speeds (C_* columns)."""
        return self.commanded[k].tolist()

    def control(self) -> None:
        """Motor commands, rotor speeds and the force/torque to apply for every row."""
        control_and_forces(*self._control_args)
