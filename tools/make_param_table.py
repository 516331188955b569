"""Build vehicles/data/px4_params.csv from a PX4 parameter metadata table (CSV).

The source table (px4_parameters.csv, from the PX4 metadata QGroundControl ships, ~v1.12) gives
names, types, ranges and units. We keep the groups a multicopter SITL instance really runs and
apply the defaults of current PX4 + the SITL/multicopter start-up scripts
(ROMFS init.d-posix/rcS, px4-rc.params, the airframe file). Parameters that current PX4 has but
the old table lacks are added from the PX4 parameter definition file (module_params.yaml or
*_params.c) named next to them.

Run:  python tools/make_param_table.py PX4_PARAMETERS.csv vehicles/data/px4_params.csv
"""

from __future__ import annotations

import csv
import sys

KEEP_GROUPS = {
    "Commander",
    "Mission",
    "Return Mode",
    "Return To Land",
    "Geofence",
    "Multicopter Position Control",
    "Multicopter Attitude Control",
    "Multicopter Rate Control",
    "Battery Calibration",
    "MAVLink",
    "System",
    "Land Detector",
    "EKF2",
    "Sensors",
    "Sensor Calibration",
    "Data Link Loss",
    "SD Logging",
    "Failure Detector",
    "GPS",
    "Hover Thrust Estimator",
    "Follow target",
    "Precision Land",
    "Circuit Breaker",
    "SITL",
    "Events",
    "Telemetry",
    "Miscellaneous",
    "Mixer Output",
}

# Single parameters of groups not kept whole, which the simulated vehicle uses: the motors'
# thrust model (FunctionMotors, MixingOutput's THR_MDL_FAC).
KEEP_NAMES = {"THR_MDL_FAC"}

