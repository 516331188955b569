"""PX4's own SITL test harness, ``test/mavsdk_tests/autopilot_tester.cpp`` (PX4 v1.15.2), over
MAVSDK-Python 3.x: the same calls, time-outs, tolerances and checks, so that PX4's test cases
(``test_multicopter_*.cpp``) run against a vehicle here as PX4's CI runs them against PX4 SITL
(``mavsdk_test_runner.py --speed-factor 20``).

As there:
- time-outs and sleeps count the autopilot's time (ATTITUDE_QUATERNION's timestamp) once a
  vehicle is connected, the host's before;
- ``check`` (Catch2's CHECK) records a failure and goes on, ``require`` (REQUIRE) stops the
  test; ``AutopilotTester.failures`` is asserted empty when the test ends;
- MAVSDK's synchronous getters (``_telemetry->armed()``…) read the latest value of each
  telemetry stream, kept here by one subscription per stream, and ``subscribe_*(callback)``
  (``None`` to unsubscribe) is called with each new value.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import time
from dataclasses import dataclass
from typing import Any, Callable

from mavsdk import System
from mavsdk.action import ActionError
from mavsdk.failure import FailureError, FailureType, FailureUnit
from mavsdk.mission import MissionError, MissionItem, MissionPlan
from mavsdk.offboard import OffboardError, PositionNedYaw, VelocityNedYaw
from mavsdk.telemetry import FlightMode, LandedState

from gateway.ci.launcher import free_tcp_port
from tests.e2e.autopilot_tester_flights import ManualFlights
from vehicles.geodesy import project, reproject

NAN = float("nan")


class RequireFailed(AssertionError):
    """A REQUIRE did not hold: the test stops."""


@dataclass
class MissionOptions:
    leg_length_m: float = 20.0
    relative_altitude_m: float = 10.0
    rtl_at_end: bool = False
    fly_through: bool = False


# AutopilotTester::RcLossException: the COM_RCL_EXCEPT bit it sets
RC_LOSS_EXCEPTION_MISSION, RC_LOSS_EXCEPTION_HOLD, RC_LOSS_EXCEPTION_OFFBOARD = 0, 1, 2
HEIGHT_SOURCE_BARO, HEIGHT_SOURCE_GPS = 0, 1  # EKF2_HGT_REF

# The streams kept (attribute of drone.telemetry / drone.mission → the getter's name).
_STREAMS = {
    "telemetry": ("attitude_quaternion", "armed", "in_air", "landed_state", "flight_mode",
                  "position", "position_velocity_ned", "health", "health_all_ok", "home"),
    "mission": ("mission_progress",),
}


def point_to_line_distance(p, a, b) -> float:
    """math_helpers.h point_to_line_distance: the distance of ``p`` from the line through a, b."""
    ab = [b[i] - a[i] for i in range(3)]
    ap = [p[i] - a[i] for i in range(3)]
    cross = (ab[1] * ap[2] - ab[2] * ap[1], ab[2] * ap[0] - ab[0] * ap[2],
             ab[0] * ap[1] - ab[1] * ap[0])
    return math.sqrt(sum(c * c for c in cross)) / math.sqrt(sum(c * c for c in ab))


class CoordinateTransformation:
    """MAVSDK's geometry::CoordinateTransformation (azimuthal equidistant, as PX4's)."""

    def __init__(self, lat_deg: float, lon_deg: float) -> None:
        self.lat, self.lon = lat_deg, lon_deg

    def local_from_global(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        return project(self.lat, self.lon, lat_deg, lon_deg)

    def global_from_local(self, north_m: float, east_m: float) -> tuple[float, float]:
        return reproject(self.lat, self.lon, north_m, east_m)


def mission_item(lat: float, lon: float, rel_alt_m: float, fly_through: bool) -> MissionItem:
    """A Mission::MissionItem with MAVSDK C++'s defaults for every field not named."""
    return MissionItem(lat, lon, rel_alt_m, NAN, fly_through, NAN, NAN,
                       MissionItem.CameraAction.NONE, NAN, 1.0, NAN, NAN, NAN,
                       MissionItem.VehicleAction.NONE)


