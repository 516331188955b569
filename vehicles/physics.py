"""PyBullet backend: one DIRECT client holding every vehicle body, stepped at a fixed rate.

Rules and invariants:
- One ``World`` = one PyBullet client in DIRECT mode; every call passes ``physicsClientId``
  (never the global client), so several worlds can coexist (tests do this).
- PyBullet's world frame is ENU (x East, y North, z Up) and bodies are FLU. Everything outside
  this module and vehicles/inner_loop.py is NED / FRD; the inner loop's ``measure`` and
  ``control_and_forces`` kernels are the only conversions.
- Forces are computed in the body frame (per-rotor thrust k·ω² and reaction torque, first-order
  motor lag, linear drag; inner_loop.py), rotated to the world frame and applied at the centre of
  mass with ``WORLD_FRAME`` (PyBullet's LINK_FRAME torque on a base is unreliable). PyBullet
  clears external forces after each ``stepSimulation``, so they are applied every step.
- A step is: every vehicle's autopilot (its 50 Hz part when due, Python) handing its row of the
  inner loop a new command when it has one, one compiled call for every
  vehicle's attitude/rate/mixer/motor loop, the PyBullet calls per body, one compiled call
  (``after_physics``) that turns the bodies' states into measurements, samples every vehicle's
  sensors and updates its estimate (estimation.py). So a step enters compiled code twice,
  whatever the number of vehicles: numba's per-call cost (checking each argument's type) is
  paid twice, not per kernel and vehicle. PyBullet has no call that reads or pushes many bodies
  at once, so the per-body calls stay.
- The controllers, the autopilot and the telemetry read the estimate (``measurement``), the
  physics and the radio's position the truth (``truth``).
- Fixed step ``dt_s`` (default 0.004 s = 250 Hz, PX4 lockstep), one sub-step.
- ``World.step(now_s)`` steps each vehicle (``Vehicle.step_functions``) at ``now_s`` on the state
  measured at ``now_s``, then integrates to ``now_s + dt_s``; the new state is stamped
  ``now_s + dt_s``. A vehicle's 50 Hz part runs on every POSITION_CONTROL_DIVIDER-th step from
  its index's (counted from the step it was added at), so the World's vehicles do not all do
  their 50 Hz work on one step.
- Vehicle ``index`` spawns where ``spawn_ned_m[index]`` says (metres north, east of home), else on
  a grid (``SPAWN_SPACING_M``, ``SPAWN_COLUMNS`` per row, rows to the north); its local NED origin
  is its spawn point on the ground (centre of mass at rest).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from vehicles.airframe import X500, Airframe
from vehicles.allocation_params import allocation, esc_outputs
from vehicles.autopilot import POSITION_CONTROL_DIVIDER
from vehicles.control import compiled, position_control, position_smoothing
from vehicles.control.compiled import njit_cached
from vehicles.estimation import (
    BARO_RATE_HZ,
    E_AID_AGE,
    E_RATIOS,
    E_Z_RESET,
    GPS_RATE_HZ,
    HISTORY,
    NAVSAT_RATE_HZ,
    R_ACC,
    R_ACC_IN,
    R_ACC_LP,
    R_GYRO,
    R_Q,
    R_RATES,
    R_SIZE,
    R_TRUE_Q,
    R_TRUE_RATES,
    S_ACC,
    S_GYRO,
    Estimation,
    estimate,
)
from vehicles.inner_loop import (
    IDLE_THRUST_NORM,
    M_ACCEL,
    M_POS,
    M_Q,
    M_RATES,
    M_VEL,
    MODE_FLY,
    O_DISARMED,
    RAW_SIZE,
    InnerLoop,
    measure,
)
from vehicles.params import ParamStore
from vehicles.quiet_import import import_quietly
from vehicles.sensing import sense
from vehicles.types import (
    EXACT_SENSORS,
    GRAVITY_MPS2,
    PX4_SITL_HOME,
    GeoPoint,
    Measurement,
    SensorConfig,
    grid_spawn_ned_m,
)
from vehicles.vehicle import Vehicle
from vehicles.vehicle_acceleration import (
    IMU_ACCEL_CUTOFF_HZ,
    RESET_STEPS,
    cutoff_update,
    filter_cutoff_hz,
    lowpass2p,
    lowpass_accel,
)
from vehicles.wind import Wind

pb = import_quietly("pybullet")
log = logging.getLogger(__name__)
_uncached_warned = False  # the warning about numba's cache is given once per process

GROUND_FRICTION = 1.0
_SQRT_HALF = math.sqrt(0.5)
# Spawn with the nose north (NED yaw 0): FLU x along ENU y is a +90 deg turn about ENU z.
_FACING_NORTH_XYZW = (0.0, 0.0, _SQRT_HALF, _SQRT_HALF)


@njit_cached
def navsat_steps_ago(t_s, dt_s):  # pragma: no cover - compiled
    """Steps since the one that took the last navsat sample before ``t_s`` (a sample is due in
    the first step ending at or after each multiple of its period, as ``gps_due``'s rule)."""
    tick_s = math.floor(t_s * NAVSAT_RATE_HZ + 1e-9) / NAVSAT_RATE_HZ
    tick_step = math.ceil(tick_s / dt_s - 1e-6)
    return max(0, min(HISTORY - 1, int(round(t_s / dt_s)) - tick_step))


@njit_cached
def after_physics(raw, meas_dt_s, t_s, hist_i, noise_j, spawn_enu, measured, estimated, mode,
                  landed, recent, dt_s, scale, noise, delay, hist, bias, sensed, sense_consts,
                  failed, aiding, hparams, est, ehist, est_consts, acc_lp, acc_lp_reset
                  ):  # pragma: no cover - compiled
    """Everything compiled that follows PyBullet's step, for every row, in one call: ``raw``
    (RAW_SIZE numbers per body, flat) into the true state, then the sensors and the estimate
    (estimation.py). ``meas_dt_s``: the time since the last measurement (the acceleration's
    finite difference); ``t_s``: the time the step ended at; ``hist_i``, ``noise_j``: this
    step's slot of the history rings (``recent`` too) and column of the noise block."""
    n = len(measured)
    measure(raw.reshape((n, RAW_SIZE)), spawn_enu, meas_dt_s, measured)
    # Whether a barometer/magnetometer sample and a GPS fix fall within this step, and how many
    # steps ago the last navsat sample (the GPS's ground truth) fell.
    baro_due = int(t_s * BARO_RATE_HZ + 1e-9) != int((t_s - dt_s) * BARO_RATE_HZ + 1e-9)
    gps_due = int(t_s * GPS_RATE_HZ + 1e-9) != int((t_s - dt_s) * GPS_RATE_HZ + 1e-9)
    navsat_age = navsat_steps_ago(t_s, dt_s)
    sense(measured, noise, noise_j, dt_s, scale, baro_due, gps_due, navsat_age, hist, hist_i,
          bias, sensed, sense_consts, failed)
    flying = np.empty(n, np.bool_)  # the rows whose drag tells the wind
    for v in range(n):
        flying[v] = mode[v] == MODE_FLY and not landed[v]
    estimate(sensed, est, ehist, hist_i, delay, dt_s, t_s, baro_due, gps_due, flying, est_consts,
             estimated, failed, aiding, hparams)
    for v in range(n):
        r, s, e, m = recent[v, hist_i], sensed[v], estimated[v], measured[v]
        for i in range(3):
            r[R_GYRO + i] = s[S_GYRO + i]
            r[R_ACC + i] = s[S_ACC + i]
            r[R_RATES + i] = e[M_RATES + i]
            r[R_TRUE_RATES + i] = m[M_RATES + i]
        for i in range(4):
            r[R_Q + i] = e[M_Q + i]
            r[R_TRUE_Q + i] = m[M_Q + i]
    lowpass_accel(recent, hist_i, sensed, est, acc_lp, acc_lp_reset)


def _accel_cutoff_param(params: ParamStore) -> float:
    return float(params.get("IMU_ACCEL_CUTOFF", IMU_ACCEL_CUTOFF_HZ) or 0.0)


def _create_body(client: int, airframe: Airframe, spawn_enu_m: tuple[float, float, float]) -> int:
    """One rigid box with the airframe's mass and inertia, nose north, in ``client``."""
    half = [s / 2.0 for s in airframe.collision_box_m]
    shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=client)
    body_id = pb.createMultiBody(
        baseMass=airframe.mass_kg, baseCollisionShapeIndex=shape,
        basePosition=spawn_enu_m, baseOrientation=_FACING_NORTH_XYZW, physicsClientId=client,
    )
    pb.changeDynamics(
        body_id, -1,
        localInertiaDiagonal=[airframe.ixx_kgm2, airframe.iyy_kgm2, airframe.izz_kgm2],
        lateralFriction=GROUND_FRICTION, restitution=0.0, linearDamping=0.0,
        angularDamping=0.0, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING,
        physicsClientId=client,
    )
    return body_id


