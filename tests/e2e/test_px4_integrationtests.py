"""PX4's MAVROS integration tests for multicopters (PX4 v1.15.2
``integrationtests/python_src/px4_it/mavros/``: ``mission_test.py`` with the MC missions
``missions/MC_mission_box.plan`` and ``missions/MC_safe_landing.plan``,
``mavros_offboard_posctl_test.py``, ``mavros_offboard_attctl_test.py``,
``mavros_offboard_yawrate_test.py``, on the helpers of ``mavros_test_common.py``), as PX4 runs them
(``test/mavros_posix_test_mission.test``, ``test/mavros_posix_test_safe_landing.test``,
``test/mavros_posix_tests_offboard_{posctl,attctl,rpyrt_ctl}.test``: the iris quadrotor, real
time, a 300 s rostest time limit), over pymavlink on the onboard link (tests/e2e/px4_integration.py
is the MAVROS side). Mode changes go as COMMAND_LONG DO_SET_MODE (MAVROS's set_mode service sends
SET_MODE, which PX4 handles the same way).

PX4 runs them at 1x with ROS on the simulation clock; here the daemon runs at ``--speed 10`` and
every time-out counts the vehicle's clock, so the time-outs are PX4's. The 300 s rostest limit is
kept as simulated time too (the vehicle's clock when the test ends).

Differences in what is around the vehicle, not in the checks: MC_safe_landing ran on
``iris_obs_avoid`` with PX4/PX4-Avoidance's safe_landing_planner in a world of boxes; here the
plain iris flies it (no planner, flat ground), through mission_test.py's same checks. The ulog
estimator analysis at the end of mission_test.py (px4tools ``estimator_analysis``) compares
ATTITUDE with the ground truth of HIL_STATE_QUATERNION, asked at 10 Hz (the log's ``dt=0.1``).
In PX4's CI (``.github/workflows``) only MC_mission_box and posctl still ran; attctl and
rpyrt_ctl were commented out there.
"""

from __future__ import annotations

import logging
import math

import pytest

from tests.e2e.px4_integration import (
    M,
    MavrosClient,
    MavrosTestCommon,
    enu_baselink_to_ned_aircraft,
    estimator_analysis,
    q_from_euler,
    q_to_euler,
    reach_local_position,
    reach_mission_position,
    read_mission,
)

pytestmark = [pytest.mark.e2e, pytest.mark.slow]
log = logging.getLogger("px4_it")

SPEED = "10"
ROSTEST_TIME_LIMIT_S = 300.0  # <test ... time-limit="300.0"/>
ON_GROUND = M.MAV_LANDED_STATE_ON_GROUND
FRAME_GLOBAL, FRAME_GLOBAL_REL_ALT = 0, 3  # mavros_msgs/Waypoint
HIL_STATE_QUATERNION = 115


@pytest.fixture
def px4(daemon_factory):
    d = daemon_factory("--speed", SPEED)
    c = MavrosClient(d.api_port(0))
    try:
        yield MavrosTestCommon(c)
        assert c.now_s <= ROSTEST_TIME_LIMIT_S, f"over rostest's time-limit: {c.describe()}"
    finally:
        c.setpoint = None
        c.close()


# --- mission_test.py ----------------------------------------------------------------------------
@pytest.mark.parametrize("mission", ["MC_mission_box.plan", "MC_safe_landing.plan"])
def test_mission(px4, mission):
    c = px4.c
    c.gcs_heartbeat_hz = 2.0  # "need to simulate heartbeat to prevent datalink loss detection"
    wps = read_mission(mission)

    # make sure the simulation is ready to start the mission
    px4.wait_for_topics(60)
    # the ulog's attitude and ground truth, from here on
    assert c.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, HIL_STATE_QUATERNION, 100_000) == 0
    px4.wait_for_landed_state(ON_GROUND, 10, -1)
    assert px4.wait_for_mav_type(10) == M.MAV_TYPE_QUADROTOR

    # push waypoints to FCU and start mission
    px4.send_wps(wps, 30)
    px4.set_mode("AUTO.MISSION", 5)
    px4.set_arm(True, 5)

    for index, wp in enumerate(wps):
        # only check position for waypoints where this makes sense
        if wp.frame in (FRAME_GLOBAL_REL_ALT, FRAME_GLOBAL):
            lat, lon, alt = wp.params[4:7]
            if wp.frame == FRAME_GLOBAL_REL_ALT:
                a = c.topics["alt"]
                alt += a.altitude_amsl - a.altitude_relative
            reach_mission_position(px4, lat, lon, alt, 60, index, len(wps))
        # VTOL transitions, if applicable (none in the MC missions)
        if wp.command in (M.MAV_CMD_NAV_VTOL_TAKEOFF, M.MAV_CMD_NAV_VTOL_LAND,
                          M.MAV_CMD_DO_VTOL_TRANSITION):
            transition = {M.MAV_CMD_NAV_VTOL_TAKEOFF: M.MAV_VTOL_STATE_FW,
                          M.MAV_CMD_NAV_VTOL_LAND: M.MAV_VTOL_STATE_MC}.get(wp.command,
                                                                           wp.params[0])
            px4.wait_for_vtol_state(int(transition), 60, index)
        # after reaching position, wait for landing detection if applicable
        if wp.command in (M.MAV_CMD_NAV_VTOL_LAND, M.MAV_CMD_NAV_LAND):
            px4.wait_for_landed_state(ON_GROUND, 120, index)

    px4.set_arm(False, 5)
    px4.clear_wps(5)

    # enforce performance
    res = estimator_analysis(c.ground_truth)
    log.info("estimator analysis over %d samples: %s", len(c.ground_truth), res)
    assert len(c.ground_truth) > 100, "no ground truth"
    assert abs(res["roll_error_mean"]) < 5.0, res
    assert abs(res["pitch_error_mean"]) < 5.0, res
    assert abs(res["yaw_error_mean"]) < 5.0, res
    assert res["roll_error_std"] < 5.0, res
    assert res["pitch_error_std"] < 5.0, res
    assert res["yaw_error_std"] < 10.0, res


