"""The lte model (netsim/models/lte.py): latency shape, loss and range with distance, A3
handover with hysteresis and time-to-trigger, the handover gap, determinism, validation."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from netsim.backend import EmbeddedBackend, Mobility
from netsim.kernel import Kernel
from netsim.models import Drop, make_model, model_names
from netsim.models.lte import LteModel
from netsim.rng import UniformStream
from netsim.topology import make_router

SEED = 21
TWO_CELLS = [[0.0, 0.0, -30.0], [1000.0, 0.0, -30.0]]
ALTITUDE_NED_M = -10.0
UL_BASE_S = 0.008 + 0.001 + 0.0015 + 0.005  # grant, one TTI, decoding, core
DL_BASE_S = 0.001 + 0.0015 + 0.005


def _lte(north_m, *, up=True, seed=SEED, stream="v1/gcs/down", **params):
    mobility = Mobility({"v1": (north_m, 0.0, ALTITUDE_NED_M)})
    src, dst = ("v1", "core") if up else ("core", "v1")
    model = make_model("lte", params, seed=seed, stream_name=stream, mobility=mobility,
                       src=src, dst=dst)
    return model, mobility


def _delays(model, n, period_s=0.01, size=100):
    return [model.transit(size, i * period_s) for i in range(n)]


def _delivered(verdicts):
    return sorted(v for v in verdicts if not isinstance(v, Drop))


def _percentile(values, q):
    return values[min(len(values) - 1, int(q * len(values)))]


def test_registered_as_positional():
    assert "lte" in model_names()
    with pytest.raises(ValueError, match="positional"):
        make_model("lte", {}, seed=0, stream_name="x")


def test_the_vehicle_end_sets_the_direction():
    up, _ = _lte(100.0, up=True)
    down, _ = _lte(100.0, up=False)
    assert up.uplink and up.vehicle == "v1"
    assert not down.uplink and down.vehicle == "v1"
    assert up.sinr_db(0) < down.sinr_db(0)  # 23 dBm on 5 PRBs against 46 dBm: uplink-limited


# --- latency -------------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", [1, 2])
def test_latency_distribution_in_good_coverage(seed):
    up = _delivered(_delays(_lte(300.0, seed=seed, shadowing_sigma_db=0.0)[0], 4000))
    down = _delivered(_delays(_lte(300.0, up=False, seed=seed, shadowing_sigma_db=0.0)[0], 4000))
    assert len(up) == len(down) == 4000
    # Uplink: U(0, 10 ms) to the scheduling request + 8 ms to the grant + 1 TTI + 1.5 + 5 core.
    assert min(up) >= UL_BASE_S - 1e-12
    assert 0.019 <= _percentile(up, 0.5) <= 0.022, f"seed={seed}"
    assert _percentile(up, 0.05) >= 0.015
    assert 0.024 <= _percentile(up, 0.95) <= 0.035
    # Downlink: U(0, 3 TTIs) of scheduling + 1 TTI + 1.5 + 5 core.
    assert min(down) >= DL_BASE_S - 1e-12
    assert 0.0085 <= _percentile(down, 0.5) <= 0.0095
    assert _percentile(down, 0.95) <= 0.019
    assert _percentile(up, 0.5) > _percentile(down, 0.5) + 0.008
    # HARQ: link adaptation aims at ~10 % first-attempt errors, each costing 8 ms.
    retransmitted = sum(d > UL_BASE_S + 0.010 + 1e-9 for d in up) / len(up)
    assert 0.03 < retransmitted < 0.25, f"seed={seed}"


def test_larger_packets_at_low_cqi_take_more_ttis():
    def mean_delay(north_m, size):
        model, _ = _lte(north_m, shadowing_sigma_db=0.0, fading_sigma_db=0.0)
        return sum(_delivered(_delays(model, 500, size=size))) / 500

    # CQI 1 on 5 PRBs carries 91 bits per TTI: 20 bytes take 5 TTIs, 280 bytes 28.
    assert mean_delay(1700.0, 280) - mean_delay(1700.0, 20) == pytest.approx(0.023, abs=0.002)
    assert mean_delay(300.0, 280) - mean_delay(300.0, 20) < 0.002  # one or two TTIs near


def test_in_order_delivery_holds_packets_behind_retransmissions():
    def arrivals(**params):
        model, _ = _lte(2100.0, shadowing_sigma_db=0.0, **params)  # HARQ and RLC at work
        return [i * 0.01 + v for i, v in enumerate(_delays(model, 3000))
                if not isinstance(v, Drop)]

    ordered = arrivals()
    assert ordered == sorted(ordered)
    free = arrivals(in_order=False)
    assert free != sorted(free)  # late retransmissions are overtaken
    assert sum(ordered) > sum(free)  # head-of-line blocking only ever adds delay


# --- distance ------------------------------------------------------------------------------------

DISTANCES_M = [500, 1500, 1900, 2000, 2100, 2200, 2300, 3000]


@pytest.mark.parametrize("seed", [3, 4])
def test_loss_and_latency_grow_with_distance(seed):
    # Common random numbers: every distance replays the same stream, so a farther vehicle is
    # worse packet by packet and the trend is not lost in sampling noise.
    rows = []
    for d in DISTANCES_M:
        verdicts = _delays(_lte(d, seed=seed, shadowing_sigma_db=0.0)[0], 3000)
        ok = _delivered(verdicts)
        rows.append(((len(verdicts) - len(ok)) / len(verdicts),
                     sum(ok) / len(ok) if ok else math.inf,
                     {v for v in verdicts if isinstance(v, Drop)}))
    losses = [r[0] for r in rows]
    means = [r[1] for r in rows]
    assert losses == sorted(losses), f"seed={seed} {losses}"
    assert means == sorted(means), f"seed={seed} {means}"
    assert losses[0] == losses[1] == 0.0
    assert 0.0 < losses[5] < 0.1  # HARQ and RLC running out near the edge
    assert rows[5][2] == {Drop.LOSS} and rows[-1][2] == {Drop.RANGE} and losses[-1] == 1.0


def test_out_of_coverage_is_range_and_the_uplink_goes_first():
    up, mobility = _lte(2300.0, shadowing_sigma_db=0.0)
    down, _ = _lte(2300.0, up=False, shadowing_sigma_db=0.0)
    assert set(_delays(up, 200)) == {Drop.RANGE}  # uplink SINR under min_sinr_db
    assert not any(isinstance(v, Drop) for v in _delays(down, 200))
    mobility.update(3.0, {"v1": (5000.0, 0.0, ALTITUDE_NED_M)})
    assert up.transit(100, 3.0) is Drop.RANGE
    mobility.update(4.0, {"v1": (100.0, 0.0, ALTITUDE_NED_M)})  # back in coverage
    assert not isinstance(up.transit(100, 4.0), Drop)


def test_shadowing_is_a_map_shared_by_every_link():
    a, mob_a = _lte(700.0, stream="v1/gcs/down")
    b, _ = _lte(700.0, stream="v1/api/down", up=False)
    c, _ = _lte(700.0, seed=SEED + 1)
    assert a.rsrp_dbm() == b.rsrp_dbm() != c.rsrp_dbm()
    plain, mob_plain = _lte(700.0, shadowing_sigma_db=0.0)
    values = []
    for i in range(400):  # a 20 km line: samples of the map many decorrelation lengths apart
        mob_a.update(float(i), {"v1": (700.0, 50.0 * i, ALTITUDE_NED_M)})
        mob_plain.update(float(i), {"v1": (700.0, 50.0 * i, ALTITUDE_NED_M)})
        values.append(a.rsrp_dbm()[0] - plain.rsrp_dbm()[0])
    mean = sum(values) / len(values)
    sigma = math.sqrt(sum((v - mean) ** 2 for v in values) / len(values))
    assert abs(mean) < 2.0 and 3.5 < sigma < 8.5
    mob_a.update(500.0, {"v1": (700.0, 1000.0, ALTITUDE_NED_M)})
    here = a.rsrp_dbm()[0]
    mob_a.update(501.0, {"v1": (700.0, 1000.5, ALTITUDE_NED_M)})  # half a metre: the same place
    assert abs(a.rsrp_dbm()[0] - here) < 1.0


# --- handover ------------------------------------------------------------------------------------

def _fly(model, mobility, track, duration_s, *, step_s=0.02, packet_every=1, offset_s=0.0):
    """Move the vehicle along ``track(t)`` (north m), one mobility update per step, a packet
    every ``packet_every`` steps (``offset_s`` after it); the verdicts with their send times."""
    out = []
    for i in range(int(round(duration_s / step_s))):
        t = i * step_s
        mobility.update(t, {"v1": (track(t), 0.0, ALTITUDE_NED_M)})
        if i % packet_every == 0:
            out.append((t + offset_s, model.transit(100, t + offset_s)))
    return out


def _crossing(t):
    return 100.0 + 800.0 * t / 120.0  # 100 m → 900 m in 120 s


# Without shadowing the second cell is 3 dB better at 37.6·log10(d0/d1) = 3 → d1 = 454 m
# (horizontally): 546 m north, reached at t = 66.9 s.
T_3DB_S = (545.9 - 100.0) / 800.0 * 120.0


@pytest.mark.parametrize("seed", [5, 6, 7])
def test_crossing_hands_over_once_after_the_time_to_trigger(seed):
    model, mobility = _lte(100.0, seed=seed, cells_ned_m=TWO_CELLS, shadowing_sigma_db=0.0)
    _fly(model, mobility, _crossing, 120.0)
    assert len(model.handovers) == 1, model.handovers
    start_s, old, new = model.handovers[0]
    assert (old, new) == (0, 1) and model.serving == 1
    # Measurement noise and the layer-3 filter move it by a couple of seconds at most (~10 m).
    assert T_3DB_S + 0.32 <= start_s + 1.5 and start_s <= T_3DB_S + 3.0, start_s


def test_every_link_of_a_vehicle_hands_over_at_the_same_instant():
    """Each link direction is its own instance on its own stream, sending at its own times;
    the measurements follow a grid in absolute time from the vehicle's shared noise stream."""
    mobility = Mobility({"v1": (100.0, 0.0, ALTITUDE_NED_M)})
    models = [make_model("lte", {"cells_ned_m": TWO_CELLS}, seed=SEED, stream_name=name,
                         mobility=mobility, src=src, dst=dst)
              for name, src, dst in (("v1/gcs/down", "v1", "core"), ("v1/gcs/up", "core", "v1"),
                                     ("v1/api/down", "v1", "core"))]
    for i in range(6000):
        t = i * 0.02
        mobility.update(t, {"v1": (_crossing(t), 0.0, ALTITUDE_NED_M)})
        for j, model in enumerate(models):
            if i % (j + 2) == 0:  # every 40, 60, 80 ms
                model.transit(60, t + 0.001 * j)
    assert models[0].handovers
    assert models[0].handovers == models[1].handovers == models[2].handovers


