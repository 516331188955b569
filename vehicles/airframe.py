"""One parameter source per airframe, shared by the physics backend and the controllers.

Rules:
- Values are physical (SI units in the names); the body frame is FRD, rotor positions are FRD.
- Rotors are listed in PX4 motor order (motor 1..4 = index 0..3 here).
- Derived quantities (max thrust, hover thrust, mixer rows) are computed here once, so the
  controller and the plant can never disagree about the geometry.

Source of the X500 numbers: PX4/PX4-gazebo-models ``models/x500_base/model.sdf`` (base_link
2.0 kg, ixx = iyy = 0.021667, izz = 0.04 kg m²; four rotor links of 0.016077 kg at
(±0.174, ±0.174, 0.06) m, which gz carries with the body: the rigid body here is the base with its
rotors, 2.064 kg, inertia about the base's origin by the parallel-axis rule, each rotor's own
inertia averaged over its spin) and ``models/x500/model.sdf``
(MulticopterMotorModel: motorConstant 8.54858e-06 N/(rad/s)², momentConstant 0.016 m,
maxRotVelocity 1000 rad/s, timeConstantUp 0.0125 s, timeConstantDown 0.025 s;
rotor_0 (+x,-y FLU = front-right) ccw, rotor_1 rear-left ccw, rotor_2 front-left cw,
rotor_3 rear-right cw). Collision box after the sdf's 0.354 m square base plate.

The motor command: PX4's mixer output for a motor (actuator_motors, 0..1, linear in the
allocated thrust with the default THR_MDL_FAC 0) goes to gz as a rotor speed through the ESC
output range of airframe 4001_gz_x500, SIM_GZ_EC_MINn 150 and SIM_GZ_EC_MAXn 1000 rad/s:
ω = 150 + 850·u rounded to a whole number (MixingOutput's lroundf), and 0 disarmed
(SIM_GZ_EC_DISn). Thrust, k·ω², is therefore quadratic in the
command, and an armed motor at zero command still spins at 150 rad/s. The hover command follows
from it (≈ 0.73 for the X500; PX4 sets MPC_THR_HOVER 0.60 for it and its hover-thrust estimator
converges to the plant's value).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from vehicles.control.mixer import pseudo_inverse_mix, rotor_effectiveness
from vehicles.types import GRAVITY_MPS2


@dataclass(frozen=True)
class Rotor:
    """One rotor: position in body FRD (m) and spin direction seen from above."""

    position_frd_m: tuple[float, float, float]
    ccw: bool

    @property
    def yaw_sign(self) -> float:
        # A CCW rotor's reaction torque turns the body clockwise seen from above, i.e. positive
        # yaw about FRD z (PX4 CA_ROTORx_KM > 0 for CCW).
        return 1.0 if self.ccw else -1.0


def _x500_rotors() -> tuple[Rotor, ...]:
    arm = 0.174
    return (
        Rotor((arm, arm, 0.0), ccw=True),  # motor 1 front-right
        Rotor((-arm, -arm, 0.0), ccw=True),  # motor 2 rear-left
        Rotor((arm, -arm, 0.0), ccw=False),  # motor 3 front-left
        Rotor((-arm, arm, 0.0), ccw=False),  # motor 4 rear-right
    )


# x500_base's rotor links: mass (kg), position (m, FLU; the sign does not matter here) and
# their own inertia (kg m²) about their x, y and spin axis.
_ROTOR_MASS_KG = 0.016076923076923075
_ROTOR_XYZ_M = (0.174, 0.174, 0.06)
_ROTOR_INERTIA = (3.8464910483993325e-07, 2.6115851691700804e-05, 2.649858234714004e-05)


def _with_rotors(base_kgm2: float, axis: int) -> float:
    """The base link's moment about ``axis`` (0 x, 1 y, 2 z) plus the four rotors'."""
    x, y, z = _ROTOR_XYZ_M
    arm2 = (y * y + z * z, x * x + z * z, x * x + y * y)[axis]
    own = _ROTOR_INERTIA[2] if axis == 2 else (_ROTOR_INERTIA[0] + _ROTOR_INERTIA[1]) / 2.0
    return base_kgm2 + 4 * (own + _ROTOR_MASS_KG * arm2)


@dataclass(frozen=True)
class Airframe:
    name: str = "x500"
    mass_kg: float = 2.0 + 4 * _ROTOR_MASS_KG
    ixx_kgm2: float = _with_rotors(0.02166666666666667, 0)
    iyy_kgm2: float = _with_rotors(0.02166666666666667, 1)
    izz_kgm2: float = _with_rotors(0.04, 2)
    rotors: tuple[Rotor, ...] = field(default_factory=_x500_rotors)
    motor_constant_n_per_radps2: float = 8.54858e-06
    moment_constant_m: float = 0.016
    max_rotor_speed_radps: float = 1000.0
    # The ESC output range (SIM_GZ_EC_MINn / SIM_GZ_EC_MAXn of 4001_gz_x500): command 0 → min.
    esc_min_radps: float = 150.0
    esc_max_radps: float = 1000.0
    motor_time_constant_up_s: float = 0.0125
    motor_time_constant_down_s: float = 0.025
    # Linear body drag (N per m/s), not in the sdf: a small value so that cruise needs a tilt.
    linear_drag_n_per_mps: float = 0.25
    # Collision box (full size, m) centred on the centre of mass.
    collision_box_m: tuple[float, float, float] = (0.354, 0.354, 0.1)
    # The geometry PX4's control allocation is configured with, per motor: CA_ROTORn_PX, _PY (m,
    # FRD) and _KM (4001_gz_x500; CA_ROTORn_CT cancels out in the normalization). It is not the
    # model's (±0.174 m square): PX4 SITL flies the gz x500 with this allocation, and so do we.
    allocation_rotors: tuple[tuple[float, float, float], ...] = (
        (0.13, 0.22, 0.05), (-0.13, -0.20, 0.05), (0.13, -0.22, -0.05), (-0.13, 0.20, -0.05))

    @property
    def rotor_count(self) -> int:
        return len(self.rotors)

    @property
    def max_rotor_thrust_n(self) -> float:
        return self.motor_constant_n_per_radps2 * self.max_rotor_speed_radps**2

    @property
    def max_total_thrust_n(self) -> float:
        return self.rotor_count * self.max_rotor_thrust_n

    def rotor_speed_radps(self, command: float) -> float:
        """The rotor speed an armed motor is commanded for mixer output ``command`` (0..1)."""
        return self.esc_min_radps + (self.esc_max_radps - self.esc_min_radps) * command

    def rotor_thrust_n(self, command: float) -> float:
        """One rotor's steady thrust at mixer output ``command`` (armed)."""
        w = min(self.rotor_speed_radps(command), self.max_rotor_speed_radps)
        return self.motor_constant_n_per_radps2 * w * w

    @property
    def hover_thrust_norm(self) -> float:
        """The collective thrust command (0..1, what every motor gets level and still) whose
        thrust balances gravity."""
        w = math.sqrt(self.mass_kg * GRAVITY_MPS2
                      / (self.rotor_count * self.motor_constant_n_per_radps2))
        return (w - self.esc_min_radps) / (self.esc_max_radps - self.esc_min_radps)

    @property
    def rest_height_m(self) -> float:
        """Height of the centre of mass above the ground when resting on it."""
        return self.collision_box_m[2] / 2.0

    def mixer_rows(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        """Per-motor command change for unit normalized roll, pitch and yaw torque: PX4's
        multicopter allocation (control_allocator: ActuatorEffectivenessRotors' effectiveness
        from ``allocation_rotors`` with thrust along -z, then ControlAllocationPseudoInverse's
        pseudo-inverse and normalization, see vehicles/control/mixer.py ``pseudo_inverse_mix``;
        the thrust column becomes -1 per motor, so the collective thrust is the motor command).
        Roll (right side down) raises the left motors, pitch (nose up) the front ones, yaw the
        motors whose KM > 0 (counter-clockwise)."""
        mix = pseudo_inverse_mix(rotor_effectiveness(self.allocation_rotors))
        roll, pitch, yaw = (tuple(float(v) for v in mix[:, axis]) for axis in range(3))
        return roll, pitch, yaw

X500 = Airframe()
