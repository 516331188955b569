"""The simulator's ground truth as PX4 SITL's logger writes it (logged_topics.cpp's SITL block:
vehicle_attitude_groundtruth, vehicle_angular_velocity_groundtruth at 10 ms,
vehicle_local_position_groundtruth at 20 ms, vehicle_global_position_groundtruth at 100 ms), read
from the World's true state; the rules are logged_topics.py's."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from gateway.onboard.topic import U64, D, F, Topic
from vehicles.control.quat import q_yaw
from vehicles.estimation import R_TRUE_Q, R_TRUE_RATES


def _attitude_truth_step(r: Sequence[float], t_us: int) -> Sequence[float]:
    return r[R_TRUE_Q:R_TRUE_Q + 4]


def _angular_velocity_truth_step(r: Sequence[float], t_us: int) -> tuple:
    return (t_us, *r[R_TRUE_RATES:R_TRUE_RATES + 3])


def _attitude_truth(v: Any, now_us: int) -> tuple:
    return v.truth.attitude_q


def _angular_velocity_truth(v: Any, now_us: int) -> tuple:
    return (now_us, *v.truth.rates_frd_radps)


def _local_position_truth(v: Any, now_us: int) -> tuple:
    m = v.truth
    o = v.origin
    return (*m.position_ned_m, *m.velocity_ned_mps, *m.accel_ned_mps2, q_yaw(m.attitude_q),
            o.lat_deg, o.lon_deg, o.alt_amsl_m)


def _global_position_truth(v: Any, now_us: int) -> tuple:
    n, e, d = v.truth.position_ned_m
    g = v.origin.offset_ned(n, e, d)
    return (g.lat_deg, g.lon_deg, g.alt_amsl_m)


TRUTH_TOPICS: tuple[Topic, ...] = (
    Topic("vehicle_attitude_groundtruth", (("float[4]", "q"),), 0.01, _attitude_truth,
          step=_attitude_truth_step),
    Topic("vehicle_angular_velocity_groundtruth", ((U64, "timestamp_sample"),
                                                   ("float[3]", "xyz")), 0.01,
          _angular_velocity_truth, step=_angular_velocity_truth_step),
    Topic("vehicle_local_position_groundtruth", ((F, "x"), (F, "y"), (F, "z"), (F, "vx"),
                                                 (F, "vy"), (F, "vz"), (F, "ax"), (F, "ay"),
                                                 (F, "az"), (F, "heading"), (D, "ref_lat"),
                                                 (D, "ref_lon"), (F, "ref_alt")), 0.02,
          _local_position_truth),
    Topic("vehicle_global_position_groundtruth", ((D, "lat"), (D, "lon"), (F, "alt")), 0.1,
          _global_position_truth),
)
