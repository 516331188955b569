"""Sensor calibration as PX4 SITL answers MAV_CMD_PREFLIGHT_CALIBRATION, for the calibrations
that need no handling of the vehicle: gyro, level horizon, barometer.

Source: PX4 src/modules/commander/calibration_messages.h (the "[cal] …" texts QGC's sensor
page parses), gyro_calibration.cpp, level_calibration.cpp.
Rules:
- ``start`` while disarmed: "[cal] calibration started: 2 <kind>", then "[cal] progress <N>" in
  steps of 10 as ``update`` runs over ``DURATION_S``, then "[cal] calibration done: <kind>".
  Armed → DENIED; one at a time (TEMPORARILY_REJECTED while one runs). Exact sensors need no
  new offsets, so no parameter changes.
- The calibrations that need the vehicle turned by hand (accelerometer, magnetometer) and radio
  or ESC calibration are not modelled: the caller refuses them.
"""

from __future__ import annotations

from vehicles.status_log import StatusLog
from vehicles.types import CommandResult

DURATION_S = 2.0
KINDS = ("gyro", "level", "baro")


class Calibration:
    def __init__(self, log: StatusLog) -> None:
        self.log = log
        self.kind: str | None = None
        self._t0 = 0.0
        self._progress = -1

    def start(self, now_s: float, kind: str, armed: bool) -> CommandResult:
        if armed:
            return CommandResult.DENIED
        if self.kind is not None:
            return CommandResult.TEMPORARILY_REJECTED
        self.kind, self._t0, self._progress = kind, now_s, -1
        self.log.info(now_s, f"[cal] calibration started: 2 {kind}")
        return CommandResult.ACCEPTED

    def update(self, now_s: float) -> None:
        if self.kind is None:
            return
        pct = min(100, int((now_s - self._t0) / DURATION_S * 100.0) // 10 * 10)
        while self._progress < pct:
            self._progress += 10 if self._progress >= 0 else 1
            self.log.info(now_s, f"[cal] progress <{self._progress}>")
        if pct >= 100:
            self.log.info(now_s, f"[cal] calibration done: {self.kind}")
            self.kind = None
