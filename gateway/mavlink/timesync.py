"""The time offset to a client's clock, as each PX4 MAVLink instance estimates it (PX4
src/lib/timesync/Timesync.cpp, driven by mavlink_timesync.cpp).

Rules (PX4 v1.15's, with its integer types):
- The link's TIMESYNC stream asks (tc1 = 0, ts1 = our time in ns, telemetry_link.py); a reply
  (tc1 > 0: the client's time in ns, ts1 echoed) is a sample: offset = (ts1 + now - 2·tc1) / 2
  (µs, our clock minus the client's), RTT = now - ts1. Samples with an RTT of 10 ms or more are
  left out (ten in a row: "RTT too high for timesync" on the console); once converged, samples
  more than 100 ms from the estimate are outliers, and more than ten of them in a row reset the
  filter ("time jump detected").
- The estimate is a double exponential smoothing of the samples (offset and skew), whose gains
  go from 0.05 to 0.003 over the first CONVERGENCE_WINDOW (500) samples along a sigmoid; it has
  converged after 500 samples (50 s of PX4's 10 Hz requests, with a client that answers them:
  MAVROS does; MAVSDK only once its application enables timesync, which the C++ API's
  System::enable_timesync does and MAVSDK-Python cannot; pymavlink scripts do not).
- ``sync_stamp(usec)``: a client's timestamp on our clock once converged (uint64: a remote
  stamp of 0 lands in the far future), else the time now. MavlinkReceiver stamps
  LANDING_TARGET's landing_target_pose with it.
- Every reply publishes timesync_status (logged, logged_status.py), whatever was done with it.
  PX4 1.15's MAVLink instances construct their Timesync without a source, so source_protocol
  is SOURCE_PROTOCOL_UNKNOWN (0).
- Time is an argument (µs of simulated time since boot); nothing here reads a clock.
"""

from __future__ import annotations

import logging
import math
from typing import NamedTuple

log = logging.getLogger(__name__)

ALPHA_GAIN_INITIAL = 0.05
BETA_GAIN_INITIAL = 0.05
ALPHA_GAIN_FINAL = 0.003
BETA_GAIN_FINAL = 0.003
CONVERGENCE_WINDOW = 500
MAX_RTT_SAMPLE_US = 10_000
MAX_DEVIATION_SAMPLE_US = 100_000
MAX_CONSECUTIVE_HIGH_RTT = 10
MAX_CONSECUTIVE_HIGH_DEVIATION = 10
SOURCE_PROTOCOL_UNKNOWN = 0

_U64 = (1 << 64) - 1


def _int64(value: int) -> int:
    """A uint64 bit pattern as int64 (two's complement)."""
    value &= _U64
    return value - (1 << 64) if value >> 63 else value


def _trunc_div(a: int, b: int) -> int:
    """C's signed integer division (toward zero)."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


class TimesyncStatus(NamedTuple):
    """timesync_status (TimesyncStatus.msg) as one reply publishes it."""

    timestamp_us: int
    source_protocol: int
    remote_timestamp_us: int
    observed_offset_us: int
    estimated_offset_us: int
    round_trip_time_us: int


class Timesync:
    """One MAVLink instance's estimate of its client's clock (module rules)."""

    def __init__(self, name: str = "") -> None:
        self.name = name  # for the console lines
        self.status: TimesyncStatus | None = None  # the last publication
        self.published_at_us: int | None = None  # the first publication (its uORB instance)
        self.reset_filter()

    def reset_filter(self) -> None:
        self.sequence = 0
        self.time_offset = 0.0
        self.time_skew = 0.0
        self.filter_alpha = ALPHA_GAIN_INITIAL
        self.filter_beta = BETA_GAIN_INITIAL
        self.high_deviation_count = 0
        self.high_rtt_count = 0

    @property
    def converged(self) -> bool:
        return self.sequence >= CONVERGENCE_WINDOW

    @property
    def offset_us(self) -> int:
        """Our clock minus the client's, µs (Timesync::offset: the estimate truncated)."""
        return int(self.time_offset)

    def update(self, now_us: int, remote_ns: int, originate_ns: int) -> None:
        """A TIMESYNC reply at ``now_us``: tc1 = ``remote_ns``, ts1 = ``originate_ns``."""
        if remote_ns <= 0:
            return
        originate_us = (originate_ns & _U64) // 1000  # C: (uint64) / 1000ULL
        remote_us = (remote_ns & _U64) // 1000
        offset = _trunc_div(_int64(originate_us + now_us - remote_us * 2), 2)
        rtt = (now_us - originate_us) & _U64
        deviation = abs(int(self.time_offset) - offset)
        if rtt < MAX_RTT_SAMPLE_US:
            if self.converged and deviation > MAX_DEVIATION_SAMPLE_US:
                self.high_deviation_count += 1
                if self.high_deviation_count > MAX_CONSECUTIVE_HIGH_DEVIATION:
                    log.warning("%s time jump detected. Resetting time synchroniser.", self.name)
                    self.reset_filter()
            else:
                if not self.converged:
                    progress = self.sequence / CONVERGENCE_WINDOW
                    p = 1.0 - math.exp(0.5 * (1.0 - 1.0 / (1.0 - progress)))
                    self.filter_alpha = p * ALPHA_GAIN_FINAL + (1.0 - p) * ALPHA_GAIN_INITIAL
                    self.filter_beta = p * BETA_GAIN_FINAL + (1.0 - p) * BETA_GAIN_INITIAL
                else:
                    self.filter_alpha = ALPHA_GAIN_FINAL
                    self.filter_beta = BETA_GAIN_FINAL
                self._add_sample(offset)
                self.sequence += 1
                self.high_deviation_count = 0
                self.high_rtt_count = 0
        else:
            self.high_rtt_count += 1
            if self.high_rtt_count == MAX_CONSECUTIVE_HIGH_RTT:
                log.warning("%s RTT too high for timesync: %d ms", self.name, rtt // 1000)
        if self.published_at_us is None:
            self.published_at_us = now_us
        self.status = TimesyncStatus(now_us, SOURCE_PROTOCOL_UNKNOWN, remote_us, offset,
                                     int(self.time_offset), rtt & 0xFFFFFFFF)

    def _add_sample(self, offset_us: int) -> None:
        previous = self.time_offset
        if self.sequence == 0:
            self.time_offset = float(offset_us)
        else:
            a, b = self.filter_alpha, self.filter_beta
            self.time_offset = a * offset_us + (1.0 - a) * (self.time_offset + self.time_skew)
            self.time_skew = b * (self.time_offset - previous) + (1.0 - b) * self.time_skew

    def sync_stamp(self, usec: int, now_us: int) -> int:
        """``usec`` of the client's clock on ours (uint64), once converged; else ``now_us``."""
        if self.converged:
            return (usec + int(self.time_offset)) & _U64
        return now_us
