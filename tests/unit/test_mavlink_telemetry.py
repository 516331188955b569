"""Telemetry internals: the grouped scheduler against a per-stream reference, and payloads shared
between the links of one vehicle."""

import dataclasses
import math
import random

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as M
from test_mavlink_support import FakeVehicle, make

from gateway.mavlink import streams
from gateway.mavlink.session import LinkKind, Session
from gateway.mavlink.streams import NEVER, STREAMS, STREAMS_BY_ID, Scheduler
from gateway.testing import Sim
from vehicles.types import GeoPoint, HomePosition, Kinematics


class ReferenceScheduler:
    """The plain per-stream algorithm the grouped Scheduler must reproduce exactly."""

    def __init__(self, kind: LinkKind, now_s: float) -> None:
        self.kind = kind
        start = int(round(now_s * 1e6))
        # What PX4 keeps (MESSAGE_INTERVAL: µs, −1 unlimited, 0 no stream) and how often it goes
        self.requested = {s.msg_id: streams._interval_us(s.default_hz(kind)) if s.stream else 0
                          for s in STREAMS}
        self.interval = {s.msg_id: self._period(s, streams._interval_us(s.default_hz(kind)))
                         for s in STREAMS}
        self.next = {i: start if iv else NEVER for i, iv in self.interval.items()}

    @staticmethod
    def _period(spec, iv: int) -> int:
        if spec.silent:
            return 0
        if iv > 0:  # one send per MAVLink loop at most
            return max(iv, streams.MAVLINK_MIN_INTERVAL_US)
        if iv < 0:  # unlimited: at each update of its topic
            return int(1e6 / spec.data_hz) if spec.data_hz > 0 else 0
        return 0

    def set_interval(self, msg_id: int, interval_us: float, now_s: float) -> bool:
        spec = STREAMS_BY_ID.get(msg_id)
        if spec is None or not spec.stream or msg_id in streams.FIXED_RATE_IDS:
            return False
        if interval_us < -1e-5:  # MavlinkReceiver::set_message_interval: stop
            iv = 0
        elif interval_us > 1e-5:  # a rate, back to whole µs (Mavlink::configure_stream)
            rate = 1e6 / interval_us
            iv = int(1e6 / rate) if rate > 1e-6 else 0
        else:  # 0, NaN: the mode's default; a stream the mode does not configure stops
            iv = 0 if spec.boot else streams._interval_us(spec.default_hz(self.kind))
        self.requested[msg_id] = iv
        self.interval[msg_id] = self._period(spec, iv)
        self.next[msg_id] = int(round(now_s * 1e6)) if self.interval[msg_id] else NEVER
        return True

    def due(self, now_s: float) -> list[int]:
        now_us = int(round(now_s * 1e6))
        out = []
        for msg_id, nxt in self.next.items():
            if nxt <= now_us:
                iv = self.interval[msg_id]
                nxt += iv
                if nxt <= now_us:
                    nxt = now_us + iv
                self.next[msg_id] = nxt
                out.append(msg_id)
        return out

    @property
    def next_us(self) -> int:
        return min(self.next.values())


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("kind", list(LinkKind))
def test_grouped_scheduler_matches_the_per_stream_reference(kind, seed):
    rng = random.Random(seed)
    ids = [s.msg_id for s in STREAMS] + [M.MAVLINK_MSG_ID_RAW_IMU]  # one without a builder
    ours, ref = Scheduler(kind, 0.25), ReferenceScheduler(kind, 0.25)
    now_s = 0.25
    for _ in range(3000):
        roll = rng.random()
        if roll < 0.03:
            msg_id = rng.choice(ids)
            interval = rng.choice([-1.0, 0.0, math.nan, 7_000.0, 20_000.0, 33_333.4, 1e6, 0.3,
                                   1.0, 1_000.0, math.inf, -math.inf, 3e38])
            assert ours.set_interval(msg_id, interval, now_s) == ref.set_interval(
                msg_id, interval, now_s)
        elif roll < 0.1:
            now_s += rng.uniform(0.0, 0.3)  # a late wake-up (re-phase, never burst)
        else:  # wake at the deadline, as the session does, or a little early
            nxt = ours.next_us
            if nxt < NEVER:
                now_s = max(now_s, nxt * 1e-6 - rng.choice([0.0, 0.0, 0.0, 1e-4]))
        assert [s.msg_id for s in ours.due(now_s)] == ref.due(now_s)
        assert ours.next_us == ref.next_us
        for msg_id in ids:
            assert ours.interval_us(msg_id) == ref.requested.get(msg_id, 0)


