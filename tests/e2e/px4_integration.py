"""PX4 v1.15.2's MAVROS test harness (``integrationtests/python_src/px4_it/mavros/
mavros_test_common.py``, the helpers of ``mission_test.py`` and of the offboard tests) over
pymavlink: the client MAVROS is, on the onboard (API) link, as ``mavros_posix_sitl.launch``
connects it (``fcu_url udp://:14540@localhost:14557``; MAVROS's ids 1/240).

- MAVROS's topics are the latest of the messages it makes them from: altitude ← ALTITUDE,
  extended_state ← EXTENDED_SYS_STATE, global_position/global ← GLOBAL_POSITION_INT,
  local_position/pose ← LOCAL_POSITION_NED + ATTITUDE_QUATERNION (ENU), imu/data ←
  ATTITUDE_QUATERNION (FLU), home_position/home ← HOME_POSITION, mission/waypoints ← the mission
  pulled at connection, pushed or cleared (current_seq ← MISSION_CURRENT), mission/reached ←
  MISSION_ITEM_REACHED, state ← HEARTBEAT. MAVROS's own HEARTBEAT (ONBOARD_CONTROLLER) goes out
  at 1 Hz; setpoints as MAVROS converts them (ENU/FLU → NED/FRD, ftf_frame_conversions.cpp).
- Every loop counts ROS time, which PX4's SITL runs on Gazebo's clock (use_sim_time): here the
  vehicle's (its telemetry's time_boot_ms), so at ``--speed 10`` the time-outs are PX4's. A clock
  that stops for STALL_WALL_S wall seconds fails the test.
"""

from __future__ import annotations

import json
import logging
import math
import queue
import struct
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from pymavlink import mavutil

M = mavutil.mavlink
log = logging.getLogger("px4_it")
STALL_WALL_S = 10.0
MISSIONS_DIR = Path(__file__).parent / "data" / "px4_missions"
# mavros/src/plugins/sys_status.cpp px4_custom_mode table: name → (main mode, sub mode)
PX4_MODES = {"MANUAL": (1, 0), "ALTCTL": (2, 0), "POSCTL": (3, 0), "AUTO.READY": (4, 1),
             "AUTO.TAKEOFF": (4, 2), "AUTO.LOITER": (4, 3), "AUTO.MISSION": (4, 4),
             "AUTO.RTL": (4, 5), "AUTO.LAND": (4, 6), "AUTO.RTGS": (4, 7),
             "AUTO.FOLLOW_TARGET": (4, 8), "AUTO.PRECLAND": (4, 9), "ACRO": (5, 0),
             "OFFBOARD": (6, 0), "STABILIZED": (7, 0)}
_PROTOCOL = {"COMMAND_ACK", "MISSION_ACK", "MISSION_REQUEST", "MISSION_REQUEST_INT",
             "MISSION_COUNT", "MISSION_ITEM_INT", "PARAM_VALUE"}
_TOPICS = {"ALTITUDE": "alt", "GLOBAL_POSITION_INT": "global_pos", "LOCAL_POSITION_NED": "local_pos",
           "ATTITUDE_QUATERNION": "imu", "ATTITUDE": "attitude", "HOME_POSITION": "home_pos"}