@pytest.mark.parametrize("seed", [8, 9])
def test_hovering_at_the_midpoint_does_not_ping_pong(seed):
    def hover(t):
        return 500.0 + (0.3 if int(t / 0.02) % 2 else -0.3)  # position jitter

    model, mobility = _lte(500.0, seed=seed, cells_ned_m=TWO_CELLS, shadowing_sigma_db=0.0)
    _fly(model, mobility, hover, 600.0)
    assert not model.handovers  # 2 dB noise per sample, 3 dB hysteresis held for 320 ms
    # The same noise without the time-to-trigger: the filtered RSRPs cross the hysteresis now
    # and then, and every crossing is a handover.
    eager, mobility = _lte(500.0, seed=seed, cells_ned_m=TWO_CELLS, shadowing_sigma_db=0.0,
                           handover_ttt_s=0.0)
    _fly(eager, mobility, hover, 600.0)
    assert eager.handover_count == len(eager.handovers) > 50


@pytest.mark.parametrize("north_m", [300.0, 450.0, 500.0, 550.0, 700.0])
def test_hovering_anywhere_with_shadowing_never_hands_back(north_m):
    model, mobility = _lte(north_m, cells_ned_m=TWO_CELLS)
    _fly(model, mobility, lambda t: north_m + 0.2 * math.sin(t), 300.0, packet_every=2)
    assert len(model.handovers) <= 1  # at most once, where the map sits at the hysteresis