def test_streams_due_together_go_out_in_table_order():
    sched = Scheduler(LinkKind.GCS, 0.0)
    assert [s.msg_id for s in sched.due(0.0)] == [s.msg_id for s in STREAMS
                                                  if s.gcs_hz > 0 and not s.silent]
    for spec in STREAMS:
        sched.set_interval(spec.msg_id, -1, 0.0)  # refused for HEARTBEAT (fixed rate)
    assert sched.next_us == 1_000_000
    assert sched.due(0.5) == ()
    sched.set_interval(M.MAVLINK_MSG_ID_MISSION_CURRENT, 500_000, 0.5)
    assert [s.msg_id for s in sched.due(1.0)] == [M.MAVLINK_MSG_ID_HEARTBEAT,
                                                  M.MAVLINK_MSG_ID_MISSION_CURRENT]


class SteadyVehicle(FakeVehicle):
    """A FakeVehicle whose ``kinematics`` is one object per state, like the real Vehicle's."""

    def __init__(self, sysid: int = 1) -> None:
        super().__init__(sysid)
        self._kin_of = None

    @property
    def kinematics(self) -> Kinematics:
        if self._kin_of is not self.state:
            self._kin_of, self._kin = self.state, Kinematics.of(self.state)
        return self._kin


def frames_at(session: Session, now_s: float) -> dict[str, M.MAVLink_message]:
    session.handle_timer(now_s)
    parser = M.MAVLink(None, 0, 0)
    out = {}
    for datagram in session.datagrams_to_send(now_s):
        for msg in parser.parse_buffer(datagram) or ():
            out[msg.get_type()] = msg
    return out


def test_links_of_one_vehicle_share_payloads_and_keep_their_own_framing():
    vehicle = SteadyVehicle()
    vehicle.become_ready()
    vehicle.move_to(3.0, -4.0, -10.0, yaw_rad=0.3)
    gcs, api = Session(vehicle, LinkKind.GCS), Session(vehicle, LinkKind.API)
    api.samples = gcs.samples
    alone = Session(SteadyVehicle(), LinkKind.API)  # the same vehicle state, nothing shared
    alone.vehicle.state, alone.vehicle.home = vehicle.state, vehicle.home
    api.encoder.seq = 200  # the links count on their own
    first = frames_at(gcs, 0.0)
    # Home moves between the two links' wake-ups of one instant (a command): what depends on it
    # must follow, what does not is taken from the first link's packing.
    vehicle.home = alone.vehicle.home = HomePosition(GeoPoint(47.397742, 8.545594, 480.0),
                                                     (0.0, 0.0, 8.0), 0.0)
    second, reference = frames_at(api, 0.0), frames_at(alone, 0.0)
    assert gcs.samples._last is not None and gcs.samples._last.payloads  # shared for real
    for name in ("ATTITUDE", "ATTITUDE_QUATERNION", "GLOBAL_POSITION_INT", "GPS_RAW_INT"):
        assert second[name].get_payload() == reference[name].get_payload(), name
        assert second[name].get_seq() != first[name].get_seq()
    assert first["ATTITUDE"].get_payload() == second["ATTITUDE"].get_payload()
    assert first["GLOBAL_POSITION_INT"].relative_alt == 10000
    assert second["GLOBAL_POSITION_INT"].relative_alt == 18000
    assert second["ALTITUDE"].altitude_relative == pytest.approx(18.0)


def test_a_new_physics_sample_is_never_served_from_the_cache():
    vehicle = SteadyVehicle()
    gcs, api = Session(vehicle, LinkKind.GCS), Session(vehicle, LinkKind.API)
    api.samples = gcs.samples
    frames_at(gcs, 0.0)
    vehicle.move_to(1.0, 2.0, -3.0)  # a new state at the same instant
    assert frames_at(api, 0.0)["LOCAL_POSITION_NED"].x == 1.0


def test_vfr_hud_throttle_is_the_thrust_setpoint_while_armed():
    from gateway.sim.simulation import Simulation

    sim = Simulation(1, link_kinds=(LinkKind.API,))
    mav = M.MAVLink(None)
    huds = []
    sim.on_downlink = lambda i, k, data, peer: huds.extend(
        m for m in mav.parse_buffer(data) or [] if m.get_type() == "VFR_HUD")
    try:
        sim.run(until=1.5)
        assert huds and all(m.throttle == 0 for m in huds)  # disarmed
        vehicle = sim.vehicles[0]
        vehicle.arm(sim.now)
        vehicle.takeoff(sim.now)
        sim.run(until=8.0)  # hovering
        thrust = vehicle.status.extra["thrust_norm"]
        assert 0.3 < thrust < 0.9
        assert abs(huds[-1].throttle - thrust * 100) <= 2
    finally:
        sim.close()