# Current PX4 defaults and SITL / multicopter overrides (PX4's parameter files and rcS scripts).
OVERRIDES = {
    "SYS_AUTOSTART": "4001",  # gz_x500: PX4 SITL's default quad with the gz bridge
    "MAV_PROTO_VER": "2",
    "MAV_TYPE": "2",
    "COM_OF_LOSS_T": "1.0",
    "GF_ACTION": "2",
    "MPC_Z_VEL_MAX_DN": "1.5",
    "MPC_Z_VEL_MAX_UP": "3.0",
    "RTL_LAND_DELAY": "0",
    "COM_RC_IN_MODE": "1",
    "COM_LOW_BAT_ACT": "2",  # init.d-posix/rcS (v1.15): Land at the critical level
    "NAV_ACC_RAD": "2.0",
    "RTL_RETURN_ALT": "30",
    "RTL_DESCEND_ALT": "10",
    "NAV_LOITER_RAD": "80",
    "RTL_MIN_DIST": "10",
    "MIS_TAKEOFF_ALT": "2.5",
    "MPC_XY_CRUISE": "5.0",
    "MPC_XY_VEL_MAX": "12.0",
    "MPC_TKO_SPEED": "1.5",
    "MPC_LAND_SPEED": "0.7",
    "MPC_THR_HOVER": "0.6",
    "NAV_DLL_ACT": "0",
    "NAV_RCL_ACT": "2",
    "COM_DL_LOSS_T": "10",
    "COM_DISARM_LAND": "2.0",
    "COM_DISARM_PRFLT": "10.0",
    "COM_ARM_WO_GPS": "1",
    "COM_TAKEOFF_ACT": "0",
    "COM_CPU_MAX": "-1",
    "BAT1_N_CELLS": "4",
    "BAT1_V_CHARGED": "4.05",
    "BAT1_V_EMPTY": "3.6",
    "BAT_LOW_THR": "0.15",
    "BAT_CRIT_THR": "0.07",
    "BAT_EMERGEN_THR": "0.05",
    "CAL_ACC0_ID": "1310988",
    "CAL_GYRO0_ID": "1310988",
    "CAL_MAG0_ID": "197388",
    "SDLOG_MODE": "1",
    "SDLOG_DIRS_MAX": "7",  # init.d-posix/rcS
    "SDLOG_PROFILE": "131",  # init.d-posix/rcS: default, estimator replay, vision/avoidance
    "CBRK_SUPPLY_CHK": "894281",  # init.d-posix/rcS
    "IMU_INTEG_RATE": "250",  # init.d-posix/px4-rc.simulator: the simulator's IMU rate
    "IMU_GYRO_RATEMAX": "800",  # init.d/rc.mc_defaults: 400 (v1.15's default) → 800
    "SENS_MAG_RATE": "15.0",  # sensor_params_mag.c (v1.15): 15 Hz
    "GPS_UBX_DYNMODEL": "6",  # init.d/rc.mc_defaults
    "SYS_FAILURE_EN": "1",
    "LNDMC_Z_VEL_MAX": "0.25",
    "EKF2_REQ_GPS_H": "0.5",
    "HTE_HT_NOISE": "0.0036",  # hover_thrust_estimator_params.yaml
    "RTL_CONE_ANG": "45",  # rtl_params.yaml (PX4 1.15)
    "MPC_POS_MODE": "4",  # mc_pos_control_params.c (PX4 1.15): acceleration based
    "MPC_ALT_MODE": "2",  # mc_pos_control_params.c (PX4 1.15): terrain following
    # v1.15.2's PARAM_DEFINE / module.yaml defaults where the old table has an older one
    "BAT1_R_INTERNAL": "0.005",
    "BAT1_V_LOAD_DROP": "0.1",
    "BAT2_R_INTERNAL": "0.005",
    "BAT2_SOURCE": "-1",
    "BAT2_V_EMPTY": "3.6",
    "BAT2_V_LOAD_DROP": "0.1",
    "BAT_N_CELLS": "3",
    "BAT_V_EMPTY": "3.6",
    "CBRK_IO_SAFETY": "22027",
    "CBRK_USB_CHK": "197848",
    "COM_ARM_CHK_ESCS": "0",
    "COM_ARM_MAG_ANG": "60",
    "COM_ARM_MAG_STR": "2",
    "COM_PREARM_MODE": "0",
    "EKF2_BCOEF_X": "100.0",
    "EKF2_BCOEF_Y": "100.0",
    "EKF2_DECL_TYPE": "3",
    "EKF2_EVA_NOISE": "0.1",
    "EKF2_EV_DELAY": "0.0",
    "EKF2_GND_EFF_DZ": "4.0",
    "EKF2_MAG_CHECK": "1",
    "EKF2_OF_DELAY": "20.0",
    "EKF2_TAS_GATE": "5.0",
    "IMU_DGYRO_CUTOFF": "30.0",
    "IMU_GYRO_CUTOFF": "40.0",
    "LNDFW_AIRSPD_MAX": "6.0",
    "LNDFW_VEL_Z_MAX": "1.0",
    "MC_ACRO_EXPO": "0.0",
    "MC_ACRO_EXPO_Y": "0.0",
    "MC_ACRO_P_MAX": "100.0",
    "MC_ACRO_R_MAX": "100.0",
    "MC_ACRO_SUPEXPO": "0.0",
    "MC_ACRO_SUPEXPOY": "0.0",
    "MC_ACRO_Y_MAX": "100.0",
    "SENS_FLOW_MAXHGT": "100.0",
    "SENS_FLOW_MAXR": "8.0",
    "SENS_FLOW_MINHGT": "0.08",
    "SENS_FLOW_ROT": "0",
    "SENS_GPS_MASK": "7",
}

