"""One topic PX4's logger writes: its uORB name, the fields CORNET logs and how they are read.

Rules (logged_topics.py says which topics and why): ``fields`` come after the leading
``uint64_t timestamp``, each a (ULog type, PX4 field name) pair with PX4 1.15's name and type;
``read(vehicle, now_us)`` returns their values flat (an array's elements one by one; a
``stamped`` topic's own timestamp first), or None while PX4 would not have published the topic;
``step`` (row of the recent-steps ring, the step's time µs) reads a topic PX4 publishes at the
sensors' rate. A topic PX4 logs with add_topic_multi has one Topic per instance
(``multi_id``), sharing its format.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

from gateway.onboard import ulog

Fields = Sequence[tuple[str, str]]
F, D, B, U64 = "float", "double", "bool", "uint64_t"  # ULog type names


# Commander::run publishes actuator_armed, vehicle_control_mode, vehicle_status and
# failure_detector_status on every change and 500 ms after the last publication
COMMANDER_REPUBLISH_S = 0.5


@dataclass(frozen=True)
class Topic:
    name: str
    fields: Fields  # after the leading "uint64_t timestamp"
    interval_s: float  # logged_topics.cpp's interval (0: every tick)
    read: Callable[[Any, int], Sequence[Any] | None]  # (vehicle, now µs) → the values, flat
    on_change: bool = False  # log only when the values change (and at the start)
    # (ring row, step time µs) → the values, for a topic logged at the sensors' rate
    step: Callable[[Sequence[float], int], Sequence[Any]] | None = None
    # the publisher's period, for a topic logged at every update (no interval) that its module
    # publishes at a fixed rate (load_mon's cpuload: 500 ms)
    period_s: float = 0.0
    multi_id: int = 0  # the uORB instance (add_topic_multi), its subscription's multi_id
    # an ``on_change`` topic its module also publishes this long after its last publication
    # (Commander's vehicle_status, actuator_armed, vehicle_control_mode, failure_detector_status:
    # 500 ms): logged then too, unchanged
    republish_s: float = 0.0
    # ``read`` returns the record's timestamp first (µs: the one its publisher stamped the
    # message with, timesync_status's), not the logger's sampling instant
    stamped: bool = False

    @property
    def every_s(self) -> float:
        """How often a record is written: the logger's interval or the publisher's period."""
        return max(self.interval_s, self.period_s)


class Records(NamedTuple):
    """How a logger writes its topics' records (``records_of``): per topic its struct (the
    leading timestamp included), its data messages' prefix and packer; the same for the extra
    formats logged after the topics (msg_id after theirs)."""

    structs: list[struct.Struct]
    prefixes: list[bytes]
    packers: list[Callable[..., bytes]]
    extra_structs: list[struct.Struct]
    extra_prefixes: list[bytes]


_RECORDS: dict[tuple[Any, ...], Records] = {}


def records_of(topics: Sequence[Topic], nested: Mapping[str, Fields],
               extra: Sequence[Fields] = ()) -> Records:
    """The records of ``topics`` (msg_id = index) and ``extra`` (msg_id after them), made once
    per process for each set of formats and shared (read only) by every vehicle's logger: a
    daemon of 254 vehicles would otherwise build the same ~50 structs 254 times at its start."""
    key = (tuple((t.fields, t.stamped) for t in topics), tuple(nested.items()), tuple(extra))
    records = _RECORDS.get(key)
    if records is None:
        stamp = ("uint64_t", "timestamp")
        structs = [ulog.struct_of((stamp, *t.fields), nested) for t in topics]
        extra_structs = [ulog.struct_of((stamp, *fields)) for fields in extra]
        n = len(topics)
        records = _RECORDS[key] = Records(
            structs, [ulog.data_prefix(i, st.size) for i, st in enumerate(structs)],
            [_stamped(ulog.data_packer(i, st)) if t.stamped else ulog.data_packer(i, st)
             for i, (t, st) in enumerate(zip(topics, structs))], extra_structs,
            [ulog.data_prefix(n + k, st.size) for k, st in enumerate(extra_structs)])
    return records


def _stamped(pack: Callable[..., bytes]) -> Callable[..., bytes]:
    """A ``stamped`` topic's packer: the timestamp its read returned, not the sampling instant."""
    def packer(_sample_us: int, stamp_us: int, *values: Any) -> bytes:
        return pack(stamp_us, *values)
    return packer
