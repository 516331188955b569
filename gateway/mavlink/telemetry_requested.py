"""Messages PX4 SITL sends only when a client asks for them (SET_MESSAGE_INTERVAL), from a
``Snapshot`` of the vehicle: SCALED_IMU, RC_CHANNELS, DISTANCE_SENSOR, HIL_STATE_QUATERNION,
ACTUATOR_OUTPUT_STATUS, MANUAL_CONTROL, AUTOPILOT_STATE_FOR_GIMBAL_DEVICE.

Source: PX4's stream classes src/modules/mavlink/streams/<MESSAGE>.hpp. Each is compiled into
SITL, so MavlinkReceiver::set_message_interval accepts it, and it sends only when its uORB topic
has new data.
Rules:
- A builder returns None where the default SITL quad publishes no such topic: RC_CHANNELS
  (input_rc: no RC input, COM_RC_IN_MODE 1 takes MAVLink MANUAL_CONTROL, which PX4 publishes as
  manual_control_setpoint) and DISTANCE_SENSOR (no rangefinder on the default airframe).
- Fields are filled as PX4's streams fill them, quirks included: C's float-to-integer
  conversions truncate toward zero; HIL_STATE_QUATERNION leaves time_usec 0 and puts the ground
  truth's acceleration in m/s² into its mG fields.
- None of these is streamed by default (streams.py: 0 Hz on both links).
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.codec import Encoder, f32_mul, i16, i32, payload_of
from gateway.mavlink.snapshot import Snapshot
from gateway.mavlink.telemetry import G, imu_sample
from gateway.mavlink.telemetry_estimator import gps_ctrl_of, solution_status
from vehicles.types import LandedState

# actuator_outputs.noutputs: MixingOutput publishes all of its channels (MixingOutput::
# MAX_ACTUATORS, the gz bridge's ESC output module), the unassigned ones at their disarmed 0.
ACTUATOR_OUTPUTS = 16
_SCALED_IMU = payload_of(M.MAVLink_scaled_imu_message)
_HIL_STATE_QUATERNION = payload_of(M.MAVLink_hil_state_quaternion_message)
_ACTUATOR_OUTPUT_STATUS = payload_of(M.MAVLink_actuator_output_status_message)
_FLIGHT_INFORMATION = payload_of(M.MAVLink_flight_information_message)
_MANUAL_CONTROL = payload_of(M.MAVLink_manual_control_message)
_AUTOPILOT_STATE_FOR_GIMBAL_DEVICE = payload_of(M.MAVLink_autopilot_state_for_gimbal_device_message)


def scaled_imu(enc: Encoder, s: Snapshot) -> bytes:
    """SCALED_IMU.hpp: the IMU (vehicle_imu, IMU_INTEG_RATE 250 Hz in SITL, so it has a new
    sample at any requested rate) in mG and mrad/s, the magnetometer in mgauss; the temperature
    is the IMU's, else the magnetometer's, when finite: the gz bridge's accelerometer and gyro
    and sensor_mag_sim publish NaN, so it stays 0. The same samples as HIGHRES_IMU."""
    fx, fy, fz, p, q, r, mx, my, mz = imu_sample(s)
    temperature = 0
    return _SCALED_IMU(s.time_boot_ms,
                       i16(fx * 1000.0 / G), i16(fy * 1000.0 / G), i16(fz * 1000.0 / G),
                       i16(p * 1000.0), i16(q * 1000.0), i16(r * 1000.0),
                       i16(mx * 1000.0), i16(my * 1000.0), i16(mz * 1000.0), temperature)


def manual_control(enc: Encoder, s: Snapshot) -> bytes | None:
    """MANUAL_CONTROL.hpp: each manual_control_setpoint publication once (the latest one since
    the last send; vehicles/manual_setpoint.py says when ManualControl publishes), target this
    system, pitch/roll/throttle/yaw × 1000 in float32 truncated (the throttle in PX4's [-1, 1]
    range, so MAVSDK's centred 500 comes back as 0), buttons 0: without RC there is no
    manual_control_switches to copy. The link's first send is the latest publication (its
    subscription sees it, as a new uORB subscription does); a request sends only a publication
    the link has not sent yet, as the stream's send() does."""
    published = getattr(s.vehicle, "manual_control_setpoint", None)
    if published is None:
        return None
    seq, sticks = published(s.now_s)
    link = s.link
    if link is not None:
        if seq == link.manual_seq:
            return None
        link.manual_seq = seq
    return _MANUAL_CONTROL(enc.sysid, i16(f32_mul(sticks.pitch, 1000.0)),
                           i16(f32_mul(sticks.roll, 1000.0)),
                           i16(f32_mul(sticks.throttle, 1000.0)),
                           i16(f32_mul(sticks.yaw, 1000.0)), 0)


