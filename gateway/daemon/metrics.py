"""Counters of a running daemon for Prometheus, served by prometheus_client.

``Exporter.snapshot()`` reads, on the event loop, what the daemon already counts — per vehicle
link: datagrams and bytes in and out, malformed / unknown / foreign frames, frames refused by
signing, datagrams dropped by the rate limit or the kernel; per network link: sent, delivered,
dropped by reason, late, latency; the pacer: simulated seconds, slips (overruns); internal
errors — as prometheus_client metric families. ``MetricsServer`` refreshes that snapshot every
SNAPSHOT_PERIOD_S and serves the latest one with prometheus_client's WSGI application on the
standard library's threaded WSGI server: a scrape never touches the simulation, and a slow or
stuck client only holds its own thread until REQUEST_TIMEOUT_S.

Names follow Prometheus conventions: ``cornet_`` prefix, ``_total`` for counters, base units
(seconds, bytes). The real-time factor is ``rate(cornet_sim_seconds_total[1m])``; a gauge of it
over the last snapshot interval is exported too, for dashboards without PromQL.
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from collections.abc import Callable, Iterable
from socketserver import ThreadingMixIn
from typing import Any, Protocol
from wsgiref.simple_server import WSGIRequestHandler, WSGIServer, make_server

from prometheus_client import CollectorRegistry, make_wsgi_app
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, Metric
from prometheus_client.registry import Collector

from gateway.sim.radios import tag_name

log = logging.getLogger(__name__)

SNAPSHOT_PERIOD_S = 1.0  # wall seconds between two snapshots of the counters
REQUEST_TIMEOUT_S = 5.0  # a client that sends nothing for this long is dropped

# (SessionStats field, metric name, help) — per vehicle link, labels vehicle and link.
SESSION_COUNTERS = (
    ("rx_datagrams", "cornet_mavlink_rx_datagrams_total", "Datagrams parsed by the link."),
    ("rx_bytes", "cornet_mavlink_rx_bytes_total", "Bytes parsed by the link."),
    ("rx_frames", "cornet_mavlink_rx_frames_total", "Valid MAVLink frames received."),
    ("rx_malformed", "cornet_mavlink_rx_malformed_total",
     "Malformed input: bad CRC, garbage, truncated frames."),
    ("rx_unknown", "cornet_mavlink_rx_unknown_total", "Frames with unknown message ids."),
    ("rx_lost", "cornet_mavlink_rx_lost_total",
     "Frames missing from the senders' sequence numbers (MAVLink's loss count)."),
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
    ("rx_ping_replies", "cornet_mavlink_rx_ping_replies_total",
     "Answers to the vehicle's own PING requests."),
    ("tx_frames", "cornet_mavlink_tx_frames_total", "MAVLink frames sent."),
    ("tx_datagrams", "cornet_mavlink_tx_datagrams_total", "Datagrams sent."),
    ("tx_bytes", "cornet_mavlink_tx_bytes_total", "Bytes sent."),
)
# (EndpointStats field, metric name, help) — per UDP port.
ENDPOINT_COUNTERS = (
    ("rx_datagrams", "cornet_udp_rx_datagrams_total", "Datagrams let in by the UDP port."),
    ("rx_rate_limited", "cornet_udp_rx_rate_limited_total",
     "Datagrams shed by admission (source, host or port budget)."),
    ("rx_kernel_dropped", "cornet_udp_rx_kernel_dropped_total",
     "Datagrams the kernel dropped (receive buffer full)."),
    ("tx_datagrams", "cornet_udp_tx_datagrams_total", "Datagrams sent by the UDP port."),
    ("tx_dropped", "cornet_udp_tx_dropped_total", "Sends dropped because they would block."),
    ("tx_errors", "cornet_udp_tx_errors_total", "Send errors (ICMP unreachable and the like)."),
)



class _Families:
    """Metric families by name, built in the order they are first touched."""

    def __init__(self) -> None:
        self.by_name: dict[str, Metric] = {}
        self._counters: dict[str, CounterMetricFamily] = {}
        self._gauges: dict[str, GaugeMetricFamily] = {}

    def counter(self, name: str, help_text: str, labels: Iterable[str] = ()) -> CounterMetricFamily:
        fam = self._counters.get(name)
        if fam is None:
            fam = self._counters[name] = CounterMetricFamily(name, help_text, labels=list(labels))
            self.by_name[name] = fam
        return fam

    def gauge(self, name: str, help_text: str, labels: Iterable[str] = ()) -> GaugeMetricFamily:
        fam = self._gauges.get(name)
        if fam is None:
            fam = self._gauges[name] = GaugeMetricFamily(name, help_text, labels=list(labels))
            self.by_name[name] = fam
        return fam


class Exporter:
    """Builds snapshots of one daemon's counters; remembers the previous one for the RTF gauge."""

    def __init__(self, daemon: Any, clock: Callable[[], float] = time.monotonic) -> None:
        self.daemon = daemon
        self._clock = clock
        self._prev: tuple[float, float] | None = None

    def snapshot(self) -> list[Metric]:
        d = self.daemon
        sim = d.sim
        f = _Families()
        f.gauge("cornet_vehicles", "Simulated vehicles.").add_metric([], len(sim.vehicles))
        f.counter("cornet_sim_seconds_total",
                  "Simulated seconds since start (rate() of it is the real-time factor)."
                  ).add_metric([], sim.now)
        wall = self._clock()
        rtf = float("nan")
        if self._prev is not None and wall > self._prev[0]:
            rtf = (sim.now - self._prev[1]) / (wall - self._prev[0])
        self._prev = (wall, sim.now)
        f.gauge("cornet_real_time_factor",
                "Simulated seconds per wall second over the last snapshot interval."
                ).add_metric([], rtf)
        pacer = d.pacer
        f.counter("cornet_pacer_slips_total",
                  "Times simulated time slipped behind the wall clock (overruns)."
                  ).add_metric([], pacer.slips)
        f.counter("cornet_pacer_slipped_seconds_total",
                  "Simulated seconds given up to overruns.").add_metric([], pacer.slipped_s)
        f.counter("cornet_internal_errors_total",
                  "Exceptions caught inside the simulation (bugs).").add_metric([],
                                                                             sim.internal_errors)
        link_labels = ("vehicle", "link")
        for (index, kind), link in sim.links.items():
            values = [str(index + 1), tag_name(kind)]
            stats = link.session.stats
            for field, name, help_text in SESSION_COUNTERS:
                if hasattr(stats, field):
                    f.counter(name, help_text, link_labels).add_metric(values, getattr(stats, field))
            endpoint = getattr(d, "endpoints", {}).get((index, kind))
            if endpoint is not None:
                for field, name, help_text in ENDPOINT_COUNTERS:
                    f.counter(name, help_text, link_labels).add_metric(
                        values, getattr(endpoint.stats, field))
                admission = getattr(endpoint, "admission", None)
                if admission is not None:
                    shed = f.counter("cornet_udp_rx_shed_total",
                                     "Datagrams shed by admission, by the budget that refused "
                                     "them (source, host, port).", link_labels + ("budget",))
                    for budget in ("source", "host", "port"):
                        shed.add_metric(values + [budget],
                                        getattr(admission.stats, f"shed_{budget}"))
        net = ("net_link",)
        for name, st in sim.link_stats().items():
            f.counter("cornet_net_sent_total", "Datagrams handed to the network.", net
                      ).add_metric([name], st["sent"])
            f.counter("cornet_net_delivered_total", "Datagrams the network delivered.", net
                      ).add_metric([name], st["delivered"])
            f.counter("cornet_net_sent_bytes_total", "Bytes handed to the network.", net
                      ).add_metric([name], st["bytes_sent"])
            f.gauge("cornet_net_in_flight", "Datagrams in the network now.", net
                    ).add_metric([name], st["in_flight"])
            dropped = f.counter("cornet_net_dropped_total",
                                "Datagrams the network dropped, by reason (loss, queue, range, "
                                "outage, late, backend).", ("net_link", "reason"))
            for reason, n in sorted(st["dropped"].items()):
                dropped.add_metric([name, reason], n)
            f.counter("cornet_net_late_delivered_total",
                      "Datagrams an external backend delivered late (policy deliver).", net
                      ).add_metric([name], st["late_delivered"])
            lat = f.gauge("cornet_net_latency_seconds",
                          "One-way network latency of delivered datagrams.",
                          ("net_link", "quantile"))
            for q, key in (("0.5", "latency_p50_ms"), ("0.99", "latency_p99_ms"),
                           ("1", "latency_max_ms")):
                lat.add_metric([name, q], st[key] / 1e3)
        return list(f.by_name.values())


