"""The sensors' noise (estimation.py): standard normal draws for every vehicle of a World, drawn
ahead in blocks from each vehicle's own seeded generator, so that the compiled sensor kernel reads
one row of numbers per vehicle and step and the generators are called rarely.

Rules: every draw of a vehicle comes from its own stream, in the stream's order, at the same step
whatever else runs; no other randomness here.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

# Noise draws per vehicle and step (columns of a noise block).
N_GYRO, N_GYRO_BIAS, N_ACC, N_ACC_BIAS, N_BARO, N_MAG, N_GPS_POS, N_GPS_VEL, N_SIZE = (
    0, 3, 6, 9, 12, 13, 16, 19, 22)
BLOCK = 250  # steps of noise kept ahead per vehicle


def with_rows(old: np.ndarray, n: int) -> np.ndarray:
    """``old`` grown to ``n`` rows (new rows zero): a view of its buffer while that has room, else
    of one twice as large, so adding vehicles one by one copies O(n) rows in all, not O(n²)."""
    buf = old.base if isinstance(old.base, np.ndarray) and old.base.shape[1:] == old.shape[1:] \
        and old.base.dtype == old.dtype else old
    if n > len(buf):
        buf = np.zeros((max(n, 2 * len(buf)),) + old.shape[1:], dtype=old.dtype)
        buf[:len(old)] = old
    return buf[:n]


class NoiseBlocks:
    """Standard normal draws for every row, ``BLOCK`` steps ahead, each row from its own
    generator (``rng_for(index)``: a seeded stream named after the vehicle).

    Row k's block is a ring: step ``steps`` reads column ``j = steps % BLOCK``, which holds draw
    number ``steps - first`` of the row's stream (``first``: the start of the block the row was
    added in, as when every row drew a whole block at every ``j == 0``). The rows do not refill
    together: row k refills when ``j`` comes to k % BLOCK, with every draw up to ``BLOCK`` steps
    ahead. So a step of many vehicles draws for one or two of them, not for all of them every
    ``BLOCK`` steps (a stall of tens of milliseconds at 250 vehicles), and each row's draws are
    the same numbers in the same order at the same steps: a generator's stream does not depend
    on how its draws are split into calls."""

    def __init__(self, rng_for: Callable[[int], np.random.Generator] | None) -> None:
        self._rng_for = rng_for
        self._gens: list[np.random.Generator | None] = []
        self._drawn: list[int] = []  # per row: the step whose draw comes next from its stream
        self._due: list[list[int]] = [[] for _ in range(BLOCK)]  # rows refilled as j comes to i
        self.block = np.zeros((0, BLOCK, N_SIZE))
        self.steps = 0
        self.j = 0

    def add(self, index: int) -> None:
        gen = self._rng_for(index) if self._rng_for is not None else None
        k = len(self._gens)
        self._gens.append(gen)
        start = self.steps - self.j
        self._drawn.append(start)
        self.block = with_rows(self.block, k + 1)
        if gen is not None:
            phase = k % BLOCK
            self._due[phase].append(k)
            # Up to its first refill: the rest of this block, or into the next one when the
            # refill's turn has passed in this one.
            refill = self.steps + (phase - self.j - 1) % BLOCK + 1
            self._fill(k, max(start + BLOCK, refill))

    def _fill(self, k: int, until: int) -> None:
        """Row ``k``'s draws for the steps before ``until`` that it has not drawn yet."""
        gen, row, d = self._gens[k], self.block[k], self._drawn[k]
        assert gen is not None
        while d < until:
            i = d % BLOCK
            m = min(until - d, BLOCK - i)
            gen.standard_normal(out=row[i:i + m])
            d += m
        self._drawn[k] = d

    def advance(self) -> None:
        """Move to the next step's draws (refilling the rows whose turn it is)."""
        self.steps += 1
        j = self.j = self.steps % BLOCK
        for k in self._due[j]:
            self._fill(k, self.steps + BLOCK)