def autopilot_state_for_gimbal_device(enc: Encoder, s: Snapshot) -> bytes:
    """AUTOPILOT_STATE_FOR_GIMBAL_DEVICE.hpp, on each vehicle_attitude (a new one at any rate):
    target 0/0 (PX4's TODO), time_boot_us the attitude's timestamp, its quaternion, the local
    velocity, vehicle_attitude_setpoint's yaw_sp_move_rate as the feed-forward yaw rate, EKF2's
    solution status flags, landed as on the ground or in the air (take-off and landing count as
    in the air: PX4 reads only vehicle_land_detected.landed); the delays and angular_velocity_z
    0, as PX4 leaves them."""
    kin = s.kin
    targets = s.targets
    e = s.sample.estimator
    flags = 0 if e is None else solution_status(e, gps_ctrl_of(s.vehicle.params))
    landed = s.status.landed_state is LandedState.ON_GROUND
    return _AUTOPILOT_STATE_FOR_GIMBAL_DEVICE(
        0, 0, s.time_usec, kin.attitude_q, 0, *kin.velocity_ned_mps, 0,
        0.0 if targets is None else targets.yawspeed_radps, flags,
        LandedState.ON_GROUND if landed else LandedState.IN_AIR)


def rc_channels(enc: Encoder, s: Snapshot) -> None:
    """RC_CHANNELS.hpp sends on input_rc updates; SITL has no RC input."""
    return None


def distance_sensor(enc: Encoder, s: Snapshot) -> None:
    """DISTANCE_SENSOR.hpp sends on distance_sensor updates; the default quad has no
    rangefinder."""
    return None


def unpublished(enc: Encoder, s: Snapshot) -> None:
    """A stream whose uORB topic nothing here publishes (streams.py's ``silent`` ones): its
    send() has nothing, so a REQUEST_MESSAGE for it is DENIED."""
    return None


def hil_state_quaternion(enc: Encoder, s: Snapshot) -> bytes | None:
    """HIL_STATE_QUATERNION.hpp: the simulator's ground truth (vehicle_*_groundtruth): attitude,
    body rates, position (degE7, mm AMSL), NED velocity in cm/s, acceleration (m/s², as PX4
    puts it); airspeeds 0, time_usec never set (0). Nothing without a ground truth."""
    truth = getattr(s.vehicle, "truth", None)
    if truth is None:
        return None
    g = s.vehicle.origin.offset_ned(*truth.position_ned_m)
    p, q, r = truth.rates_frd_radps
    vn, ve, vd = truth.velocity_ned_mps
    an, ae, ad = truth.accel_ned_mps2
    return _HIL_STATE_QUATERNION(0, list(truth.attitude_q), p, q, r,
                                 i32(g.lat_deg * 1e7), i32(g.lon_deg * 1e7), i32(g.alt_amsl_m * 1e3),
                                 i16(vn * 100.0), i16(ve * 100.0), i16(vd * 100.0), 0, 0,
                                 i16(an), i16(ae), i16(ad))


def actuator_output_status(enc: Encoder, s: Snapshot) -> bytes | None:
    """ACTUATOR_OUTPUT_STATUS.hpp: actuator_outputs as the gz bridge's ESC outputs publish them
    (SIM_GZ_EC_MIN/MAX 0..1000: the commanded rotor speed in rad/s; 0 disarmed), ``active`` = the
    number of channels."""
    sp = s.targets
    if sp is None:
        return None
    outputs = [float(w) for w in sp.outputs[:ACTUATOR_OUTPUTS]]
    outputs += [0.0] * (32 - len(outputs))
    return _ACTUATOR_OUTPUT_STATUS(s.time_usec, ACTUATOR_OUTPUTS,
                                   outputs)


def flight_information(enc: Encoder, s: Snapshot) -> bytes | None:
    """FLIGHT_INFORMATION.hpp (on request): despite the field names, the arming and takeoff
    times are vehicle_status's armed_time and takeoff_time, microseconds since boot (0 when
    disarmed or not yet flying); flight_uuid is COM_FLIGHT_UUID, which every disarm counts up."""
    status = s.status
    armed, takeoff = status.extra.get("armed_at_s"), status.extra.get("takeoff_at_s")
    uuid = int(s.vehicle.params.get("COM_FLIGHT_UUID", 0) or 0) % 2**64  # static_cast<uint64_t>
    return _FLIGHT_INFORMATION(s.time_boot_ms,
                               0 if armed is None else int(armed * 1e6), 0 if takeoff is None else
                               int(takeoff * 1e6), uuid)
