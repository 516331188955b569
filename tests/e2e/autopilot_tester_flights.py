"""autopilot_tester.cpp's failure injection (inject_failure, execute_mission_and_lose_*) and
flights on sticks and attitude setpoints (fly_forward_in_posctl, fly_forward_in_altctl,
fly_forward_in_offboard_attitude), for AutopilotTester (whose clock, checks and latest values
they use)."""

from __future__ import annotations

from typing import Any

from mavsdk.failure import FailureType, FailureUnit
from mavsdk.telemetry import FlightMode


class ManualFlights:
    drone: Any

    # --- failure injection -------------------------------------------------------------------
    async def create_failure_plugin(self) -> None:
        """What autopilot_tester.cpp's connect does with ``new Failure(system)``: MAVSDK's
        Failure plugin exists from then on, following SYS_FAILURE_EN's changes. mavsdk_server
        creates a plugin at its first call, so here one call that changes nothing: no
        failure (OK) of every motor."""
        await self._inject(FailureUnit.SYSTEM_MOTOR, FailureType.OK, 0)

    async def inject_failure(self, unit: FailureUnit, kind: FailureType, instance: int,
                             expected: str) -> None:
        got = await self._inject(unit, kind, instance)
        self.check(got == expected, f"inject {unit.name} {kind.name} {instance}: {got}, "
                                    f"expected {expected}")

    async def _mission_continues_after(self, unit: FailureUnit, kind: FailureType,
                                       timeout_s: float = 90) -> None:
        await self.set_param_int("SYS_FAILURE_EN", 1)
        await self.start_and_wait_for_mission_sequence(1)
        await self.inject_failure(unit, kind, 0, "SUCCESS")

        def finished() -> bool:
            p = self.get("mission_progress")
            return p is not None and p.current == p.total

        self.require(await self.poll_condition_with_timeout(finished, timeout_s),
                     f"mission finished after {unit.name} {kind.name}")

    async def execute_mission_and_lose_gps(self) -> None:
        await self.set_param_int("SYS_FAILURE_EN", 1)
        await self.start_and_wait_for_mission_sequence(1)
        await self.inject_failure(FailureUnit.SENSOR_GPS, FailureType.OFF, 0, "SUCCESS")
        await self.wait_for_flight_mode(FlightMode.LAND, 30)  # a blind land

    async def execute_mission_and_lose_mag(self) -> None:
        await self._mission_continues_after(FailureUnit.SENSOR_MAG, FailureType.OFF)

    async def execute_mission_and_lose_baro(self) -> None:
        await self._mission_continues_after(FailureUnit.SENSOR_BARO, FailureType.OFF)

    async def execute_mission_and_get_baro_stuck(self) -> None:
        await self._mission_continues_after(FailureUnit.SENSOR_BARO, FailureType.STUCK)

    # --- manual control ----------------------------------------------------------------------
    async def _sticks(self, x: float, y: float, z: float, r: float, seconds: float,
                      rate_hz: int = 50, until_landed: bool = False) -> None:
        for _ in range(int(seconds * rate_hz)):
            await self.drone.manual_control.set_manual_control_input(x, y, z, r)
            await self.sleep_for(1.0 / rate_hz)
            if until_landed and self.get("in_air") is False:
                break

    async def _fly_forward(self, start_mode) -> None:
        await self._sticks(0.0, 0.0, 0.5, 0.0, 1)  # something, so that RC is available
        try:
            await start_mode()
        except Exception as exc:
            self.check(False, f"{start_mode.__name__}: {exc}")
        await self.store_home()
        await self.wait_until_ready()
        await self.arm()
        await self._sticks(0.0, 0.0, 1.0, 0.0, 5)  # climb for 5 s
        await self._sticks(0.5, 0.0, 0.5, 0.0, 10)  # forward for 10 s
        await self._sticks(0.0, 0.0, 0.0, 0.0, 60, until_landed=True)  # descend until landed

    async def fly_forward_in_posctl(self) -> None:
        await self._fly_forward(self.drone.manual_control.start_position_control)

    async def fly_forward_in_altctl(self) -> None:
        await self._fly_forward(self.drone.manual_control.start_altitude_control)

    async def fly_forward_in_offboard_attitude(self) -> None:
        from mavsdk.offboard import Attitude

        def steady() -> bool:
            gps, att = self.get("raw_gps"), self.get("attitude_euler")
            return gps is not None and att is not None and gps.altitude_ellipsoid_m > 0 \
                and abs(att.roll_deg) < 5 and abs(att.pitch_deg) < 5

        self.check(await self.poll_condition_with_timeout(steady, 20), "raw GPS, steady attitude")
        start_alt = self.get("raw_gps").altitude_ellipsoid_m
        attitude = [0.0, 0.0, 0.0, 0.0]  # roll, pitch, yaw, thrust
        await self.drone.offboard.set_attitude(Attitude(*attitude))
        await self._action(self.drone.offboard.start)
        self.check(await self.poll_condition_with_timeout(self._armable, 20), "is armable")
        await self.arm()
        rate_hz = 50

        async def hold(seconds: float | None) -> None:
            n = 0
            while True:
                if seconds is None:
                    if self.get("raw_gps").altitude_ellipsoid_m - start_alt >= 10.0:
                        return
                elif n >= seconds * rate_hz:
                    return
                await self.drone.offboard.set_attitude(Attitude(*attitude))
                await self.sleep_for(1.0 / rate_hz)
                n += 1

        attitude[3] = 0.8
        await hold(None)  # climb 10 m
        attitude[1] = -20.0
        await hold(3)  # forward for 3 s
        est = self.get("attitude_euler")
        self.check(abs(attitude[0] - est.roll_deg) < 5, f"roll {est.roll_deg:.1f}")
        self.check(abs(attitude[1] - est.pitch_deg) < 5, f"pitch {est.pitch_deg:.1f}")
        attitude[3], attitude[1] = 0.4, 0.0
        await hold(6)  # descend
        attitude[3] = 0.0
        await self.drone.offboard.set_attitude(Attitude(*attitude))