def _gap_run(packet_step_s, **params):
    model, mobility = _lte(100.0, cells_ned_m=TWO_CELLS, shadowing_sigma_db=0.0,
                           handover_gap_s=0.05, **params)
    every = max(1, round(packet_step_s / 0.005))
    # Packets half-way between the 5 ms steps, clear of the 40 ms measurement grid.
    return model, _fly(model, mobility, _crossing, 80.0, step_s=0.005, packet_every=every,
                       offset_s=0.0025)


def test_packets_in_the_handover_gap_wait_for_its_end():
    model, verdicts = _gap_run(0.005)
    [(start_s, _, _)] = model.handovers
    sparse, _ = _gap_run(0.04)
    assert sparse.handovers == model.handovers  # the handover does not depend on the traffic
    end_s = start_s + 0.05
    held = [(t, v) for t, v in verdicts if start_s <= t < end_s]
    assert len(held) == 10
    for t, v in held:
        assert not isinstance(v, Drop) and t + v >= end_s + UL_BASE_S - 1e-9
    after = [v for t, v in verdicts if end_s + 0.1 <= t < end_s + 5.0]
    assert max(after) < 0.08 and not any(isinstance(v, Drop) for v in after)


def test_handover_loss_drops_the_packets_in_the_gap():
    model, verdicts = _gap_run(0.005, handover_loss=1.0)
    [(start_s, _, _)] = model.handovers
    dropped = {t for t, v in verdicts if v is Drop.LOSS}
    assert dropped == {t for t, _ in verdicts if start_s <= t < start_s + 0.05}
    assert len(dropped) == 10


