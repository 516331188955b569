"""PyBullet backend: one DIRECT client holding every vehicle body, stepped at a fixed rate.

Rules and invariants:
- One ``World`` = one PyBullet client in DIRECT mode; every call passes ``physicsClientId``
  (never the global client), so several worlds can coexist (tests do this).
- PyBullet's world frame is ENU (x East, y North, z Up) and bodies are FLU. Everything outside
  this module is NED / FRD: ``_Body.read`` and ``_Body.apply`` are the only conversions.
- Forces are computed here in the body frame (per-rotor thrust k·ω² and reaction torque, first-
  order motor lag, linear drag), rotated to the world frame and applied at the centre of mass with
  ``WORLD_FRAME`` (PyBullet's LINK_FRAME torque on a base is unreliable). PyBullet clears external
  forces after each ``stepSimulation``, so they are applied every step.
- Fixed step ``dt_s`` (default 0.004 s = 250 Hz, PX4 lockstep), one sub-step.
- ``World.step(now_s)`` runs each vehicle's autopilot at ``now_s`` on the state measured at
  ``now_s``, then integrates to ``now_s + dt_s``; the new state is stamped ``now_s + dt_s``.
- Vehicle ``index`` spawns on a grid (``SPAWN_SPACING_M``, ``SPAWN_COLUMNS`` per row, rows to the
  north); its local NED origin is its spawn point on the ground (centre of mass at rest).
"""

from __future__ import annotations

import logging
import math

import pybullet as pb

from vehicles.airframe import X500, Airframe
from vehicles.params import ParamStore
from vehicles.types import GRAVITY_MPS2, PX4_SITL_HOME, GeoPoint
from vehicles.vehicle import Measurement, Vehicle

log = logging.getLogger(__name__)

SPAWN_SPACING_M = 5.0
SPAWN_COLUMNS = 10
GROUND_FRICTION = 1.0
_SQRT_HALF = math.sqrt(0.5)
# Spawn with the nose north (NED yaw 0): FLU x along ENU y is a +90 deg turn about ENU z.
_FACING_NORTH_XYZW = (0.0, 0.0, _SQRT_HALF, _SQRT_HALF)


class _Body:
    """One rigid body and its four motors, in one PyBullet client."""

    def __init__(self, client: int, airframe: Airframe, spawn_enu_m: tuple[float, float, float],
                 dt_s: float) -> None:
        self._c = client
        self._af = airframe
        self._dt = dt_s
        self.spawn_enu_m = spawn_enu_m
        half = [s / 2.0 for s in airframe.collision_box_m]
        shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=client)
        self.body_id = pb.createMultiBody(
            baseMass=airframe.mass_kg, baseCollisionShapeIndex=shape,
            basePosition=spawn_enu_m, baseOrientation=_FACING_NORTH_XYZW, physicsClientId=client,
        )
        pb.changeDynamics(
            self.body_id, -1,
            localInertiaDiagonal=[airframe.ixx_kgm2, airframe.iyy_kgm2, airframe.izz_kgm2],
            lateralFriction=GROUND_FRICTION, restitution=0.0, linearDamping=0.0,
            angularDamping=0.0, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING,
            physicsClientId=client,
        )
        n = airframe.rotor_count
        self.rotor_speed_radps = [0.0] * n
        self._alpha_up = 1.0 - math.exp(-dt_s / airframe.motor_time_constant_up_s)
        self._alpha_down = 1.0 - math.exp(-dt_s / airframe.motor_time_constant_down_s)
        self._rotor_xy = [(r.position_frd_m[0], r.position_frd_m[1]) for r in airframe.rotors]
        self._yaw_k = [r.yaw_sign * airframe.moment_constant_m for r in airframe.rotors]
        self._com_enu = list(spawn_enu_m)
        self._q_ned = (1.0, 0.0, 0.0, 0.0)
        self._vel_ned = (0.0, 0.0, 0.0)

    def read(self) -> Measurement:
        c = self._c
        pos, orn = pb.getBasePositionAndOrientation(self.body_id, physicsClientId=c)
        lin, ang = pb.getBaseVelocity(self.body_id, physicsClientId=c)
        self._com_enu = pos
        # ENU/FLU quaternion (x, y, z, w) -> NED/FRD (w, x, y, z): q_ned_enu ⊗ q ⊗ q_flu_frd.
        x, y, z, w = orn
        s = _SQRT_HALF
        q = (s * (w + z), s * (x + y), s * (x - y), s * (w - z))
        if q[0] < 0.0:
            q = (-q[0], -q[1], -q[2], -q[3])
        self._q_ned = q
        sx, sy, sz = self.spawn_enu_m
        position = (pos[1] - sy, pos[0] - sx, sz - pos[2])
        velocity = (lin[1], lin[0], -lin[2])
        self._vel_ned = velocity
        # Body rates: R^T · ω_ned.
        wn, we, wd = ang[1], ang[0], -ang[2]
        qw, qx, qy, qz = q
        r00 = 1 - 2 * (qy * qy + qz * qz)
        r01 = 2 * (qx * qy - qw * qz)
        r02 = 2 * (qx * qz + qw * qy)
        r10 = 2 * (qx * qy + qw * qz)
        r11 = 1 - 2 * (qx * qx + qz * qz)
        r12 = 2 * (qy * qz - qw * qx)
        r20 = 2 * (qx * qz - qw * qy)
        r21 = 2 * (qy * qz + qw * qx)
        r22 = 1 - 2 * (qx * qx + qy * qy)
        rates = (
            r00 * wn + r10 * we + r20 * wd,
            r01 * wn + r11 * we + r21 * wd,
            r02 * wn + r12 * we + r22 * wd,
        )
        return Measurement(position, velocity, q, rates)

    def apply(self, motor_u: tuple[float, ...] | None) -> None:
        """Advance the motor lag by one step and apply this step's force and torque."""
        af = self._af
        w_max = af.max_rotor_speed_radps
        k = af.motor_constant_n_per_radps2
        speeds = self.rotor_speed_radps
        total = tx = ty = tz = 0.0
        for i in range(len(speeds)):
            cmd = 0.0 if motor_u is None else motor_u[i] * w_max
            w = speeds[i]
            w += (cmd - w) * (self._alpha_up if cmd > w else self._alpha_down)
            speeds[i] = w
            t = k * w * w
            x, y = self._rotor_xy[i]
            total += t
            tx -= y * t
            ty += x * t
            tz += self._yaw_k[i] * t
        if total == 0.0 and self._vel_ned == (0.0, 0.0, 0.0):
            return
        qw, qx, qy, qz = self._q_ned
        # Body force (0, 0, -total) in NED = -total · third column of R; plus linear drag.
        c = af.linear_drag_n_per_mps
        vn, ve, vd = self._vel_ned
        fn = -total * 2 * (qx * qz + qw * qy) - c * vn
        fe = -total * 2 * (qy * qz - qw * qx) - c * ve
        fd = -total * (1 - 2 * (qx * qx + qy * qy)) - c * vd
        # Body torque into NED: R · τ.
        mn = (1 - 2 * (qy * qy + qz * qz)) * tx + 2 * (qx * qy - qw * qz) * ty + 2 * (qx * qz + qw * qy) * tz
        me = 2 * (qx * qy + qw * qz) * tx + (1 - 2 * (qx * qx + qz * qz)) * ty + 2 * (qy * qz - qw * qx) * tz
        md = 2 * (qx * qz - qw * qy) * tx + 2 * (qy * qz + qw * qx) * ty + (1 - 2 * (qx * qx + qy * qy)) * tz
        c_id = self._c
        pb.applyExternalForce(self.body_id, -1, (fe, fn, -fd), self._com_enu, pb.WORLD_FRAME,
                              physicsClientId=c_id)
        pb.applyExternalTorque(self.body_id, -1, (me, mn, -md), pb.WORLD_FRAME,
                               physicsClientId=c_id)