# Ranges (min, max) of current PX4 where the old table has another or none.
RANGES = {
    "MPC_POS_MODE": ("0", "4"),
    "COM_RC_IN_MODE": ("0", "4"),  # commander_params.c (v1.15): 3 keep first, 4 disabled
    # flight_mode_manager/tasks/Orbit/flight_task_orbit_params.c (v1.15)
    "MC_ORBIT_RAD_MAX": ("1.0", "10000.0"),
    # mc_pos_control/multicopter_position_mode_params.c (v1.15)
    "MPC_VEL_MAN_SIDE": ("-1", "20"),
    "MPC_VEL_MAN_BACK": ("-1", "20"),
    # flight_mode_manager/tasks/ManualAccelerationSlow/flight_task_acceleration_slow_params.c
    **{f"MC_SLOW_MAP_{k}": ("0", "6") for k in ("HVEL", "VVEL", "YAWR")},
    "MC_SLOW_MIN_HVEL": ("0.1", ""), "MC_SLOW_MIN_VVEL": ("0.1", ""),
    "MC_SLOW_MIN_YAWR": ("1", ""), "MC_SLOW_DEF_HVEL": ("0.1", ""),
    "MC_SLOW_DEF_VVEL": ("0.1", ""), "MC_SLOW_DEF_YAWR": ("1", ""),
    "EKF2_GPS_CTRL": ("0", "15"),
    "COM_SPOOLUP_TIME": ("0.0", "30.0"),
    "EKF2_HGT_REF": ("0", "3"),
    "EKF2_BARO_CTRL": ("0", "1"),
}

