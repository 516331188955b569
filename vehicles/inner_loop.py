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
from vehicles.control.mixer import (
    ROW_SIZE,
    allocation_rows,
    clip_into,
    desaturate_into,
    pseudo_inverse_into,
)
from vehicles.control.rate_control import STATE_INTEGRAL, STATE_SIZE, d_filter_alpha, rate_pid
from vehicles.control.rotation import dcm

MODE_OFF = 0
MODE_IDLE = 1
MODE_FLY = 2
# Disarmed, with PX4's actuator test (MAV_CMD_ACTUATOR_TEST) driving motors: ``tests`` holds each
# motor's test value (0..1 over its output's range; NaN: the output stays at its disarmed value).
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
# Columns of ``InnerLoop.rotors`` (one row per rotor of the airframe, where the thrust acts):
# the rotor's x and y (FRD, m), its reaction torque per newton of thrust (signed, m).
R_X, R_Y, R_YAW_K, R_SIZE = 0, 1, 2, 3
# ``InnerLoop.alloc``: per row, the allocation PX4's control_allocator makes from CA_ROTOR_COUNT
# and CA_ROTORn_* (mixer.allocation_rows): item 0 holds the motor count (column A_COUNT) and
# CA_METHOD (A_METHOD), items 1.. the rows ``mix_into`` takes, one per motor (at most
# MAX_MOTORS: NUM_ROTORS_MAX), with the motor's CA_Rn_SLEW (s; 0: none) in column A_SLEW.
MAX_MOTORS, A_COUNT, A_METHOD, A_SLEW, A_SIZE = 12, 0, 1, ROW_SIZE, ROW_SIZE + 1
CA_METHOD_PSEUDO_INVERSE = 0  # with output clipping; 1 and 2 (automatic): sequential desaturation
FLT_EPSILON = 1.1920929e-07
# Columns of ``InnerLoop.outputs`` (per row, one per rotor: the gz bridge's ESC outputs, which
# the x500 model's motors 0.. take): SIM_GZ_EC_FUNCn, _MINn, _MAXn, _DISn, and 1.0 where
# SIM_GZ_EC_REV has the output's bit.
O_FUNCTION, O_MIN, O_MAX, O_DISARMED, O_REVERSE, O_SIZE = 0, 1, 2, 3, 4, 5
# Output functions (PX4's output_functions.yaml): Constant Min, Constant Max, Motor 1 (..12).
FUNCTION_CONSTANT_MIN, FUNCTION_CONSTANT_MAX, FUNCTION_MOTOR1 = 1, 2, 101
CA_ROTOR_CT_DEFAULT, CA_METHOD_DEFAULT = 6.5, 2  # control_allocator/module.yaml
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
    motor_test: tuple[float, ...] = ()  # MODE_TEST: each motor's test value (NaN: none)