@contextlib.asynccontextmanager
async def connected(tester: AutopilotTester, udp_port: int):
    """``tester`` connected to a vehicle's link on ``udp_port``, closed afterwards."""
    await tester.connect(udp_port)
    try:
        yield tester
    finally:
        await tester.close()


class AutopilotTester(ManualFlights):
    def __init__(self) -> None:
        self.failures: list[str] = []
        self.drone: System | None = None
        self._latest: dict[str, Any] = {}
        self._callbacks: dict[str, Callable[[Any], None] | None] = {}
        self._tasks: list[asyncio.Task] = []
        self._started: set[str] = set()
        self._home = None

    # --- Catch2 ----------------------------------------------------------------------------
    def check(self, ok: bool, what: str) -> bool:
        if not ok:
            self.failures.append(what)
        return ok

    def require(self, ok: bool, what: str) -> None:
        if not ok:
            raise RequireFailed(f"{what}; {self.describe()}"
                                + (f"; and earlier: {self.failures}" if self.failures else ""))

    def describe(self) -> str:
        """The vehicle as the latest telemetry has it (for a failure's message)."""
        pos, pv = self.get("position"), self.get("position_velocity_ned")
        return (f"at {self._autopilot_us() / 1e6:.1f} s autopilot time: "
                f"mode {self.get('flight_mode')}, landed state {self.get('landed_state')}, "
                f"armed {self.get('armed')}, relative altitude "
                f"{pos.relative_altitude_m if pos else None}, velocity "
                f"{pv.velocity if pv else None}, mission {self.get('mission_progress')}")

    # --- the latest values -----------------------------------------------------------------
    def get(self, name: str) -> Any:
        self._start(name)
        return self._latest.get(name)

    def subscribe(self, name: str, callback: Callable[[Any], None] | None) -> None:
        self._start(name)
        self._callbacks[name] = callback

    def _start(self, name: str) -> None:
        """The other telemetry streams start at their first read (each costs at speed 20)."""
        if name not in self._started and self.drone is not None:
            self._started.add(name)
            self._tasks.append(asyncio.ensure_future(self._keep(self.drone.telemetry, name)))

    async def _keep(self, plugin: Any, name: str) -> None:
        async for value in getattr(plugin, name)():
            self._latest[name] = value
            callback = self._callbacks.get(name)
            if callback is not None:
                callback(value)

    def _autopilot_us(self) -> int:
        q = self._latest.get("attitude_quaternion")
        return 0 if q is None else q.timestamp_us

    async def poll_condition_with_timeout(self, fun: Callable[[], bool], timeout_s: float) -> bool:
        """autopilot_tester.h: ``fun`` polled 100 times per time-out, counted in the autopilot's
        time once one is connected (in the host's before)."""
        period = timeout_s / 100
        start_us = self._autopilot_us()
        start = time.monotonic()
        while not fun():
            await asyncio.sleep(period if start_us == 0 else min(period, 0.05))
            if start_us:
                if self._autopilot_us() - start_us > timeout_s * 1e6:
                    return False
            elif time.monotonic() - start > timeout_s:
                return False
        return True

    async def sleep_for(self, seconds: float) -> None:
        """autopilot_tester.h sleep_for: the autopilot's time, polled every millisecond."""
        start_us = self._autopilot_us()
        if start_us == 0:
            await asyncio.sleep(seconds)
            return
        while self._autopilot_us() - start_us <= seconds * 1e6:
            await asyncio.sleep(0.001)

    async def wait_for(self, name: str, predicate: Callable[[Any], bool], timeout_s: float,
                       what: str) -> None:
        """A subscription that resolves a promise, waited on with ``fut.wait_for(timeout)``:
        REQUIRE'd. The wait is the host's time, as std::future's."""
        loop = asyncio.get_running_loop()
        fut: asyncio.Future = loop.create_future()

        def callback(value: Any) -> None:
            if predicate(value) and not fut.done():
                self.subscribe(name, None)
                fut.set_result(None)

        self.subscribe(name, callback)
        try:
            await asyncio.wait_for(fut, timeout_s)
        except asyncio.TimeoutError:
            self.subscribe(name, None)
            self.require(False, f"timed out after {timeout_s} s waiting for {what}")

    # --- AutopilotTester -------------------------------------------------------------------
    async def connect(self, udp_port: int) -> None:
        self.drone = drone = System(port=free_tcp_port())
        await drone.connect(system_address=f"udpin://0.0.0.0:{udp_port}")
        connected = False

        async def seen() -> None:
            nonlocal connected
            async for state in drone.core.connection_state():
                if state.is_connected:
                    connected = True
                    return

        watcher = asyncio.ensure_future(seen())
        ok = await self.poll_condition_with_timeout(lambda: connected, 25)
        watcher.cancel()
        self.require(ok, "system connect")
        for plugin_name, names in _STREAMS.items():
            plugin = getattr(drone, plugin_name)
            for name in names:
                self._started.add(name)
                self._tasks.append(asyncio.ensure_future(self._keep(plugin, name)))

    async def close(self) -> None:
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        if self.drone is not None:
            self.drone._stop_mavsdk_server()

    async def wait_until_ready(self) -> None:
        self.check(await self.poll_condition_with_timeout(
            lambda: bool(self.get("health_all_ok")), 30), "health all ok")
        self.check(await self.poll_condition_with_timeout(self._armable, 20), "is armable")

    def _armable(self) -> bool:
        health = self.get("health")
        return health is not None and health.is_armable

    async def request_ground_truth(self) -> None:
        try:
            await self.drone.telemetry.set_rate_ground_truth(15)
        except Exception as exc:
            self.check(False, f"set_rate_ground_truth: {exc}")

    async def store_home(self) -> None:
        await self.request_ground_truth()

        def home_known() -> bool:
            self._home = self.get("ground_truth")
            return self._home is not None and math.isfinite(self._home.latitude_deg) \
                and math.isfinite(self._home.longitude_deg)

        self.check(await self.poll_condition_with_timeout(home_known, 10), "home position")

    def _ground_truth_distance_m(self, target) -> float:
        self.check(math.isfinite(target.latitude_deg) and math.isfinite(target.longitude_deg),
                   "target finite")
        current = self.get("ground_truth")
        self.check(current is not None and math.isfinite(current.latitude_deg),
                   "ground truth finite")
        ct = CoordinateTransformation(target.latitude_deg, target.longitude_deg)
        north, east = ct.local_from_global(current.latitude_deg, current.longitude_deg)
        return math.hypot(north, east)

    def check_home_within(self, acceptance_radius_m: float) -> None:
        d = self._ground_truth_distance_m(self._home)
        self.check(d < acceptance_radius_m, f"home within {acceptance_radius_m} m: {d:.2f} m")

    def check_home_not_within(self, min_distance_m: float) -> None:
        d = self._ground_truth_distance_m(self._home)
        self.check(d > min_distance_m, f"home not within {min_distance_m} m: {d:.2f} m")

    async def _action(self, call, *args, require: bool = True) -> bool:
        try:
            await call(*args)
            return True
        except (ActionError, MissionError, OffboardError) as exc:
            (self.require if require else self.check)(False, f"{call.__name__}: {exc}")
            return False

    async def set_param_int(self, name: str, value: int) -> None:
        try:
            await self.drone.param.set_param_int(name, value)
        except Exception as exc:
            self.check(False, f"set_param_int {name}={value}: {exc}")

    async def set_takeoff_altitude(self, altitude_m: float) -> None:
        await self._action(self.drone.action.set_takeoff_altitude, altitude_m, require=False)
        got = await self.drone.action.get_takeoff_altitude()
        self.check(abs(got - altitude_m) < 1e-3 * max(1.0, altitude_m), f"takeoff altitude {got}")

    async def set_rtl_altitude(self, altitude_m: float) -> None:
        await self._action(self.drone.action.set_return_to_launch_altitude, altitude_m,
                           require=False)
        got = await self.drone.action.get_return_to_launch_altitude()
        self.check(abs(got - altitude_m) < 1e-3 * max(1.0, altitude_m), f"RTL altitude {got}")

    async def set_height_source(self, source: int) -> None:
        await self.set_param_int("EKF2_HGT_REF", source)

    async def set_rc_loss_exception(self, bit: int) -> None:
        await self.set_param_int("COM_RCL_EXCEPT", 1 << bit)

    async def arm(self) -> None:
        await self._action(self.drone.action.arm)

    async def takeoff(self) -> None:
        await self._action(self.drone.action.takeoff)

    async def land(self) -> None:
        await self._action(self.drone.action.land)

    async def execute_rtl(self) -> None:
        await self._action(self.drone.action.return_to_launch)

    async def wait_until_disarmed(self, timeout_s: float = 60) -> None:
        self.require(await self.poll_condition_with_timeout(
            lambda: self.get("armed") is False, timeout_s), f"disarmed within {timeout_s} s")

    async def wait_until_hovering(self) -> None:
        await self.wait_for("landed_state", lambda s: s == LandedState.IN_AIR, 45, "in air")

    async def wait_until_altitude(self, rel_altitude_m: float, timeout_s: float) -> None:
        await self.wait_for("position",
                            lambda p: abs(rel_altitude_m - p.relative_altitude_m) <= 0.5,
                            timeout_s, f"relative altitude {rel_altitude_m} m")

    async def wait_until_speed_lower_than(self, speed: float, timeout_s: float) -> None:
        def slow(pv) -> bool:
            v = pv.velocity
            return math.sqrt(v.north_m_s ** 2 + v.east_m_s ** 2 + v.down_m_s ** 2) <= speed

        await self.wait_for("position_velocity_ned", slow, timeout_s, f"speed <= {speed} m/s")

    async def wait_for_flight_mode(self, mode: FlightMode, timeout_s: float) -> None:
        await self.wait_for("flight_mode", lambda m: m == mode, timeout_s, f"mode {mode}")

    async def wait_for_mission_finished(self, timeout_s: float) -> None:
        await self.wait_for("mission_progress", lambda p: p.current == p.total, timeout_s,
                            "mission finished")

    # --- missions --------------------------------------------------------------------------
    async def get_coordinate_transformation(self) -> CoordinateTransformation:
        # MAVSDK C++'s home() is the last HOME_POSITION received, which health_all_ok implies;
        # this stream's first value may still be on its way.
        await self.poll_condition_with_timeout(lambda: self.get("home") is not None, 1.0)
        home = self.get("home")
        self.check(home is not None and math.isfinite(home.latitude_deg), "home finite")
        return CoordinateTransformation(home.latitude_deg, home.longitude_deg)

    async def _upload(self, legs: list[tuple[float, float]], options: MissionOptions) -> None:
        ct = await self.get_coordinate_transformation()
        items = [mission_item(*ct.global_from_local(n, e), options.relative_altitude_m,
                              options.fly_through) for n, e in legs]
        await self.drone.mission.set_return_to_launch_after_mission(options.rtl_at_end)
        await self._action(self.drone.mission.upload_mission, MissionPlan(items))

    async def prepare_square_mission(self, options: MissionOptions) -> None:
        leg = options.leg_length_m
        await self._upload([(leg, 0.0), (leg, leg), (0.0, leg)], options)

    async def prepare_straight_mission(self, options: MissionOptions) -> None:
        leg = options.leg_length_m
        await self._upload([(k * leg, 0.0) for k in range(5)], options)

    async def execute_mission(self) -> None:
        async def start() -> bool:
            try:
                await self.drone.mission.start_mission()
                return True
            except MissionError:
                return False

        # REQUIRE(poll_condition_with_timeout(start_mission() == Success, 3 s))
        started = await start()
        deadline_us = self._autopilot_us() + 3_000_000
        while not started and self._autopilot_us() < deadline_us:
            await asyncio.sleep(0.03)
            started = await start()
        self.require(started, "mission started")
        await self.wait_for_mission_finished(90)

    async def start_and_wait_for_mission_sequence(self, sequence_number: int) -> None:
        loop = asyncio.get_running_loop()
        fut: asyncio.Future = loop.create_future()

        def callback(progress) -> None:
            if progress.current >= sequence_number and not fut.done():
                self.subscribe("mission_progress", None)
                fut.set_result(None)

        self.subscribe("mission_progress", callback)
        await self._action(self.drone.mission.start_mission)
        try:
            await asyncio.wait_for(fut, 60)
        except asyncio.TimeoutError:
            self.require(False, f"mission item {sequence_number} within 60 s")

    async def _inject(self, unit: FailureUnit, kind: FailureType, instance: int) -> str:
        try:
            await self.drone.failure.inject(unit, kind, instance)
            return "SUCCESS"
        except FailureError as exc:
            return exc._result.result.name

    async def check_tracks_mission(self, corridor_radius_m: float = 1.5) -> None:
        """Every position (5 Hz) while between two items: within ``corridor_radius_m`` of the
        line through them (the downloaded mission's items, local to home)."""
        plan = await self.drone.mission.download_mission()
        items = plan.mission_items
        ct = await self.get_coordinate_transformation()

        def local(item) -> tuple[float, float, float]:
            n, e = ct.local_from_global(item.latitude_deg, item.longitude_deg)
            return n, e, -item.relative_altitude_m

        await self.drone.telemetry.set_rate_position_velocity_ned(5)

        def callback(pv) -> None:
            progress = self.get("mission_progress")
            if progress is None or not 0 < progress.current < progress.total:
                return
            p = pv.position
            d = point_to_line_distance((p.north_m, p.east_m, p.down_m),
                                       local(items[progress.current - 1]),
                                       local(items[progress.current]))
            self.check(d < corridor_radius_m, f"off the track by {d:.2f} m going to item "
                                              f"{progress.current}")

        self.subscribe("position_velocity_ned", callback)

    async def check_mission_item_speed_above(self, item_index: int, min_speed_m_s: float) -> None:
        await self.drone.telemetry.set_rate_velocity_ned(10)

        async def watch() -> None:
            async for v in self.drone.telemetry.velocity_ned():
                progress = self.get("mission_progress")
                if progress is not None and progress.current == item_index:
                    h = math.hypot(v.north_m_s, v.east_m_s)
                    self.check(h > min_speed_m_s, f"speed {h:.2f} m/s at item {item_index}")

        self._tasks.append(asyncio.ensure_future(watch()))

    def get_current_position_ned(self) -> tuple[float, float, float]:
        p = self.get("position_velocity_ned").position
        return p.north_m, p.east_m, p.down_m

    def start_checking_altitude(self, max_deviation_m: float) -> None:
        target = self.get_current_position_ned()[2]

        def callback(pos) -> None:
            d = abs(-target - pos.relative_altitude_m)
            self.check(d <= max_deviation_m, f"altitude off by {d:.2f} m")

        self.subscribe("position", callback)

    def stop_checking_altitude(self) -> None:
        self.subscribe("position", None)

    # --- offboard ----------------------------------------------------------------------------
    def _estimated_close(self, target: PositionNedYaw, radius_m: float) -> bool:
        pv = self.get("position_velocity_ned")
        if pv is None:
            return False
        p = pv.position
        return math.sqrt((p.north_m - target.north_m) ** 2 + (p.east_m - target.east_m) ** 2
                         + (p.down_m - target.down_m) ** 2) < radius_m

    async def offboard_goto(self, target: PositionNedYaw, acceptance_radius_m: float = 0.3,
                            timeout_s: float = 60) -> None:
        await self.drone.offboard.set_position_ned(target)
        await self._action(self.drone.offboard.start)
        self.check(await self.poll_condition_with_timeout(
            lambda: self._estimated_close(target, acceptance_radius_m), timeout_s),
            f"offboard target {target} within {timeout_s} s")

    async def offboard_land(self) -> None:
        await self.drone.offboard.set_velocity_ned(VelocityNedYaw(0.0, 0.0, 1.0, 0.0))
