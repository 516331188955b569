"""Event kernel and links: ordering, determinism, model statistics, counters."""

import math

import pytest

from netsim.kernel import PRIORITY_NETWORK, PRIORITY_PHYSICS, Kernel, SchedulingError, Ticker
from netsim.link import Link, LinkStats
from netsim.models import Drop, make_model, model_names
from netsim.rng import UniformStream


def test_events_run_in_time_priority_then_insertion_order():
    k = Kernel()
    out = []
    k.schedule(2.0, out.append, "c")
    k.schedule(1.0, out.append, "b2", priority=PRIORITY_NETWORK)
    k.schedule(1.0, out.append, "a", priority=PRIORITY_PHYSICS)
    k.schedule(1.0, out.append, "b3", priority=PRIORITY_NETWORK)
    k.run()
    assert out == ["a", "b2", "b3", "c"]
    assert k.now == 2.0


def test_run_until_stops_and_sets_now():
    k = Kernel()
    out = []
    k.schedule(0.5, out.append, 1)
    k.schedule(1.5, out.append, 2)
    k.run(until=1.0)
    assert out == [1] and k.now == 1.0
    assert k.peek() == 1.5
    k.run(until=2.0)
    assert out == [1, 2] and k.now == 2.0
    assert k.peek() == math.inf


def test_cancel_and_past_scheduling():
    k = Kernel()
    out = []
    ev = k.schedule(1.0, out.append, "x")
    ev.cancel()
    k.run(until=2.0)
    assert out == []
    with pytest.raises(SchedulingError):
        k.schedule(1.0, out.append, "late")
    with pytest.raises(SchedulingError):
        k.schedule(float("nan"), out.append, "nan")


def test_callbacks_can_schedule_at_now():
    k = Kernel()
    out = []

    def first():
        out.append("first")
        k.schedule(k.now, out.append, "same-time")

    k.schedule(1.0, first)
    k.schedule(1.0, out.append, "second")
    k.run()
    assert out == ["first", "second", "same-time"]


def test_ticker_does_not_drift():
    k = Kernel()
    ticks = []
    Ticker(k, 0.004, ticks.append)
    k.run(until=1000.0)
    assert len(ticks) == 250_001
    assert ticks[-1] == pytest.approx(1000.0, abs=1e-9)
    assert ticks[125_000] == 125_000 * 0.004


def _link(k, name="l", model="fixed", seed=1, fifo=False, **params):
    got = []
    link = Link(k, make_model(model, params, seed=seed, stream_name=name),
                lambda p, meta: got.append((k.now, p, meta)), name=name, fifo=fifo)
    return link, got


def test_ideal_link_delivers_immediately_with_meta():
    k = Kernel()
    link, got = _link(k, model="ideal")
    k.run(until=1.0)
    link.send(b"abc", ("127.0.0.1", 14550))
    k.run(until=1.0)
    assert got == [(1.0, b"abc", ("127.0.0.1", 14550))]
    assert link.stats.delivered == 1 and link.stats.sent == 1


def test_an_instant_delivery_is_counted_as_a_zero_latency_one():
    k = Kernel()
    link, _ = _link(k, model="ideal")
    trace = []
    link.tracer = lambda *event: trace.append(event)
    k.run(until=0.5)
    link.send(b"abcd")
    link.send(b"ef")
    expected = LinkStats(sent=2, bytes_sent=6)
    expected.record_delivery(0.0, 4)
    expected.record_delivery(0.0, 2)
    assert link.stats == expected
    assert [e[0] for e in trace] == ["send", "recv", "send", "recv"]
    assert trace[1] == ("recv", "l", 0.5, 4, "")


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_fixed_model_statistics(seed):
    k = Kernel()
    link, got = _link(k, seed=seed, latency_s=0.08, jitter_s=0.02, loss=0.2)
    n = 20_000
    for i in range(n):
        k.schedule(i * 0.001, link.send, b"x" * 10)
    k.run()
    s = link.stats
    assert s.sent == n
    assert s.delivered + s.dropped_total == n and s.in_flight == 0
    assert abs(s.dropped["loss"] / n - 0.2) < 0.015, f"seed={seed}"
    mean = s.latency_sum_s / s.delivered
    assert 0.079 < mean < 0.081, f"seed={seed}"
    assert s.latency_max_s <= 0.1 + 1e-9


def test_fifo_never_reorders():
    k = Kernel()
    link, got = _link(k, latency_s=0.05, jitter_s=0.05, fifo=True)
    for i in range(2000):
        k.schedule(i * 0.001, link.send, i.to_bytes(4, "little"))
    k.run()
    seq = [int.from_bytes(p, "little") for _, p, _ in got]
    assert seq == sorted(seq)


