"""PX4's actuator test (MAV_CMD_ACTUATOR_TEST): motors driven directly while disarmed.

Source: PX4 src/modules/commander/Commander.cpp (handleCommandActuatorTest), src/lib/mixer_module
(ActuatorTest).
Rules:
- ``command`` maps the command's function: 1..12 motor 1..12 (MAVLink's ACTUATOR_OUTPUT_FUNCTION),
  33..40 a servo (accepted; a quadrotor has none), 1000 + n PX4's own function n (101: motor 1);
  anything else UNSUPPORTED. The caller checks arming and COM_MOT_TEST_EN first. The motor
  spins on the outputs whose function it is (SIM_GZ_EC_FUNCn; none: the test is accepted and
  nothing moves, as in PX4).
- A motor holds ``value`` (0..1 over its output's range; below 0 or NaN: its output at the
  disarmed value) for the timeout,
  at most MAX_TIMEOUT_S (PX4's 3 s, also when none is given); a timeout of 0 releases it.
- ``changed`` says the inner loop needs a new command (the autopilot clears it).
"""

from __future__ import annotations

import math

from vehicles.inner_loop import FUNCTION_MOTOR1, MAX_MOTORS
from vehicles.types import CommandResult

MAX_TIMEOUT_S = 3.0


class ActuatorTest:
    def __init__(self) -> None:
        self.tests: dict[int, tuple[float, float]] = {}  # rotor → (value, until when)
        self.changed = False

    def __bool__(self) -> bool:
        return bool(self.tests)

    def command(self, now_s: float, function: int, value: float, timeout_s: float
                ) -> CommandResult:
        if function >= 1000:
            motor = function - 1000 - FUNCTION_MOTOR1
        elif 1 <= function <= 12:
            motor = function - 1
        elif 33 <= function <= 40:
            return CommandResult.ACCEPTED
        else:
            return CommandResult.UNSUPPORTED
        timeout_ms = int(timeout_s * 1000.0 + 0.5) if math.isfinite(timeout_s) else 0
        if 0 <= motor < MAX_MOTORS:
            if timeout_ms <= 0:
                self.tests.pop(motor, None)
            else:
                limit_s = min(timeout_ms / 1000.0, MAX_TIMEOUT_S)
                self.tests[motor] = (value if value >= 0.0 else math.nan, now_s + limit_s)
            self.changed = True
        return CommandResult.ACCEPTED

    def expire(self, now_s: float) -> None:
        for motor, (_, until_s) in list(self.tests.items()):
            if now_s >= until_s:
                del self.tests[motor]
                self.changed = True

    def values(self) -> tuple[float, ...]:
        """Each rotor's test value up to the highest one tested (NaN: not tested)."""
        if not self.tests:
            return ()
        return tuple(self.tests[i][0] if i in self.tests else math.nan
                     for i in range(max(self.tests) + 1))

    def clear(self) -> None:
        if self.tests:
            self.tests.clear()
            self.changed = True
