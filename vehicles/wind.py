"""Wind: a mean wind plus gusts, the air the World's bodies move through.

- ``WindConfig``: mean speed and the direction it blows *from* (meteorological, degrees clockwise
  from north: 270 = a westerly, blowing towards the east), gust standard deviation and time
  constant. A scenario's ``[environment]`` table (gateway/sim/scenario.py) makes one.
- ``Wind.step(dt)``: the air velocity (NED, m/s) for the next physics step. Gusts are a
  first-order Gauss-Markov process per axis (vertical at half the horizontal intensity), drawn
  from the generator the shell hands in (a seeded, named stream): the same seed gives the same
  gusts. One wind field per World: every vehicle feels the same air.
- The inner loop (inner_loop.py) applies the airframe's linear drag to the velocity relative to
  this air, so a hovering vehicle is pushed downwind and its position controller leans into it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vehicles.types import Vec3

_BATCH = 1024


@dataclass(frozen=True)
class WindConfig:
    speed_mps: float = 0.0
    from_deg: float = 0.0
    gust_mps: float = 0.0  # standard deviation of the gusts (horizontal)
    gust_time_s: float = 2.0  # their correlation time

    @property
    def calm(self) -> bool:
        return self.speed_mps == 0.0 and self.gust_mps == 0.0

    @property
    def mean_ned_mps(self) -> Vec3:
        towards = math.radians(self.from_deg) + math.pi
        return (self.speed_mps * math.cos(towards), self.speed_mps * math.sin(towards), 0.0)


class Wind:
    def __init__(self, config: WindConfig, rng: np.random.Generator | None = None) -> None:
        if config.gust_mps > 0.0 and rng is None:
            raise ValueError("gusts need a seeded generator")
        self.config = config
        self._mean = config.mean_ned_mps
        self._rng = rng
        self._gust = [0.0, 0.0, 0.0]
        self._buf: list[float] = []
        self._i = 0
        self.velocity_ned_mps: Vec3 = self._mean

    def _normal(self) -> float:
        if self._i >= len(self._buf):
            assert self._rng is not None
            self._buf = self._rng.standard_normal(_BATCH).tolist()
            self._i = 0
        self._i += 1
        return self._buf[self._i - 1]

    def step(self, dt_s: float) -> Vec3:
        c = self.config
        if c.gust_mps > 0.0:
            a = dt_s / c.gust_time_s
            k = math.sqrt(2.0 * a)
            g = self._gust
            for axis, sigma in ((0, c.gust_mps), (1, c.gust_mps), (2, 0.5 * c.gust_mps)):
                g[axis] += -g[axis] * a + sigma * k * self._normal()
            m = self._mean
            self.velocity_ned_mps = (m[0] + g[0], m[1] + g[1], m[2] + g[2])
        return self.velocity_ned_mps