# --- mavros_offboard_posctl_test.py ---------------------------------------------------------------
def test_offboard_posctl(px4):
    c = px4.c
    pos = [0.0, 0.0, 0.0]  # PoseStamped, ENU
    orientation = [(0.0, 0.0, 0.0, 0.0)]  # ROS's default Quaternion until reach_position sets one

    def send_pos():  # mavros setpoint_position/local, 10 Hz
        yaw = q_to_euler(enu_baselink_to_ned_aircraft(orientation[0]))[2]
        c.send("set_position_target_local_ned", int(c.now_s * 1000), 1, 1,
               M.MAV_FRAME_LOCAL_NED, 0b1001_1111_1000, pos[1], pos[0], -pos[2], 0, 0, 0, 0, 0,
               0, yaw, 0)

    c.setpoint = send_pos
    px4.wait_for_topics(60)
    px4.wait_for_landed_state(ON_GROUND, 10, -1)

    # exempting failsafe from lost RC to allow offboard
    px4.set_param_int("COM_RCL_EXCEPT", 1 << 2, 5)
    px4.set_mode("OFFBOARD", 5)
    px4.set_arm(True, 5)

    positions = ((0, 0, 0), (50, 50, 20), (50, -50, 20), (-50, -50, 20), (0, 0, 20))
    for x, y, z in positions:
        # "For demo purposes we will lock yaw/heading to north" (ENU yaw 0: MAVROS sends east)
        orientation[0] = q_from_euler(0, 0, math.radians(0))
        reach_local_position(px4, pos, x, y, z, 30, radius=1)

    px4.set_mode("AUTO.LAND", 5)
    px4.wait_for_landed_state(ON_GROUND, 45, 0)
    px4.set_arm(False, 5)


# --- mavros_offboard_attctl_test.py / mavros_offboard_yawrate_test.py ------------------------------
def attitude_sender(c: MavrosClient, orientation_enu, body_rate_flu, thrust: float,
                    type_mask: int):
    """mavros setpoint_raw/attitude at 10 Hz: orientation ENU/base_link → NED/aircraft, body
    rates base_link → aircraft."""
    q = enu_baselink_to_ned_aircraft(orientation_enu)
    r = body_rate_flu[0], -body_rate_flu[1], -body_rate_flu[2]

    def send():
        c.send("set_attitude_target", int(c.now_s * 1000), 1, 1, type_mask, list(q), *r, thrust)

    return send


@pytest.mark.xfail(strict=True, reason=(
    "airframe: the open-loop thrust 0.7, tilted 0.25/0.15 rad, is below this vehicle's hover "
    "command (gz x500: 0.73, vehicles/airframe.py:24-26); it slides along the ground, never above "
    "20 m. PX4 ran it on gazebo-classic iris (hover 0.705 by iris.sdf) and disabled it in its CI"))
def test_offboard_attctl(px4):
    c = px4.c
    c.setpoint = attitude_sender(c, q_from_euler(-0.25, 0.15, 0), (0, 0, 0), 0.7, 7)
    boundary_x, boundary_y, boundary_z = 200, 100, 20

    px4.wait_for_topics(60)
    px4.wait_for_landed_state(ON_GROUND, 10, -1)
    px4.set_mode("OFFBOARD", 5)
    px4.set_arm(True, 5)

    timeout = 90
    for _ in c.ticks(timeout, 2):
        x, y, z = c.local_position_enu()
        if x > boundary_x and y > boundary_y and z > boundary_z:
            break
    else:
        px4.fail(f"took too long to cross boundaries | timeout(seconds): {timeout}")

    px4.set_mode("AUTO.LAND", 5)
    px4.wait_for_landed_state(ON_GROUND, 90, 0)
    px4.set_arm(False, 5)


@pytest.mark.xfail(strict=True, reason=(
    "airframe: MAVROS starts with the all-zero quaternion, which PX4 (and CORNET) takes and "
    "which stops the motors until a valid one comes; then the thrust 0.59 is below this "
    "vehicle's hover command (gz x500: 0.73), so it never lifts off to yaw. PX4 ran it on "
    "gazebo-classic iris and disabled it in its CI"))
def test_offboard_yawrate(px4):
    c = px4.c
    des_yawrate, yawrate_tol = 0.1, 0.02
    # att.orientation = local_position.pose.orientation when setUp starts the thread: before
    # the subscriber heard anything, ROS's all-zero Quaternion
    c.setpoint = attitude_sender(c, c.local_orientation_enu(), (0, 0, des_yawrate), 0.59, 3)
    boundary_x, boundary_y, boundary_z = 5, 5, 10

    px4.wait_for_topics(60)
    px4.wait_for_landed_state(ON_GROUND, 10, -1)
    px4.set_arm(True, 5)
    px4.set_mode("OFFBOARD", 5)

    timeout = 90
    for _ in c.ticks(timeout, 2):
        x, y, z = c.local_position_enu()
        if (-boundary_x < x < boundary_x and -boundary_y < y < boundary_y and z > boundary_z
                and abs(c.imu_yaw_rate_flu() - des_yawrate) < yawrate_tol):
            break
    else:
        px4.fail(f"took too long to finish test | yaw rate {c.imu_yaw_rate_flu():.2f} | "
                 f"timeout(seconds): {timeout}")

    px4.set_mode("AUTO.LAND", 5)
    px4.wait_for_landed_state(ON_GROUND, 90, 0)
    px4.set_arm(False, 5)
