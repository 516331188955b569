"""PX4's follow-me test harness, ``test/mavsdk_tests/autopilot_tester_follow_me.{h,cpp}`` (PX4
v1.15.2), over MAVSDK-Python 3.x: the same calls, time-outs, tolerances and checks as there, on
top of tests/e2e/autopilot_tester.py (the port of autopilot_tester.cpp).

- ``FollowTargetSimulator``: a target moving north at 2 m/s, its noise deterministic as
  PX4's: libstdc++'s ``std::default_random_engine`` (minstd_rand0) seeded with the update
  count, through ``std::normal_distribution<double>`` (Marsaglia's polar method), so the
  same sequence of target reports reaches the vehicle as in PX4's CI.
- MAVSDK C++'s ``FollowMe::Config`` and ``TargetLocation`` defaults (the proto's default
  values: height 8 m, distance 8 m, responsiveness 0.1, altitude mode constant, tangential
  velocity 8 m/s, angle 180°; a location all NaN) stand for the ``{}`` of the C++ structs.
- ``CHECK(FollowMe::Result::Success == ...)``: a ``FollowMeError`` (or ``ManualControlError``)
  is a recorded failure; the test goes on.
- ``sleep_for`` is the autopilot's time, as PX4's (the harness's ``sleep_for``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from mavsdk.follow_me import Config, FollowMeError, TargetLocation
from mavsdk.manual_control import ManualControlError

from tests.e2e.autopilot_tester import AutopilotTester, CoordinateTransformation

NAN = float("nan")
Vec3 = tuple[float, float, float]


# --- std::default_random_engine + std::normal_distribution<double> (libstdc++) -------------------

class _MinstdRand0:
    """std::minstd_rand0: x <- 16807 x mod (2^31 - 1); a seed of 0 (mod m) starts at 1."""

    A, M = 16807, 2147483647

    def __init__(self, seed: int) -> None:
        s = seed % self.M
        self.x = 1 if s == 0 else s

    def __call__(self) -> int:
        self.x = (self.A * self.x) % self.M
        return self.x


class _Normal:
    """std::normal_distribution<double>(mean, stddev) as libstdc++ draws it: uniforms from
    generate_canonical<double, 53> (two engine calls each, the engine's range 2^31 - 2),
    Marsaglia's polar method, the second value of a pair kept for the next draw."""

    _R = float(_MinstdRand0.M - 1)  # max() - min() + 1, min() = 1

    def __init__(self, mean: float, stddev: float) -> None:
        self.mean, self.stddev = mean, stddev
        self._saved: float | None = None

    def _canonical(self, engine: _MinstdRand0) -> float:
        total, tmp = 0.0, 1.0
        for _ in range(2):
            total += float(engine() - 1) * tmp
            tmp *= self._R
        ret = total / tmp
        return ret if ret < 1.0 else math.nextafter(1.0, 0.0)

    def __call__(self, engine: _MinstdRand0) -> float:
        if self._saved is not None:
            ret, self._saved = self._saved, None
        else:
            while True:
                x = 2.0 * self._canonical(engine) - 1.0
                y = 2.0 * self._canonical(engine) - 1.0
                r2 = x * x + y * y
                if 0.0 < r2 <= 1.0:
                    break
            mult = math.sqrt(-2.0 * math.log(r2) / r2)
            self._saved = x * mult
            ret = y * mult
        return ret * self.stddev + self.mean


def _noisy(v: Vec3, seed: int, stddev: float) -> Vec3:
    engine, dist = _MinstdRand0(seed), _Normal(0.0, stddev)
    return (v[0] + dist(engine), v[1] + dist(engine), v[2] + dist(engine))


# --- MAVSDK C++ defaults ---------------------------------------------------------------------------

@dataclass
class FollowMeConfig:
    """FollowMe::Config with its C++ defaults (follow_me.proto's default values)."""
    follow_height_m: float = 8.0
    follow_distance_m: float = 8.0
    responsiveness: float = 0.1
    altitude_mode: Config.FollowAltitudeMode = Config.FollowAltitudeMode.CONSTANT
    max_tangential_vel_m_s: float = 8.0
    follow_angle_deg: float = 180.0

    def to_mavsdk(self) -> Config:
        return Config(self.follow_height_m, self.follow_distance_m, self.responsiveness,
                      self.altitude_mode, self.max_tangential_vel_m_s, self.follow_angle_deg)


def target_location(lat: float = NAN, lon: float = NAN, alt: float = NAN, vx: float = NAN,
                    vy: float = NAN, vz: float = NAN) -> TargetLocation:
    """FollowMe::TargetLocation{} (all NaN) with the fields given."""
    return TargetLocation(lat, lon, alt, vx, vy, vz)


def _norm(v) -> float:
    return math.sqrt(sum(c * c for c in v))


def _diff(a, b) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


# --- FollowTargetSimulator ---------------------------------------------------------------------------

class FollowTargetSimulator:
    """A target moving on a straight line in the X+ (north) direction."""

    POS_NOISE_STD = 0.3
    VEL_NOISE_STD = 0.1

    def __init__(self, initial_position_ned: Vec3, home) -> None:
        self._position_ned = tuple(initial_position_ned)
        self._velocity_ned: Vec3 = (0.0, 0.0, 0.0)
        self._home = home
        self._update_count = 0

    def update(self, delta_t_s: float) -> None:
        """Integrate one time step: 2 m/s north."""
        velocity_m_s = 2.0
        self._velocity_ned = (velocity_m_s, 0.0, self._velocity_ned[2])
        self._position_ned = tuple(p + v * delta_t_s
                                   for p, v in zip(self._position_ned, self._velocity_ned))
        self._update_count += 1

    def get_position_global(self, add_noise: bool, check=None) -> tuple[float, float, float]:
        # PX4's get_position_global draws its noise with a standard deviation of 1 (not
        # pos_noise_std), and adds the NED down component to the altitude as it is.
        pos = _noisy(self._position_ned, self._update_count, 1.0) if add_noise \
            else self._position_ned
        if check is not None:
            check(math.isfinite(self._home.latitude_deg), "home latitude finite")
            check(math.isfinite(self._home.longitude_deg), "home longitude finite")
        ct = CoordinateTransformation(self._home.latitude_deg, self._home.longitude_deg)
        lat, lon = ct.global_from_local(pos[0], pos[1])
        return lat, lon, pos[2] + self._home.absolute_altitude_m

    def get_position_ned(self, add_noise: bool) -> Vec3:
        if add_noise:
            return _noisy(self._position_ned, self._update_count, self.POS_NOISE_STD)
        return self._position_ned

    def get_velocity_ned(self, add_noise: bool) -> Vec3:
        if add_noise:
            return _noisy(self._velocity_ned, self._update_count, self.VEL_NOISE_STD)
        return self._velocity_ned

    def get_position_ned_noisy(self) -> Vec3:
        return self.get_position_ned(True)

    def get_position_ground_truth_ned(self) -> Vec3:
        return self.get_position_ned(False)

    def get_velocity_ned_noisy(self) -> Vec3:
        return self.get_velocity_ned(True)

    def get_velocity_ned_ground_truth(self) -> Vec3:
        return self.get_velocity_ned(False)

    def get_position_global_noisy(self, check=None):
        return self.get_position_global(True, check)

    def get_position_global_ground_truth(self, check=None):
        return self.get_position_global(False, check)

    @staticmethod
    def check_follow_angle(check, config: FollowMeConfig, drone_pos_ned: Vec3,
                           target_pos_ned: Vec3, tolerance: float) -> None:
        """The drone where the configuration puts it around the target (which travels along
        X): the follow angle is measured from the target's course."""
        dx = drone_pos_ned[0] - target_pos_ned[0]
        dy = drone_pos_ned[1] - target_pos_ned[1]
        angle = config.follow_angle_deg * (math.pi / 180.0)
        ex = config.follow_distance_m * math.cos(angle)
        ey = config.follow_distance_m * math.sin(angle)
        check(abs(dx - ex) < tolerance,
              f"follow angle {config.follow_angle_deg}: x offset {dx:.2f} m, expected "
              f"{ex:.2f} ± {tolerance} m")
        check(abs(dy - ey) < tolerance,
              f"follow angle {config.follow_angle_deg}: y offset {dy:.2f} m, expected "
              f"{ey:.2f} ± {tolerance} m")


# --- AutopilotTesterFollowMe -------------------------------------------------------------------------

# FlightTaskAutoFollowTarget.hpp's constants, as the test copies them: how much an RC adjustment
# is expected to change each follow parameter.
FOLLOW_DISTANCE_USER_ADJUST_SPEED = 2.0  # [m/s]
FOLLOW_HEIGHT_USER_ADJUST_SPEED = 1.5  # [m/s]
FOLLOW_ANGLE_USER_ADJUST_SPEED = 1.5  # [rad/s]


class AutopilotTesterFollowMe(AutopilotTester):
    def __init__(self) -> None:
        super().__init__()
        self.trace: list[str] = []  # what each check saw (for a failure's report)

    # --- CHECK(Result::Success == ...) ------------------------------------------------------
    async def _follow_me(self, name: str, *args) -> bool:
        try:
            await getattr(self.drone.follow_me, name)(*args)
            return True
        except FollowMeError as exc:
            self.check(False, f"follow_me.{name}: {exc}")
            return False

    async def set_config(self, config: FollowMeConfig) -> bool:
        return await self._follow_me("set_config", config.to_mavsdk())

    async def _manual_control(self, x: float, y: float, z: float, r: float) -> None:
        try:
            await self.drone.manual_control.set_manual_control_input(x, y, z, r)
        except ManualControlError as exc:
            self.check(False, f"set_manual_control_input: {exc}")

    def get_home(self):
        """getHome: the ground truth store_home kept."""
        home = self._home
        self.check(home is not None, "home stored")
        return home

    def check_current_altitude(self, target_rel_altitude_m: float,
                               max_distance_m: float = 1.5) -> None:
        rel = self.get("position").relative_altitude_m
        self.check(abs(rel - target_rel_altitude_m) <= max_distance_m,
                   f"relative altitude {rel:.2f} m, expected {target_rel_altitude_m} ± "
                   f"{max_distance_m} m")

    # --- the tests ----------------------------------------------------------------------------
    async def straight_line_test(self, stream_velocity: bool) -> None:
        """Moves the target north and checks the vehicle behind, in front of, front-right of
        and front-left of it in turn. ``stream_velocity``: the reports carry the target's
        velocity (else NaN)."""
        location_update_rate = 1  # [Hz] how often the target's GPS location is generated
        position_error_tolerance = 11.0  # [m] in both X and Y
        follow_me_height_setting = 10.0  # [m] above home

        # the target starts on the vehicle's position
        target_simulator = FollowTargetSimulator(self.get_current_position_ned(),
                                                 self.get_home())
        config = FollowMeConfig(follow_height_m=follow_me_height_setting,
                                follow_distance_m=8.0, follow_angle_deg=0.0,
                                # a trajectory fast enough to be responsive
                                max_tangential_vel_m_s=15.0)

        await self.sleep_for(1.0)  # time for the mode switch
        await self._follow_me("start")
        await self.sleep_for(1.0)  # time for the mode switch

        target_moving = perform_checks = False
        for idx in range(75 * location_update_rate):
            target_truth = target_simulator.get_position_ground_truth_ned()
            position_ned = self.get_current_position_ned()
            distance_to_target = _norm(_diff(target_truth, position_ned))

            # poor man's state machine
            if idx < 5:
                pass  # the target reported, not moving
            elif idx == 5:  # follow from behind
                perform_checks = False
                config = replace(config, follow_angle_deg=180.0)
                await self.set_config(config)
            elif idx < 15:  # the target moves; the vehicle settles for 10 samples
                target_moving = True
            elif idx < 20:  # checks in steady state for 5 samples
                perform_checks = True
            elif idx == 20:  # follow from the front
                perform_checks = False
                config = replace(config, follow_angle_deg=0.0)
                await self.set_config(config)
            elif idx < 30:
                pass
            elif idx < 35:
                perform_checks = True
            elif idx == 35:  # follow from front right
                perform_checks = False
                config = replace(config, follow_angle_deg=45.0)
                await self.set_config(config)
            elif idx < 45:
                pass
            elif idx < 55:
                perform_checks = True
            elif idx == 55:  # follow from front left
                perform_checks = False
                config = replace(config, follow_angle_deg=-45.0)
                await self.set_config(config)
            elif idx < 65:
                pass
            elif idx < 75:
                perform_checks = True

            if target_moving:
                target_simulator.update(1.0 / location_update_rate)

            if perform_checks:
                self.trace.append(
                    f"sample {idx}: angle {config.follow_angle_deg}, target {target_truth}, "
                    f"vehicle {tuple(round(c, 2) for c in position_ned)}, distance "
                    f"{distance_to_target:.2f}")
                n = len(self.failures)
                self.check_current_altitude(follow_me_height_setting)
                self.check(distance_to_target <= config.follow_distance_m
                           + position_error_tolerance,
                           f"distance to target {distance_to_target:.2f} m <= "
                           f"{config.follow_distance_m} + {position_error_tolerance}")
                self.check(distance_to_target >= config.follow_distance_m
                           - position_error_tolerance,
                           f"distance to target {distance_to_target:.2f} m >= "
                           f"{config.follow_distance_m} - {position_error_tolerance}")
                FollowTargetSimulator.check_follow_angle(self.check, config, position_ned,
                                                         target_truth, position_error_tolerance)
                for i in range(n, len(self.failures)):
                    self.failures[i] = f"sample {idx}: {self.failures[i]}"

            lat, lon, alt = target_simulator.get_position_global_noisy(self.check)
            if stream_velocity:
                vel = target_simulator.get_velocity_ned_noisy()
            else:
                vel = (NAN, NAN, NAN)
            await self._follow_me("set_target_location", target_location(lat, lon, alt, *vel))

            await self.sleep_for(1.0 / location_update_rate)

        await self._follow_me("stop")

    async def stream_velocity_only(self) -> None:
        """Reports with a velocity but no position: an invalid target, the vehicle stays."""
        loop_update_rate = 1
        position_tolerance = 4.0

        await self.set_config(FollowMeConfig(follow_angle_deg=180.0))  # from behind
        await self.sleep_for(1.0)  # time for the mode switch
        await self._follow_me("start")
        await self.sleep_for(1.0)  # time for the mode switch

        drone_initial_pos = self.get_current_position_ned()
        for _ in range(15 * loop_update_rate):
            await self._follow_me("set_target_location",
                                  target_location(vx=2.0, vy=1.0, vz=0.5))
            await self.sleep_for(1.0 / loop_update_rate)

        drone_final_pos = self.get_current_position_ned()
        travelled = _norm(_diff(drone_initial_pos, drone_final_pos))
        self.check(travelled < position_tolerance,
                   f"distance travelled {travelled:.2f} m < {position_tolerance} m")

    async def rc_adjustment_test(self) -> None:
        """Throttle trims the follow height, pitch the distance, roll the angle."""
        loop_update_rate = 50  # [Hz]
        follow_height_setting = 10.0  # [m]
        follow_angle_setting = 0.0  # [deg]
        follow_distance_setting = 10.0  # [m]

        # the target stands where the vehicle is
        target_simulator = FollowTargetSimulator(self.get_current_position_ned(),
                                                 self.get_home())
        await self.set_config(FollowMeConfig(follow_height_m=follow_height_setting,
                                             follow_distance_m=follow_distance_setting,
                                             follow_angle_deg=follow_angle_setting))
        # one sample of the target's position: a stationary target
        lat, lon, alt = target_simulator.get_position_global_ground_truth(self.check)
        location = target_location(lat, lon, alt)
        target_pos = self.get_current_position_ned()

        await self._follow_me("start")
        drone_initial_pos = None
        rate = loop_update_rate
        for i in range(60 * rate + 1):
            if i % rate == 0:  # how fast the loop runs, in the autopilot's time
                pos = self.get_current_position_ned()
                self.trace.append(f"i {i}: at {self._autopilot_us() / 1e6:.2f} s, "
                                  f"{self.get('flight_mode')}, vehicle "
                                  f"{tuple(round(c, 2) for c in pos)}")
            # unchecked in PX4 (NOT_ACTIVE until a heartbeat shows Follow Me)
            try:
                await self.drone.follow_me.set_target_location(location)
            except FollowMeError:
                pass
            current = self.get_current_position_ned()

            if i < 5 * rate:  # 5 s to reach the initial position (in front)
                await self._manual_control(0.0, 0.0, 0.5, 0.0)
            elif i == 5 * rate:  # the initial position
                drone_initial_pos = self.get_current_position_ned()
                self.trace.append(f"i {i}: initial {drone_initial_pos}")
            elif i < 8 * rate:  # throttle up for 3 s: the height
                await self._manual_control(0.0, 0.0, 1.0, 0.0)
            elif i < 10 * rate:  # centred for 2 s
                await self._manual_control(0.0, 0.0, 0.5, 0.0)
            elif i == 10 * rate:  # climbed at least half what was asked (z is down)
                climbed = -(current[2] - drone_initial_pos[2])
                self.trace.append(f"i {i}: vehicle {current}, climbed {climbed:.2f}")
                self.check(climbed > FOLLOW_HEIGHT_USER_ADJUST_SPEED * 3.0 * 0.5,
                           f"climbed {climbed:.2f} m > "
                           f"{FOLLOW_HEIGHT_USER_ADJUST_SPEED * 3.0 * 0.5} m")
            elif i < 13 * rate:  # pitch down (forward) for 3 s: the distance
                await self._manual_control(1.0, 0.0, 0.5, 0.0)
            elif i < 15 * rate:  # centred for 2 s
                await self._manual_control(0.0, 0.0, 0.5, 0.0)
            elif i == 15 * rate:  # the distance grew by at least half what was asked
                distance = math.hypot(current[0] - target_pos[0], current[1] - target_pos[1])
                expected = follow_distance_setting + FOLLOW_DISTANCE_USER_ADJUST_SPEED * 3.0 * 0.5
                self.trace.append(f"i {i}: vehicle {current}, distance {distance:.2f}")
                self.check(distance > expected, f"follow distance {distance:.2f} m > "
                                                f"{expected} m")
            elif i < 18 * rate:  # roll right for 3 s: the angle (clockwise)
                await self._manual_control(0.0, 1.0, 0.5, 0.0)
            elif i < 20 * rate:  # centred for 2 s
                await self._manual_control(0.0, 0.0, 0.5, 0.0)
            elif i == 20 * rate:  # the angle grew by at least half what was asked
                angle = math.atan2(current[1] - target_pos[1], current[0] - target_pos[0])
                expected = follow_angle_setting * math.pi / 180.0 \
                    + FOLLOW_ANGLE_USER_ADJUST_SPEED * 3.0 * 0.5
                self.trace.append(f"i {i}: vehicle {current}, angle {angle:.3f}")
                self.check(angle > expected, f"follow angle {angle:.3f} rad > {expected} rad")

            await self.sleep_for(1.0 / rate)
