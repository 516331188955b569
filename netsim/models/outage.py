"""The outage model: scheduled windows of trouble on a link, for failsafe tests (data-link loss,
RC loss) and fault timelines.

``windows_s`` is a list of [start_s, duration_s] pairs in simulated seconds, optionally with a
loss probability and an added delay: [start_s, duration_s, loss, delay_s] (loss 1 and delay 0
when left out: a blackout). A packet that reaches this hop at a time t with
start ≤ t < start + duration for some window:
- any window with loss 1 → dropped (``Drop.OUTAGE``);
- else each window with 0 < loss < 1 drops it with that probability (``Drop.LOSS``: a loss
  burst), drawn from the model's own stream only while such a window is open;
- else it waits the sum of the windows' delays (a latency step).
Any other packet passes with no delay, so the model composes with others in a path (the
topology puts it first, so the window applies to the send time). Windows may overlap.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence

from netsim.models.base import Drop, check_delay, register_model
from netsim.rng import UniformStream


@register_model("outage")
class OutageModel:
    def __init__(self, rng: UniformStream | None = None,
                 windows_s: Sequence[Sequence[float]] = ()) -> None:
        self.rng = rng
        spans: list[tuple[float, float]] = []
        self.partial: list[tuple[float, float, float, float]] = []  # start, end, loss, delay
        for i, window in enumerate(windows_s):
            try:
                values = [float(x) for x in window]
                if len(values) not in (2, 4):
                    raise ValueError
            except (TypeError, ValueError):
                raise ValueError(f"outage: windows_s[{i}] must be [start_s, duration_s] or "
                                 f"[start_s, duration_s, loss, delay_s], got {window!r}") from None
            start, duration = values[0], values[1]
            loss, delay = (values[2], values[3]) if len(values) == 4 else (1.0, 0.0)
            if not (math.isfinite(start) and start >= 0):
                raise ValueError(f"outage: windows_s[{i}] start_s must be >= 0, got {start!r}")
            if not 0 < duration and math.isfinite(start + duration):
                raise ValueError(f"outage: windows_s[{i}] duration_s must be > 0, "
                                 f"got {duration!r}")
            if not 0.0 <= loss <= 1.0:
                raise ValueError(f"outage: windows_s[{i}] loss must be between 0 and 1, "
                                 f"got {loss!r}")
            check_delay("outage", f"windows_s[{i}] delay_s", delay)
            if loss >= 1.0:
                spans.append((start, start + duration))
            else:
                self.partial.append((start, start + duration, loss, delay))
        if any(0.0 < w[2] for w in self.partial) and rng is None:
            raise ValueError("outage: a loss window needs a random stream")
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
        delay = 0.0
        for start, end, loss, extra in self.partial:
            if start <= now_s < end:
                if loss > 0.0 and self.rng is not None and self.rng.next() < loss:
                    return Drop.LOSS
                delay += extra
        return delay
