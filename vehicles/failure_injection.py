"""MAV_CMD_INJECT_FAILURE as PX4 v1.15.2 SITL's modules answer it.

Source: PX4 v1.15.2 simulation/simulator_mavlink SimulatorMavlink::check_failure_injections
(sensors), simulation/battery_simulator BatterySimulator::updateCommands (battery),
commander/failure_detector FailureInjector::update (motors). The MAVLink module passes the
command on only with SYS_FAILURE_EN (else it answers DENIED itself, gateway/mavlink/commands.py);
each module reads static_cast<int>(param + 0.5f) and ACKs the units it takes, to every link,
addressed to system 0 component 0. A unit no module takes gets no ACK at all.
Rules (``answer``):
- gyro, accel, mag, baro: ok, off and stuck ACCEPTED, another type UNSUPPORTED; the instance
  (0 all, 1.. one) is never refused (one out of range changes nothing).
- GPS: ok and off, whatever the instance; airspeed: ok, off and wrong; VIO: ok and off; other
  types UNSUPPORTED. A multicopter has neither airspeed sensor nor VIO: no effect.
- battery: ok and off, instance 0 only (another: UNSUPPORTED); another type is not taken.
- motors: ok for instance 0 (all) to CONNECTED_ESC_MAX, else UNSUPPORTED; off and wrong
  ACCEPTED for any instance; another type UNSUPPORTED.
Effects (``apply``): sensors as the simulator blocks or freezes them (a baro's ok clears off,
not stuck, as SimulatorMavlink does); the battery empty (BatterySimulator's force empty); a
motor off stops its rotor — the simulation's doing: PX4 v1.15's FailureInjector only hides the
ESC from esc_status.
"""

from __future__ import annotations

from typing import Protocol

from vehicles import estimation as est
from vehicles.types import CommandResult

MAV_CMD_INJECT_FAILURE = 420

# FAILURE_UNIT (MAVLink)
(FAILURE_UNIT_SENSOR_GYRO, FAILURE_UNIT_SENSOR_ACCEL, FAILURE_UNIT_SENSOR_MAG,
 FAILURE_UNIT_SENSOR_BARO, FAILURE_UNIT_SENSOR_GPS) = range(5)
FAILURE_UNIT_SENSOR_VIO = 6
FAILURE_UNIT_SENSOR_AIRSPEED = 8
FAILURE_UNIT_SYSTEM_BATTERY, FAILURE_UNIT_SYSTEM_MOTOR = 100, 101
# FAILURE_TYPE (MAVLink)
FAILURE_TYPE_OK, FAILURE_TYPE_OFF, FAILURE_TYPE_STUCK = 0, 1, 2
FAILURE_TYPE_WRONG = 4
CONNECTED_ESC_MAX = 8  # esc_status_s::CONNECTED_ESC_MAX

# Sensor units → (the bits that fail when off, when stuck); this vehicle has one of each.
SENSOR_FAILURES = {
    FAILURE_UNIT_SENSOR_GYRO: (est.F_GYRO_OFF, est.F_GYRO_STUCK),
    FAILURE_UNIT_SENSOR_ACCEL: (est.F_ACC_OFF, est.F_ACC_STUCK),
    FAILURE_UNIT_SENSOR_MAG: (est.F_MAG_OFF, est.F_MAG_STUCK),
    FAILURE_UNIT_SENSOR_BARO: (est.F_BARO_OFF, est.F_BARO_STUCK),
    FAILURE_UNIT_SENSOR_GPS: (est.F_GPS_OFF, 0),  # SimulatorMavlink's GPS has no stuck
}
# The types each unit's module takes (all ACCEPTED); another type is UNSUPPORTED
_TYPES = {
    **dict.fromkeys((FAILURE_UNIT_SENSOR_GYRO, FAILURE_UNIT_SENSOR_ACCEL, FAILURE_UNIT_SENSOR_MAG,
                     FAILURE_UNIT_SENSOR_BARO),
                    (FAILURE_TYPE_OK, FAILURE_TYPE_OFF, FAILURE_TYPE_STUCK)),
    FAILURE_UNIT_SENSOR_GPS: (FAILURE_TYPE_OK, FAILURE_TYPE_OFF),
    FAILURE_UNIT_SENSOR_AIRSPEED: (FAILURE_TYPE_OK, FAILURE_TYPE_OFF, FAILURE_TYPE_WRONG),
    FAILURE_UNIT_SENSOR_VIO: (FAILURE_TYPE_OK, FAILURE_TYPE_OFF),
    FAILURE_UNIT_SYSTEM_MOTOR: (FAILURE_TYPE_OK, FAILURE_TYPE_OFF, FAILURE_TYPE_WRONG),
}


def answer(unit: int, failure_type: int, instance: int) -> CommandResult | None:
    """The module's ACK (module docstring); None: no module takes it, no ACK."""
    if unit == FAILURE_UNIT_SYSTEM_BATTERY:
        if failure_type not in (FAILURE_TYPE_OK, FAILURE_TYPE_OFF):
            return None
        return CommandResult.ACCEPTED if instance == 0 else CommandResult.UNSUPPORTED
    types = _TYPES.get(unit)
    if types is None:
        return None
    if failure_type not in types:
        return CommandResult.UNSUPPORTED
    if (unit == FAILURE_UNIT_SYSTEM_MOTOR and failure_type == FAILURE_TYPE_OK
            and not 0 <= instance <= CONNECTED_ESC_MAX):
        return CommandResult.UNSUPPORTED
    return CommandResult.ACCEPTED


class Target(Protocol):
    """What a failure acts on: the vehicle's sensors and rotors in the World, its battery."""

    def set_sensor_failed(self, bits: int, failed: bool) -> None: ...
    def set_motor_off(self, motor: int, off: bool) -> None: ...
    def set_battery_empty(self, empty: bool) -> None: ...


def apply(target: Target, rotor_count: int, unit: int, failure_type: int, instance: int) -> None:
    """The effect of an ACCEPTED failure (module docstring)."""
    off = failure_type == FAILURE_TYPE_OFF
    if unit in SENSOR_FAILURES:
        if unit != FAILURE_UNIT_SENSOR_GPS and unit != FAILURE_UNIT_SENSOR_BARO \
                and instance not in (0, 1):
            return  # another IMU or magnetometer than ours
        off_bits, stuck_bits = SENSOR_FAILURES[unit]
        if failure_type == FAILURE_TYPE_OK:
            # SimulatorMavlink: a baro's ok unblocks it but leaves it stuck
            target.set_sensor_failed(off_bits if unit == FAILURE_UNIT_SENSOR_BARO
                                     else off_bits | stuck_bits, False)
        elif off:
            target.set_sensor_failed(off_bits, True)
            if unit != FAILURE_UNIT_SENSOR_BARO:  # its off leaves stuck as it was
                target.set_sensor_failed(stuck_bits, False)
        else:
            target.set_sensor_failed(off_bits, False)
            target.set_sensor_failed(stuck_bits, True)
    elif unit == FAILURE_UNIT_SYSTEM_BATTERY:
        target.set_battery_empty(off)
    elif unit == FAILURE_UNIT_SYSTEM_MOTOR and failure_type != FAILURE_TYPE_WRONG:
        for motor in range(rotor_count) if instance == 0 else (instance - 1,):
            if 0 <= motor < rotor_count:
                target.set_motor_off(motor, off)