def test_downlink_gap_is_met_at_the_enb():
    """The downlink packet reaches the radio core_latency_s after it is sent: what it meets
    there is the gap that counts."""
    model, mobility = _lte(100.0, up=False, cells_ned_m=TWO_CELLS, shadowing_sigma_db=0.0,
                           handover_gap_s=0.05)
    verdicts = _fly(model, mobility, _crossing, 80.0, step_s=0.005, offset_s=0.0025)
    [(start_s, _, _)] = model.handovers
    end_s = start_s + 0.05
    # Sent in [start − 5 ms, end − 5 ms): they reach the eNB in the gap and wait for its end.
    held = [(t, v) for t, v in verdicts if start_s - 0.005 <= t < end_s - 0.005]
    assert len(held) == 10
    assert all(t + v >= end_s + DL_BASE_S - 0.005 - 1e-9 for t, v in held)
    before = [v for t, v in verdicts if start_s - 0.1 <= t < start_s - 0.005]
    assert before and max(before) < 0.03


# --- determinism ---------------------------------------------------------------------------------

def _run(seed=SEED, n=3000, **params):
    model, mobility = _lte(1800.0, seed=seed, cells_ned_m=TWO_CELLS, **params)
    return _fly(model, mobility, lambda t: 1800.0 - 20.0 * t, n * 0.02)


def test_same_seed_same_results():
    assert _run() == _run()
    assert _run() != _run(seed=SEED + 1)


def test_a_parameter_change_does_not_reshuffle_later_draws():
    base = _run()
    slower = _run(core_latency_s=0.012)
    assert [t for t, _ in base] == [t for t, _ in slower]
    for (_, a), (_, b) in zip(base, slower):
        assert (a is b) if isinstance(a, Drop) else b == pytest.approx(a + 0.007)
    # A model that drops more (a lossy gap) takes the same draws: the packets outside the gap
    # keep their delays.
    lossy = _run(handover_loss=1.0, handover_gap_s=0.04)
    same = sum(a == b for (_, a), (_, b) in zip(base, lossy))
    assert same >= len(base) - 20


class _Counting(UniformStream):
    __slots__ = ("draws",)

    def __init__(self, seed, name):
        super().__init__(seed, name)
        self.draws = 0

    def next(self):
        self.draws += 1
        return super().next()


@settings(max_examples=60, deadline=None)
@given(north=st.floats(-4000, 4000), east=st.floats(-4000, 4000), down=st.floats(-300, 0),
       gap=st.floats(0.0, 0.1), loss=st.floats(0.0, 1.0), harq=st.integers(1, 8),
       rlc=st.integers(0, 8), size=st.integers(0, 1500), up=st.booleans())
