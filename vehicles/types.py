"""Value types shared by physics, controllers, autopilot and (read-only) the gateway.

Rules:
- Every quantity carries its unit and frame in its name: ``_m``, ``_mps``, ``_rad``, ``_radps``,
  ``_ned`` (north-east-down, local to the vehicle's EKF origin = its spawn point), ``_frd`` (body
  forward-right-down).
- Quaternions are (w, x, y, z) and rotate body FRD vectors into NED.
- Targets use NaN for "not commanded" (PX4's convention). They are validated where built.
- Nothing here knows about MAVLink, sockets or the wall clock.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from vehicles.geodesy import EARTH_RADIUS_M, GeoPoint  # noqa: F401 (re-exported)

GRAVITY_MPS2 = 9.80665

# A 3-vector of plain floats (the fast form the controllers pass around; frames in the names).
Vec3 = tuple[float, float, float]
# A unit quaternion (w, x, y, z).
Quat = tuple[float, float, float, float]


class Measurement(NamedTuple):
    """Kinematic truth of one physics step as plain floats (a NamedTuple: cheap at 250 Hz); what
    the World measures and the autopilot's 50 Hz part reads."""

    position_ned_m: Vec3
    velocity_ned_mps: Vec3
    attitude_q: Quat  # FRD -> NED
    rates_frd_radps: Vec3
    accel_ned_mps2: Vec3  # over the last physics step


class NavState(enum.IntEnum):
    """PX4 ``vehicle_status.nav_state`` values (msg/VehicleStatus.msg)."""

    MANUAL = 0
    ALTCTL = 1
    POSCTL = 2
    AUTO_MISSION = 3
    AUTO_LOITER = 4
    AUTO_RTL = 5
    POSITION_SLOW = 6
    ACRO = 10
    DESCEND = 12
    TERMINATION = 13
    OFFBOARD = 14
    STAB = 15
    AUTO_TAKEOFF = 17
    AUTO_LAND = 18
    AUTO_FOLLOW_TARGET = 19
    AUTO_PRECLAND = 20
    ORBIT = 21


class LandedState(enum.IntEnum):
    """MAV_LANDED_STATE values; PX4 never reports UNDEFINED (0)."""

    ON_GROUND = 1
    IN_AIR = 2
    TAKEOFF = 3
    LANDING = 4


class CommandResult(enum.IntEnum):
    """MAV_RESULT values, returned by every autopilot command method."""

    ACCEPTED = 0
    TEMPORARILY_REJECTED = 1
    DENIED = 2
    UNSUPPORTED = 3
    FAILED = 4
    IN_PROGRESS = 5
    CANCELLED = 6


class Severity(enum.IntEnum):
    """MAV_SEVERITY values for status texts."""

    EMERGENCY = 0
    ALERT = 1
    CRITICAL = 2
    ERROR = 3
    WARNING = 4
    NOTICE = 5
    INFO = 6
    DEBUG = 7


# PX4 SITL default home (gazebo-classic iris / jMAVSim: PX4_HOME_LAT/LON/ALT unset).
PX4_SITL_HOME = GeoPoint(47.397742, 8.545594, 488.0)


def q_euler_rad(q: tuple[float, float, float, float]) -> tuple[float, float, float]:
    """(roll, pitch, yaw) in radians of a (w, x, y, z) quaternion, ZYX as PX4's Eulerf."""
    # The math functions as module globals and the clamp as comparisons (the same values as
    # max(-1, min(1, s)), NaN included: min(1, NaN) is 1): every ATTITUDE and every 50 Hz tick.
    w, x, y, z = q
    s = 2.0 * (w * y - z * x)
    s = s if s < 1.0 else 1.0
    s = s if s > -1.0 else -1.0
    return (_atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y)), _asin(s),
            _atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))


_atan2, _asin = math.atan2, math.asin


@dataclass(frozen=True)
class VehicleState:
    """Kinematic truth of one vehicle at ``time_s`` (simulated seconds since boot)."""

    time_s: float
    position_ned_m: np.ndarray
    velocity_ned_mps: np.ndarray
    acceleration_ned_mps2: np.ndarray
    attitude_q: np.ndarray  # (w, x, y, z), FRD -> NED
    rates_frd_radps: np.ndarray

    @staticmethod
    def at_rest(time_s: float = 0.0) -> VehicleState:
        z = np.zeros(3)
        return VehicleState(time_s, z.copy(), z.copy(), z.copy(), np.array([1.0, 0, 0, 0]), z.copy())

    def euler_rad(self) -> tuple[float, float, float]:
        """(roll, pitch, yaw) in radians, ZYX convention as PX4's Eulerf."""
        w, x, y, z = (float(v) for v in self.attitude_q)
        return q_euler_rad((w, x, y, z))


