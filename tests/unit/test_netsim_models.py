"""Link models against theory: burst (Gilbert–Elliott), queue, wireless, outage; determinism."""

import math

import pytest

from netsim.backend import Mobility
from netsim.kernel import Kernel
from netsim.link import Link
from netsim.models import Drop, make_model, model_names
from netsim.models.wireless import MCS_TABLE

SEED = 11


def _model(name, seed=SEED, stream="l", **params):
    return make_model(name, params, seed=seed, stream_name=stream)


def _radio(distance_m, seed=SEED, stream="radio", **params):
    mobility = Mobility({"a": (0.0, 0.0, 0.0), "b": (distance_m, 0.0, 0.0)})
    model = make_model("wireless", params, seed=seed, stream_name=stream, mobility=mobility,
                       src="a", dst="b")
    return model, mobility


def test_all_models_registered():
    assert {"ideal", "fixed", "burst", "queue", "wireless", "outage"} <= set(model_names())


# --- burst ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", [1, 2])
@pytest.mark.parametrize("p_gb, p_bg, loss_good, loss_bad", [
    (0.02, 0.25, 0.0, 1.0),
    (0.05, 0.10, 0.01, 0.6),
    (0.30, 0.30, 0.1, 0.9),
])
def test_burst_stationary_loss_matches_theory(seed, p_gb, p_bg, loss_good, loss_bad):
    model = _model("burst", seed=seed, p_good_to_bad=p_gb, p_bad_to_good=p_bg,
                   loss_good=loss_good, loss_bad=loss_bad)
    pi_bad = p_gb / (p_gb + p_bg)
    expected = (1 - pi_bad) * loss_good + pi_bad * loss_bad
    assert model.stationary_loss() == pytest.approx(expected)
    n = 60_000
    lost = sum(model.transit(50, 0.0) is Drop.LOSS for _ in range(n))
    # Losses are correlated: allow a few times the binomial standard error.
    assert abs(lost / n - expected) < 0.012, f"seed={seed}"


def test_burst_lengths_are_geometric_in_packets():
    # Bad state loses everything, good state nothing: runs of losses are the Bad sojourns,
    # mean 1 / p_bad_to_good packets.
    model = _model("burst", p_good_to_bad=0.05, p_bad_to_good=0.2, loss_good=0.0, loss_bad=1.0)
    runs, run = [], 0
    for _ in range(100_000):
        if model.transit(10, 0.0) is Drop.LOSS:
            run += 1
        elif run:
            runs.append(run)
            run = 0
    assert sum(runs) / len(runs) == pytest.approx(1 / 0.2, rel=0.05)


def test_burst_delay_and_no_loss_when_never_bad():
    model = _model("burst", p_good_to_bad=0.0, p_bad_to_good=1.0, latency_s=0.02,
                   jitter_s=0.005)
    delays = [model.transit(10, 0.0) for _ in range(5000)]
    assert all(0.015 <= d <= 0.025 for d in delays)
    assert sum(delays) / len(delays) == pytest.approx(0.02, abs=3e-4)


# --- queue ---------------------------------------------------------------------------------------

def test_queue_serialization_delays_add_up_back_to_back():
    model = _model("queue", rate_bps=1e6, queue_packets=10, latency_s=0.003)
    # 1000 bytes at 1 Mbit/s = 8 ms each; sent together, the n-th waits for n-1 before it.
    delays = [model.transit(1000, 0.0) for _ in range(4)]
    assert delays == pytest.approx([0.011, 0.019, 0.027, 0.035])
    # Once the backlog is gone a packet only pays its own serialization.
    assert model.transit(500, 1.0) == pytest.approx(0.004 + 0.003)