# In current PX4 but not in the old metadata table: (type, default, unit, group, description).
ADDED = {
    "MIS_TKO_LAND_REQ": ("INT32", "0", "", "Mission", "Mission takeoff/landing required"),
    "MPC_Z_V_AUTO_UP": ("FLOAT", "3.0", "m/s", "Multicopter Position Control", "Automatic ascent velocity"),
    "MPC_Z_V_AUTO_DN": ("FLOAT", "1.5", "m/s", "Multicopter Position Control", "Automatic descent velocity"),
    "MPC_LAND_CRWL": ("FLOAT", "0.3", "m/s", "Multicopter Position Control", "Land crawl descend rate"),
    "COM_RCL_EXCEPT": ("INT32", "0", "", "Commander", "RC loss exceptions"),
    "COM_OBC_LOSS_T": ("FLOAT", "5.0", "s", "Commander", "Offboard computer loss timeout"),
    "COM_FAIL_ACT_T": ("FLOAT", "5.0", "s", "Commander", "Delay between failsafe condition and action"),
    "COM_HOME_EN": ("INT32", "1", "", "Commander", "Allows setting the home position"),
    "COM_ARMABLE": ("INT32", "1", "", "Commander", "Flag to allow arming"),
    "GF_PREDICT": ("INT32", "0", "", "Geofence", "Use predictive geofence"),
    "SIM_BAT_ENABLE": ("INT32", "1", "", "SITL", "Simulator battery enabled"),
    "EKF2_EN": ("INT32", "1", "", "EKF2", "EKF2 enable"),
    # commander/commander_params.c (v1.15): MPC_SPOOLUP_TIME's successor (0..30 s)
    "COM_SPOOLUP_TIME": ("FLOAT", "1.0", "s", "Commander",
                         "Enforced delay between arming and further navigation"),
    # ekf2/module.yaml (v1.15): a bitmask, 0 lon/lat, 1 altitude, 2 3D velocity, 3 dual antenna
    "EKF2_GPS_CTRL": ("INT32", "7", "", "EKF2", "GNSS sensor aiding"),
    # ekf2/module.yaml (v1.15): EKF2_HGT_MODE's successors (v1.14). The height converges to the
    # reference (0 barometer, 1 GPS, 2 range sensor, 3 vision); the barometer aids it
    "EKF2_HGT_REF": ("INT32", "1", "", "EKF2",
                     "Determines the reference source of height data used by the EKF"),
    "EKF2_BARO_CTRL": ("INT32", "1", "", "EKF2", "Barometric sensor height aiding"),
    "LNDMC_ALT_GND": ("FLOAT", "2.0", "m", "Land Detector", "Ground effect altitude"),
    "SYS_VEHICLE_RESP": ("FLOAT", "-0.4", "", "Multicopter Position Control", "Vehicle responsiveness"),
    # Follow Me since PX4 v1.13 (flight_mode_manager/tasks/AutoFollowTarget/
    # follow_target_params.yaml); MAVSDK's follow_me.set_config writes these.
    "FLW_TGT_HT": ("FLOAT", "8.0", "m", "Follow target", "Follow target height"),
    "FLW_TGT_DST": ("FLOAT", "8.0", "m", "Follow target", "Distance to follow target from"),
    "FLW_TGT_FA": ("FLOAT", "180.0", "", "Follow target", "Follow Angle setting in degrees"),
    "FLW_TGT_RS": ("FLOAT", "0.1", "", "Follow target",
                   "Responsiveness to target movement in Target Estimator"),
    "FLW_TGT_ALT_M": ("INT32", "0", "", "Follow target", "Altitude control mode"),
    "FLW_TGT_MAX_VEL": ("FLOAT", "5.0", "m/s", "Follow target",
                        "Max tangential velocity for follow orbit trajectory"),
    # The hover thrust estimator's (mc_hover_thrust_estimator/hover_thrust_estimator_params.yaml).
    "HTE_VXY_THR": ("FLOAT", "10.0", "m/s", "Hover Thrust Estimator",
                    "Horizontal velocity threshold for sensitivity reduction"),
    "HTE_VZ_THR": ("FLOAT", "2.0", "m/s", "Hover Thrust Estimator",
                   "Vertical velocity threshold for sensitivity reduction"),
    "HTE_THR_RANGE": ("FLOAT", "0.2", "normalized_thrust", "Hover Thrust Estimator",
                      "Max deviation from MPC_THR_HOVER"),
    # commander/commander_params.c (v1.15): the sticks may disarm in flight in Stabilized/Acro
    "COM_DISARM_MAN": ("INT32", "1", "", "Commander", "Allow disarming via switch/stick/button "
                       "on multicopters in manual thrust modes"),
    # manual_control/manual_control_params.c (v1.15)
    "MAN_ARM_GESTURE": ("INT32", "1", "", "Manual Control", "Enable arm/disarm stick gesture"),
    # land_detector_params_mc.c (v1.15)
    "LNDMC_TRIG_TIME": ("FLOAT", "1.0", "s", "Land Detector",
                        "Multicopter land detection trigger time"),
    # navigator/rtl_params.c (v1.15): RtlTimeEstimator's safety margin
    "RTL_TIME_FACTOR": ("FLOAT", "1.1", "", "Return To Land",
                        "RTL time estimate safety margin factor"),
    "RTL_TIME_MARGIN": ("INT32", "100", "s", "Return To Land",
                        "RTL time estimate safety margin offset"),
    # flight_mode_manager/tasks/Orbit/flight_task_orbit_params.c (v1.15)
    "MC_ORBIT_RAD_MAX": ("FLOAT", "1000.0", "m", "Multicopter Position Control",
                         "Maximum radius of orbit"),
    # mc_pos_control/multicopter_position_mode_params.c (v1.15)
    "MPC_VEL_MAN_SIDE": ("FLOAT", "-1.0", "m/s", "Multicopter Position Control",
                         "Maximum sideways velocity in Position mode"),
    "MPC_VEL_MAN_BACK": ("FLOAT", "-1.0", "m/s", "Multicopter Position Control",
                         "Maximum backward velocity in Position mode"),
    # flight_mode_manager/tasks/ManualAccelerationSlow/flight_task_acceleration_slow_params.c
    # (v1.15): Position Slow mode
    "MC_SLOW_MAP_HVEL": ("INT32", "0", "", "Multicopter Position Slow Mode",
                         "Manual input mapped to scale horizontal velocity in position slow mode"),
    "MC_SLOW_MAP_VVEL": ("INT32", "0", "", "Multicopter Position Slow Mode",
                         "Manual input mapped to scale vertical velocity in position slow mode"),
    "MC_SLOW_MAP_YAWR": ("INT32", "0", "", "Multicopter Position Slow Mode",
                         "Manual input mapped to scale yaw rate in position slow mode"),
    "MC_SLOW_MIN_HVEL": ("FLOAT", "0.3", "m/s", "Multicopter Position Slow Mode",
                         "Horizontal velocity lower limit"),
    "MC_SLOW_MIN_VVEL": ("FLOAT", "0.3", "m/s", "Multicopter Position Slow Mode",
                         "Vertical velocity lower limit"),
    "MC_SLOW_MIN_YAWR": ("FLOAT", "3.0", "deg/s", "Multicopter Position Slow Mode",
                         "Yaw rate lower limit"),
    "MC_SLOW_DEF_HVEL": ("FLOAT", "3.0", "m/s", "Multicopter Position Slow Mode",
                         "Default horizontal velocity limit"),
    "MC_SLOW_DEF_VVEL": ("FLOAT", "1.0", "m/s", "Multicopter Position Slow Mode",
                         "Default vertical velocity limit"),
    "MC_SLOW_DEF_YAWR": ("FLOAT", "45.0", "deg/s", "Multicopter Position Slow Mode",
                         "Default yaw rate limit"),
}

