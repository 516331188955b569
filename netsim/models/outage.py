"""The outage model: scheduled blackouts, for failsafe tests (data-link loss, RC loss).

``windows_s`` is a list of [start_s, duration_s] pairs in simulated seconds. A packet that
reaches this hop at a time t with start ≤ t < start + duration for some window is dropped
(``Drop.OUTAGE``); any other packet passes with no delay, so the model composes with others in a
path (the topology puts it first, so the window applies to the send time). Windows may overlap.
No random draws.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence

from netsim.models.base import Drop, register_model
from netsim.rng import UniformStream


@register_model("outage")
class OutageModel:
    def __init__(self, rng: UniformStream | None = None,
                 windows_s: Sequence[Sequence[float]] = ()) -> None:
        del rng
        spans: list[tuple[float, float]] = []
        for i, window in enumerate(windows_s):
            try:
                start, duration = (float(x) for x in window)
            except (TypeError, ValueError):
                raise ValueError(f"outage: windows_s[{i}] must be [start_s, duration_s], "
                                 f"got {window!r}") from None
            if not (math.isfinite(start) and start >= 0):
                raise ValueError(f"outage: windows_s[{i}] start_s must be >= 0, got {start!r}")
            if not 0 < duration and math.isfinite(start + duration):
                raise ValueError(f"outage: windows_s[{i}] duration_s must be > 0, "
                                 f"got {duration!r}")
            spans.append((start, start + duration))
        # Merge overlapping windows into disjoint sorted spans, searched by bisection.
        spans.sort()
        merged: list[list[float]] = []
        for start, end in spans:
            if merged and start <= merged[-1][1]:
                merged[-1][1] = max(merged[-1][1], end)
            else:
                merged.append([start, end])
        self.spans = [(s, e) for s, e in merged]
        self._starts = [s for s, _ in merged]
        self._ends = [e for _, e in merged]

    def down(self, now_s: float) -> bool:
        i = bisect.bisect_right(self._starts, now_s) - 1
        return i >= 0 and now_s < self._ends[i]

    def transit(self, size_bytes: int, now_s: float) -> float | Drop:
        if self._starts and self.down(now_s):
            return Drop.OUTAGE
        return 0.0
