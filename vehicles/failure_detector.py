"""PX4's failure detector, its attitude part (commander/failure_detector/FailureDetector.cpp).

Rules:
- While attitude control runs (vehicle_control_mode flag_control_attitude_enabled: every
  multicopter mode but Acro, Termination and Offboard on body rates), a roll beyond FD_FAIL_R
  degrees held for FD_FAIL_R_TTRI seconds is a roll failure, the same for pitch (FD_FAIL_P,
  FD_FAIL_P_TTRI); a threshold of 0 turns its check off. A failure clears as soon as the angle is
  back within the threshold (PX4's hysteresis: from false to true after the time, at once back).
- Without attitude control both flags are false.
- ``critical`` is failsafe_flags fd_critical_failure: the commander's failsafe disarms, terminates
  or warns (failsafe.py), and the health report denies arming ("Attitude failure detected").
- Pure: time and the attitude are arguments.
"""

from __future__ import annotations

import math

from vehicles.types import NavState, q_euler_rad

NO_ATTITUDE_CONTROL = frozenset({NavState.ACRO, NavState.TERMINATION})


def attitude_control(nav_state: NavState, offboard_setpoint) -> bool:
    """vehicle_control_mode flag_control_attitude_enabled of a multicopter (control_mode.cpp)."""
    if nav_state in NO_ATTITUDE_CONTROL:
        return False
    sp = offboard_setpoint
    return not (nav_state is NavState.OFFBOARD and sp is not None and sp.attitude_q is None
                and sp.has_body_rates)


class FailureDetector:
    def __init__(self) -> None:
        self.roll = self.pitch = False
        self._roll_since: float | None = None  # since when the roll has been beyond its limit
        self._pitch_since: float | None = None
        self._version = -1  # the parameters' version the limits below were read at
        self._limits = (0.0, 0.0, 0.0, 0.0)  # max roll, max pitch (rad), their trigger times (s)
        # Above this 1 - 2(x² + y²) of the attitude (the cosine of the tilt, which is at least
        # as large as the roll and the pitch) neither checked angle can be beyond its limit.
        self._level_cos = 2.0

    @property
    def critical(self) -> bool:
        return self.roll or self.pitch

    def update(self, now_s: float, q: tuple[float, float, float, float], attitude_control: bool,
               params) -> None:
        if not attitude_control:
            self.roll = self.pitch = False
            self._roll_since = self._pitch_since = None
            return
        if params.version != self._version:  # read again only when a parameter changed
            self._version = params.version
            self._limits = (abs(math.radians(float(params["FD_FAIL_R"]))),
                            abs(math.radians(float(params["FD_FAIL_P"]))),
                            float(params["FD_FAIL_R_TTRI"]), float(params["FD_FAIL_P_TTRI"]))
            checked = [lim for lim in self._limits[:2] if lim > 1e-7]
            self._level_cos = (math.cos(min(*checked, math.pi / 2 - 0.01)) + 1e-6 if checked
                               else -math.inf)
        if self._roll_since is None and self._pitch_since is None:
            _w, x, y, _z = q
            if 1.0 - 2.0 * (x * x + y * y) > self._level_cos:  # (not NaN) within both limits
                return  # nothing beyond, nothing held: the flags stay False
        max_roll, max_pitch, roll_ttri, pitch_ttri = self._limits
        roll, pitch, _ = q_euler_rad(q)
        self.roll, self._roll_since = _held(
            max_roll > 1e-7 and abs(roll) > max_roll, self._roll_since, now_s, roll_ttri,
            self.roll)
        self.pitch, self._pitch_since = _held(
            max_pitch > 1e-7 and abs(pitch) > max_pitch, self._pitch_since, now_s, pitch_ttri,
            self.pitch)


def _held(beyond: bool, since: float | None, now_s: float, hold_s: float,
          state: bool) -> tuple[bool, float | None]:
    """systemlib::Hysteresis with a time from false only: (state, since when beyond)."""
    if not beyond:
        return False, None
    since = now_s if since is None else since
    return state or now_s - since >= hold_s, since