class Snapshots(Protocol):
    """What a MetricsServer serves: ``Exporter``, or a sharded run's (gateway/daemon/shard/)."""

    def snapshot(self) -> list[Metric]: ...


class _Snapshot(Collector):
    """What a scrape returns: the latest snapshot, swapped in whole (no lock needed)."""

    def __init__(self) -> None:
        self.metrics: list[Metric] = []

    def collect(self) -> Iterable[Metric]:
        return self.metrics


class _Server(ThreadingMixIn, WSGIServer):
    daemon_threads = True  # a stuck scrape never keeps the process alive


class _QuietHandler(WSGIRequestHandler):
    timeout = REQUEST_TIMEOUT_S  # socket time-out of each connection

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (the base's name)
        pass


class MetricsServer:
    """``GET /metrics`` on ``bind:port`` (0: any free port) from a snapshot refreshed on the
    event loop; prometheus_client's exposition, served by a thread per request."""

    def __init__(self, exporter: Snapshots, bind: str = "127.0.0.1", port: int = 9464) -> None:
        self.exporter = exporter
        self.bind = bind
        self.port = port
        self._snapshot = _Snapshot()
        registry = CollectorRegistry(auto_describe=False)
        registry.register(self._snapshot)
        self._app = make_wsgi_app(registry)
        self._server: _Server | None = None
        self._thread: threading.Thread | None = None
        self._refresh_task: asyncio.Task | None = None

    def refresh(self) -> None:
        self._snapshot.metrics = self.exporter.snapshot()

    async def start(self) -> None:
        """Bind (OSError if the port is taken), take a first snapshot, serve."""
        self._server = make_server(self.bind, self.port, self._app, server_class=_Server,
                                   handler_class=_QuietHandler)
        self.port = self._server.server_address[1]
        self.refresh()
        self._thread = threading.Thread(target=self._server.serve_forever, name="cornet-metrics",
                                        daemon=True)
        self._thread.start()
        self._refresh_task = asyncio.create_task(self._refresh_forever(), name="metrics")

    async def _refresh_forever(self) -> None:
        while True:
            await asyncio.sleep(SNAPSHOT_PERIOD_S)
            try:
                self.refresh()
            except Exception:  # noqa: BLE001 - metrics must never take the daemon down
                log.exception("metrics snapshot failed")

    def close(self) -> None:
        if self._refresh_task is not None:
            self._refresh_task.cancel()
            self._refresh_task = None
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
            self._server = None
        if self._thread is not None:
            self._thread.join(timeout=2)
            self._thread = None
