"""Counters of a running daemon in the Prometheus text format (exposition format 0.0.4).

``render(daemon)`` reads what the daemon already counts — per vehicle link: datagrams and bytes
in and out, malformed / unknown / foreign frames, frames refused by signing, datagrams dropped by
the rate limit or the kernel; per network link: sent, delivered, dropped by reason, late,
latency; the pacer: simulated seconds, slips (overruns); internal errors — and formats them.
``MetricsServer`` serves it on ``GET /metrics`` (an optional HTTP port, 127.0.0.1 by default).

Names follow Prometheus conventions: ``cornet_`` prefix, ``_total`` for counters, base units
(seconds, bytes). The real-time factor is ``rate(cornet_sim_seconds_total[1m])``; a gauge of it
over the last scrape interval is exported too, for dashboards without PromQL.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Iterable
from typing import Any

log = logging.getLogger(__name__)

CONTENT_TYPE = "text/plain; version=0.0.4; charset=utf-8"
MAX_REQUEST_BYTES = 8192
REQUEST_TIMEOUT_S = 5.0
MAX_CONNECTIONS = 16

# (SessionStats field, metric name, help) — per vehicle link, labels vehicle and link.
SESSION_COUNTERS = (
    ("rx_datagrams", "cornet_mavlink_rx_datagrams_total", "Datagrams parsed by the link."),
    ("rx_bytes", "cornet_mavlink_rx_bytes_total", "Bytes parsed by the link."),
    ("rx_frames", "cornet_mavlink_rx_frames_total", "Valid MAVLink frames received."),
    ("rx_malformed", "cornet_mavlink_rx_malformed_total",
     "Malformed input: bad CRC, garbage, truncated frames."),
    ("rx_unknown", "cornet_mavlink_rx_unknown_total", "Frames with unknown message ids."),
    ("rx_bad_datagrams", "cornet_mavlink_rx_bad_datagrams_total",
     "Datagrams with anything unusable in them (malformed or unknown)."),
    ("rx_other_target", "cornet_mavlink_rx_other_target_total",
     "Frames addressed to another system."),
    ("rx_unhandled", "cornet_mavlink_rx_unhandled_total", "Valid frames no service handles."),
    ("rx_unsigned", "cornet_mavlink_rx_unsigned_total",
     "Unsigned frames refused (signing on)."),
    ("rx_bad_signature", "cornet_mavlink_rx_bad_signature_total",
     "Frames with a bad signature refused."),
    ("rx_replayed", "cornet_mavlink_rx_replayed_total",
     "Signed frames refused as replays (old timestamp)."),
    ("rx_signed", "cornet_mavlink_rx_signed_total", "Frames with a valid signature accepted."),
    ("rx_setup_signing_refused", "cornet_mavlink_rx_setup_signing_refused_total",
     "SETUP_SIGNING messages refused (the key is the operator's)."),
    ("tx_frames", "cornet_mavlink_tx_frames_total", "MAVLink frames sent."),
    ("tx_datagrams", "cornet_mavlink_tx_datagrams_total", "Datagrams sent."),
    ("tx_bytes", "cornet_mavlink_tx_bytes_total", "Bytes sent."),
)
# (EndpointStats field, metric name, help) — per UDP port.
ENDPOINT_COUNTERS = (
    ("rx_datagrams", "cornet_udp_rx_datagrams_total", "Datagrams let in by the UDP port."),
    ("rx_rate_limited", "cornet_udp_rx_rate_limited_total",
     "Datagrams dropped by the per-source rate limit."),
    ("rx_kernel_dropped", "cornet_udp_rx_kernel_dropped_total",
     "Datagrams the kernel dropped (receive buffer full)."),
    ("tx_datagrams", "cornet_udp_tx_datagrams_total", "Datagrams sent by the UDP port."),
    ("tx_dropped", "cornet_udp_tx_dropped_total", "Sends dropped because they would block."),
    ("tx_errors", "cornet_udp_tx_errors_total", "Send errors (ICMP unreachable and the like)."),
)


def _esc(value: str) -> str:
    return value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")


def _labels(labels: dict[str, Any]) -> str:
    if not labels:
        return ""
    return "{" + ",".join(f'{k}="{_esc(str(v))}"' for k, v in labels.items()) + "}"


def _num(value: float) -> str:
    if value != value:
        return "NaN"
    if value in (float("inf"), float("-inf")):
        return "+Inf" if value > 0 else "-Inf"
    return repr(float(value)) if isinstance(value, float) else str(int(value))


class _Family:
    def __init__(self, name: str, kind: str, help_text: str) -> None:
        self.name, self.kind, self.help = name, kind, help_text
        self.samples: list[tuple[dict[str, Any], float]] = []

    def add(self, value: float, **labels: Any) -> None:
        self.samples.append((labels, value))

    def lines(self) -> Iterable[str]:
        yield f"# HELP {self.name} {self.help}"
        yield f"# TYPE {self.name} {self.kind}"
        for labels, value in self.samples:
            yield f"{self.name}{_labels(labels)} {_num(value)}"


class Exporter:
    """Formats one daemon's counters; remembers the previous scrape for the RTF gauge."""

    def __init__(self, daemon: Any, clock: Callable[[], float] = time.monotonic) -> None:
        self.daemon = daemon
        self._clock = clock
        self._prev: tuple[float, float] | None = None

    def render(self) -> str:
        d = self.daemon
        sim = d.sim
        fams: dict[str, _Family] = {}

        def fam(name: str, kind: str, help_text: str) -> _Family:
            f = fams.get(name)
            if f is None:
                f = fams[name] = _Family(name, kind, help_text)
            return f

        fam("cornet_vehicles", "gauge", "Simulated vehicles.").add(len(sim.vehicles))
        fam("cornet_sim_seconds_total", "counter",
            "Simulated seconds since start (rate() of it is the real-time factor).").add(sim.now)
        wall = self._clock()
        rtf = float("nan")
        if self._prev is not None and wall > self._prev[0]:
            rtf = (sim.now - self._prev[1]) / (wall - self._prev[0])
        self._prev = (wall, sim.now)
        fam("cornet_real_time_factor", "gauge",
            "Simulated seconds per wall second since the previous scrape.").add(rtf)
        pacer = d.pacer
        fam("cornet_pacer_slips_total", "counter",
            "Times simulated time slipped behind the wall clock (overruns).").add(pacer.slips)
        fam("cornet_pacer_slipped_seconds_total", "counter",
            "Simulated seconds given up to overruns.").add(pacer.slipped_s)
        fam("cornet_internal_errors_total", "counter",
            "Exceptions caught inside the simulation (bugs).").add(sim.internal_errors)

        for (index, kind), link in sim.links.items():
            labels = {"vehicle": index + 1, "link": kind.name.lower()}
            stats = link.session.stats
            for field, name, help_text in SESSION_COUNTERS:
                if hasattr(stats, field):
                    fam(name, "counter", help_text).add(getattr(stats, field), **labels)
            endpoint = getattr(d, "endpoints", {}).get((index, kind))
            if endpoint is not None:
                for field, name, help_text in ENDPOINT_COUNTERS:
                    fam(name, "counter", help_text).add(getattr(endpoint.stats, field), **labels)

        for name, st in sim.link_stats().items():
            labels = {"net_link": name}
            fam("cornet_net_sent_total", "counter", "Datagrams handed to the network.").add(
                st["sent"], **labels)
            fam("cornet_net_delivered_total", "counter", "Datagrams the network delivered.").add(
                st["delivered"], **labels)
            fam("cornet_net_sent_bytes_total", "counter", "Bytes handed to the network.").add(
                st["bytes_sent"], **labels)
            fam("cornet_net_in_flight", "gauge", "Datagrams in the network now.").add(
                st["in_flight"], **labels)
            dropped = fam("cornet_net_dropped_total", "counter",
                          "Datagrams the network dropped, by reason (loss, queue, range, "
                          "outage, late, backend).")
            for reason, n in sorted(st["dropped"].items()):
                dropped.add(n, **labels, reason=reason)
            fam("cornet_net_late_delivered_total", "counter",
                "Datagrams an external backend delivered late (policy deliver).").add(
                st["late_delivered"], **labels)
            lat = fam("cornet_net_latency_seconds", "gauge",
                      "One-way network latency of delivered datagrams.")
            for q, key in (("0.5", "latency_p50_ms"), ("0.99", "latency_p99_ms"),
                           ("1", "latency_max_ms")):
                lat.add(st[key] / 1e3, **labels, quantile=q)
        out: list[str] = []
        for f in fams.values():
            out.extend(f.lines())
        return "\n".join(out) + "\n"


