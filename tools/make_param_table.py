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
    "MIS_DIST_1WP": "10000",
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
    "COM_DLL_EXCEPT": ("INT32", "0", "", "Commander", "Datalink loss exceptions"),
    "COM_OBC_LOSS_T": ("FLOAT", "5.0", "s", "Commander", "Offboard computer loss timeout"),
    "COM_FAIL_ACT_T": ("FLOAT", "5.0", "s", "Commander", "Delay between failsafe condition and action"),
    "COM_HOME_EN": ("INT32", "1", "", "Commander", "Allows setting the home position"),
    "COM_ARMABLE": ("INT32", "1", "", "Commander", "Flag to allow arming"),
    "COM_RAM_MAX": ("FLOAT", "-1", "%", "Commander", "Maximum allowed RAM usage to pass checks"),
    "COM_MODE_ARM_CHK": ("INT32", "1", "", "Commander", "Enable mode-specific arming checks"),
    "GF_PREDICT": ("INT32", "0", "", "Geofence", "Use predictive geofence"),
    "SIM_BAT_ENABLE": ("INT32", "1", "", "SITL", "Simulator battery enabled"),
    "EKF2_EN": ("INT32", "1", "", "EKF2", "EKF2 enable"),
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

# In the old metadata table but gone from PX4 v1.15 (param_find fails, as a client's get does).
REMOVED = {
    "LNDMC_ALT_MAX",  # not in v1.15's land_detector_params_mc.c
    "EKF2_HGT_MODE",  # EKF2_HGT_REF and the *_CTRL switches since v1.14 (no translation)
}

FIELDS = ["name", "type", "default", "min", "max", "unit", "group", "short_desc"]


def main(src: str, dst: str) -> None:
    rows = []
    with open(src, newline="") as f:
        for row in csv.DictReader(f):
            if (row["group"] not in KEEP_GROUPS and row["name"] not in KEEP_NAMES) or \
                    row["type"] not in ("INT32", "FLOAT") or row["name"] in REMOVED:
                continue
            row["default"] = OVERRIDES.get(row["name"], row["default"])
            rows.append({k: row[k] for k in FIELDS})
    have = {r["name"] for r in rows}
    for name, (typ, default, unit, group, desc) in ADDED.items():
        if name not in have:
            rows.append(dict(name=name, type=typ, default=default, min="", max="", unit=unit,
                             group=group, short_desc=desc))
    for row in rows:
        row["min"], row["max"] = RANGES.get(row["name"], (row["min"], row["max"]))
    missing = (set(OVERRIDES) | set(RANGES)) - {r["name"] for r in rows}
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