@njit_cached
def esc_output(o, u, flying: bool) -> float:  # pragma: no cover
    """One ESC output of the gz bridge (MixingOutput): ``o`` its O_* configuration (uint16
    values, minimum ≤ maximum: allocation_params.esc_outputs), ``u`` the motors' commands (0..1,
    NaN: none); ``flying``: armed, not in the actuator test (the constant functions then hold
    too). A motor's command over SIM_GZ_EC_MIN..MAX (output_limit_calc_single: the range
    reversed by SIM_GZ_EC_REV, the result rounded as lroundf and kept within 0..65535); no value
    (disarmed, no function, a motor beyond CA_ROTOR_COUNT): SIM_GZ_EC_DIS."""
    f = o[O_FUNCTION]
    x = math.nan
    if FUNCTION_MOTOR1 <= f < FUNCTION_MOTOR1 + MAX_MOTORS:
        x = u[int(f) - FUNCTION_MOTOR1]
    elif flying and f == FUNCTION_CONSTANT_MIN:
        x = 0.0
    elif flying and f == FUNCTION_CONSTANT_MAX:
        x = 1.0
    if math.isnan(x):
        return o[O_DISARMED]
    if o[O_REVERSE] != 0.0:
        x = 1.0 - x
    x = max(0.0, min(x, 1.0))
    return max(0.0, min(math.floor(o[O_MIN] + (o[O_MAX] - o[O_MIN]) * x + 0.5), 65535.0))


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
                       rotors, alloc, last_sp, outputs, tests, plant, measured, estimated,
                       rotor_speed, wind, forces, motor_ok, commanded):  # pragma: no cover
    """One physics step of every vehicle's inner loop (module rules). The controllers fly on
    ``estimated`` (attitude, gyro rates less their bias); the physics acts on ``measured``, the
    truth. ``rotors``: the airframe's rotors (R_* columns: where they push); ``alloc``: each
    row's allocation (A_* items: the count, CA_METHOD, ``mix_into``'s rows and CA_Rn_SLEW, one
    per motor of CA_ROTOR_COUNT); ``last_sp``: each motor's last allocated setpoint (the slew
    rate limit's _prev_actuator_sp); ``outputs``: each row's ESC outputs (O_* columns, one per
    rotor: SIM_GZ_EC_FUNCn, _MINn, _MAXn, _DISn and the SIM_GZ_EC_REV bit); ``tests``: each
    motor's actuator test value (MODE_TEST; NaN: not tested); ``plant``: max rotor speed, motor
    constant, lag coefficient up, lag coefficient down, linear drag, idle thrust, the D term's
    filter coefficient, the step (s); ``wind``: the air's velocity (NED), which the drag acts
    against; ``motor_ok``: 0 for a rotor whose motor has failed (failure injection: it spins
    down). ``commanded`` (out): per row the rate controller's setpoint (C_RATES_SP, PX4
    vehicle_rates_setpoint; 0 when it does not run), its torque and integrator (C_TORQUE_SP,
    C_RATE_INT; 0 when it does not run) and each output's value (C_OUTPUTS, rad/s: PX4's
    actuator_outputs as the gz bridge's ESC outputs carry them, before the motor's lag and
    whatever failure injection did to the motor)."""
    w_max, k_motor, alpha_up, alpha_down, drag = plant[0], plant[1], plant[2], plant[3], plant[4]
    idle, alpha, dt_s = plant[5], plant[6], plant[7]
    n_rotors = len(rotors)
    u = np.zeros(MAX_MOTORS)  # actuator_motors: each motor's command, NaN: none
    for v in range(len(mode)):
        m = measured[v]
        q = (m[M_Q], m[M_Q + 1], m[M_Q + 2], m[M_Q + 3])
        est = estimated[v]
        q_est = (est[M_Q], est[M_Q + 1], est[M_Q + 2], est[M_Q + 3])
        out_cmd = commanded[v]
        for i in range(C_OUTPUTS):
            out_cmd[i] = 0.0
        count = int(alloc[v, 0, A_COUNT])
        rows = alloc[v, 1:count + 1]
        motors = u[:count]
        u[:] = math.nan
        armed = mode[v] != MODE_OFF
        if mode[v] == MODE_TEST:
            rate_state[v, :] = 0.0
            for i in range(MAX_MOTORS):
                x = tests[v, i]
                # NaN (or below 0): stopped; the test value goes through the thrust model too
                u[i] = thrust_model(min(x, 1.0), gains[v, G_THR_MDL_FAC]) if x >= 0.0 else math.nan
        elif armed:
            thrust = roll = pitch = yaw = 0.0
            if mode[v] == MODE_IDLE:
                rate_state[v, :] = 0.0
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
                thrust, roll, pitch, yaw = c[SP_THRUST], torque[0], torque[1], torque[2]
                for i in range(3):
                    out_cmd[C_TORQUE_SP + i] = torque[i]
                    out_cmd[C_RATE_INT + i] = rate_state[v, STATE_INTEGRAL + i]
            # ControlAllocator::Run: allocate, the slew rate limit, clip
            if alloc[v, 0, A_METHOD] == CA_METHOD_PSEUDO_INVERSE:
                pseudo_inverse_into(thrust, roll, pitch, yaw, rows, motors)
            else:
                desaturate_into(thrust, roll, pitch, yaw, rows, motors)
            prev = last_sp[v]
            for i in range(count):
                slew_s = rows[i, A_SLEW]
                if slew_s > FLT_EPSILON:
                    step = dt_s / slew_s
                    motors[i] = max(prev[i] - step, min(motors[i], prev[i] + step))
            flags = clip_into(roll, pitch, yaw, rows, idle, motors)
            for i in range(count):
                prev[i] = motors[i]
            if mode[v] == MODE_FLY:
                for i in range(6):
                    saturation[v, i] = flags[i]
            factor = gains[v, G_THR_MDL_FAC]
            if factor > 0.0:
                for i in range(count):
                    u[i] = thrust_model(u[i], factor)
        if not armed or mode[v] == MODE_TEST:
            last_sp[v, :] = 0.0  # the allocator's zero thrust and torque while disarmed
        # Motor lag (first order, faster up than down) and the rotors' thrust and torque.
        speeds = rotor_speed[v]
        total = tx = ty = tz = 0.0
        for i in range(n_rotors):
            cmd = esc_output(outputs[v, i], u, armed and mode[v] != MODE_TEST)
            out_cmd[C_OUTPUTS + i] = cmd
            # the gz model's MulticopterMotorModel: at most maxRotVelocity either way
            cmd = max(-w_max, min(cmd, w_max)) * motor_ok[v, i]
            w = speeds[i]
            w += (cmd - w) * (alpha_up if cmd > w else alpha_down)
            speeds[i] = w
            t = k_motor * w * abs(w)
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


# Allocations made, by geometry (set_allocation_into; at most 64 kept)
_ALLOCATIONS: dict[tuple[tuple[float, ...], ...], np.ndarray] = {}