def test_queue_drop_tail_at_overload_counts():
    k = Kernel()
    model = _model("queue", rate_bps=80_000, queue_packets=5)  # 100 B = 10 ms
    link = Link(k, model, lambda p, m: None, name="q")
    for _ in range(20):
        link.send(b"x" * 100)
    assert link.stats.dropped["queue"] == 15
    k.run()
    assert link.stats.delivered == 5
    # Steady overload at twice the rate for 10 s: the link carries its capacity, the rest drops.
    k2 = Kernel()
    link2 = Link(k2, _model("queue", rate_bps=80_000, queue_packets=5), lambda p, m: None,
                 name="q2")
    for i in range(2000):
        k2.schedule(i * 0.005, link2.send, b"x" * 100)
    k2.run()
    s = link2.stats
    assert s.delivered + s.dropped["queue"] == 2000
    assert abs(s.delivered - 1000) <= 6  # 10 s of 10 ms slots, plus the queue's 5
    assert s.latency_max_s == pytest.approx(0.05, abs=1e-9)  # 5 packets ahead at most


def test_queue_byte_limit_and_validation():
    model = _model("queue", rate_bps=8_000, queue_bytes=250)  # 1 ms per byte
    assert [model.transit(100, 0.0) for _ in range(3)][:2] == pytest.approx([0.1, 0.2])
    assert model.transit(100, 0.0) is Drop.QUEUE
    assert model.backlog(0.15) == (1, 100)
    with pytest.raises(ValueError, match="rate_bps"):
        _model("queue")
    with pytest.raises(ValueError, match="rate_bps"):
        _model("queue", rate_bps=0)
    with pytest.raises(ValueError, match="queue_packets"):
        _model("queue", rate_bps=1e6, queue_packets=0)
    with pytest.raises(ValueError, match="queue_bytes"):
        _model("queue", rate_bps=1e6, queue_bytes=-5)
    with pytest.raises(ValueError, match="latency_s"):
        _model("queue", rate_bps=1e6, latency_s=-1)


# --- wireless ------------------------------------------------------------------------------------

DISTANCES_M = [10, 25, 50, 100, 150, 200, 250, 300]


def _profile(distance_m, n, seed, size=100, **params):
    model, _ = _radio(distance_m, seed=seed, **params)
    delivered, latency_sum, reasons = 0, 0.0, {}
    for i in range(n):
        v = model.transit(size, i * 0.01)
        if isinstance(v, Drop):
            reasons[v] = reasons.get(v, 0) + 1
        else:
            delivered += 1
            latency_sum += v
    mean = latency_sum / delivered if delivered else math.inf
    return (n - delivered) / n, mean, reasons


@pytest.mark.parametrize("seed", [3, 4])
def test_wireless_latency_and_loss_rise_with_distance(seed):
    # The same stream at every distance (common random numbers): a farther hop sees the same
    # fades, so it is worse packet by packet, and the trend is not hidden by sampling noise.
    rows = [_profile(d, 4000, seed) for d in DISTANCES_M]
    losses = [r[0] for r in rows]
    means = [r[1] for r in rows]
    for i in range(len(rows) - 1):
        assert losses[i + 1] >= losses[i], f"seed={seed} loss {losses}"
        assert means[i + 1] >= means[i], f"seed={seed} latency {means}"
    assert losses[0] == 0.0 and losses[-1] > 0.3  # small near the AP, large near 300 m
    assert means[-1] > 2 * means[0]  # retries: the paper's Fig. 6 trend
    assert all(set(r[2]) <= {Drop.LOSS} for r in rows)


def test_wireless_range_limit_and_sensitivity():
    loss, _, reasons = _profile(150, 200, SEED, range_m=120.0)
    assert loss == 1.0 and reasons == {Drop.RANGE: 200}
    # Default detection threshold −101 dBm: mean SNR 75 − 30·log10(d) < −6 dB beyond ~501 m.
    assert _profile(520, 100, SEED)[2] == {Drop.RANGE: 100}
    assert Drop.RANGE not in _profile(480, 100, SEED)[2]