# In current PX4, not in the old table, with a range: (type, default, min, max, unit, group,
# description). Instanced parameters (a module.yaml's ``${i}``) are built by _each.
Spec = tuple[str, str, str, str, str, str, str]


def _each(name: str, numbers: range, typ: str, default: str, lo: str, hi: str, unit: str,
          group: str, desc: str) -> dict[str, Spec]:
    """The instances of a module.yaml ``${i}`` parameter, ``${i}`` replaced in name and text."""
    return {name.replace("${i}", str(i)):
            (typ, default, lo, hi, unit, group, desc.replace("${i}", str(i))) for i in numbers}


def _outputs(prefix: str, module: str, label: str, channels: range,
             standard: tuple[str, str] | None, rev_max: str) -> dict[str, Spec]:
    """An output driver's parameters as Tools/module_config/generate_params.py makes them from its
    module.yaml ``actuator_output``, group "Actuator Outputs": ``<prefix>_FUNCn`` per channel (the
    output function: 0 disabled, 101.. motors); with ``standard`` = (disarmed default, maximum)
    also _DISn, _MINn, _MAXn and _FAILn (-1: by function); ``<prefix>_REV``, the bitmask of the
    channels whose output range is reversed."""
    group, channel = "Actuator Outputs", module + " " + label + " ${i} "
    params = _each(prefix + "_FUNC${i}", channels, "INT32", "0", "", "", "", group,
                   channel + "Output Function")
    if standard is not None:
        disarmed, top = standard
        for suffix, default, lo, text in (("DIS", disarmed, "0", "Disarmed"),
                                          ("MIN", "0", "0", "Minimum"),
                                          ("MAX", top, "0", "Maximum"),
                                          ("FAIL", "-1", "-1", "Failsafe")):
            params |= _each(prefix + "_" + suffix + "${i}", channels, "INT32", default, lo, top,
                            "", group, channel + text + " Value")
    params[prefix + "_REV"] = ("INT32", "0", "0", rev_max, "", group,
                               "Reverse Output Range for " + module)
    return params


_GEOMETRY = "Geometry"
_ROTORS, _SERVOS = range(12), range(8)  # control_allocator: max_num_mc_motors, max_num_servos


def _rotor_geometry() -> dict[str, Spec]:
    """CA_ROTORn_PX/PY/PZ (m), _AX/AY/AZ (the thrust axis, default -z), _CT and _KM."""
    params: dict[str, Spec] = {}
    for axis in "XYZ":
        params |= _each("CA_ROTOR${i}_P" + axis, _ROTORS, "FLOAT", "0.0", "-100", "100", "m",
                        _GEOMETRY, f"Position of rotor ${{i}} along {axis} body axis relative "
                        "to center of gravity")
        params |= _each("CA_ROTOR${i}_A" + axis, _ROTORS, "FLOAT",
                        "-1.0" if axis == "Z" else "0.0", "-100", "100", "", _GEOMETRY,
                        f"Axis of rotor ${{i}} thrust vector, {axis} body axis component")
    return params | _each("CA_ROTOR${i}_CT", _ROTORS, "FLOAT", "6.5", "0", "100", "", _GEOMETRY,
                          "Thrust coefficient of rotor ${i}") \
        | _each("CA_ROTOR${i}_KM", _ROTORS, "FLOAT", "0.05", "-1", "1", "", _GEOMETRY,
                "Moment coefficient of rotor ${i}")