def test_highres_imu_odometry_and_pressure_at_rest_and_yawed():
    """PX4's sensor streams: specific force and field in the body frame, the gz barometer's
    pressure at the altitude (HIGHRES_IMU.hpp: in Pa, SCALED_PRESSURE.hpp: in hPa), odometry in
    local NED."""
    vehicle, session, client = make(LinkKind.API)
    vehicle.become_ready()
    vehicle.move_to(3.0, -4.0, -10.0, yaw_rad=math.pi / 2)  # facing east
    vehicle.state = dataclasses.replace(vehicle.state, velocity_ned_mps=np.array([0.0, 2.0, 0.0]))
    msgs = client.run_until(0.2)
    imu = [m for m in msgs if m.get_type() == "HIGHRES_IMU"][-1]
    assert (imu.xacc, imu.yacc, imu.zacc) == pytest.approx((0.0, 0.0, -9.80665), abs=1e-4)
    # North-pointing field seen from a nose pointing east: to the left (−y).
    assert imu.ymag == pytest.approx(-0.2145, abs=1e-3) and imu.zmag == pytest.approx(0.4296)
    # gz-sensors' air pressure (standard atmosphere at the geopotential height), the gz
    # bridge's constant 288.15 as °C, PX4's getAltitudeFromPressure at SENS_BARO_QNH.
    alt = vehicle.origin.alt_amsl_m + 10.0
    geo = 6356766.0 * alt / (6356766.0 + alt)
    pa = 101325.0 * (1.0 - 0.0065 * geo / 288.15) ** (9.80665 * 28.9644 / (8314.32 * 0.0065))
    assert imu.abs_pressure == pytest.approx(pa, rel=1e-6)  # baro_pressure_pa as is
    assert imu.pressure_alt == pytest.approx(
        ((pa / 101325.0) ** (0.0065 * 287.1 / 9.80665) * 288.15 - 288.15) / -0.0065, abs=1e-3)
    assert imu.pressure_alt == pytest.approx(alt, abs=0.2)
    assert imu.temperature == pytest.approx(288.15)
    sp = [m for m in msgs if m.get_type() == "SCALED_PRESSURE"][-1]
    assert sp.press_abs == pytest.approx(pa / 100.0, rel=1e-6)
    assert sp.temperature == 28815


def test_odometry_is_ekf2s_vehicle_odometry_in_local_ned():
    """ODOMETRY.hpp of EKF2's vehicle_odometry: velocity in NED (child_frame_id LOCAL_NED, not
    the body frame), estimator type AUTOPILOT, quality 0, covariances NaN off the diagonal."""
    vehicle, session, client = make(LinkKind.API)
    vehicle.become_ready()
    vehicle.move_to(3.0, -4.0, -10.0, yaw_rad=math.pi / 2)  # facing east, flying east
    vehicle.state = dataclasses.replace(vehicle.state, velocity_ned_mps=np.array([0.0, 2.0, 0.0]))
    odo = [m for m in client.run_until(0.2) if m.get_type() == "ODOMETRY"][-1]
    assert (odo.x, odo.y, odo.z) == pytest.approx((3.0, -4.0, -10.0))
    assert (odo.vx, odo.vy, odo.vz) == pytest.approx((0.0, 2.0, 0.0), abs=1e-6)
    assert (odo.frame_id, odo.child_frame_id) == (M.MAV_FRAME_LOCAL_NED, M.MAV_FRAME_LOCAL_NED)
    assert (odo.estimator_type, odo.quality) == (M.MAV_ESTIMATOR_TYPE_AUTOPILOT, 0)
    diag = (0, 6, 11)  # x, y, z; orientation (15, 18, 20) and velocity are not modelled: NaN
    assert all(math.isnan(c) != (i in diag) for i, c in enumerate(odo.pose_covariance))
    assert all(math.isnan(c) for c in odo.velocity_covariance)


def test_odometry_position_variances_follow_the_estimates_accuracy():
    with Sim(1) as sim:
        sim.advance(3.0)
        odo = sim.api().messages("ODOMETRY")[-1]
        est = sim.api().messages("ESTIMATOR_STATUS")[-1]
    # get_ekf_lpos_accuracy: eph = sqrt(var_x + var_y), epv = sqrt(var_z)
    assert odo.pose_covariance[0] + odo.pose_covariance[6] == pytest.approx(
        est.pos_horiz_accuracy ** 2, rel=0.5)
    assert odo.pose_covariance[11] == pytest.approx(est.pos_vert_accuracy ** 2, rel=0.5)


def test_gps_raw_int_carries_the_sim_receivers_course_and_speed_accuracy_at_rest():
    """GPS_RAW_INT.hpp: cog is degrees(wrap_2pi(cog_rad)) x 100 of every sample, with no
    speed threshold (sensor_gps_sim's cog_rad is atan2 of its noisy velocity, so it wanders at
    rest); vel is the speed x 100 and vel_acc s_variance_m_s x 1000 (the receiver's 0.4 m/s),
    each converted to an integer as C converts a float: truncated."""
    from gateway.testing import Sim

    with Sim(1) as sim:
        sim.advance(3.0)
        gps = sim.api().messages("GPS_RAW_INT")
    assert len(gps) > 10
    assert all(m.vel_acc == 400 for m in gps)
    assert all(0 <= m.cog < 36000 for m in gps)
    assert len({m.cog for m in gps}) > len(gps) // 2  # at rest: the noise's direction
    assert all(m.vel < 100 for m in gps)  # truncated cm/s of a noisy rest