def test_wireless_follows_mobility_updates():
    model, mobility = _radio(10.0)
    assert all(not isinstance(model.transit(100, 0.0), Drop) for _ in range(200))
    mobility.update(1.0, {"b": (2000.0, 0.0, 0.0)})
    assert model.transit(100, 1.0) is Drop.RANGE
    mobility.update(2.0, {"b": (0.0, 0.0, 0.0)})  # on top of it: clamped to min_distance_m
    assert model.mean_snr_db(0.0) == pytest.approx(75.0)
    assert not isinstance(model.transit(100, 2.0), Drop)


def test_wireless_floor_latency_is_one_clean_attempt():
    model, _ = _radio(10.0, shadowing_sigma_db=0.0)
    delays = [model.transit(100, 0.0) for _ in range(4000)]
    # DIFS 28 + airtime(166 B at MCS 0: 36 + 52·4 + 6) + SIFS 10 + ACK 50 µs, + 0..15 slots.
    floor = 28e-6 + 250e-6 + 10e-6 + 50e-6
    assert min(delays) >= floor and max(delays) <= floor + 15 * 9e-6 + 1e-6
    assert sum(delays) / len(delays) == pytest.approx(floor + 7.5 * 9e-6, abs=3e-6)


def test_wireless_per_and_airtime_by_mcs():
    model0, _ = _radio(10.0, mcs=0)
    model7, _ = _radio(10.0, mcs=7)
    assert model7.airtime_s(1000) < model0.airtime_s(1000) / 5
    # Higher MCS needs more SNR; bigger frames fail more often.
    snr10_0 = next(s / 10 for s in range(-100, 400) if model0.packet_error_rate(s / 10, 100) < 0.1)
    snr10_7 = next(s / 10 for s in range(-100, 400) if model7.packet_error_rate(s / 10, 100) < 0.1)
    assert 2.0 < snr10_0 < 6.0 and 20.0 < snr10_7 < 26.0
    assert model0.packet_error_rate(3.0, 1000) > model0.packet_error_rate(3.0, 50)
    assert set(MCS_TABLE) == set(range(8))


@pytest.mark.parametrize("param, value", [
    ("path_loss_exponent", 0.5), ("ref_distance_m", 0.0), ("shadowing_sigma_db", -1.0),
    ("mcs", 8), ("retry_limit", -1), ("range_m", 0.0), ("latency_s", -0.1),
    ("tx_power_dbm", math.nan), ("cw_max", 3),
])
def test_wireless_validation_names_the_parameter(param, value):
    with pytest.raises(ValueError, match=param):
        _radio(10.0, **{param: value})


def test_wireless_needs_positions():
    with pytest.raises(ValueError, match="positional"):
        make_model("wireless", {}, seed=0, stream_name="x")


# --- outage --------------------------------------------------------------------------------------

def test_outage_windows_are_exact():
    model = _model("outage", windows_s=[[10.0, 2.5], [30.0, 1.0], [30.5, 1.0]])
    assert model.transit(10, 9.999999) == 0.0
    assert model.transit(10, 10.0) is Drop.OUTAGE
    assert model.transit(10, 12.499999) is Drop.OUTAGE
    assert model.transit(10, 12.5) == 0.0
    assert model.transit(10, 30.9) is Drop.OUTAGE  # overlapping windows merge
    assert model.transit(10, 31.4999) is Drop.OUTAGE
    assert model.transit(10, 31.5) == 0.0
    assert model.spans == [(10.0, 12.5), (30.0, 31.5)]
    assert _model("outage").transit(10, 0.0) == 0.0


def test_outage_on_a_link_counts_outage_drops():
    k = Kernel()
    link = Link(k, _model("outage", windows_s=[[1.0, 0.5]]), lambda p, m: None, name="o")
    for i in range(300):
        k.schedule(i * 0.01, link.send, b"x")
    k.run()
    assert link.stats.dropped == {"outage": 50}
    assert link.stats.delivered == 250


