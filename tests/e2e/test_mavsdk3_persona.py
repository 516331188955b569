"""The PX4 persona with unmodified MAVSDK-Python 3.x: offboard, missions, goto/hold/RTL, params."""

import asyncio
import math

import pytest
from mavsdk.mission import MissionItem, MissionPlan
from mavsdk.offboard import PositionNedYaw, VelocityBodyYawspeed

from tests.e2e.persona import (
    HOME_LAT,
    HOME_LON,
    connected,
    distance_m,
    first,
    land_and_disarm,
    latest,
    offset_deg,
    project,
)

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


def near(pv, n, e, d, tol):
    p = pv.position
    return math.dist((p.north_m, p.east_m, p.down_m), (n, e, d)) < tol


@pytest.mark.asyncio
async def test_offboard_position_then_body_velocity(daemon_factory):
    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        await drone.action.arm()
        await drone.offboard.set_position_ned(PositionNedYaw(0.0, 0.0, 0.0, 0.0))
        await drone.offboard.start()
        for n, e, dn in [(0, 0, -5), (10, 0, -5), (10, 10, -8)]:
            await drone.offboard.set_position_ned(PositionNedYaw(n, e, dn, 0.0))
            await first(drone.telemetry.position_velocity_ned(),
                        lambda pv, n=n, e=e, dn=dn: near(pv, n, e, dn, 0.7), 40,
                        f"offboard position ({n}, {e}, {dn})")
        await drone.offboard.set_position_ned(PositionNedYaw(10, 10, -8, 90.0))
        await first(drone.telemetry.heading(), lambda h: abs(h.heading_deg - 90) < 5, 20,
                    "yaw 90")
        start = (await latest(drone.telemetry.position_velocity_ned())).position
        await drone.offboard.set_velocity_body(VelocityBodyYawspeed(2.0, 0.0, 0.0, 0.0))
        await asyncio.sleep(4)
        end = (await latest(drone.telemetry.position_velocity_ned())).position
        assert end.east_m - start.east_m > 4.0, (start, end)  # forward = east when facing 90°
        assert abs(end.north_m - start.north_m) < 1.5, (start, end)
        await drone.offboard.stop()
        await drone.action.land()
        await land_and_disarm(drone)


def square_mission(side_m: float = 20.0) -> list[MissionItem]:
    items = []
    for i, (n, e) in enumerate([(side_m, 0), (side_m, side_m), (0, side_m), (0, 0)]):
        lat, lon = offset_deg(HOME_LAT, HOME_LON, n + 2, e + 2)
        items.append(MissionItem(lat, lon, 12.0 + i, 5.0, True, float("nan"), float("nan"),
                                 MissionItem.CameraAction.NONE, float("nan"), float("nan"),
                                 float("nan"), float("nan"), float("nan"),
                                 MissionItem.VehicleAction.NONE))
    return items


@pytest.mark.asyncio
async def test_mission_square_with_return(daemon_factory):
    d = daemon_factory("--speed", "2")  # PX4_SIM_SPEED_FACTOR=2: the same flight in half the time
    async with connected(d.api_port()) as drone:
        items = square_mission()
        await drone.mission.set_return_to_launch_after_mission(True)
        await drone.mission.upload_mission(MissionPlan(items))
        downloaded = await drone.mission.download_mission()
        assert len(downloaded.mission_items) == len(items)
        for up, down in zip(items, downloaded.mission_items, strict=True):
            assert up.latitude_deg == pytest.approx(down.latitude_deg, abs=1e-7)
            assert up.longitude_deg == pytest.approx(down.longitude_deg, abs=1e-7)
            assert up.relative_altitude_m == pytest.approx(down.relative_altitude_m, abs=1e-3)
        home = await latest(drone.telemetry.home())
        await drone.action.arm()
        await drone.mission.start_mission()
        progress = await first(drone.mission.mission_progress(),
                               lambda p: p.total > 0 and p.current == p.total, 240,
                               "mission progress to reach total")
        assert progress.total == len(items)
        await land_and_disarm(drone, 180)
        pos = await latest(drone.telemetry.position())
        assert distance_m(home.latitude_deg, home.longitude_deg,
                          pos.latitude_deg, pos.longitude_deg) < 2.0