class InnerLoop:
    """The arrays of every vehicle's inner loop and the two kernels over them (module rules)."""

    def __init__(self, airframe: Airframe, dt_s: float, idle_thrust_norm: float) -> None:
        self.dt_s = dt_s
        self.idle_thrust_norm = idle_thrust_norm
        self.alpha = d_filter_alpha(dt_s)
        self.rotors = np.array([
            (r.position_frd_m[0], r.position_frd_m[1], r.yaw_sign * airframe.moment_constant_m)
            for r in airframe.rotors], dtype=float)
        # What a new row starts with: 4001_gz_x500's allocation (CA_ROTOR_COUNT and CA_ROTORn_*,
        # CA_ROTORn_CT at its default) and ESC outputs (SIM_GZ_EC_FUNCn = Motor n, MIN, MAX).
        self.default_alloc = np.zeros((MAX_MOTORS + 1, A_SIZE))
        self.set_allocation_into(self.default_alloc, [
            (px, py, 0.0, 0.0, 0.0, -1.0, CA_ROTOR_CT_DEFAULT, km)
            for px, py, km in airframe.allocation_rotors], CA_METHOD_DEFAULT, ())
        self.default_outputs = np.array([
            (FUNCTION_MOTOR1 + i, airframe.esc_min_radps, airframe.esc_max_radps, 0.0, 0.0)
            for i in range(airframe.rotor_count)], dtype=float)
        self.plant = np.array([
            airframe.max_rotor_speed_radps, airframe.motor_constant_n_per_radps2,
            1.0 - math.exp(-dt_s / airframe.motor_time_constant_up_s),
            1.0 - math.exp(-dt_s / airframe.motor_time_constant_down_s),
            airframe.linear_drag_n_per_mps, idle_thrust_norm, self.alpha, dt_s,
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
        self.alloc = grow(get("alloc"), (n, MAX_MOTORS + 1, A_SIZE))
        self.last_sp = grow(get("last_sp"), (n, MAX_MOTORS))
        self.outputs = grow(get("outputs"), (n, self._rotors, O_SIZE))
        self.tests = grow(get("tests"), (n, MAX_MOTORS))
        # ``control_and_forces``' arguments, gathered once per resize rather than looked up
        # attribute by attribute at every step (the arrays are only ever written in place), and
        # few: numba checks the type of every argument at every call.
        self._control_args = (
            self.mode, self.setpoint, self.use_rates_sp, self.landed, self.gains,
            self.rate_state, self.saturation, self.rotors, self.alloc, self.last_sp, self.outputs,
            self.tests,
            self.plant, self.measured, self.estimated, self.rotor_speed, self.wind, self.forces,
            self.motor_ok, self.commanded)
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
        self.alloc[k] = self.default_alloc
        self.outputs[k] = self.default_outputs
        self.tests[k] = math.nan
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
            n = min(len(motor_test), MAX_MOTORS)
            tests = self.tests[k]
            tests[:] = math.nan
            tests[:n] = motor_test[:n]

    @staticmethod
    def set_allocation_into(alloc: np.ndarray, geometry: list[tuple[float, ...]], method: int,
                            slews_s: tuple[float, ...]) -> None:
        """``alloc`` (one row's A_* items) for rotors given as (CA_ROTORn_PX, _PY, _PZ, _AX, _AY,
        _AZ, _CT, _KM), at most MAX_MOTORS, allocated by CA_METHOD ``method`` with the motors'
        CA_Rn_SLEW ``slews_s`` (ControlAllocator's update of the effectiveness and parameters)."""
        key = tuple(tuple(float(v) for v in rotor) for rotor in geometry[:MAX_MOTORS])
        rows = _ALLOCATIONS.get(key)
        if rows is None:  # a World's vehicles share their geometry: one pseudo-inverse
            rows = _ALLOCATIONS[key] = allocation_rows(key)
            if len(_ALLOCATIONS) > 64:
                _ALLOCATIONS.pop(next(iter(_ALLOCATIONS)))
        n = len(key)
        alloc[:] = 0.0
        alloc[0, A_COUNT], alloc[0, A_METHOD] = n, method
        alloc[1:n + 1, :ROW_SIZE] = rows
        for i, slew_s in enumerate(slews_s[:n]):
            alloc[1 + i, A_SLEW] = slew_s

    def set_allocation(self, k: int, geometry: list[tuple[float, ...]], method: int,
                       slews_s: tuple[float, ...]) -> None:
        """Row ``k``'s allocation (``set_allocation_into``)."""
        self.set_allocation_into(self.alloc[k], geometry, method, slews_s)

    def set_outputs(self, k: int, outputs: list[tuple[float, ...]]) -> None:
        """Row ``k``'s ESC outputs (O_* columns, one per rotor: SIM_GZ_EC_FUNCn, _MINn, _MAXn,
        _DISn, the SIM_GZ_EC_REV bit)."""
        self.outputs[k] = outputs

    def commanded_row(self, k: int) -> list[float]:
        """Row ``k``'s last rate setpoint and commanded rotor speeds (C_* columns)."""
        return self.commanded[k].tolist()

    def control(self) -> None:
        """Motor commands, rotor speeds and the force/torque to apply for every row."""
        control_and_forces(*self._control_args)