def test_outage_loss_and_latency_windows():
    """A window with a loss below 1 drops that share of its packets (Drop.LOSS, the model's own
    stream, drawn only in the window); one with a delay adds it; blackouts still win."""
    model = _model("outage", windows_s=[[1.0, 10.0, 0.25, 0.0], [20.0, 5.0, 0.0, 0.3],
                                        [22.0, 1.0]])
    times = [1.0 + i * 0.001 for i in range(10_000)]
    drops = sum(model.transit(10, t) is Drop.LOSS for t in times)
    assert 2300 < drops < 2700
    assert model.transit(10, 0.5) == 0.0 and model.transit(10, 11.0) == 0.0
    assert model.transit(10, 20.0) == pytest.approx(0.3)
    assert model.transit(10, 22.5) is Drop.OUTAGE
    a, b = (_model("outage", windows_s=[[1.0, 10.0, 0.25, 0.0]]) for _ in range(2))
    assert [a.transit(10, t) for t in times[:500]] == [b.transit(10, t) for t in times[:500]]


@pytest.mark.parametrize("windows", [[[1.0]], [[-1.0, 2.0]], [[1.0, 0.0]], [["a", 1]],
                                     [[1.0, 1.0, 1.5, 0.0]], [[1.0, 1.0, 0.5, -1.0]],
                                     [[1.0, 1.0, 0.5]]])
def test_outage_validation(windows):
    with pytest.raises(ValueError, match=r"windows_s\[0\]"):
        _model("outage", windows_s=windows)


@pytest.mark.parametrize("param, value", [
    ("p_good_to_bad", 1.5), ("p_bad_to_good", -0.1), ("loss_good", 2.0), ("loss_bad", math.nan),
    ("latency_s", -1.0), ("jitter_s", -1.0),
])
def test_burst_validation_names_the_parameter(param, value):
    with pytest.raises(ValueError, match=param):
        _model("burst", **{param: value})


# --- determinism ---------------------------------------------------------------------------------

MODELS = {
    "burst": {"p_good_to_bad": 0.1, "p_bad_to_good": 0.3, "loss_bad": 0.8, "latency_s": 0.01,
              "jitter_s": 0.005},
    "queue": {"rate_bps": 200_000, "queue_packets": 4},
    "wireless": {},
    "outage": {"windows_s": [[0.2, 0.1]]},
}


def _trace(name, seed):
    k = Kernel()
    events = []
    mobility = Mobility({"a": (0.0, 0.0, 0.0), "b": (220.0, 0.0, 0.0)})
    model = make_model(name, MODELS[name], seed=seed, stream_name="up", mobility=mobility,
                       src="a", dst="b")
    link = Link(k, model, lambda p, m: None, name="up", tracer=lambda *e: events.append(e))
    for i in range(600):
        k.schedule(i * 0.001, link.send, b"p" * (20 + i % 200))
    k.run()
    return events


@pytest.mark.parametrize("name", sorted(MODELS))
def test_same_seed_same_trace(name):
    assert _trace(name, 5) == _trace(name, 5)
    if name in ("burst", "wireless"):  # the random ones
        assert _trace(name, 5) != _trace(name, 6)


@pytest.mark.parametrize("model, key, value", [
    ("wireless", "tx_power_dbm", 1e308), ("wireless", "ref_loss_db", -1e308),
    ("wireless", "noise_floor_dbm", 1e308), ("wireless", "shadowing_sigma_db", 1e308),
    ("wireless", "shadowing_sigma_db", math.inf),
    ("lte", "enb_tx_power_dbm", 1e308), ("lte", "ue_noise_figure_db", 1e308),
    ("lte", "ref_loss_db", -1e308),
])
def test_a_radio_level_a_float_cannot_hold_is_refused_naming_it(model, key, value):
    """10^(x/10) of such a level overflowed: when the first packet crossed (wireless) or when
    the model was built (lte), an OverflowError instead of the scenario's key."""
    params = {key: value}
    if model == "lte":
        params["cells_ned_m"] = [[0.0, 0.0, -30.0]]
    mobility = Mobility({"a": (0.0, 0.0, 0.0), "b": (50.0, 0.0, 0.0)})
    with pytest.raises(ValueError, match=key):
        make_model(model, params, seed=0, stream_name="x", mobility=mobility, src="a", dst="b")