@pytest.mark.asyncio
async def test_takeoff_altitude_params_goto_hold_and_return(daemon_factory):
    d = daemon_factory("--speed", "2")
    async with connected(d.api_port()) as drone:
        assert await drone.action.get_takeoff_altitude() == pytest.approx(2.5)
        await drone.action.set_takeoff_altitude(6.0)
        assert await drone.param.get_param_float("MIS_TAKEOFF_ALT") == pytest.approx(6.0)
        all_params = await drone.param.get_all_params()
        assert len(all_params.int_params) + len(all_params.float_params) >= 100
        await drone.action.arm()
        await drone.action.takeoff()
        await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 5.7, 30,
                    "takeoff to 6 m")
        await asyncio.sleep(3)
        assert 5.7 < (await latest(drone.telemetry.position())).relative_altitude_m < 6.3

        home = await latest(drone.telemetry.home())
        lat, lon = offset_deg(home.latitude_deg, home.longitude_deg, 21.0, 28.0)  # 35 m away
        amsl = home.absolute_altitude_m + 15.0
        await drone.action.goto_location(lat, lon, amsl, 0.0)

        def arrived(p):
            return distance_m(lat, lon, p.latitude_deg, p.longitude_deg) < 1.5 and \
                abs(p.absolute_altitude_m - amsl) < 1.5

        await first(drone.telemetry.position(), arrived, 60, "goto target")
        await drone.action.hold()
        for _ in range(10):
            await asyncio.sleep(0.5)
            assert arrived(await latest(drone.telemetry.position()))

        await drone.action.return_to_launch()
        await land_and_disarm(drone, 120)
        pos = await latest(drone.telemetry.position())
        assert distance_m(home.latitude_deg, home.longitude_deg,
                          pos.latitude_deg, pos.longitude_deg) < 2.0


async def again_on_timeout(transfer, attempts: int = 10):
    """At 20 % loss each way a whole upload or download times out now and then — against PX4 too.
    The big one: the vehicle sends the final MISSION_ACK once (PX4 does), and MAVSDK, having sent
    the last item, only waits for it (5 × 0.5 s) and never repeats the item, so a lost final ACK
    fails the upload (p ≈ 0.2 per attempt); a transfer step also fails after 5 retries in a row.
    A script for lossy links asks again (after a time-out MAVSDK may still be winding the old
    transfer down: BUSY, so wait a moment); ten attempts all failing has p ≈ 1e-7.
    The other way round, when MAVSDK's final MISSION_ACK of a download is lost, PX4 stays in the
    download until its 5 s protocol time-out ("Operation timeout") and refuses a new upload with
    MAV_MISSION_ERROR ("WPM: IGN MISSION_COUNT: Busy"), which MAVSDK reports as PROTOCOL_ERROR:
    that one waits the vehicle's time-out out."""
    from mavsdk.mission import MissionError

    for attempt in range(attempts):
        try:
            return await transfer()
        except MissionError as exc:
            retry = any(r in str(exc) for r in ("TIMEOUT", "BUSY", "PROTOCOL_ERROR"))
            if not retry or attempt == attempts - 1:
                raise
            await asyncio.sleep(5.5 if "PROTOCOL_ERROR" in str(exc) else 1.0)


@pytest.mark.asyncio
async def test_mission_upload_over_a_lossy_link(daemon_factory):
    d = daemon_factory("--loss", "0.2", "--seed", "11")
    async with connected(d.api_port()) as drone:
        items = square_mission()
        for _ in range(3):  # three uploads and downloads, each through 20 % loss both ways
            await again_on_timeout(lambda: drone.mission.upload_mission(MissionPlan(items)))
            downloaded = await again_on_timeout(drone.mission.download_mission)
            got = [v for i in downloaded.mission_items for v in (i.latitude_deg, i.longitude_deg)]
            want = [v for i in items for v in (i.latitude_deg, i.longitude_deg)]
            assert got == pytest.approx(want, abs=1e-7)


