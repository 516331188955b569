"""PING and TIMESYNC responders (PX4 mavlink_receiver.cpp handle_message_ping, MavlinkTimesync).

- PING with target 0/0 is a request: answer with the same time_usec/seq, target = sender.
  A PING addressed to this vehicle answers its own PING stream (telemetry_link.py): counted
  (``rx_ping_replies``, what PX4 keeps as its ping statistics); others' replies are ignored.
- TIMESYNC with tc1 == 0 is a request: answer tc1 = our clock (simulated ns since boot),
  ts1 echoed. tc1 > 0 is a reply to the link's own requests: a sample of the client's clock
  for the link's ``Timesync`` (timesync.py); a negative tc1 is nothing.
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.link import LinkContext
from gateway.mavlink.timesync import Timesync


class PingService:
    """Uses the context's encoder, send and stats only, and the link's ``timesync``."""

    def __init__(self, ctx: LinkContext, timesync: Timesync) -> None:
        self.encoder = ctx.encoder
        self.send = ctx.send
        self.stats = ctx.stats
        self.timesync = timesync

    def on_ping(self, msg: M.MAVLink_ping_message, now_s: float) -> None:
        if msg.target_system != 0 or msg.target_component != 0:
            if msg.target_system == self.encoder.sysid \
                    and msg.target_component == self.encoder.compid:
                self.stats.rx_ping_replies += 1
            return
        self.send(self.encoder.pack(M.MAVLink_ping_message, msg.time_usec, msg.seq,
                                    msg.get_srcSystem(), msg.get_srcComponent()))

    def on_timesync(self, msg: M.MAVLink_timesync_message, now_s: float) -> None:
        if msg.tc1 != 0:
            if msg.tc1 > 0:
                self.timesync.update(round(now_s * 1e6), msg.tc1, msg.ts1)
            return
        # pymavlink 2.4.50's TIMESYNC has no target fields (added to common.xml later).
        self.send(self.encoder.pack(M.MAVLink_timesync_message, int(now_s * 1e9), msg.ts1))
