"""Ns3Backend against the reference engine (no ns-3 build needed): lockstep timing and
determinism, late policies under a forced-slow engine in real time, dead and hung engines."""

from __future__ import annotations

import logging
import time

import pytest

from netsim.kernel import PRIORITY_PHYSICS, Kernel, Ticker
from netsim.ns3 import DROP_BACKEND, Ns3Backend, Ns3BuildMissing, Ns3Error

SYNC_S = 0.02
LATENCY_S = 0.003


def make(kernel: Kernel, *, realtime: bool = False, late_policy: str = "drop",
         strict: bool = False, tracer=None, **reference) -> Ns3Backend:
    config = {"engine": "reference", "nodes": {"gcs": {"position": [0.0, 0.0, 0.0]}},
              "timeout_s": 2.0, "reference": {"latency_s": LATENCY_S, **reference}}
    return Ns3Backend(kernel, config, seed=7, sync_period_s=SYNC_S, late_policy=late_policy,
                      realtime=realtime, strict=strict, tracer=tracer)


class Rig:
    """One vehicle and the GCS, a telemetry-like stream each way, positions every sync period,
    and a physics ticker whose count proves the simulation kept running."""

    def __init__(self, backend: Ns3Backend, kernel: Kernel) -> None:
        self.kernel = kernel
        self.backend = backend
        self.received: list[tuple[float, bytes]] = []
        self.physics_ticks = 0
        deliver = lambda packet, meta: self.received.append((kernel.now, packet))
        self.up = backend.make_link("v1/up", "gcs", "v1", deliver)
        self.down = backend.make_link("v1/down", "v1", "gcs", deliver)
        Ticker(kernel, 0.004, self._physics, priority=PRIORITY_PHYSICS)
        Ticker(kernel, SYNC_S, lambda now: backend.update_mobility(now, {"v1": (now, 0.0, -5.0)}),
               priority=PRIORITY_PHYSICS)
        Ticker(kernel, 0.01, self._traffic, start_s=0.001)
        self.n = 0

    def _physics(self, now: float) -> None:
        self.physics_ticks += 1

    def _traffic(self, now: float) -> None:
        self.n += 1
        self.down.send(b"T%05d" % self.n)
        self.up.send(b"C%05d" % self.n)

    def check_accounting(self) -> None:
        for link in (self.up, self.down):
            s = link.stats
            assert s.sent == s.delivered + s.dropped_total + s.in_flight, s.as_dict()


@pytest.fixture
def kernel():
    return Kernel()


def run_lockstep(seed_trace: list) -> Rig:
    kernel = Kernel()
    backend = make(kernel, tracer=lambda *event: seed_trace.append(event))
    try:
        rig = Rig(backend, kernel)
        kernel.run(until=1.0)
        rig.check_accounting()
        return rig
    finally:
        backend.close()


def test_lockstep_delivers_everything_at_the_engines_time_and_is_deterministic():
    """Exact time: each datagram enters the engine at its send time and arrives at the
    engine's delivery time (no pipeline); an exchange happens only while packets travel."""
    trace_a: list = []
    trace_b: list = []
    rig = run_lockstep(trace_a)
    run_lockstep(trace_b)
    assert trace_a == trace_b and len(trace_a) > 300
    for link in (rig.up, rig.down):
        s = link.stats
        assert s.dropped_total == 0 and s.late_delivered == 0
        assert s.delivered == s.sent  # the last ones (sent at 0.991 s) arrived at 0.994 s
        # end-to-end = the engine's latency, exactly
        assert s.latency_sum_s / s.delivered == pytest.approx(LATENCY_S, abs=1e-9)
        assert s.latency_max_s == pytest.approx(LATENCY_S, abs=1e-9)
        assert s.as_dict()["net_latency_mean_ms"] == pytest.approx(LATENCY_S * 1e3)
    stats = rig.backend.backend_stats()
    assert stats["pipeline_ms"] == 0.0
    # 100 sends of two datagrams: one exchange to inject them and stop at their delivery (both
    # arrive at the same instant), one more when a physics tick falls between send and
    # delivery (the engine runs to the tick first); between deliveries and sends none.
    assert 100 <= stats["exchanges"] <= 200
    sends = [e[2] for e in trace_a if e[0] == "send"]
    recvs = [e[2] for e in trace_a if e[0] == "recv"]
    assert [round(r - s, 9) for s, r in zip(sends[::2], recvs[::2])] == [LATENCY_S] * 100


def test_lockstep_waits_for_a_slow_engine_so_nothing_is_late(kernel):
    backend = make(kernel, cycle_delay_s=0.01)
    try:
        rig = Rig(backend, kernel)
        kernel.run(until=0.3)
        assert rig.down.stats.delivered > 0
        assert rig.down.stats.dropped_total == 0 and rig.down.stats.late_delivered == 0
    finally:
        backend.close()


def paced_run(kernel: Kernel, backend: Ns3Backend, sim_s: float) -> tuple[float, float]:
    """A minimal real-time pacer (what gateway/pacer does): bring the kernel to the wall clock
    every millisecond. Returns (real-time factor, wall seconds spent inside update_mobility)."""
    spent = [0.0]
    original = backend.update_mobility

    def timed(now_s, positions):
        t = time.perf_counter()
        original(now_s, positions)
        spent[0] += time.perf_counter() - t

    backend.update_mobility = timed
    backend.start()  # init + warm-up before the clock starts, as the daemon does
    t0 = time.perf_counter()
    while kernel.now < sim_s:
        kernel.run(until=min(sim_s, time.perf_counter() - t0))
        time.sleep(0.001)
    return sim_s / (time.perf_counter() - t0), spent[0]