def mode_name(custom_mode: int) -> str:
    main, sub = (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF
    for name, (m, s) in PX4_MODES.items():
        if m == main and (s == sub or m != 4):
            return name
    return f"CMODE({custom_mode})"


# --- quaternions (w, x, y, z), as tf / Eigen in MAVROS ---------------------------------------------
def q_mul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def q_from_euler(roll: float, pitch: float, yaw: float):
    """tf.transformations.quaternion_from_euler (static xyz: Rz·Ry·Rx), as (w, x, y, z)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy)


def q_to_euler(q):
    w, x, y, z = q
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


NED_ENU_Q = q_from_euler(math.pi, 0.0, math.pi / 2)  # ftf: NED_ENU_Q
AIRCRAFT_BASELINK_Q = q_from_euler(math.pi, 0.0, 0.0)  # ftf: AIRCRAFT_BASELINK_Q


def enu_baselink_to_ned_aircraft(q):
    """transform_orientation_enu_ned(transform_orientation_baselink_aircraft(q))."""
    return q_mul(NED_ENU_Q, q_mul(q, AIRCRAFT_BASELINK_Q))


# --- QGC plan files (mission_test.py read_plan_file) --------------------------------------------
@dataclass
class Waypoint:
    frame: int
    command: int
    params: tuple  # param1..4 (NaN for null), x_lat, y_long, z_alt
    autocontinue: bool
    is_current: bool = False


def read_mission(name: str) -> list[Waypoint]:
    d = json.loads((MISSIONS_DIR / name).read_text())
    d = d.get("mission", d)
    if "items" not in d:
        raise OSError("no mission items")
    wps = []
    for it in d["items"]:
        if it.get("type", "SimpleItem") != "SimpleItem":
            raise OSError(f"unsupported plan item {it.get('type')}")
        p = [math.nan if v is None else float(v) for v in it["params"]]
        wps.append(Waypoint(int(it["frame"]), int(it["command"]), tuple(p),
                            bool(it["autoContinue"])))
    if wps:
        wps[0].is_current = True
    return wps


# --- the client -------------------------------------------------------------------------------------
class MavrosClient:
    """What MavrosTestCommon reads and calls, kept up to date by a reader thread."""

    def __init__(self, port: int, target: int = 1) -> None:
        self.conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=1,
                                               source_component=240, dialect="common")
        self.target = target
        self.lock = threading.Lock()
        self.protocol: queue.Queue = queue.Queue()
        self.now_s = 0.0  # the vehicle's clock
        self.topics: dict[str, object] = {}  # MAVROS topic → latest message
        self.armed, self.mode, self.landed_state, self.vtol_state, self.current_seq = (
            False, "", 0, 0, 0)
        self.waypoints: list[Waypoint] | None = None  # None until pulled
        self.mission_item_reached = -1
        self.gcs_heartbeat_hz = 0.0  # mission_test.py's extra GCS HEARTBEAT (sys 2, comp 1)
        self.setpoint = None  # a callable sending one setpoint (10 Hz) or None
        self.ground_truth: list[tuple] = []  # (estimated (r, p, y), true (r, p, y))
        self._gcs_mav = M.MAVLink(None, srcSystem=2, srcComponent=1)
        self._due = {"hb": 0.0, "gcs": 0.0, "sp": 0.0}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="mavros-reader", daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self.conn.close()

    def send(self, name: str, *args) -> None:
        with self.lock:
            getattr(self.conn.mav, name + "_send")(*args)

    # reader thread: topics, clock, and what MAVROS and the tests' threads stream
    def _run(self) -> None:
        while not self._stop.is_set():
            msg = self.conn.recv_match(blocking=True, timeout=0.05)
            if msg is not None and msg.get_srcSystem() == self.target:
                try:
                    self._handle(msg)
                except Exception:  # pragma: no cover - keep the reader alive; log it
                    log.exception("handling %s", msg)
            self._stream()

    def _handle(self, msg) -> None:
        t = msg.get_type()
        t_ms = getattr(msg, "time_boot_ms", None)
        if t_ms is not None and t_ms / 1000.0 > self.now_s:
            self.now_s = t_ms / 1000.0
        if t in _PROTOCOL:
            self.protocol.put(msg)
        if t == "HEARTBEAT" and msg.get_srcComponent() == 1:
            armed = bool(msg.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)
            mode = mode_name(msg.custom_mode)
            if (armed, mode) != (self.armed, self.mode):
                log.info("state: armed %s, mode %s at %.1f s", armed, mode, self.now_s)
            self.armed, self.mode = armed, mode
            self.topics["state"] = msg
        elif t == "EXTENDED_SYS_STATE":
            if msg.landed_state != self.landed_state:
                log.info("landed state %s → %s at %.1f s", self.landed_state, msg.landed_state,
                         self.now_s)
            self.landed_state, self.vtol_state = msg.landed_state, msg.vtol_state
            self.topics["ext_state"] = msg
        elif t in _TOPICS and not (t == "ALTITUDE" and math.isnan(msg.altitude_amsl)):
            self.topics[_TOPICS[t]] = msg  # (altitude: "amsl has been observed to be nan")
        elif t == "MISSION_CURRENT":
            if msg.seq != self.current_seq:
                log.info("current mission seq %d at %.1f s", msg.seq, self.now_s)
            self.current_seq = msg.seq
        elif t == "MISSION_ITEM_REACHED":
            if msg.seq != self.mission_item_reached:
                log.info("mission item reached: %d at %.1f s", msg.seq, self.now_s)
            self.mission_item_reached = msg.seq
        elif t == "HIL_STATE_QUATERNION" and "attitude" in self.topics:
            a = self.topics["attitude"]
            self.ground_truth.append(((a.roll, a.pitch, a.yaw), q_to_euler(msg.attitude_quaternion)))

    def _stream(self) -> None:
        now, due = self.now_s, self._due
        if now <= 0.0:
            return
        if now >= due["hb"]:
            self.send("heartbeat", M.MAV_TYPE_ONBOARD_CONTROLLER, M.MAV_AUTOPILOT_INVALID, 0, 0,
                      M.MAV_STATE_ACTIVE)
            due["hb"] = now + 1.0
        if self.gcs_heartbeat_hz and now >= due["gcs"]:
            hb = M.MAVLink_heartbeat_message(M.MAV_TYPE_GCS, 0, 0, 0, 0, 0)
            with self.lock:
                self.conn.write(hb.pack(self._gcs_mav))
            due["gcs"] = now + 1.0 / self.gcs_heartbeat_hz
        if self.setpoint is not None and now >= due["sp"]:
            self.setpoint()
            due["sp"] = now + 0.1  # the offboard tests' rospy.Rate(10)

    # --- time ---------------------------------------------------------------------------------
    def sleep(self, dt_s: float) -> None:
        """Sleep ``dt_s`` of the vehicle's (ROS) time."""
        target = self.now_s + dt_s
        last, moved_at = self.now_s, time.monotonic()
        while self.now_s < target:
            time.sleep(0.002)
            if self.now_s != last:
                last, moved_at = self.now_s, time.monotonic()
            elif time.monotonic() - moved_at > STALL_WALL_S:
                raise AssertionError(f"the vehicle's clock stopped at {self.now_s:.2f} s")

    def ticks(self, timeout: float, loop_freq: float):
        """``for i in xrange(timeout * loop_freq): ...; rate.sleep()``: yields i, sleeps after."""
        for i in range(int(timeout * loop_freq)):
            yield i
            self.sleep(1.0 / loop_freq)

    def expect(self, types: set[str], timeout_s: float, cond=lambda m: True):
        """The next protocol message of ``types`` (for which ``cond``), None after ``timeout_s``
        of vehicle time."""
        end, wall_end = self.now_s + timeout_s, time.monotonic() + STALL_WALL_S
        while self.now_s < end and time.monotonic() < wall_end:
            try:
                msg = self.protocol.get(timeout=0.01)
            except queue.Empty:
                continue
            if msg.get_type() in types and cond(msg):
                return msg
        return None

    def drain(self) -> None:
        self.protocol = queue.Queue()

    # --- MAVROS services ------------------------------------------------------------------------
    def command(self, command: int, *params: float) -> int | None:
        """mavros/cmd/*: COMMAND_LONG, its COMMAND_ACK's result (None: none came)."""
        p = list(params) + [0.0] * (7 - len(params))
        self.drain()
        self.send("command_long", self.target, 1, command, 0, *p)
        ack = self.expect({"COMMAND_ACK"}, 1.0, lambda m: m.command == command)
        return None if ack is None else ack.result

    def set_mode_srv(self, mode: str) -> bool:
        flag = M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        return self.command(M.MAV_CMD_DO_SET_MODE, flag, *PX4_MODES[mode]) is not None

    def param_get(self, name: str) -> float | None:
        self.drain()
        self.send("param_request_read", self.target, 1, name.encode(), -1)
        msg = self.expect({"PARAM_VALUE"}, 1.0, lambda m: m.param_id == name)
        return None if msg is None else msg.param_value

    def param_set_int(self, name: str, value: int) -> bool:
        """mavros/param/set with an integer: PX4's byte-wise encoding of an INT32."""
        raw = struct.unpack("<f", struct.pack("<i", value))[0]
        self.drain()
        self.send("param_set", self.target, 1, name.encode(), raw, M.MAV_PARAM_TYPE_INT32)
        msg = self.expect({"PARAM_VALUE"}, 1.0, lambda m: m.param_id == name)
        return msg is not None and struct.unpack("<i", struct.pack("<f", msg.param_value))[0] == value

    def pull_mission(self) -> bool:
        """mavros/mission/pull (what MAVROS does once connected)."""
        self.drain()
        self.send("mission_request_list", self.target, 1, 0)
        count = self.expect({"MISSION_COUNT"}, 2.0)
        if count is None:
            return False
        items = []
        for seq in range(count.count):
            self.send("mission_request_int", self.target, 1, seq, 0)
            it = self.expect({"MISSION_ITEM_INT"}, 2.0, lambda m, s=seq: m.seq == s)
            if it is None:
                return False
            items.append(Waypoint(it.frame, it.command, (it.param1, it.param2, it.param3,
                                  it.param4, it.x / 1e7, it.y / 1e7, it.z), bool(it.autocontinue)))
        self.send("mission_ack", self.target, 1, M.MAV_MISSION_ACCEPTED, 0)
        self.waypoints = items
        return True

    def push_mission(self, wps: list[Waypoint]) -> bool:
        """mavros/mission/push: MISSION_COUNT, a MISSION_ITEM_INT per request, MISSION_ACK."""
        self.drain()
        self.send("mission_count", self.target, 1, len(wps), 0)
        while True:
            msg = self.expect({"MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"}, 5.0)
            if msg is None:
                return False
            if msg.get_type() == "MISSION_ACK":
                ok = msg.type == M.MAV_MISSION_ACCEPTED
                if ok:
                    self.waypoints = list(wps)
                return ok
            w = wps[msg.seq]
            p1, p2, p3, p4, lat, lon, alt = w.params
            self.send("mission_item_int", self.target, 1, msg.seq, w.frame, w.command,
                      int(w.is_current), int(w.autocontinue), p1, p2, p3, p4,
                      int(round(lat * 1e7)), int(round(lon * 1e7)), alt, 0)

    def clear_mission(self) -> bool:
        self.drain()
        self.send("mission_clear_all", self.target, 1, 0)
        ack = self.expect({"MISSION_ACK"}, 2.0)
        if ack is not None and ack.type == M.MAV_MISSION_ACCEPTED:
            self.waypoints = []
            return True
        return False

    # --- topics as MAVROS publishes them ----------------------------------------------------------
    def local_position_enu(self) -> tuple[float, float, float]:
        p = self.topics.get("local_pos")
        return (0.0, 0.0, 0.0) if p is None else (p.y, p.x, -p.z)

    def local_orientation_enu(self):
        """local_position/pose's orientation (ROS's default all-zero Quaternion before any)."""
        a = self.topics.get("imu")
        if a is None:
            return (0.0, 0.0, 0.0, 0.0)
        return q_mul(NED_ENU_Q, q_mul((a.q1, a.q2, a.q3, a.q4), AIRCRAFT_BASELINK_Q))

    def imu_yaw_rate_flu(self) -> float:
        a = self.topics.get("imu")
        return 0.0 if a is None else -a.yawspeed

    def describe(self) -> str:
        return (f"at {self.now_s:.1f} s: mode {self.mode}, armed {self.armed}, landed state "
                f"{self.landed_state}, local ENU {tuple(round(v, 2) for v in self.local_position_enu())}"
                f", mission seq {self.current_seq}, reached {self.mission_item_reached}")


class MavrosTestCommon:
    """mavros_test_common.py's helpers: the same loops, rates, time-outs and messages."""

    TOPICS = ("alt", "ext_state", "global_pos", "home_pos", "local_pos", "mission_wp", "state",
              "imu")

    def __init__(self, client: MavrosClient) -> None:
        self.c = client

    def fail(self, what: str) -> None:
        raise AssertionError(f"{what} | {self.c.describe()}")

    def ready(self) -> dict[str, bool]:
        return {k: (self.c.waypoints is not None) if k == "mission_wp" else k in self.c.topics
                for k in self.TOPICS}

    def wait_for_topics(self, timeout: int) -> None:
        for i in self.c.ticks(timeout, 1):
            if self.c.waypoints is None and "state" in self.c.topics:
                self.c.pull_mission()
            if all(self.ready().values()):
                log.info("simulation topics ready | seconds: %s of %s", i, timeout)
                return
        self.fail(f"failed to hear from all subscribed simulation topics | topic ready flags: "
                  f"{self.ready()} | timeout(seconds): {timeout}")

    def wait_for_landed_state(self, desired: int, timeout: int, index: int) -> None:
        for i in self.c.ticks(timeout, 10):
            if self.c.landed_state == desired:
                log.info("landed state confirmed | seconds: %s of %s", i / 10, timeout)
                return
        self.fail(f"landed state not detected | desired: {desired}, current: "
                  f"{self.c.landed_state} | index: {index}, timeout(seconds): {timeout}")

    def wait_for_vtol_state(self, transition: int, timeout: int, index: int) -> None:
        for _ in self.c.ticks(timeout, 10):
            if self.c.vtol_state == transition:
                return
        self.fail(f"transition not detected | desired: {transition} | index: {index}")

    def set_arm(self, arm: bool, timeout: int) -> None:
        old = self.c.armed
        for i in self.c.ticks(timeout, 1):
            if self.c.armed == arm:
                log.info("set arm success | seconds: %s of %s", i, timeout)
                return
            if self.c.command(M.MAV_CMD_COMPONENT_ARM_DISARM, float(arm)) != M.MAV_RESULT_ACCEPTED:
                log.error("failed to send arm command")
        self.fail(f"failed to set arm | new arm: {arm}, old arm: {old} | timeout(seconds): "
                  f"{timeout}")

    def set_mode(self, mode: str, timeout: int) -> None:
        old = self.c.mode
        for i in self.c.ticks(timeout, 1):
            if self.c.mode == mode:
                log.info("set mode success | seconds: %s of %s", i, timeout)
                return
            if not self.c.set_mode_srv(mode):
                log.error("failed to send mode command")
        self.fail(f"failed to set mode | new mode: {mode}, old mode: {old} | timeout(seconds): "
                  f"{timeout}")

    def set_param_int(self, name: str, value: int, timeout: int) -> None:
        for _ in self.c.ticks(timeout, 1):
            if self.c.param_set_int(name, value):
                return
        self.fail(f"failed to set param | param_id: {name}, param_value: {value} | "
                  f"timeout(seconds): {timeout}")

    def wait_for_mav_type(self, timeout: int) -> int:
        for _ in self.c.ticks(timeout, 1):
            value = self.c.param_get("MAV_TYPE")
            if value is not None:
                return struct.unpack("<i", struct.pack("<f", value))[0]
        self.fail(f"MAV_TYPE param get failed | timeout(seconds): {timeout}")
        return -1

    def send_wps(self, wps: list[Waypoint], timeout: int) -> None:
        sent = verified = False
        for _ in self.c.ticks(timeout, 1):
            if not sent:
                sent = self.c.push_mission(wps)
            elif self.c.waypoints is not None and len(self.c.waypoints) == len(wps):
                verified = True
            if sent and verified:
                return
        self.fail(f"mission could not be transferred and verified | timeout(seconds): {timeout}")

    def clear_wps(self, timeout: int) -> None:
        for _ in self.c.ticks(timeout, 1):
            if not self.c.waypoints:
                return
            if not self.c.clear_mission():
                log.error("failed to send waypoint clear command")
        self.fail(f"failed to clear waypoints | timeout(seconds): {timeout}")


def distance_to_wp(c: MavrosClient, lat: float, lon: float, alt: float) -> tuple[float, float]:
    """mission_test.py distance_to_wp: haversine on R = 6371000 m; |alt − altitude.amsl|."""
    g, a = c.topics["global_pos"], c.topics["alt"]
    glat, glon = g.lat / 1e7, g.lon / 1e7
    r = 6371000
    dlat, dlon = math.radians(glat - lat), math.radians(glon - lon)
    h = (math.sin(dlat / 2) ** 2
         + math.cos(math.radians(lat)) * math.cos(math.radians(glat)) * math.sin(dlon / 2) ** 2)
    return r * 2 * math.atan2(math.sqrt(h), math.sqrt(1 - h)), abs(alt - a.altitude_amsl)


def estimator_analysis(pairs: list[tuple]) -> dict[str, float]:
    """px4tools ulog.estimator_analysis: the mean and standard deviation, in degrees, of the
    estimated minus the true roll, pitch and yaw (here ATTITUDE vs HIL_STATE_QUATERNION, PX4's
    vehicle_attitude vs vehicle_attitude_groundtruth, sampled at 10 Hz)."""
    out = {}
    for k, name in enumerate(("roll", "pitch", "yaw")):
        errs = [math.degrees(math.remainder(est[k] - true[k], 2 * math.pi)) for est, true in pairs]
        n = len(errs)
        mean = sum(errs) / n
        out[f"{name}_error_mean"] = mean
        out[f"{name}_error_std"] = math.sqrt(sum((e - mean) ** 2 for e in errs) / max(n - 1, 1))
    return out


def reach_mission_position(t: MavrosTestCommon, lat: float, lon: float, alt: float,
                           timeout: int, index: int, mission_length: int) -> None:
    """mission_test.py reach_position: at 2 Hz for ``timeout`` s, until the vehicle advanced past
    item ``index`` (MISSION_CURRENT) or, for the last item, reported it reached; the distances
    are only logged (best and current in the failure's message), never judged."""
    c = t.c
    best_xy = best_z = None
    xy = z = math.nan
    for i in c.ticks(timeout, 2):
        xy, z = distance_to_wp(c, lat, lon, alt)
        best_xy = xy if best_xy is None or best_xy > xy else best_xy
        best_z = z if best_z is None or best_z > z else best_z
        if index < c.current_seq or (index == mission_length - 1
                                     and c.mission_item_reached == index):
            log.info("position reached | pos_xy_d: %.2f, pos_z_d: %.2f, index: %d | seconds: "
                     "%s of %s", xy, z, index, i / 2, timeout)
            return
    t.fail(f"position not reached | lat: {lat:.9f}, lon: {lon:.9f}, alt: {alt:.2f}, current "
           f"pos_xy_d: {xy:.2f}, current pos_z_d: {z:.2f}, best pos_xy_d: {best_xy:.2f}, best "
           f"pos_z_d: {best_z:.2f}, index: {index} | timeout(seconds): {timeout}")


def reach_local_position(t: MavrosTestCommon, target: list[float], x: float, y: float, z: float,
                         timeout: int, radius: float) -> None:
    """mavros_offboard_posctl_test.py reach_position: set the (ENU) setpoint, then at 2 Hz for
    ``timeout`` s until local_position/pose is within ``radius`` m of it."""
    target[:] = [x, y, z]
    c = t.c
    for i in c.ticks(timeout, 2):
        p = c.local_position_enu()
        if math.dist(p, (x, y, z)) < radius:
            log.info("position reached | seconds: %s of %s", i / 2, timeout)
            return
    t.fail(f"took too long to get to position ({x}, {y}, {z}) | timeout(seconds): {timeout}")