class World:
    """Every vehicle of the simulation in one PyBullet client (see module rules)."""

    def __init__(self, dt_s: float = 0.004, home: GeoPoint = PX4_SITL_HOME,
                 airframe: Airframe = X500, wind: Wind | None = None,
                 sensors: SensorConfig = EXACT_SENSORS,
                 rng_for: Callable[[int], np.random.Generator] | None = None,
                 spawn_ned_m: Sequence[tuple[float, float]] = ()) -> None:
        """``wind``: the air every body moves through (wind.py); None: calm. ``sensors``: how
        noisy the sensors are (estimation.py); ``rng_for(index)``: vehicle ``index``'s seeded
        noise stream (needed when ``sensors.noise`` > 0). ``spawn_ned_m[index]``: where vehicle
        ``index`` spawns, (north, east) metres from home; vehicles past its end: the grid."""
        self._spawn = tuple((float(n), float(e)) for n, e in spawn_ned_m)
        self.dt_s = dt_s
        self.wind = wind
        self.home = home
        self.airframe = airframe
        self.time_s = 0.0
        self.steps = 0  # physics steps taken: a vehicle's cached views are valid for one step
        self.client_id = pb.connect(pb.DIRECT)
        c = self.client_id
        pb.setGravity(0, 0, -GRAVITY_MPS2, physicsClientId=c)
        pb.setPhysicsEngineParameter(fixedTimeStep=dt_s, numSubSteps=1, physicsClientId=c)
        plane = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=c)
        self.ground_id = pb.createMultiBody(0, plane, physicsClientId=c)
        pb.changeDynamics(self.ground_id, -1, lateralFriction=GROUND_FRICTION, restitution=0.0,
                          physicsClientId=c)
        self.inner = InnerLoop(airframe, dt_s, IDLE_THRUST_NORM)  # compiles its kernels
        self.estimation = Estimation(dt_s, sensors, airframe.mass_kg,
                                     airframe.linear_drag_n_per_mps, rng_for)
        self.recent = np.zeros((0, HISTORY, R_SIZE))  # the recent-steps ring (R_* columns)
        self._vehicles: list[Vehicle] = []
        self._tick_phase: list[int] = []  # per row: steps % POSITION_CONTROL_DIVIDER of its ticks
        # per step of the POSITION_CONTROL_DIVIDER: (row, parameters, step function) of each
        # vehicle, its 50 Hz ``step`` on its phase, its ``poll`` on the others
        self._schedule: list[list[tuple[int, ParamStore, Callable[[float], Any]]]] = [
            [] for _ in range(POSITION_CONTROL_DIVIDER)]
        self._bind()
        self._after_physics(np.zeros(0), 0.0, 0.0)  # compile (or load) it now, with no rows
        position_control.compile_now()
        position_smoothing.compile_now()
        global _uncached_warned
        if compiled.UNCACHED and not _uncached_warned:
            _uncached_warned = True
            log.warning("numba found no writable cache directory, so %s are compiled at every "
                        "start (a few seconds): set NUMBA_CACHE_DIR to a writable directory",
                        ", ".join(compiled.UNCACHED))
        self._body_ids: list[int] = []
        self._com_enu: list[tuple[float, float, float]] = []  # where forces are applied
        # each row's vehicle_acceleration filter: (parameter version seen, its cutoff in Hz)
        self._acc_filter: list[tuple[int, float]] = []
        # each row's allocation parameters as last applied (_set_allocation)
        self._allocation: list[tuple | None] = []
        self._truth_rows: list[list[float]] | None = None  # ``inner.measured`` as lists
        self._closed = False

    @property
    def vehicles(self) -> tuple[Vehicle, ...]:
        return tuple(self._vehicles)

    def spawn_offset_ned_m(self, index: int) -> tuple[float, float]:
        """Where vehicle ``index`` spawns (north, east metres from home)."""
        return self._spawn[index] if index < len(self._spawn) else grid_spawn_ned_m(index)

    def add_vehicle(self, index: int, params: ParamStore | None = None) -> Vehicle:
        if any(v.index == index for v in self._vehicles):
            raise ValueError(f"vehicle index {index} already exists")
        north, east = self.spawn_offset_ned_m(index)
        spawn = (east, north, self.airframe.rest_height_m)
        body_id = _create_body(self.client_id, self.airframe, spawn)
        row = self.inner.add(spawn, self._read(body_id))
        store = params if params is not None else ParamStore()
        cutoff = _accel_cutoff_param(store)
        self.estimation.add(index, self.inner.measured[row], self.inner.estimated[row],
                            float(store.get("EKF2_GPS_DELAY", 110.0) or 0.0) * 1e-3,
                            lowpass2p(1.0 / self.dt_s, cutoff), store.get("EKF2_HGT_REF"))
        self._set_aiding(row, store)
        self._allocation.append(None)
        self._set_allocation(row, store)
        # followed at every parameter change (_params_changed), as EKF2's parameters are
        self._acc_filter.append((store.version, filter_cutoff_hz(1.0 / self.dt_s, cutoff)))
        self._truth_rows = None
        self.recent = np.concatenate([self.recent, np.zeros((1, HISTORY, R_SIZE))])
        # VehicleAcceleration resets its filter to the first sample: at rest, -g along z (FRD)
        self.recent[-1, :, R_ACC_IN + 2] = self.recent[-1, :, R_ACC_LP + 2] = -GRAVITY_MPS2
        origin = self.home.offset_ned(north, east, 0.0)
        vehicle = Vehicle(index, store, self.airframe,
                          origin, self.dt_s, boot_time_s=self.time_s, world=self, row=row)
        self._vehicles.append(vehicle)
        self._body_ids.append(body_id)
        self._com_enu.append(spawn)
        tick_phase = (self.steps + index) % POSITION_CONTROL_DIVIDER
        self._tick_phase.append(tick_phase)
        step, poll = vehicle.step_functions()
        for phase, entries in enumerate(self._schedule):
            entries.append((row, store, step if phase == tick_phase else poll))
        self._bind()
        log.debug("vehicle %d spawned at N%.1f E%.1f (client %d)", index, north, east, self.client_id)
        return vehicle

    def _bind(self) -> None:
        """What the step and the readers take, gathered once per added row rather than looked up
        at every step or read (the arrays are only ever written in place until the next row
        grows them): ``after_physics``' arrays, each row's views."""
        inner, estimation = self.inner, self.estimation
        self._after_args = (
            inner.spawn_enu, inner.measured, inner.estimated, inner.mode, inner.landed,
            self.recent, self.dt_s, *estimation.kernel_args())
        self._estimated_rows = list(inner.estimated)
        self._sensed_rows = list(estimation.sensed)
        self._est_rows = list(estimation.est)

    def _read(self, body_id: int) -> tuple[float, ...]:
        pos, orn = pb.getBasePositionAndOrientation(body_id, physicsClientId=self.client_id)
        lin, ang = pb.getBaseVelocity(body_id, physicsClientId=self.client_id)
        return pos + orn + lin + ang

    def measurement(self, row: int) -> Measurement:
        """Row ``row``'s estimated state after the last step (NED/FRD): what it flies on. One row
        converted per call: a vehicle keeps its own per step, and between the autopilot's ticks
        only the few whose telemetry is due ask."""
        return _measurement(self._estimated_rows[row].tolist())

    def truth(self, row: int) -> Measurement:
        """Row ``row``'s true state after the last step (NED/FRD). Every row is converted at once:
        the network asks for every vehicle's position together."""
        rows = self._truth_rows
        if rows is None:
            rows = self._truth_rows = self.inner.measured.tolist()
        return _measurement(rows[row])

    def true_positions_ned_m(self) -> list[list[float]]:
        """Every row's true position (NED from its spawn point), in row order, in one read: the
        network asks for every vehicle's at each sync point."""
        return self.inner.measured[:, M_POS:M_POS + 3].tolist()

    def recent_steps(self, row: int, after_s: float | None) -> list[tuple[float, list[float]]]:
        """Row ``row``'s ring entries (R_* columns) of the physics steps taken after ``after_s``
        (None: the last step only; at most HISTORY steps), oldest first, each with the time it
        was taken at: ``step(now_s)`` makes its state current from ``now_s`` on."""
        t = self.time_s - self.dt_s  # the last step's
        count = 1 if after_s is None else int(round((t - after_s) / self.dt_s))
        count = max(0, min(count, HISTORY, self.steps))
        i = self.estimation.hist_i
        ring = self.recent[row]
        return [(t - k * self.dt_s, ring[(i - k) % HISTORY].tolist())
                for k in range(count - 1, -1, -1)]

    def sensors(self, row: int) -> list[float]:
        """Row ``row``'s latest sensor samples (estimation.S_* columns)."""
        return self._sensed_rows[row].tolist()

    def estimator(self, row: int) -> list[float]:
        """Row ``row``'s estimator state (estimation.E_* columns)."""
        return self._est_rows[row].tolist()

    def aiding_age_s(self, row: int) -> float:
        """Row ``row``'s time since its estimator last fused a GPS fix's horizontal position or
        velocity (estimation.E_AID_AGE): what EKF2_NOAID_TOUT counts."""
        return self._est_rows[row].item(E_AID_AGE)

    def aiding(self, row: int) -> list[float]:
        """Row ``row``'s ``aiding_age_s``, then its estimator's reset counts and changes
        (estimation.E_XY_RESET, E_VXY_RESET, E_VZ_RESET, E_Z_RESET: 10 columns)."""
        return self._est_rows[row][E_AID_AGE:E_Z_RESET + 2].tolist()

    def estimator_ratios(self, row: int) -> list[float]:
        """Row ``row``'s innovation test ratios (estimation.E_RATIOS, four columns)."""
        return self._est_rows[row][E_RATIOS:E_RATIOS + 4].tolist()

    def set_motor_off(self, row: int, motor: int, off: bool) -> None:
        """Failure injection: motor ``motor`` (0-based) of row ``row`` stops (``off``) or runs."""
        self.inner.motor_ok[row, motor] = 0.0 if off else 1.0

    def set_sensor_failed(self, row: int, bits: int, on: bool) -> None:
        """Failure injection: row ``row``'s sensors of ``bits`` (estimation.F_*) fail or work."""
        self.estimation.set_failed(row, bits, on)

    def sensor_failures(self, row: int) -> int:
        return int(self.estimation.failed[row])

    def set_wind(self, wind: Wind | None) -> None:
        """From the next step the bodies move through ``wind`` (None: calm air)."""
        self.wind = wind
        if wind is None:
            self.inner.wind[:] = 0.0

    def rotor_speeds(self, row: int) -> tuple[float, ...]:
        return tuple(self.inner.rotor_speed[row].tolist())

    def commanded(self, row: int) -> list[float]:
        """Row ``row``'s last rate setpoint and commanded rotor speeds (inner_loop C_* columns)."""
        return self.inner.commanded_row(row)

    def step(self, now_s: float) -> None:
        inner = self.inner
        if self.wind is not None:
            inner.wind[:] = self.wind.step(self.dt_s)
        load = inner.load
        acc_filter = self._acc_filter
        for k, params, vehicle_step in self._schedule[self.steps % POSITION_CONTROL_DIVIDER]:
            if params.version != acc_filter[k][0]:
                self._params_changed(k, params)
            command = vehicle_step(now_s)
            if command is not None:
                load(k, command)
        inner.control()
        # PyBullet's functions take their arguments by position too, and parse those faster.
        c = self.client_id
        apply_force, apply_torque, frame = pb.applyExternalForce, pb.applyExternalTorque, pb.WORLD_FRAME
        for body_id, f, com in zip(self._body_ids, inner.forces.tolist(), self._com_enu):
            if f[6]:
                apply_force(body_id, -1, f[0:3], com, frame, c)
                apply_torque(body_id, -1, f[3:6], frame, c)
        pb.stepSimulation(c)
        get_pose, get_velocity = pb.getBasePositionAndOrientation, pb.getBaseVelocity
        raw: list[float] = []  # RAW_SIZE numbers per body, one flat list
        extend = raw.extend
        self._com_enu = coms = []
        for body_id in self._body_ids:
            pos, orn = get_pose(body_id, c)
            lin, ang = get_velocity(body_id, c)
            coms.append(pos)
            extend(pos)
            extend(orn)
            extend(lin)
            extend(ang)
        t = now_s + self.dt_s
        # fromiter with the dtype and count: the same doubles as np.array(raw), without its
        # search of the list for a shape and a type
        self._after_physics(np.fromiter(raw, float, len(raw)), t - self.time_s, t)
        self._truth_rows = None
        self.time_s = t
        self.steps += 1

    def _set_aiding(self, row: int, params: ParamStore) -> None:
        self.estimation.set_aiding(row, params.get("EKF2_GPS_CTRL"), params.get("EKF2_BARO_CTRL"),
                                   params.get("EKF2_HGT_REF"))
        self.estimation.set_height_params(row, params.get)

    def _set_allocation(self, row: int, params: ParamStore) -> None:
        """ControlAllocator's and the gz bridge's parameter update: the row's allocation anew
        when CA_ROTOR_COUNT, a CA_ROTORn_*, CA_METHOD or a CA_Rn_SLEW changed, its ESC outputs
        when a SIM_GZ_EC_* did."""
        configured = allocation(params.get)
        outputs = esc_outputs(params.get, self.airframe.rotor_count)
        previous = self._allocation[row]
        if (configured, outputs) == previous:
            return
        if configured is not None and (previous is None or previous[0] != configured):
            geometry, method, slews = configured
            self.inner.set_allocation(row, list(geometry), method, slews)
        if outputs is not None:
            self.inner.set_outputs(row, list(outputs))
        self._allocation[row] = (configured, outputs)

    def disarmed_outputs(self, row: int) -> tuple[float, ...]:
        """Row ``row``'s ESC outputs' disarmed values (SIM_GZ_EC_DISn), as sent while disarmed."""
        return tuple(self.inner.outputs[row, :, O_DISARMED].tolist())

    def _params_changed(self, row: int, params: ParamStore) -> None:
        """Before row ``row``'s next sample: EKF2's parameter update (EKF2_GPS_CTRL, EKF2_BARO_CTRL,
        EKF2_HGT_REF), and
        VehicleAcceleration::ParametersUpdate → CheckAndUpdateFilters: IMU_ACCEL_CUTOFF more
        than 0.1 Hz from the filter's cutoff sets the filter anew (lowpass2p) and resets it to
        the last corrected sample."""
        self._set_aiding(row, params)
        self._set_allocation(row, params)
        sample_hz, param_hz = 1.0 / self.dt_s, _accel_cutoff_param(params)
        cutoff = self._acc_filter[row][1]
        new = cutoff_update(sample_hz, cutoff, param_hz)
        if new is not None:
            cutoff = new
            self.estimation.acc_lp[row] = lowpass2p(sample_hz, param_hz)
            self.estimation.acc_lp_reset[row] = RESET_STEPS
        self._acc_filter[row] = (params.version, cutoff)

    def _after_physics(self, raw: np.ndarray, meas_dt_s: float, t_s: float) -> None:
        estimation = self.estimation
        hist_i, noise_j = estimation.begin_step()
        after_physics(raw, meas_dt_s, t_s, hist_i, noise_j, *self._after_args)
        estimation.end_step()

    def close(self) -> None:
        if not self._closed:
            pb.disconnect(physicsClientId=self.client_id)
            self._closed = True


_new_tuple = tuple.__new__
_POS, _VEL, _Q = slice(M_POS, M_POS + 3), slice(M_VEL, M_VEL + 3), slice(M_Q, M_Q + 4)
_RATES, _ACCEL = slice(M_RATES, M_RATES + 3), slice(M_ACCEL, M_ACCEL + 3)


def _measurement(m: list[float]) -> Measurement:
    """A row of M_* columns as a Measurement: slices of one tuple, and the NamedTuple made as
    a tuple (its ``__new__`` is a Python function; the readers ask hundreds of times a second)."""
    t = tuple(m)
    return _new_tuple(Measurement, (t[_POS], t[_VEL], t[_Q], t[_RATES], t[_ACCEL]))