@pytest.mark.slow
@pytest.mark.parametrize("policy", ["drop", "deliver"])
def test_forced_slow_engine_in_real_time_makes_late_packets_and_never_stalls_physics(
        kernel, policy, caplog):
    # The engine needs 50 ms of wall time per step: it misses every exchange's wait, so the
    # backend goes over to the pipeline, and still falls behind there (20 ms cycles).
    backend = make(kernel, realtime=True, late_policy=policy, cycle_delay_s=0.05)
    try:
        rig = Rig(backend, kernel)
        rtf, blocked_s = paced_run(kernel, backend, 2.0)
        rig.check_accounting()
        down = rig.down.stats
        assert rtf >= 0.95
        assert blocked_s < 0.1  # the physics never waited for the network
        stats = backend.backend_stats()
        assert stats["replies_late"] > 0 and stats["exchanges_late"] >= 10
        assert stats["pipeline_ms"] == pytest.approx(2 * SYNC_S * 1e3)
        assert any("cannot keep up at exact time" in r.getMessage() for r in caplog.records)
        if policy == "drop":
            assert down.dropped["late"] > 0 and down.late_delivered == 0
        else:
            assert down.late_delivered > 0 and "late" not in down.dropped
        assert rig.physics_ticks >= 2.0 / 0.004
    finally:
        backend.close()


@pytest.mark.slow
def test_a_fast_engine_in_real_time_is_never_late(kernel):
    backend = make(kernel, realtime=True)
    try:
        rig = Rig(backend, kernel)
        rtf, _ = paced_run(kernel, backend, 1.0)
        assert rtf >= 0.95
        stats = backend.backend_stats()
        for s in (rig.up.stats, rig.down.stats):
            assert s.dropped_total == 0 and s.late_delivered == 0 and s.delivered > 50
            if stats["exchanges_late"] == 0:  # every reply within a sync period of wall time: exact time
                assert s.latency_sum_s / s.delivered == pytest.approx(LATENCY_S, abs=1e-9)
        assert stats["pipeline_ms"] == 0.0 and stats["exchanges"] > 100
    finally:
        backend.close()


@pytest.mark.parametrize("failure", [{"exit_at_step": 5}, {"hang_at_step": 5}])
def test_lost_engine_drops_its_packets_logs_once_and_physics_continues(kernel, caplog, failure):
    backend = make(kernel, **failure)
    backend.timeout_s = 0.3
    try:
        rig = Rig(backend, kernel)
        with caplog.at_level(logging.ERROR, logger="netsim.ns3"):
            kernel.run(until=1.0)
        rig.check_accounting()
        lost = [r for r in caplog.records if "lost" in r.getMessage()]
        assert len(lost) == 1
        assert backend.backend_stats()["cycles_lost"] == 1
        for s in (rig.up.stats, rig.down.stats):
            assert s.delivered > 0  # before the failure
            assert s.dropped[DROP_BACKEND] > 40  # everything after it
            assert s.in_flight == 0
        assert rig.physics_ticks == pytest.approx(1.0 / 0.004, abs=1)
    finally:
        backend.close()


def test_real_time_hang_is_detected_on_the_simulated_clock(kernel):
    backend = make(kernel, realtime=True, hang_at_step=3)
    backend.timeout_s = 0.2
    try:
        rig = Rig(backend, kernel)
        paced_run(kernel, backend, 0.6)
        assert backend.lost and "no reply" in backend.lost
        assert rig.down.stats.dropped[DROP_BACKEND] > 0
        rig.check_accounting()
    finally:
        backend.close()


def test_strict_raises_when_the_engine_is_lost(kernel):
    backend = make(kernel, strict=True, exit_at_step=2)
    try:
        Rig(backend, kernel)
        with pytest.raises(Ns3Error, match="lost"):
            kernel.run(until=1.0)
    finally:
        backend.close()


def test_missing_build_is_an_error_that_says_how_to_build(kernel, tmp_path):
    with pytest.raises(Ns3BuildMissing, match="make -C .*netsim/ns3` .*apt-get install libns3-dev"):
        Ns3Backend(kernel, {"binary": str(tmp_path / "cornet-ns3")})


def test_bad_config_and_late_links_are_refused(kernel):
    with pytest.raises(ValueError, match="unknown config keys"):
        Ns3Backend(kernel, {"engine": "reference", "sped": 1})
    with pytest.raises(ValueError, match="late_policy"):
        Ns3Backend(kernel, {"engine": "reference"}, late_policy="maybe")
    backend = make(kernel)
    try:
        backend.make_link("v1/down", "v1", "gcs", lambda p, m: None)
        backend.update_mobility(0.0, {"v1": (0.0, 0.0, 0.0)})
        with pytest.raises(ValueError, match="before the first sync cycle"):
            backend.make_link("v2/down", "v2", "gcs", lambda p, m: None)
    finally:
        backend.close()