ADDED_RANGED: dict[str, Spec] = {
    # control_allocator/module.yaml (v1.15): the allocation's airframe and rotor geometry (what
    # QGC's Actuators page shows, from the actuators metadata)
    "CA_AIRFRAME": ("INT32", "0", "", "", "", _GEOMETRY, "Airframe selection"),
    "CA_METHOD": ("INT32", "2", "", "", "", _GEOMETRY, "Control allocation method"),
    "CA_FAILURE_MODE": ("INT32", "0", "", "", "", _GEOMETRY, "Motor failure handling mode"),
    "CA_R_REV": ("INT32", "0", "0", "4095", "", _GEOMETRY, "Bidirectional/Reversible motors"),
    **_each("CA_R${i}_SLEW", _ROTORS, "FLOAT", "0.0", "0", "10", "", _GEOMETRY,
            "Motor ${i} slew rate limit"),
    **_each("CA_SV${i}_SLEW", _SERVOS, "FLOAT", "0.0", "0", "10", "", _GEOMETRY,
            "Servo ${i} slew rate limit"),
    "CA_ROTOR_COUNT": ("INT32", "0", "0", "12", "", _GEOMETRY, "Total number of rotors"),
    **_rotor_geometry(),
    # simulation/gz_bridge/module.yaml (v1.15): the gz bridge's outputs, ESCs and servos 1..8
    # (0..1000), wheels 1..2 (0..200); the x500's four motors are ESCs 1..4
    **_outputs("SIM_GZ_EC", "SIM_GZ", "ESC", range(1, 9), ("0", "1000"), "255"),
    **_outputs("SIM_GZ_SV", "SIM_GZ", "Servo", range(1, 9), ("500", "1000"), "255"),
    **_outputs("SIM_GZ_WH", "SIM_GZ", "Wheels", range(1, 3), ("100", "200"), "3"),
    # simulation/gz_bridge/parameters.c (v1.15): @boolean, @reboot_required true, @group UAVCAN
    "SIM_GZ_EN": ("INT32", "0", "", "", "", "UAVCAN", "Simulator Gazebo bridge enable"),
    # drivers/pwm_out_sim/module_sim.yaml (v1.15): pwm_out_sim's 16 channels, functions only
    **_outputs("PWM_MAIN", "SIM", "Channel", range(1, 17), None, "65535"),
}

# The airframe's own values (ROMFS/px4fmu_common/init.d-posix/airframes/4001_gz_x500): the gz
# bridge on, four rotors of the x500 (CA_ROTORn_PX, _PY, _KM; vehicles/airframe.py
# allocation_rotors) on ESCs 1..4 as motors 1..4, spinning from 150 to 1000 rad/s.
AIRFRAME = {
    "SIM_GZ_EN": "1",
    "CA_ROTOR_COUNT": "4",
    **{f"CA_ROTOR{i}_{k}": v for i, rotor in enumerate((("0.13", "0.22", "0.05"),
                                                         ("-0.13", "-0.20", "0.05"),
                                                         ("0.13", "-0.22", "-0.05"),
                                                         ("-0.13", "0.20", "-0.05")))
       for k, v in zip(("PX", "PY", "KM"), rotor)},
    **{f"SIM_GZ_EC_{k}{n}": v for n in range(1, 5)
       for k, v in (("FUNC", str(100 + n)), ("MIN", "150"), ("MAX", "1000"))},
}