def test_same_seed_same_trace_other_seed_differs():
    def trace(seed):
        k = Kernel()
        events = []
        model = make_model("fixed", {"latency_s": 0.01, "jitter_s": 0.005, "loss": 0.3},
                           seed=seed, stream_name="up")
        link = Link(k, model, lambda p, m: None, name="up",
                    tracer=lambda *e: events.append(e))
        for i in range(500):
            k.schedule(i * 0.002, link.send, b"p")
        k.run()
        return events

    assert trace(7) == trace(7)
    assert trace(7) != trace(8)


def test_named_streams_are_independent():
    a1 = UniformStream(5, "vehicle1/up")
    b = UniformStream(5, "vehicle2/up")
    a2 = UniformStream(5, "vehicle1/up")
    xs = [a1.next() for _ in range(3000)]
    assert xs == [a2.next() for _ in range(3000)]
    assert xs != [b.next() for _ in range(3000)]


def test_a_sibling_stream_is_the_named_stream_of_the_same_seed():
    parent = UniformStream(5, "v1/gcs/down")
    first = parent.next()
    sibling = parent.sibling("lte/shadowing")
    reference = UniformStream(5, "lte/shadowing")
    assert [sibling.next() for _ in range(50)] == [reference.next() for _ in range(50)]
    again = UniformStream(5, "v1/gcs/down")
    assert again.next() == first and again.next() == parent.next()  # the parent is untouched


def test_bad_model_config():
    with pytest.raises(ValueError, match="unknown link model"):
        make_model("nope", {}, seed=0, stream_name="x")
    with pytest.raises(ValueError):
        make_model("fixed", {"loss": 1.5}, seed=0, stream_name="x")
    with pytest.raises(ValueError):
        make_model("fixed", {"latency_s": -1}, seed=0, stream_name="x")
    assert {"fixed", "ideal"} <= set(model_names())


def test_drop_reasons_are_counter_names():
    assert Drop.LOSS.value == "loss"


def test_latency_percentiles_from_the_histogram():
    k = Kernel()
    link, got = _link(k, latency_s=0.05, jitter_s=0.05, seed=4)
    for i in range(5000):
        k.schedule(i * 0.001, link.send, b"x")
    k.run()
    s = link.stats
    # Uniform delay on [0, 0.1] s: p50 ≈ 50 ms, p99 ≈ 99 ms, to the histogram's 25 % resolution.
    assert 0.04 <= s.latency_percentile_s(0.5) <= 0.0625
    assert 0.09 <= s.latency_percentile_s(0.99) <= 0.1
    d = s.as_dict()
    assert d["latency_p50_ms"] <= d["latency_p99_ms"] <= d["latency_max_ms"]


def test_the_horizon_hook_runs_before_the_kernel_passes_it():
    """A co-simulated network's horizon: before an event later than it, and before ``run``
    ends past it, ``on_horizon(t)`` is asked; it may put an earlier event in first."""
    k = Kernel()
    seen: list = []
    asked: list = []

    def hook(t: float) -> None:
        asked.append(t)
        if t > 0.5 and not any(name == "found" for name, _ in seen):
            k.schedule(0.25, lambda: seen.append(("found", k.now)))  # found on the way to t
            k.horizon = 0.25
        else:
            k.horizon = t

    k.on_horizon = hook
    k.schedule(0.1, lambda: seen.append(("a", k.now)))
    k.schedule(1.0, lambda: seen.append(("b", k.now)))
    k.horizon = 0.2
    k.run(until=2.0)
    assert seen == [("a", 0.1), ("found", 0.25), ("b", 1.0)]
    assert asked == [1.0, 1.0, 2.0]
    assert k.now == 2.0
    k.horizon = 2.5
    k.on_horizon = None
    k.schedule(3.0, lambda: None)
    with pytest.raises(SchedulingError, match="on_horizon"):
        k.run(until=4.0)


def _through(model) -> tuple:
    """Five packets through one link with ``model``: counters, trace, deliveries, fast path."""
    k = Kernel()
    got, trace = [], []
    link = Link(k, model, lambda p, meta: got.append((k.now, p, meta)), name="l",
                tracer=lambda *event: trace.append(event))
    for i in range(5):
        k.schedule(0.1 * i, link.send, bytes(10 + i), ("peer", i))
    k.run()
    return link.stats.as_dict(), link.stats.latency_histogram, trace, got, "send" in vars(link)


def test_an_ideal_link_counts_traces_and_delivers_as_any_link_with_no_delay():
    """An ideal link skips its model (Link._send_ideal): a zero-delay, lossless fixed model goes
    the general way, and both must leave the same counters, trace lines and deliveries."""
    ideal = _through(make_model("ideal", {}, seed=1, stream_name="l"))
    fixed = _through(make_model("fixed", {"latency_s": 0.0, "jitter_s": 0.0, "loss": 0.0},
                                seed=1, stream_name="l"))
    assert ideal[:4] == fixed[:4]
    assert (ideal[4], fixed[4]) == (True, False)  # the fast path, the general one
    assert ideal[0]["sent"] == ideal[0]["delivered"] == 5
