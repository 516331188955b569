"""What a lockstep client received: (time, message id, frame) per MAVLink frame, compactly.

A vehicle's API link brings ~420 frames per simulated second. Kept as tuples of a float, an int
and a bytes object they cost ~170 bytes each (~270 MB per vehicle-hour); here each costs its
bytes plus 20 (time, id, end offset in three arrays, the frames back to back in one buffer).
With ``history_s`` the store also forgets frames older than that many simulated seconds, so a
long or crowded lockstep run keeps a bounded window.

Indices are absolute and never reused: frame ``i`` is the i-th frame received, ``len`` counts
every frame received, and ``store[i]`` of a forgotten frame raises ``IndexError`` saying so.
Iteration and slices cover the frames still kept.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Iterator

Frame = tuple[float, int, bytes]


class FrameStore:
    """Frames as ``(time_s, msgid, frame)``, indexed by arrival (see the module docstring)."""

    __slots__ = ("history_s", "_t", "_id", "_end", "_data", "_first", "_byte0", "_forget_at")

    def __init__(self, history_s: float = math.inf) -> None:
        if not history_s > 0:
            raise ValueError(f"history_s must be > 0 (got {history_s!r})")
        self.history_s = history_s
        self._t = array("d")
        self._id = array("I")
        self._end = array("Q")  # absolute end offset of each kept frame in the received bytes
        self._data = bytearray()  # the kept frames, back to back
        self._first = 0  # absolute index of the oldest kept frame
        self._byte0 = 0  # absolute offset of self._data[0]
        # The oldest frame's time + 1.5 history_s: then forget (-inf: set at the first frame).
        self._forget_at = -math.inf

    def append(self, time_s: float, msgid: int, frame: bytes) -> int:
        """Keep one frame; returns its index."""
        data = self._data
        data += frame
        times = self._t
        times.append(time_s)
        self._id.append(msgid)
        self._end.append(self._byte0 + len(data))
        if time_s > self._forget_at:  # forget in batches, not frame by frame
            self._forget_before(time_s - self.history_s)
        return self._first + len(times) - 1

    def _forget_before(self, t_s: float) -> None:
        times = self._t
        k = 0
        while k < len(times) and times[k] < t_s:
            k += 1
        if not k:  # nothing yet (the first frame): when to look next
            self._forget_at = times[0] + 1.5 * self.history_s
            return
        cut = self._end[k - 1] - self._byte0
        del self._data[:cut]
        self._byte0 += cut
        del times[:k]
        del self._id[:k]
        del self._end[:k]
        self._first += k
        self._forget_at = times[0] + 1.5 * self.history_s if times else math.inf

    @property
    def first(self) -> int:
        """The index of the oldest frame kept (0 unless ``history_s`` forgot some)."""
        return self._first

    def _row(self, i: int) -> int:
        j = i - self._first
        if j < 0:
            raise IndexError(f"frame {i} is forgotten: the client keeps {self.history_s} s")
        if j >= len(self._t):
            raise IndexError(f"frame {i} not received yet ({len(self)} so far)")
        return j

    def time_s(self, i: int) -> float:
        return self._t[self._row(i)]

    def msgid(self, i: int) -> int:
        return self._id[self._row(i)]

    def frame(self, i: int) -> bytes:
        j = self._row(i)
        end = self._end[j] - self._byte0
        start = self._end[j - 1] - self._byte0 if j else 0
        return bytes(self._data[start:end])

    def find(self, msgids: frozenset[int] | set[int], start: int, stop: int | None = None
             ) -> Iterator[int]:
        """Indices in [start, stop) of the kept frames whose id is one of ``msgids``."""
        ids, first = self._id, self._first
        lo = max(start - first, 0)
        hi = len(ids) if stop is None else min(stop - first, len(ids))
        for j in range(lo, hi):
            if ids[j] in msgids:
                yield first + j

    def last(self, msgid: int) -> Iterator[int]:
        """Indices of the kept frames with id ``msgid``, newest first."""
        ids, first = self._id, self._first
        for j in range(len(ids) - 1, -1, -1):
            if ids[j] == msgid:
                yield first + j

    def __len__(self) -> int:
        return self._first + len(self._t)

    def __getitem__(self, key: int | slice) -> Frame | list[Frame]:
        if isinstance(key, slice):
            return [self[i] for i in range(*key.indices(len(self)))  # type: ignore[misc]
                    if i >= self._first]
        i = key + len(self) if key < 0 else key
        j = self._row(i)
        return self._t[j], self._id[j], self.frame(i)

    def __iter__(self) -> Iterator[Frame]:
        for i in range(self._first, len(self)):
            yield self[i]  # type: ignore[misc]