# In the old metadata table but gone from PX4 v1.15 (param_find fails, as a client's get does).
REMOVED = {
    "LNDMC_ALT_MAX",  # not in v1.15's land_detector_params_mc.c
    "EKF2_HGT_MODE",  # EKF2_HGT_REF and the *_CTRL switches since v1.14 (no translation)
    # Nor these: no PARAM_DEFINE or module.yaml of a px4_sitl_default v1.15.2 build defines
    # them (renamed, such as MPC_SPOOLUP_TIME → COM_SPOOLUP_TIME, or gone). MAV_BROADCAST stays:
    # this gateway's own switch for PX4 SITL's broadcast option (gateway/daemon/px4_sitl.py).
    *(
        "BAT_A_PER_V",
        "BAT_CAPACITY",
        "BAT_C_MULT",
        "BAT_R_INTERNAL",
        "BAT_SMBUS_MODEL",
        "BAT_SOURCE",
        "BAT_V_DIV",
        "CAL_MAG_ROT_AUTO",
        "CBRK_AIRSPD_CHK",
        "CBRK_ENGINEFAIL",
        "CBRK_RATE_CTRL",
        "CBRK_VELPOSERR",
        "COM_ARM_AUTH",
        "COM_ARM_EKF_AB",
        "COM_ARM_EKF_GB",
        "COM_EF_C2T",
        "COM_EF_THROT",
        "COM_EF_TIME",
        "COM_HOME_H_T",
        "COM_HOME_V_T",
        "COM_OBL_ACT",
        "COM_POS_FS_EPV",
        "COM_POS_FS_GAIN",
        "COM_POS_FS_PROB",
        "COM_REARM_GRACE",
        "EKF2_AID_MASK",
        "EKF2_IMU_ID",
        "EKF2_MAGBIAS_ID",
        "EKF2_MAGBIAS_X",
        "EKF2_MAGBIAS_Y",
        "EKF2_MAGBIAS_Z",
        "EKF2_MAGB_K",
        "EKF2_MAGB_VREF",
        "EKF2_MAG_YAWLIM",
        "EKF2_MIN_OBS_DT",
        "EKF2_MOVE_TEST",
        "EKF2_RNG_AID",
        "EKF2_WIND_NOISE",
        "EXFW_HDNG_P",
        "EXFW_PITCH_P",
        "EXFW_ROLL_P",
        "GF_ALTMODE",
        "GF_COUNT",
        "GPS_1_CONFIG",
        "GPS_2_CONFIG",
        "IMU_GYRO_NF_BW",
        "IMU_GYRO_NF_FREQ",
        "LED_RGB1_MAXBRT",
        "LED_RGB_MAXBRT",
        "MAV_0_CONFIG",
        "MAV_1_CONFIG",
        "MAV_2_CONFIG",
        "MAV_ODOM_LP",
        "MC_RATT_TH",
        "MIS_DIST_WPS",
        "MIS_LTRMIN_ALT",
        "MIS_TAKEOFF_REQ",
        "MOT_ORDERING",
        "MPC_DEC_HOR_SLOW",
        "MPC_JERK_MIN",
        "MPC_LAND_VEL_XY",
        "MPC_SPOOLUP_TIME",
        "NAV_AH_ALT",
        "NAV_AH_LAT",
        "NAV_AH_LON",
        "NAV_FT_DST",
        "NAV_FT_FS",
        "NAV_FT_RS",
        "NAV_MIN_FT_HT",
        "NAV_TRAFF_A_RADM",
        "NAV_TRAFF_A_RADU",
        "PCF8583_ADDR",
        "RV_YAW_P",
        "SENS_CM8JL65_CFG",
        "SENS_LEDDAR1_CFG",
        "SENS_SF0X_CFG",
        "SENS_TFLOW_CFG",
        "SENS_TFMINI_CFG",
        "SENS_ULAND_CFG",
        "SYS_MC_EST_GROUP",
        "SYS_PARAM_VER",
        "SYS_RESTART_TYPE",
        "SYS_USE_IO",
        "TEL_FRSKY_CONFIG",
        "TEL_HOTT_CONFIG",
    ),
}