class World:
    """Every vehicle of the simulation in one PyBullet client (see module rules)."""

    def __init__(self, dt_s: float = 0.004, home: GeoPoint = PX4_SITL_HOME,
                 airframe: Airframe = X500) -> None:
        self.dt_s = dt_s
        self.home = home
        self.airframe = airframe
        self.time_s = 0.0
        self.client_id = pb.connect(pb.DIRECT)
        c = self.client_id
        pb.setGravity(0, 0, -GRAVITY_MPS2, physicsClientId=c)
        pb.setPhysicsEngineParameter(fixedTimeStep=dt_s, numSubSteps=1, physicsClientId=c)
        plane = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=c)
        self.ground_id = pb.createMultiBody(0, plane, physicsClientId=c)
        pb.changeDynamics(self.ground_id, -1, lateralFriction=GROUND_FRICTION, restitution=0.0,
                          physicsClientId=c)
        self._vehicles: list[Vehicle] = []
        self._bodies: list[_Body] = []
        self._closed = False

    @property
    def vehicles(self) -> tuple[Vehicle, ...]:
        return tuple(self._vehicles)

    @staticmethod
    def spawn_offset_ned_m(index: int) -> tuple[float, float]:
        return (SPAWN_SPACING_M * (index // SPAWN_COLUMNS), SPAWN_SPACING_M * (index % SPAWN_COLUMNS))

    def add_vehicle(self, index: int, params: ParamStore | None = None) -> Vehicle:
        if any(v.index == index for v in self._vehicles):
            raise ValueError(f"vehicle index {index} already exists")
        north, east = self.spawn_offset_ned_m(index)
        body = _Body(self.client_id, self.airframe, (east, north, self.airframe.rest_height_m),
                     self.dt_s)
        origin = self.home.offset_ned(north, east, 0.0)
        vehicle = Vehicle(index, params if params is not None else ParamStore(), self.airframe,
                          origin, self.dt_s, boot_time_s=self.time_s)
        vehicle._measure(self.time_s, body.read())
        self._vehicles.append(vehicle)
        self._bodies.append(body)
        log.debug("vehicle %d spawned at N%.1f E%.1f (client %d)", index, north, east, self.client_id)
        return vehicle

    def step(self, now_s: float) -> None:
        for vehicle, body in zip(self._vehicles, self._bodies):
            body.apply(vehicle._control(now_s))
        pb.stepSimulation(physicsClientId=self.client_id)
        t = now_s + self.dt_s
        for vehicle, body in zip(self._vehicles, self._bodies):
            vehicle._measure(t, body.read())
            vehicle._rotor_speed_radps = body.rotor_speed_radps
        self.time_s = t

    def close(self) -> None:
        if not self._closed:
            pb.disconnect(physicsClientId=self.client_id)
            self._closed = True
