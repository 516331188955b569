"""The loggers of every vehicle of a Simulation, and the files they write (the shell around
logger.py).

Rules:
- Each vehicle's logs go under each of its roots (``roots_for(sysid)``: the state dir's and the
  run's ``vehicle-<sysid>``), at PX4's paths (``log/<date>/<time>.ulg``), like a PX4 SITL
  instance's rootfs.
- The loggers tick at 50 Hz of simulated time; their bytes are appended to the files every
  simulated second and at ``close`` (a crash loses at most the last second, as flightlog.py).
- ``entries(sysid)``: the vehicle's finished and running logs, oldest first (the log handler's
  list).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path

from gateway.onboard.logger import VehicleLogger
from gateway.sim.simulation import Simulation

log = logging.getLogger(__name__)

TICK_S = 0.02
FLUSH_S = 1.0


class Logs:
    def __init__(self, sim: Simulation, roots_for: Callable[[int], list[Path]],
                 boot_unix_s: float | None) -> None:
        self.roots_for = roots_for
        self.loggers: dict[int, VehicleLogger] = {}
        for vehicle in sim.vehicles:
            sysid = int(vehicle.params.get("MAV_SYS_ID", 1) or 1)
            self.loggers[sysid] = VehicleLogger(vehicle, boot_unix_s)
        self._failed = False
        sim.every(TICK_S, self._tick)
        sim.every(FLUSH_S, lambda now: self.flush())

    def _tick(self, now_s: float) -> None:
        for logger in self.loggers.values():
            logger.tick(now_s)

    def _write(self, sysid: int, chunks: list[tuple[str, bytes, bool]]) -> None:
        for rel, data, _closed in chunks:
            for root in self.roots_for(sysid):
                path = root / rel
                try:
                    path.parent.mkdir(parents=True, exist_ok=True)
                    with open(path, "ab") as f:
                        f.write(data)
                except OSError as exc:
                    if not self._failed:
                        log.error("cannot write the log %s: %s (logging goes on elsewhere)",
                                  path, exc)
                        self._failed = True

    def flush(self) -> None:
        for sysid, logger in self.loggers.items():
            self._write(sysid, logger.drain())

    def close(self) -> None:
        for sysid, logger in self.loggers.items():
            self._write(sysid, logger.close())

    def entries(self, sysid: int) -> list[Path]:
        """The vehicle's logs under its first root, oldest first."""
        roots = self.roots_for(sysid)
        if not roots:
            return []
        return [roots[0] / rel for rel in self.loggers[sysid].files
                if (roots[0] / rel).exists()]