@pytest.mark.asyncio
async def test_manual_control_position_mode_fly_and_land(daemon_factory):
    """MAVSDK's manual_control plugin as a joystick app uses it (inputs at 20 Hz): Position mode
    is refused without stick input, flies the sticks, and lands and disarms with the stick
    down (the upstream manual_control.py example's flow, bounded)."""
    from mavsdk.manual_control import ManualControlError
    from mavsdk.telemetry import FlightMode

    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        with pytest.raises(ManualControlError):  # no input yet: MAVSDK refuses by itself
            await drone.manual_control.start_position_control()
        sticks = [0.0, 0.0, 0.5, 0.0]  # x pitch, y roll, z throttle 0..1, r yaw

        async def joystick():
            while True:
                await drone.manual_control.set_manual_control_input(*sticks)
                await asyncio.sleep(0.05)

        feeder = asyncio.create_task(joystick())
        try:
            await asyncio.sleep(0.3)
            await drone.action.arm()
            await drone.manual_control.start_position_control()
            await first(drone.telemetry.flight_mode(), lambda m: m is FlightMode.POSCTL, 10,
                        "Position mode")
            await first(drone.telemetry.rc_status(), lambda rc: rc.is_available, 5,
                        "rc_status available (SYS_STATUS RC receiver)")
            sticks[2] = 0.9  # climb
            await first(drone.telemetry.position_velocity_ned(),
                        lambda pv: pv.position.down_m < -4.0, 20, "climb above 4 m")
            sticks[2] = 0.5
            start = (await latest(drone.telemetry.position_velocity_ned())).position
            sticks[0] = 0.6  # forward (north: the vehicle faces north)
            await asyncio.sleep(3)
            sticks[0] = 0.0
            await asyncio.sleep(3)
            pv = await latest(drone.telemetry.position_velocity_ned())
            assert pv.position.north_m - start.north_m > 5.0, (start, pv.position)
            assert math.hypot(pv.velocity.north_m_s, pv.velocity.east_m_s) < 0.5, pv.velocity
            assert abs(pv.position.down_m - start.down_m) < 0.7, (start, pv.position)
            sticks[2] = 0.0  # stick down: descend, touch down, auto-disarm
            await land_and_disarm(drone, 40)
        finally:
            feeder.cancel()


@pytest.mark.asyncio
async def test_do_orbit_circles_the_point_nose_to_the_centre(daemon_factory):
    """MAVSDK's do_orbit (the upstream do_orbit.py flow): DO_ORBIT as COMMAND_INT, the vehicle
    flies to the circle and around it facing the centre; Land ends it."""
    from mavsdk.action import OrbitYawBehavior

    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        home = await latest(drone.telemetry.position())
        await drone.action.arm()
        await drone.action.takeoff()
        await first(drone.telemetry.in_air(), lambda x: x, 20, "in air")
        lat, lon = offset_deg(HOME_LAT, HOME_LON, 20.0, 0.0)
        await drone.action.do_orbit(radius_m=8.0, velocity_ms=3.0,
                                    yaw_behavior=OrbitYawBehavior.HOLD_FRONT_TO_CIRCLE_CENTER,
                                    latitude_deg=lat, longitude_deg=lon,
                                    absolute_altitude_m=home.absolute_altitude_m + 8.0)

        def on_circle(p):
            return abs(distance_m(p.latitude_deg, p.longitude_deg, lat, lon) - 8.0) < 1.0

        await first(drone.telemetry.position(), on_circle, 30, "on the 8 m circle")
        for _ in range(8):  # stays on it, at the commanded altitude, facing the centre
            await asyncio.sleep(1.0)
            p = await latest(drone.telemetry.position())
            assert on_circle(p), p
            assert abs(p.relative_altitude_m - 8.0) < 1.0, p
            heading = (await latest(drone.telemetry.heading())).heading_deg
            north_m, east_m = project(p.latitude_deg, p.longitude_deg, lat, lon)
            to_center = math.degrees(math.atan2(east_m, north_m)) % 360
            assert abs((heading - to_center + 180) % 360 - 180) < 15, (heading, to_center)
        await drone.action.land()
        await land_and_disarm(drone, 60)


