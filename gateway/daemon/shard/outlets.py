"""--zmq-pub and --metrics-port of a sharded run: served by the coordinator for every vehicle.

ZeroMQ: a worker's Daemon publishes into a ``RelayPublisher`` — the same messages, built by the
same code (gateway/bus/zmq_pub.py), kept instead of sent — and hands them over with each sync
report (one batch per sync period). The coordinator's ``BusMerger`` publishes them on its own
socket in the schema of docs/zmq.md: ``cornet.state`` and ``cornet.links`` of one instant as
one message holding every shard's vehicles (in vehicle order), ``cornet.packet`` and
``cornet.fault`` as they come (each shard's in time order). Packet events are only built while
someone subscribes to them: the coordinator tells the workers when that changes.

Prometheus: every SNAPSHOT_PERIOD_S a worker sends its ``Exporter`` snapshot; the coordinator's
``ShardedExporter`` serves the latest of every shard as one: labelled series side by side,
unlabelled ones combined (simulated seconds and the real-time factor: the slowest shard's;
the rest summed).
"""

from __future__ import annotations

import math
from typing import Any

from prometheus_client.core import Metric

from gateway.bus.zmq_pub import TOPIC_LINKS, TOPIC_STATE, Publisher

# Unlabelled series that are not summed over shards: the run is as far as its slowest shard.
SLOWEST = ("cornet_sim_seconds_total", "cornet_real_time_factor")


class RelayPublisher(Publisher):
    """A worker's publisher: no socket; what it would publish waits for ``take``."""

    def __init__(self) -> None:  # no socket: the coordinator's is the one
        self.endpoint = "relay"
        self.sent = 0
        self.dropped = 0
        self.wants_packets = False  # the coordinator says when someone subscribes
        self._batch: list[tuple[bytes, dict]] = []

    def poll_subscriptions(self) -> None:
        pass

    def publish(self, topic: bytes, body: dict) -> None:
        self._batch.append((topic, body))
        self.sent += 1

    def take(self) -> list[tuple[bytes, dict]]:
        batch, self._batch = self._batch, []
        return batch

    def close(self) -> None:
        pass


class BusMerger:
    """The coordinator's side: the shards' batches published as one daemon publishes."""

    def __init__(self, publisher: Publisher, shards: int) -> None:
        self.publisher = publisher
        self.shards = shards
        self._parts: dict[tuple[bytes, float], dict[int, dict]] = {}
        self.wants_packets = False

    def take(self, shard: int, batch: list[tuple[bytes, dict]]) -> None:
        for topic, body in batch:
            if topic not in (TOPIC_STATE, TOPIC_LINKS):
                self.publisher.publish(topic, body)
                continue
            parts = self._parts.setdefault((topic, body["t"]), {})
            parts[shard] = body
            if len(parts) == self.shards:
                del self._parts[(topic, body["t"])]
                self.publisher.publish(topic, _merged(topic, [parts[k] for k in sorted(parts)]))

    def subscriptions_changed(self) -> bool:
        """Read the subscribers' notices; True when packet events are now wanted or no more."""
        self.publisher.poll_subscriptions()
        if self.publisher.wants_packets == self.wants_packets:
            return False
        self.wants_packets = self.publisher.wants_packets
        return True


def _merged(topic: bytes, bodies: list[dict]) -> dict:
    out = dict(bodies[0])
    if topic == TOPIC_STATE:
        out["vehicles"] = [v for body in bodies for v in body["vehicles"]]
    else:
        out["links"] = {name: st for body in bodies for name, st in body["links"].items()}
    return out


class ShardedExporter:
    """``Exporter``'s interface for ``MetricsServer``, over the shards' latest snapshots."""

    def __init__(self) -> None:
        self.latest: dict[int, list[Metric]] = {}

    def take(self, shard: int, snapshot: list[Metric]) -> None:
        self.latest[shard] = snapshot

    def snapshot(self) -> list[Metric]:
        families: dict[str, Metric] = {}
        values: dict[str, dict[tuple, Any]] = {}
        for shard in sorted(self.latest):
            for metric in self.latest[shard]:
                if metric.name not in families:
                    families[metric.name] = Metric(metric.name, metric.documentation,
                                                   metric.type, metric.unit)
                    values[metric.name] = {}
                series = values[metric.name]
                for sample in metric.samples:
                    key = (sample.name, tuple(sorted(sample.labels.items())))
                    before = series.get(key)
                    series[key] = sample if before is None else before._replace(
                        value=_combine(sample.name, before.value, sample.value))
        for name, metric in families.items():
            metric.samples = list(values[name].values())
        return list(families.values())


def _combine(name: str, a: float, b: float) -> float:
    if name in SLOWEST:
        return b if math.isnan(a) else a if math.isnan(b) else min(a, b)
    return a + b