def test_five_draws_per_packet_and_sane_verdicts(north, east, down, gap, loss, harq, rlc, size,
                                                 up):
    rng = _Counting(3, "prop")
    mobility = Mobility({"v1": (0.0, 0.0, -10.0)})
    model = LteModel(rng, mobility, *(("v1", "core") if up else ("core", "v1")),
                     cells_ned_m=TWO_CELLS, handover_gap_s=gap, handover_loss=loss,
                     harq_max_tx=harq, rlc_max_retx=rlc)
    for i in range(40):
        t = i * 0.05
        mobility.update(t, {"v1": (north * i / 40, east * i / 40, down)})
        verdict = model.transit(size, t)
        assert rng.draws == 5 * (i + 1)
        if not isinstance(verdict, Drop):
            assert (UL_BASE_S if up else DL_BASE_S) - 1e-12 <= verdict < 3.0


# --- configuration -------------------------------------------------------------------------------

@pytest.mark.parametrize("param, value", [
    ("cells_ned_m", []), ("cells_ned_m", [[0.0, 0.0]]), ("cells_ned_m", [[0, 0, "x"]]),
    ("enb_tx_power_dbm", math.nan), ("bandwidth_prbs", 40), ("ul_prbs", 0), ("dl_prbs", 80),
    ("interference_load", 1.5), ("path_loss_exponent", 0.5), ("min_distance_m", 0.0),
    ("shadowing_sigma_db", -1.0), ("shadowing_decorrelation_m", 0.0), ("fading_sigma_db", 40.0),
    ("harq_max_tx", 0), ("harq_max_tx", 2.5), ("rlc_max_retx", -1), ("rlc_retx_delay_s", -0.1),
    ("sr_period_s", 0.0), ("sr_period_s", 5.0), ("grant_delay_s", 100.0),
    ("dl_scheduling_ttis", 0), ("core_latency_s", -1.0), ("handover_hysteresis_db", -3.0),
    ("handover_ttt_s", math.inf), ("handover_gap_s", -0.01), ("handover_loss", 2.0),
    ("measurement_period_s", 0.0), ("measurement_sigma_db", math.nan), ("l3_filter_k", 20),
    ("in_order", "yes"),
])
def test_validation_names_the_parameter(param, value):
    with pytest.raises(ValueError, match=rf"lte: {param}"):
        _lte(100.0, **{param: value})


@pytest.mark.parametrize("radio, where", [
    ({"model": "lte", "ul_prbs": 0}, "network.radio.ul_prbs: lte: ul_prbs"),
    ({"model": "lte", "cells_ned_m": [[1.0, 2.0]]}, "network.radio.cells_ned_m: lte: "
                                                    "cells_ned_m[0]"),
    ({"model": "lte", "handover_gap_s": -1}, "network.radio.handover_gap_s: lte:"),
    ({"model": "lte", "sr_period": 0.01}, "network.radio.sr_period: link model 'lte'"),
])
def test_scenario_errors_name_the_key(radio, where):
    with pytest.raises(ValueError) as err:
        make_router({"topology": "star", "radio": radio})
    assert str(err.value).startswith(where)


def test_star_topology_carries_lte_both_ways():
    route, positions = make_router({"topology": "star", "ap": {"name": "core"},
                                    "radio": {"model": "lte", "cells_ned_m": TWO_CELLS}})
    assert [(h.model, h.src, h.dst) for h in route("v1", "gcs")] == [
        ("lte", "v1", "core"), ("fixed", "core", "gcs")]
    kernel = Kernel()
    backend = EmbeddedBackend(kernel, route, seed=SEED, fixed_positions=positions)
    backend.update_mobility(0.0, {"v1": (0.0, 0.0, -10.0)})
    arrivals = {"down": [], "up": []}
    down = backend.make_link("v1/gcs/down", "v1", "gcs",
                             lambda p, m: arrivals["down"].append(kernel.now - m))
    up = backend.make_link("v1/gcs/up", "gcs", "v1",
                           lambda p, m: arrivals["up"].append(kernel.now - m))
    for i in range(500):
        kernel.schedule(i * 0.01, lambda: down.send(b"x" * 60, kernel.now))
        kernel.schedule(i * 0.01 + 0.005, lambda: up.send(b"x" * 60, kernel.now))
    kernel.run()
    ul = sorted(arrivals["down"])
    dl = sorted(arrivals["up"])
    assert len(ul) == len(dl) == 500
    # The wired hop's 1 ms on top of the radio and core.
    assert 0.019 < ul[250] < 0.024 and 0.009 < dl[250] < 0.0115
