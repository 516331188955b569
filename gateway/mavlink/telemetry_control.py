"""What the controllers aim for and what the motors are told: ATTITUDE_TARGET,
POSITION_TARGET_LOCAL_NED, POSITION_TARGET_GLOBAL_INT, SERVO_OUTPUT_RAW (port 0), ESC_INFO and
ESC_STATUS, from the vehicle's ``targets`` (vehicles/types.py Targets).

Source: PX4's stream classes src/modules/mavlink/streams/<MESSAGE>.hpp, streamed by default
(mavlink_main.cpp configure_streams_to_default, and px4-rc.mavlink's SITL overrides for the GCS
link: 50 Hz for all but POSITION_TARGET_GLOBAL_INT).
Rules:
- ATTITUDE_TARGET: vehicle_attitude_setpoint's q_d and |thrust_body|, vehicle_rates_setpoint's
  body rates (the attitude controller's output; 0 while the motors are off), type_mask 0.
- POSITION_TARGET_LOCAL_NED: vehicle_local_position_setpoint, which mc_pos_control publishes
  whenever flag_multicopter_position_control_enabled (armed or not): a field that is NaN sets
  its IGNORE bit, as PX4 does. Before take-off PX4 resets the setpoint to NaN with a 100 m/s²
  downward acceleration; the acceleration setpoint in flight is not kept here, so it is sent as
  NaN (ignored).
- POSITION_TARGET_GLOBAL_INT: position_setpoint_triplet.current while
  flag_control_position_enabled and the navigator has one (MAV_FRAME_GLOBAL_INT, alt AMSL), with
  the local setpoint's velocity, acceleration and yaw; type_mask 0.
- SERVO_OUTPUT_RAW: actuator_outputs as the gz bridge's ESC output module publishes them
  (SIM_GZ_EC_MIN/MAX 0..1000: the commanded rotor speed in rad/s, 0 disarmed), truncated to
  uint16 as C converts; time_usec (the outputs are published at every control step: now)
  truncated to 32 bits as the message has it.
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.codec import Encoder, payload_of
from gateway.mavlink.snapshot import Snapshot
from gateway.mavlink.wip_dialect import ESC_INFO, ESC_STATUS

ESC_REPORTS = 8  # esc_status_s::CONNECTED_ESC_MAX
NO_THRUST_ACCEL = (0.0, 0.0, 100.0)  # mc_pos_control: not taken off yet
NAN3 = (math.nan, math.nan, math.nan)
_ZEROS = [0] * 16  # SERVO_OUTPUT_RAW's unused outputs
_ATTITUDE_TARGET = payload_of(M.MAVLink_attitude_target_message)
_POSITION_TARGET_LOCAL_NED = payload_of(M.MAVLink_position_target_local_ned_message)
_POSITION_TARGET_GLOBAL_INT = payload_of(M.MAVLink_position_target_global_int_message)
_SERVO_OUTPUT_RAW = payload_of(M.MAVLink_servo_output_raw_message)
_ESC_INFO_PAYLOAD = payload_of(ESC_INFO)
_ESC_STATUS_PAYLOAD = payload_of(ESC_STATUS)


def attitude_target(enc: Encoder, s: Snapshot) -> bytes | None:
    sp = s.targets
    if sp is None:
        return None
    p, q, r = sp.rates_frd_radps
    return _ATTITUDE_TARGET(int(sp.time_s * 1000.0) & 0xFFFFFFFF, 0, sp.attitude_q,
                            p, q, r, sp.thrust_norm)


def _local_fields(sp) -> tuple[float, ...]:
    """x, y, z, vx, vy, vz, afx, afy, afz, yaw, yaw_rate of vehicle_local_position_setpoint."""
    pos, vel = sp.position_ned_m, sp.velocity_ned_mps
    if math.isnan(pos[0]):  # not taken off: mc_pos_control's "no thrust" setpoint
        vel, acc = NAN3, NO_THRUST_ACCEL
    else:
        acc = sp.acceleration_ned_mps2
    return (*pos, *vel, *acc, sp.yaw_rad, sp.yawspeed_radps)


class _IgnoreMask(dict[tuple[bool, ...], int]):
    """POSITION_TARGET_TYPEMASK of the fields' NaN pattern (x, y, z, vx, vy, vz, afx, afy,
    afz, yaw, yaw_rate): the IGNORE bit of every NaN field. Few patterns ever occur, so each
    is worked out once."""

    def __missing__(self, nan: tuple[bool, ...]) -> int:
        mask = self[nan] = sum(1 << bit for bit, is_nan in zip(_IGNORE_BITS, nan) if is_nan)
        return mask


_IGNORE_BITS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 10, 11)
_IGNORE_MASK = _IgnoreMask()


def position_target_local_ned(enc: Encoder, s: Snapshot) -> bytes | None:
    sp = s.targets
    if sp is None or not sp.position_control:
        return None
    f = _local_fields(sp)
    return _POSITION_TARGET_LOCAL_NED(int(sp.time_s * 1000.0) & 0xFFFFFFFF,
                                      M.MAV_FRAME_LOCAL_NED, _IGNORE_MASK[tuple(map(math.isnan, f))], *f)


def global_target(s: Snapshot, ned: tuple[float, float, float] | None
                  ) -> tuple[float, float, float] | None:
    """The navigator's current setpoint (NED from the vehicle's origin) as (lat, lon, alt
    AMSL); alt NaN when the setpoint has none; None without a horizontal position."""
    if ned is None:
        return None
    n, e, d = ned
    if n != n or e != e:
        return None
    g = s.vehicle.origin.offset_ned(n, e, 0.0 if d != d else d)
    return g.lat_deg, g.lon_deg, (math.nan if d != d else g.alt_amsl_m)


def position_target_global_int(enc: Encoder, s: Snapshot) -> bytes | None:
    sp = s.targets
    target = None if sp is None else global_target(s, sp.global_target_ned_m)
    if target is None:
        return None
    lat, lon, alt = target
    f = _local_fields(sp)
    return _POSITION_TARGET_GLOBAL_INT(s.time_boot_ms,
                                       M.MAV_FRAME_GLOBAL_INT, 0, int(lat * 1e7), int(lon * 1e7), alt, *f[3:])


def servo_output_raw(enc: Encoder, s: Snapshot) -> bytes | None:
    sp = s.targets
    if sp is None:
        return None
    raw = list(map(int, sp.outputs[:16]))  # commanded rad/s: 0..1000, within uint16
    raw += _ZEROS[len(raw):]
    return _SERVO_OUTPUT_RAW(s.time_usec & 0xFFFFFFFF, 0, *raw)


def esc_info(enc: Encoder, s: Snapshot) -> bytes | None:
    """ESC_INFO.hpp on esc_status, which the gz bridge (GZMixingInterfaceESC::
    motorSpeedCallback) publishes at every motor-speed message: its count of ESCs, all online,
    PPM connection, no counter, failures, errors or temperature. PX4 fills each batch of four
    from the first four reports (its loop indexes ``esc[esc_index]``); the quad has one batch."""
    sp = s.targets
    if sp is None:
        return None
    n = min(len(sp.outputs), ESC_REPORTS)
    return _ESC_INFO_PAYLOAD(0, s.time_usec, 0, n, 0, (1 << n) - 1, (0,) * 4, (0,) * 4,
                             (0,) * 4)


def esc_status(enc: Encoder, s: Snapshot) -> bytes | None:
    """ESC_STATUS.hpp on the same esc_status: each report's esc_rpm, which the gz bridge sets to
    the motor's commanded value (the mixer output, SIM_GZ_EC_MAX 1000: rad/s) converted to
    int32 as C converts; no voltage or current."""
    sp = s.targets
    if sp is None:
        return None
    rpm = [int(v) for v in sp.outputs[:4]]
    rpm += [0] * (4 - len(rpm))
    return _ESC_STATUS_PAYLOAD(0, s.time_usec, rpm, (0.0,) * 4, (0.0,) * 4)