class MetricsServer:
    """A minimal HTTP/1.0 server: ``GET /metrics`` → the exporter's text; anything else 404."""

    def __init__(self, exporter: Exporter, bind: str = "127.0.0.1", port: int = 9464) -> None:
        self.exporter = exporter
        self.bind = bind
        self.port = port
        self._server: asyncio.base_events.Server | None = None
        self._active = 0

    async def start(self) -> None:
        self._server = await asyncio.start_server(self._handle, self.bind, self.port)
        self.port = self._server.sockets[0].getsockname()[1]

    def close(self) -> None:
        if self._server is not None:
            self._server.close()
            self._server = None

    async def _handle(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        if self._active >= MAX_CONNECTIONS:
            writer.close()
            return
        self._active += 1
        try:
            head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), REQUEST_TIMEOUT_S)
            if len(head) > MAX_REQUEST_BYTES:
                raise ValueError("request too large")
            parts = head.split(b"\r\n", 1)[0].split()
            if len(parts) >= 2 and parts[0] in (b"GET", b"HEAD") and \
                    parts[1].split(b"?", 1)[0] == b"/metrics":
                body = self.exporter.render().encode()
                status, ctype = "200 OK", CONTENT_TYPE
            else:
                body, status, ctype = b"not found: try /metrics\n", "404 Not Found", "text/plain"
            head_out = (f"HTTP/1.0 {status}\r\nContent-Type: {ctype}\r\n"
                        f"Content-Length: {len(body)}\r\nConnection: close\r\n\r\n").encode()
            writer.write(head_out if parts and parts[0] == b"HEAD" else head_out + body)
            await writer.drain()
        except (asyncio.TimeoutError, asyncio.IncompleteReadError, asyncio.LimitOverrunError,
                ConnectionError, ValueError):
            pass
        except Exception:  # noqa: BLE001 - a scrape must never take the daemon down
            log.exception("metrics request failed")
        finally:
            self._active -= 1
            writer.close()
