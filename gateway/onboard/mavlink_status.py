"""pxh's ``mavlink`` command for a vehicle's links: ``status`` (Mavlink::display_status for
every instance), ``status streams`` (display_status_streams) and ``stream -u PORT -s NAME -r
RATE`` (Mavlink::stream_command), from PX4's src/modules/mavlink/mavlink_main.cpp.

Rules:
- Instance k is the vehicle's k-th link (PX4 SITL's GCS link, then the API link, then extra
  radios). ``transport()`` gives its UDP ports and whether it broadcasts; None where there are
  no sockets (the lockstep simulation), and then no transport lines are printed.
- Rates are telemetry_status's: bytes over the link's last window of more than 1 s
  (gateway/mavlink/link_status.py); the stream rate multiplier is 1 (SITL's 4 MB/s never
  throttles).
- rx loss: rx_message_lost_rate, MavlinkReceiver's sequence gaps over the messages it counted
  (lost / received: its first 16 senders), printed as display_status prints it: the fraction
  itself before the % sign (0.1% for one message in ten lost).
"""

from __future__ import annotations

import ipaddress
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20 import development as M  # common's messages and CURRENT_MODE

from gateway.mavlink.link import DATARATE_B_S, LinkKind
from gateway.mavlink.log_streaming import MAX_RATE_FACTOR
from gateway.mavlink.streams import STREAMS
from vehicles.cnum import f32

NON_PAYLOAD_BYTES = 12  # MAVLINK_NUM_NON_PAYLOAD_BYTES (MAVLink 2, unsigned)
USAGE = ("\n### Description\nThis module implements the MAVLink protocol, which can be used on a "
         "Serial link or UDP network connection.\n\nUsage: mavlink <command> [arguments...]\n"
         " Commands:\n   status        Print status for all instances\n     [streams]   Print "
         "all enabled streams\n\n   stream        Configure the sending rate of a stream for a "
         "running instance\n     [-u <val>]  Select Mavlink instance via local Network Port\n"
         "     -s <val>    Mavlink stream to configure\n     -r <val>    Rate in Hz (0 = turn "
         "off, -1 = set to default)\n")
_BY_NAME = {M.mavlink_map[spec.msg_id].msgname: spec.msg_id for spec in STREAMS}

Transport = Callable[[], "tuple[int, int, bool] | None"]  # (local port, remote port, broadcast)


@dataclass
class Instance:
    session: Any  # gateway.mavlink.session.Session
    transport: Transport


def status(instances: Sequence[Instance], now_s: float, streams: bool) -> str:
    out = []
    for k, inst in enumerate(instances):
        out.append(f"\ninstance #{k}:\n")
        out.append(_streams(inst) if streams else _status(k, inst, now_s))
    return "".join(out)


def _status(k: int, inst: Instance, now_s: float) -> str:
    s = inst.session
    st = s.stats
    tx, rx = s.tstatus.tx_rate_avg, s.tstatus.rx_rate_avg
    # rx_message_lost_rate = lost / received, set at each read: 0 before any, and 0/0 (x86's
    # -nan) while nothing parsed
    if not st.rx_datagrams:
        loss_text = "0.0"
    elif not st.rx_counted:
        loss_text = "-nan"
    else:
        loss_text = f"{f32(st.rx_lost / st.rx_counted):.1f}"
    lines = ["\tGCS heartbeat valid\n"] if s.gcs_present(now_s) else []
    lines += [f"\tmavlink chan: #{k}\n", "\ttype:\t\tGENERIC LINK OR RADIO\n",
              "\tflow control: OFF\n", "\trates:\n", f"\t  tx: {tx:.1f} B/s\n",
              "\t  txerr: 0.0 B/s\n", "\t  tx rate mult: 1.000\n",
              f"\t  tx rate max: {DATARATE_B_S} B/s\n", f"\t  rx: {rx:.1f} B/s\n",
              f"\t  rx loss: {loss_text}%\n", "\tFTP enabled: YES, TX enabled: YES\n",
              f"\tmode: {'Onboard' if s.kind is LinkKind.API else 'Normal'}\n",
              "\tMAVLink version: 2\n"]
    transport = inst.transport()
    if transport is not None:
        local, remote, broadcast = transport
        lines += [f"\ttransport protocol: UDP ({local}, remote port: {remote})\n",
                  f"\tBroadcast enabled: {'YES' if broadcast else 'NO'}\n"]
        peer = s.peer
        if isinstance(peer, tuple) and peer and _is_ip(peer[0]):
            lines.append(f"\tpartner IP: {peer[0]}\n")
    stream = s.log_streaming
    if stream.active:  # this link streams the ULog (MavlinkULog's rates)
        lines.append(f"\tULog rate: {100 * stream.current_rate_factor:.1f}% of max "
                     f"{100 * MAX_RATE_FACTOR:.1f}%\n")
    return "".join(lines)


def _is_ip(host: object) -> bool:
    if not isinstance(host, str):
        return False
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


def _streams(inst: Instance) -> str:
    scheduler = inst.session.scheduler
    lines = [f"\t{'Name':<20}{'Rate Config (current) [Hz]':<16} Message Size (if active) [B]\n"]
    for spec in STREAMS:
        interval = scheduler.interval_us(spec.msg_id)
        if interval == 0:  # no such stream on this link
            continue
        cls = M.mavlink_map[spec.msg_id]
        if interval < 0:
            rate_str = "unlimited"
        else:
            rate = 1e6 / interval
            rate_str = f"{rate:6.2f} ({rate:.3f})"
        # A stream whose get_size() is 0 (no topic advertised; AVAILABLE_MODES before a change
        # of the mode list): no size printed
        size = "" if spec.silent else f" {cls.unpacker.size + NON_PAYLOAD_BYTES:3d}"
        lines.append(f"\t{cls.msgname:<30}{rate_str:<16}{size}\n")
    return "".join(lines)


def stream(instances: Sequence[Instance], args: Sequence[str], now_s: float) -> tuple[int, str]:
    """``mavlink stream -u PORT -s NAME -r RATE``: (return code, what it prints)."""
    rate, name, port = -1.0, None, None
    i = 0
    try:
        while i < len(args):
            if args[i] == "-r" and i + 1 < len(args):
                rate = float(args[i + 1])
                if rate < 0.0:
                    raise ValueError
            elif args[i] == "-s" and i + 1 < len(args):
                name = args[i + 1]
            elif args[i] == "-u" and i + 1 < len(args):
                port = int(args[i + 1])
            else:
                raise ValueError
            i += 2
    except ValueError:
        name = None
    if name is None:
        return 1, USAGE
    inst = next((x for x in instances if (t := x.transport()) is not None and t[0] == port),
                None)
    if inst is None:
        return 1, f"WARN  [mavlink] mavlink for network on port {port} is not running\n"
    msg_id = _BY_NAME.get(name)
    if msg_id is not None:  # configure_stream: an unknown name changes nothing
        interval_us = -1.0 if rate == 0.0 else 0.0 if rate == -1.0 else 1e6 / rate
        inst.session.scheduler.set_interval(msg_id, interval_us, now_s)
    return 0, ""
