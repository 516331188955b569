"""QGC's Actuators page over the wire (pymavlink on the GCS port, as QGC talks): its motor
assignment writes SIM_GZ_EC_FUNCn, its sliders send MAV_CMD_ACTUATOR_TEST (param1 the value,
param2 a 1 s timeout, param5 1000 + the function) every 50 ms, one at a time, each waiting for
its ACK (ActuatorTesting.cc), and stop with param1 NaN and timeout 0; SERVO_OUTPUT_RAW shows
the ESC outputs (vehicles/allocation_params.py, docs/onboard.md "Motor test")."""

import math
import struct
import time

import pytest
from pymavlink import mavutil

from tests.e2e.gcs import command_long, gcs, heartbeats_by_sysid

pytestmark = [pytest.mark.e2e]

ACTUATOR_TEST = mavutil.mavlink.MAV_CMD_ACTUATOR_TEST
MOTOR1 = 1101  # 1000 + output function Motor 1


def set_param(conn, name: str, value: int) -> None:
    """PARAM_SET of an INT32 as QGC sends it to PX4: its bytes in the float field."""
    as_float = struct.unpack("<f", struct.pack("<i", value))[0]
    conn.mav.param_set_send(1, 1, name.encode(), as_float, mavutil.mavlink.MAV_PARAM_TYPE_INT32)
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
        if msg is not None and msg.param_id == name:
            return
    raise AssertionError(f"no PARAM_VALUE for {name}")


def slider(conn, function: int, value: float, seconds: float) -> list:
    """A QGC slider held at ``value`` for ``seconds``: a command every 50 ms after the last
    one's ACK; returns the SERVO_OUTPUT_RAW messages seen meanwhile."""
    outputs, end = [], time.monotonic() + seconds
    while time.monotonic() < end:
        conn.mav.command_long_send(1, 1, ACTUATOR_TEST, 0, value, 1.0, 0, 0, function, 0, 0)
        deadline = time.monotonic() + 3.0  # QGC's ACK time-out
        while True:
            msg = conn.recv_match(type=["COMMAND_ACK", "SERVO_OUTPUT_RAW"], blocking=True,
                                  timeout=0.5)
            assert time.monotonic() < deadline, "no ACK"
            if msg is None:
                continue
            if msg.get_type() == "SERVO_OUTPUT_RAW":
                outputs.append(msg)
            elif msg.command == ACTUATOR_TEST:
                assert msg.result == mavutil.mavlink.MAV_RESULT_ACCEPTED
                break
        time.sleep(0.05)
    return outputs


def test_qgc_assigns_motors_and_its_slider_spins_the_assigned_output(daemon_factory):
    d = daemon_factory(vehicles=1)
    conn = gcs(d.gcs_port())
    try:
        conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                                mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert heartbeats_by_sysid(conn, {1})
        # "Identify & Assign Motors": the motor the user saw spin first is on ESC 2
        set_param(conn, "SIM_GZ_EC_FUNC1", 102)
        set_param(conn, "SIM_GZ_EC_FUNC2", 101)
        outputs = slider(conn, MOTOR1, 0.4, 1.5)
        last = outputs[-1]
        assert (last.servo1_raw, last.servo2_raw, last.servo3_raw, last.servo4_raw) == \
            (0, 490, 0, 0)  # 150 + 850 x 0.4 rad/s on ESC 2 only
        # the slider let go: NaN with no timeout stops it at once
        conn.mav.command_long_send(1, 1, ACTUATOR_TEST, 0, math.nan, 0, 0, 0, MOTOR1, 0, 0)
        deadline = time.monotonic() + 2
        while time.monotonic() < deadline:
            msg = conn.recv_match(type="SERVO_OUTPUT_RAW", blocking=True, timeout=0.5)
            if msg is not None and msg.servo2_raw == 0:
                break
        else:
            raise AssertionError("ESC 2 still spinning")
        # armed, the test is refused (Commander: DENIED)
        deadline = time.monotonic() + 20
        while command_long(conn, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) != 0:
            assert time.monotonic() < deadline, "could not arm"
            time.sleep(0.5)
        assert command_long(conn, ACTUATOR_TEST, 0.4, 1.0, 0, 0, MOTOR1) == \
            mavutil.mavlink.MAV_RESULT_DENIED
    finally:
        conn.close()