class Kinematics(NamedTuple):
    """The same truth as ``VehicleState`` (without acceleration) as plain float tuples: what
    hot paths read (telemetry builders run hundreds of times per simulated second)."""

    time_s: float
    position_ned_m: tuple[float, float, float]
    velocity_ned_mps: tuple[float, float, float]
    attitude_q: tuple[float, float, float, float]  # (w, x, y, z), FRD -> NED
    rates_frd_radps: tuple[float, float, float]

    @staticmethod
    def of(state: VehicleState) -> Kinematics:
        def v3(a) -> tuple[float, float, float]:
            return (float(a[0]), float(a[1]), float(a[2]))

        q = state.attitude_q
        return Kinematics(state.time_s, v3(state.position_ned_m), v3(state.velocity_ned_mps),
                          (float(q[0]), float(q[1]), float(q[2]), float(q[3])),
                          v3(state.rates_frd_radps))

    def euler_rad(self) -> tuple[float, float, float]:
        """(roll, pitch, yaw) in radians, ZYX convention as PX4's Eulerf."""
        return q_euler_rad(self.attitude_q)


class Targets(NamedTuple):
    """What the controllers aim for, as PX4 publishes it (the ATTITUDE_TARGET,
    POSITION_TARGET_* and SERVO_OUTPUT_RAW streams read it). Angles in rad, NED/FRD."""

    time_s: float  # the autopilot tick that set them (PX4: the setpoint's timestamp)
    attitude_q: tuple[float, float, float, float]  # vehicle_attitude_setpoint q_d
    thrust_norm: float  # |thrust_body|
    rates_frd_radps: tuple[float, float, float]  # vehicle_rates_setpoint
    # vehicle_control_mode flag_multicopter_position_control_enabled: the local setpoint exists
    position_control: bool
    position_ned_m: tuple[float, float, float]  # vehicle_local_position_setpoint, NaN: none
    velocity_ned_mps: tuple[float, float, float]
    acceleration_ned_mps2: tuple[float, float, float]  # the velocity PID's (PX4 _acc_sp)
    yaw_rad: float
    yawspeed_radps: float
    # position_setpoint_triplet.current while flag_control_position_enabled and the navigator
    # has one (NED metres from the vehicle's origin; down NaN: no altitude), else None
    global_target_ned_m: tuple[float, float, float] | None
    outputs: tuple[float, ...]  # actuator_outputs: commanded rotor speeds (rad/s), 0 disarmed
    # the rate controller's normalized torque (vehicle_torque_setpoint) and integrator
    # (rate_ctrl_status *speed_integ), FRD; 0 while it does not run
    torque_sp: tuple[float, ...] = (0.0, 0.0, 0.0)  # (roll, pitch, yaw)
    rate_integral: tuple[float, ...] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class HomePosition:
    geo: GeoPoint
    position_ned_m: tuple[float, float, float]
    yaw_rad: float
    time_s: float = 0.0  # when it was set (home_position's timestamp)


@dataclass(frozen=True)
class BatteryState:
    voltage_v: float
    current_a: float
    remaining: float  # 0..1
    consumed_mah: float
    cell_count: int


class Changes:
    """Generations of what the links poll at every wake-up, like a uORB topic's generation:
    ``mission_progress`` moves whenever ``Vehicle.mission_progress`` may have (current item,
    item count, items reached), ``status_texts`` whenever a text is logged. A poller keeps the
    generation it saw last and reads the thing itself only once it has moved; a move without a
    change is allowed, a change without a move is not."""

    __slots__ = ("mission_progress", "status_texts")

    def __init__(self) -> None:
        self.mission_progress = 0
        self.status_texts = 0


@dataclass(frozen=True)
class StatusText:
    seq: int
    time_s: float
    severity: Severity
    text: str


@dataclass(frozen=True)
class VehicleStatus:
    """What the commander publishes: the gateway builds HEARTBEAT/SYS_STATUS/EXT_SYS_STATE from it."""

    time_s: float
    armed: bool
    nav_state: NavState
    landed_state: LandedState
    position_valid: bool  # EKF/GPS ready: SYS_STATUS GPS health, home can be set
    prearm_ok: bool  # arming possible in the current mode right now
    failsafe: bool
    terminated: bool
    battery: BatteryState
    home: HomePosition | None = None
    extra: dict = field(default_factory=dict)


SPAWN_SPACING_M = 5.0  # the default spawn grid: vehicles 5 m apart, ten per row eastwards,
SPAWN_COLUMNS = 10  # rows to the north


def grid_spawn_ned_m(index: int) -> tuple[float, float]:
    """Vehicle ``index``'s place on the default spawn grid (north, east metres from home)."""
    return (SPAWN_SPACING_M * (index // SPAWN_COLUMNS), SPAWN_SPACING_M * (index % SPAWN_COLUMNS))


@dataclass(frozen=True)
class SensorConfig:
    """A scenario's ``[sensors]``: ``noise`` scales every sensor's noise and bias (0 = exact;
    vehicles/estimation.py)."""

    noise: float = 1.0


PX4_SENSORS = SensorConfig()  # the noise of PX4's simulated sensors
EXACT_SENSORS = SensorConfig(noise=0.0)


class EstimatorReset(NamedTuple):
    """What the estimator reset since the tasks last looked (FlightTask::_checkEkfResetCounters,
    on vehicle_local_position's xy_, vxy_, vz_, z_reset_counter): which moved, and the last
    resets' changes (delta_xy, delta_vxy, delta_vz, delta_z)."""

    xy: bool
    vxy: bool
    vz: bool
    delta_xy: tuple[float, float]
    delta_vxy: tuple[float, float]
    delta_vz: float
    z: bool = False
    delta_z: float = 0.0
