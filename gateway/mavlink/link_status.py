"""What PX4 keeps about one MAVLink link (telemetry_status) and sends of it: LINK_NODE_STATUS.

Source: PX4 mavlink_main.cpp (Mavlink::task_main's TX/RX rate update, send_finish's
tx_message_count), mavlink_receiver.cpp (rx_message_count, rx_message_lost_count and
rx_parse_errors: update_rx_stats and the read loop) and streams/LINK_NODE_STATUS.hpp (1 Hz on
the normal and onboard links).
Rules:
- The rates are bytes over the last window of more than 1 s, computed when a window ends (the
  link's loop: here its wake-ups). The first window has no rate; the bytes counted during it are
  not reset, so the second window's rate also counts them (PX4's ``_bytes_timestamp != 0``).
- LINK_NODE_STATUS: tx/rx buffer and overflow fields 0 (PX4: "TODO" and no overruns on UDP),
  rates truncated to uint32, parse errors (datagrams with anything unparsable) as uint16, the
  counts as uint32; its timestamp is microseconds since boot although the field says ms.
"""

from __future__ import annotations

from gateway.mavlink.codec import DecodeStats, Encoder, payload_of
from gateway.mavlink.snapshot import Snapshot
from gateway.mavlink.wip_dialect import LINK_NODE_STATUS
from vehicles.cnum import f32

_LINK_NODE_STATUS_PAYLOAD = payload_of(LINK_NODE_STATUS)


class TelemetryStatus:
    """telemetry_status's rates for one link, over its session's byte counts."""

    __slots__ = ("stats", "tx_rate_avg", "rx_rate_avg", "due_s", "_window_s", "_tx0", "_rx0")

    def __init__(self, stats: DecodeStats) -> None:
        self.stats = stats
        self.tx_rate_avg = self.rx_rate_avg = 0.0  # bytes/s
        self._window_s = 0.0  # _bytes_timestamp (0: none yet)
        self.due_s = 1.0  # the window ends at the first loop after this (_window_s + 1 s)
        self._tx0 = self._rx0 = 0  # the byte counts when the window began

    def update(self, now_s: float) -> None:
        """The link's loop at ``now_s``: a window of more than 1 s ends here (the session
        calls it only then, once ``now_s`` is past ``due_s``)."""
        if now_s <= self.due_s:
            return
        stats = self.stats
        tx = getattr(stats, "tx_bytes", 0)
        if self._window_s != 0.0:
            dt = f32(now_s - self._window_s)
            self.tx_rate_avg = f32((tx - self._tx0) / dt)
            self.rx_rate_avg = f32((stats.rx_bytes - self._rx0) / dt)
            self._tx0, self._rx0 = tx, stats.rx_bytes
        self._window_s = now_s
        self.due_s = now_s + 1.0


def link_node_status(enc: Encoder, s: Snapshot) -> bytes | None:
    link = s.link
    tstatus = link.tstatus if link is not None else None
    if tstatus is None:
        return None
    st = tstatus.stats
    return _LINK_NODE_STATUS_PAYLOAD(s.time_usec, 0, 0, int(tstatus.tx_rate_avg),
                                     int(tstatus.rx_rate_avg), st.rx_bad_datagrams & 0xFFFF, 0, 0,
                                     getattr(st, "tx_datagrams", 0) & 0xFFFFFFFF, st.rx_counted & 0xFFFFFFFF,
                                     st.rx_lost & 0xFFFFFFFF)