# PX4 v1.15.2's firmware defaults (the PARAM_DEFINE / module.yaml value, parameters.json's
# "default") of the parameters whose SITL default above is set by the start-up scripts with
# ``param set-default`` (init.d-posix/rcS and px4-rc.*, the airframe and init.d/rc.mc_defaults):
# the "firmware_default" column. The AIRFRAME values' firmware defaults are ADDED_RANGED's.
FIRMWARE_DEFAULTS: dict[str, str] = {
    "MAV_PROTO_VER": "0",  # set by init.d-posix/rcS (mavlink_params.c)
    "MAV_TYPE": "0",  # init.d/rc.mc_defaults (mavlink_params.c)
    "COM_RC_IN_MODE": "3",  # rcS (commander_params.c)
    "COM_LOW_BAT_ACT": "0",  # rcS
    "COM_CPU_MAX": "95.0",  # rcS
    "NAV_ACC_RAD": "10.0",  # rc.mc_defaults (navigator_params.c)
    "RTL_RETURN_ALT": "60.0",  # rc.mc_defaults (rtl_params.c)
    "RTL_DESCEND_ALT": "30.0",  # rc.mc_defaults
    "MPC_THR_HOVER": "0.5",  # the airframe (multicopter_position_control_params.c)
    "BAT1_N_CELLS": "0",  # rcS (lib/battery/module.yaml)
    "SDLOG_MODE": "0",  # rcS (logger/params.c)
    "SDLOG_PROFILE": "1",  # rcS
    "SDLOG_DIRS_MAX": "0",  # rcS
    "CBRK_SUPPLY_CHK": "0",  # rcS (circuit_breaker_params.c)
    "IMU_INTEG_RATE": "200",  # init.d-posix/px4-rc.simulator (imu_parameters.c)
    "IMU_GYRO_RATEMAX": "400",  # rc.mc_defaults (imu_gyro_parameters.c)
    "GPS_UBX_DYNMODEL": "7",  # rc.mc_defaults (drivers/gps/params.c)
    "SYS_FAILURE_EN": "0",  # rcS (system_params.c)
    "EKF2_REQ_GPS_H": "10.0",  # rcS (ekf2/module.yaml)
    # rcS sets these with ``param set`` (a value, not a default: PX4's reset clears them)
    "SYS_AUTOSTART": "0", "CAL_ACC0_ID": "0", "CAL_GYRO0_ID": "0", "CAL_MAG0_ID": "0",
}

FIELDS = ["name", "type", "default", "firmware_default", "min", "max", "unit", "group",
          "short_desc"]


def main(src: str, dst: str) -> None:
    rows = []
    with open(src, newline="") as f:
        for row in csv.DictReader(f):
            if (row["group"] not in KEEP_GROUPS and row["name"] not in KEEP_NAMES) or \
                    row["type"] not in ("INT32", "FLOAT") or row["name"] in REMOVED:
                continue
            row["default"] = OVERRIDES.get(row["name"], row["default"])
            row["firmware_default"] = FIRMWARE_DEFAULTS.get(row["name"], "")
            rows.append({k: row[k] for k in FIELDS})
    have = {r["name"] for r in rows}
    for name, (typ, default, unit, group, desc) in ADDED.items():
        if name not in have:
            rows.append(dict(name=name, type=typ, default=default,
                             firmware_default=FIRMWARE_DEFAULTS.get(name, ""), min="", max="",
                             unit=unit, group=group, short_desc=desc))
    for name, (typ, default, lo, hi, unit, group, desc) in ADDED_RANGED.items():
        if name not in have:
            rows.append(dict(name=name, type=typ, default=AIRFRAME.get(name, default),
                             firmware_default=default if name in AIRFRAME else "", min=lo,
                             max=hi, unit=unit, group=group, short_desc=desc))
    for row in rows:
        row["min"], row["max"] = RANGES.get(row["name"], (row["min"], row["max"]))
    missing = (set(OVERRIDES) | set(RANGES) | set(AIRFRAME) | set(FIRMWARE_DEFAULTS)) \
        - {r["name"] for r in rows}
    if missing:
        raise SystemExit(f"overrides for unknown parameters: {sorted(missing)}")
    rows.sort(key=lambda r: r["name"])
    with open(dst, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    print(f"{len(rows)} parameters -> {dst}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