@pytest.mark.asyncio
async def test_imu_odometry_and_pressure_telemetry(daemon_factory):
    """MAVSDK's imu(), odometry() and scaled_pressure() get PX4's default streams from the
    simulated sensors (noisy, as PX4 SITL's), set_rate_imu() is honoured, and every health flag
    is OK once the estimator runs."""
    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        health = await latest(drone.telemetry.health())
        assert all((health.is_gyrometer_calibration_ok, health.is_accelerometer_calibration_ok,
                    health.is_magnetometer_calibration_ok, health.is_local_position_ok,
                    health.is_global_position_ok, health.is_home_position_ok,
                    health.is_armable)), health
        imu = await latest(drone.telemetry.imu())
        assert abs(imu.acceleration_frd.down_m_s2 + 9.81) < 0.1, imu
        assert imu.magnetic_field_frd.down_gauss > 0.3, imu
        downs = set()
        async for sample in drone.telemetry.imu():
            downs.add(sample.acceleration_frd.down_m_s2)
            if len(downs) >= 3:
                break  # the accelerometer is noisy, not a constant
        odo = await latest(drone.telemetry.odometry())
        assert abs(odo.position_body.z_m) < 0.1 and abs(odo.q.w) > 0.99, odo
        sp = await latest(drone.telemetry.scaled_pressure())
        assert 900 < sp.absolute_pressure_hpa < 1013, sp
        await drone.telemetry.set_rate_imu(10.0)
        t0 = asyncio.get_running_loop().time()
        n = 0
        async for _ in drone.telemetry.imu():
            n += 1
            if n == 21:
                break
        assert 1.6 < asyncio.get_running_loop().time() - t0 < 2.6  # 20 intervals at 10 Hz


@pytest.mark.asyncio
async def test_follow_me_follows_a_moving_target(daemon_factory):
    """MAVSDK's follow_me (the upstream follow_me_example.py flow): set_config writes the
    FLW_TGT_* parameters, start() enters Follow Me, target locations stream as FOLLOW_TARGET."""
    from mavsdk.follow_me import Config, TargetLocation
    from mavsdk.telemetry import FlightMode

    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        home = await latest(drone.telemetry.position())
        await drone.action.arm()
        await drone.follow_me.set_config(Config(10.0, 6.0, 0.1, Config.FollowAltitudeMode.CONSTANT,
                                                5.0, 180.0))
        await drone.action.takeoff()
        await first(drone.telemetry.in_air(), lambda x: x, 20, "in air")
        await drone.follow_me.start()
        # MAVSDK takes targets once a HEARTBEAT shows Follow Me (as with PX4).
        await first(drone.telemetry.flight_mode(), lambda m: m is FlightMode.FOLLOW_ME, 5,
                    "Follow Me mode")
        # The follow_me plugin reads that HEARTBEAT in a handler of its own, which a loaded
        # machine may run after the telemetry stream has already shown the mode.
        for _ in range(50):
            if await drone.follow_me.is_active():
                break
            await asyncio.sleep(0.1)
        assert await drone.follow_me.is_active(), "MAVSDK's follow_me never became active"
        target_n = 10.0
        for _ in range(20):  # a target walking north at 1.5 m/s
            lat, lon = offset_deg(HOME_LAT, HOME_LON, target_n, 0.0)
            await drone.follow_me.set_target_location(
                TargetLocation(lat, lon, home.absolute_altitude_m, 1.5, 0.0, 0.0))
            await asyncio.sleep(1.0)
            target_n += 1.5
        p = await latest(drone.telemetry.position())
        lat, lon = offset_deg(HOME_LAT, HOME_LON, target_n - 1.5, 0.0)
        assert abs(distance_m(p.latitude_deg, p.longitude_deg, lat, lon) - 6.0) < 2.0, p
        assert p.latitude_deg < lat  # behind the target (south of it)
        assert abs(p.relative_altitude_m - 10.0) < 1.0, p
        await drone.follow_me.stop()
        await drone.action.land()
        await land_and_disarm(drone, 60)
