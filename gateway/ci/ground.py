"""A ground-side waypoint controller closing the loop over the network (the paper's Fig. 8).

It sees the vehicle only through telemetry (LOCAL_POSITION_NED on the API link, as old as the
network makes it) and commands it only through offboard velocity setpoints
(SET_POSITION_TARGET_LOCAL_NED), CONTROL_HZ times a second: speed = min(limit, kp · distance)
towards the current waypoint, the next one once the seen position is within the acceptance
radius. Latency delays both what it sees and what it commands, so the flown track overshoots the
corners: the drift grows with the latency. gcs_examples/trajectory_drift.py runs the same law
against ``cornet run`` over UDP; ``cornet fly/sweep --control ground`` runs it in lockstep.
"""

from __future__ import annotations

import math
from typing import Any

from vehicles.types import NavState, Vec3

CONTROL_HZ = 20.0
SPEED_MPS = 5.0  # the controller's speed limit
KP = 1.0  # 1/s: speed = min(limit, kp · distance)
VZ_MAX_MPS = 2.0
ACCEPTANCE_M = 1.0
TAKEOFF_TIMEOUT_S = 60.0
HOLD_BEFORE_OFFBOARD_S = 1.0  # PX4 enters offboard only with a fresh setpoint stream
# SET_POSITION_TARGET_LOCAL_NED type mask: velocity only (no position, acceleration, yaw).
VELOCITY_ONLY = 0b110111000111
MAV_FRAME_LOCAL_NED = 1


def velocity_towards(pos: Vec3, target: Vec3, speed_mps: float = SPEED_MPS, kp: float = KP,
                     vz_max_mps: float = VZ_MAX_MPS) -> tuple[float, float, float]:
    """The velocity setpoint (north, east, down) towards ``target`` from ``pos`` (local NED)."""
    dn, de = target[0] - pos[0], target[1] - pos[1]
    dist = math.hypot(dn, de)
    speed = min(speed_mps, kp * dist)
    vn, ve = (speed * dn / dist, speed * de / dist) if dist > 0 else (0.0, 0.0)
    return vn, ve, max(-vz_max_mps, min(vz_max_mps, kp * (target[2] - pos[2])))


def fly_ground(sim: Any, targets: list[tuple[int | None, Vec3]], res: Any,
               time_limit_s: float) -> str | None:
    """Take off, fly ``targets`` (gateway.ci.fly.planned_targets, from the start point on) in
    offboard from the ground, then land. Records when each item's last point was reached in
    ``res.item_times`` (by the position seen on the ground). Returns why it could not, or None
    once the vehicle was told to land (the caller waits for it to disarm)."""
    api = sim.api(0)
    status = sim.status
    final_land = len(targets) > 1 and targets[-1][1][2] == targets[0][1][2]
    points = targets[1:-1] if final_land else targets[1:]
    result = api.takeoff()
    if result != 0:
        return "takeoff " + ("timed out" if result is None else f"denied (MAV_RESULT {result})")
    if not sim.run_until(lambda: status(0).nav_state == NavState.AUTO_LOITER,
                         min(TAKEOFF_TIMEOUT_S, max(0.0, time_limit_s - sim.now))):
        return "takeoff did not finish"
    state = {"index": 0}
    last_of = {seq: k for k, (seq, _) in enumerate(points)}

    def control(now: float) -> None:
        m = api.last("LOCAL_POSITION_NED")
        k = state["index"]
        if m is None or k >= len(points) or status(0).nav_state not in (NavState.OFFBOARD,
                                                                         NavState.AUTO_LOITER):
            v = (0.0, 0.0, 0.0)
        else:
            pos = (m.x, m.y, m.z)
            seq, target = points[k]
            if math.dist(pos, target) < ACCEPTANCE_M:
                if seq is not None and last_of[seq] == k:
                    res.item_times.setdefault(seq, round(now, 3))
                state["index"] = k + 1
            v = velocity_towards(pos, target) if status(0).nav_state == NavState.OFFBOARD \
                else (0.0, 0.0, 0.0)
        api.send(api.mav.set_position_target_local_ned_encode(
            int(round(now * 1e3)) & 0xFFFFFFFF, api.target, 1, MAV_FRAME_LOCAL_NED,
            VELOCITY_ONLY, 0, 0, 0, *v, 0, 0, 0, 0, 0))

    ticker = sim.every(1.0 / CONTROL_HZ, control)
    try:
        sim.advance(HOLD_BEFORE_OFFBOARD_S)
        result = api.set_mode(NavState.OFFBOARD)
        if result != 0:
            return "offboard " + ("timed out" if result is None
                                  else f"denied (MAV_RESULT {result})")
        sim.run_until(lambda: state["index"] >= len(points) or not status(0).armed
                      or res.geofence_breach is not None, max(0.0, time_limit_s - sim.now))
    finally:
        ticker.cancel()
    if state["index"] < len(points):
        return None if res.geofence_breach is not None else \
            f"ground control reached {state['index']}/{len(points)} waypoints"
    res.mission_finished = True
    result = api.land()
    if result != 0:
        return "land " + ("timed out" if result is None else f"denied (MAV_RESULT {result})")
    if final_land and targets[-1][0] is not None:
        res.item_times.setdefault(targets[-1][0], round(sim.now, 3))
    return None
