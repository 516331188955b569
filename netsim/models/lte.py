"""The lte model: one hop between a vehicle (the UE) and an LTE network (FDD, 1 ms TTI) whose
eNBs stand at fixed places, core network included.

Which end is the vehicle: the one named like a vehicle (``v1``, ``v2`` …, netsim/backend.py),
src first: src a vehicle → uplink (UE → eNB → core), else dst a vehicle → downlink (core → eNB
→ UE); neither (no use for this model) → uplink from src. The other end's position is not used:
the cells are the model's own ``cells_ned_m``; in a ``star`` topology the access point stands
for the network side (name it ``core``) and its position is ignored. A vehicle without a
position yet is taken to be at home (0, 0, 0).

Radio (per cell c, recomputed when the vehicle moves):
    L_c   = ref_loss_db + 10·n·log10(max(d_c, min_distance_m)) + S_c(position)
            defaults: 3GPP TR 36.942 macro cell at 2 GHz, 128.1 + 37.6·log10(d / km) dB
    RSRP_c = enb_tx_power_dbm − 10·log10(12·bandwidth_prbs) − L_c     (per resource element)
    DL SINR = RSRP_s − [N_ue + interference_load·Σ_{c≠s} RSRP_c]       (mW sum, s = serving)
    UL SINR = ue_tx_power_dbm − 10·log10(12·ul_prbs) − L_s − N_enb − ul_noise_rise_db
    N = −174 dBm/Hz + 10·log10(15 kHz) + noise figure (ue/enb_noise_figure_db)
S_c is shadowing: a map of the terrain, not a per-packet draw — a sum of 8 sinusoids per cell
with random 3-D wave vectors and phases (Gaussian correlation exp(−Δ²/shadowing_decorrelation_m²),
standard deviation shadowing_sigma_db), drawn once from the stream ``lte/shadowing`` (a sibling
of the link's stream: same seed). Every link and every vehicle sees the same map, so a place is
good or bad for all of them, and a hovering vehicle's channel does not flicker.

Per packet, five uniform draws from the link's own stream whatever happens (fade, RLC rounds,
HARQ attempt, scheduling wait, handover loss), so a parameter change never reshuffles the draws
of later packets:
1. handover state up to the packet's time at the radio (UL: now; DL: now + core_latency_s), see
   below. In a handover gap [start, start + handover_gap_s): lost with probability
   ``handover_loss`` (Drop.LOSS), else held until the gap ends (X2 forwarding on the downlink,
   the UE's PDCP buffer on the uplink), then sent by the new cell.
2. serving cell's RSRP < min_rsrp_dbm, or this direction's SINR < min_sinr_db (radio link
   failure: Qout ≈ −8 dB) → Drop.RANGE.
3. link adaptation: the highest CQI whose 10 %-BLER SINR threshold (CQI_SINR_DB) the SINR
   reaches (CQI 1 below them all). The transmission sees SINR + a fade ~ N(0, fading_sigma_db)
   (fast fading and the report's age), held over the packet's retransmissions. HARQ attempt i
   (chase combining) fails with BLER(δ + 10·log10 i), δ = SINR + fade − threshold,
   BLER(δ) = 1 / (1 + 9·e^(1.5·δ)) (10 % at δ = 0, 1 % at +1.5 dB).
4. RLC AM, simplified: a packet whose harq_max_tx attempts all fail (probability q) is sent
   again, after harq_max_tx HARQ round trips + rlc_retx_delay_s (the status report), up to
   rlc_max_retx times; the rounds are geometric in q (one draw), more → Drop.LOSS. With
   ``in_order`` (default) the link delivers in sequence, as RLC AM does: a packet never arrives
   before the one sent before it on this link (head-of-line blocking behind retransmissions and
   the gap; per link direction, not per bearer). ``in_order = false``: packets may overtake.
5. delay = wait in a gap + access + TTIs·1 ms + (attempt − 1)·8 ms (HARQ RTT) + RLC rounds
           + rx_processing_s + core_latency_s, with
   access UL: U(0, sr_period_s) to the next scheduling request + grant_delay_s (SR → grant →
              PUSCH, the n+4 rule twice); every datagram pays it, as if the UE's buffer were
              empty (MAVLink traffic is sparse; continuous traffic rides on BSR grants);
          DL: U(0, dl_scheduling_ttis) TTIs: TTI alignment and the scheduler's queue;
   TTIs = ceil(8·(size + 35 header bytes) / (CQI efficiency · 120 data RE · PRBs)), PRBs =
   dl_prbs or ul_prbs: a big packet at a low CQI takes several TTIs.

Handover (LTE event A3, 3GPP TS 36.331 5.5.4.4), on a grid of measurement_period_s in absolute
time, caught up lazily at each packet with the position the network has then: every cell's RSRP
plus measurement noise ~ N(0, measurement_sigma_db) per sample goes through the layer-3 filter
F ← F + a·(M − F), a = 1/2^(l3_filter_k/4). A neighbour whose F exceeds the serving cell's by
more than handover_hysteresis_db at every sample for handover_ttt_s takes over; the interruption
(handover_gap_s, typically 30–60 ms for an X2 handover) starts then. The noise is drawn from the
stream ``lte/measurements/<vehicle>`` from step 0, so every link of one vehicle (one instance per
link direction) walks the same measurements and, as long as they read the same positions, changes
cell at the same instant. The first
sample picks the best cell (attach, no gap). No radio link failure recovery: the serving cell
changes only by A3.

Defaults: 10 MHz (50 PRBs) at 2 GHz, 46 dBm macro cells, a 23 dBm UE on 5 uplink PRBs, the
vehicle's downlink on 25; SR every 10 ms, 8 ms SR → PUSCH, 5 ms core; A3 with 3 dB for 320 ms,
40 ms gap. Measured (tests/unit/test_lte_model.py checks the shape) for 100-byte datagrams, one
every 100 ms, one cell, the vehicle 20 m under the antenna's height, no shadowing, 4 000 packets
per point:

    distance          100 m   500 m   1 km   1.5 km  2 km   2.1 km  2.2 km  2.3 km  2.4 km
    UL SINR dB         38.6    12.7    1.4   −5.3   −10.0  −10.8   −11.5   −12.2   −12.9
    UL loss %           0       0      0      0      0.4    1.0     2.6    range   range
    UL p50 / p95 ms   20.5/25 21/30  23/31  32/39   40/56  43/95   45/132    —       —
    DL SINR dB         50.6    24.7   13.4    6.7    2.0    1.2     0.5    −0.2   (RSRP)
    DL p50 / p95 ms    9.0/10  9.1/16 9.1/17 9.3/18 9.1/16 9.2/17  9.4/18  9.1/16  range

so in good coverage an uplink datagram takes 15.5–25.5 ms (median 20.5: 5 ms mean SR wait + 8
+ 1 + 1.5 + 5), a downlink one 7.5–10.5 ms (median 9), and a HARQ retransmission (first-attempt
BLER ≈ 10 %) adds 8 ms. The uplink runs out first (power-limited): losses appear past ~1.9 km,
where HARQ and RLC run out, RLC rounds of 72 ms fill the tail; beyond ~2.25 km the uplink SINR
is under −12 dB, beyond ~2.37 km the RSRP under −124 dBm: Drop.RANGE. Denser traffic queues
behind the retransmissions there (in order): at 2 km and 100 packets/s the uplink p95 is 175 ms.
Shadowing moves all this by its value at the place (6 dB ≈ a factor 1.44 in distance). A
handover holds the packets that reach the radio during its 40 ms (none lost with handover_loss
= 0): up to 40 ms more. Two cells 1 km apart (scenarios/lte.toml): without shadowing a vehicle
flying from one to the other changes cell once, where the new cell is 3 dB better (546 m from
the first) plus the TTT; hovering at the midpoint with 2 dB measurement noise it never changes
(with handover_ttt_s = 0 it ping-pongs hundreds of times in ten minutes). With the 6 dB
shadowing map a crossing can hand over back and forth where the map favours the far cell, as
flying LTE UEs do.
"""

from __future__ import annotations

import logging
import math
import re
from collections import deque
from collections.abc import Sequence
from statistics import NormalDist
from typing import Any

from netsim.models.base import MAX_DB, Drop, check_delay, register_model
from netsim.rng import UniformStream

TTI_S = 0.001
HARQ_RTT_S = 0.008  # FDD: 8 HARQ processes, a retransmission 8 TTIs after the first attempt
SUBCARRIER_HZ = 15_000.0
THERMAL_DBM_PER_HZ = -174.0
DATA_RE_PER_PRB = 120  # of 12×14 per TTI, after control region and reference signals
HEADER_BYTES = 35  # IPv4 20 + UDP 8 + PDCP 2 + RLC 2 + MAC 3
LTE_PRBS = (6, 15, 25, 50, 75, 100)  # 1.4, 3, 5, 10, 15, 20 MHz
SHADOW_SINUSOIDS = 8
# CQI 1..15: SINR (dB) for 10 % BLER (a common AWGN link-level mapping) and spectral efficiency
# (bits per resource element, 3GPP TS 36.213 Table 7.2.3-1).
CQI_SINR_DB = (-6.7, -4.7, -2.3, 0.2, 2.4, 4.3, 5.9, 8.1, 10.3, 11.7, 14.1, 16.3, 18.7, 21.0,
               22.7)
CQI_EFFICIENCY = (0.1523, 0.2344, 0.3770, 0.6016, 0.8770, 1.1758, 1.4766, 1.9141, 2.4063,
                  2.7305, 3.3223, 3.9023, 4.5234, 5.1152, 5.5547)
BLER_SLOPE_PER_DB = 1.5

_VEHICLE = re.compile(r"v[1-9][0-9]*\Z")
log = logging.getLogger(__name__)
_inv_normal = NormalDist().inv_cdf
Vec3 = tuple[float, float, float]


def _normal(u: float) -> float:
    return _inv_normal(u if u > 0.0 else 1e-300)


def bler(delta_db: float) -> float:
    """Block error rate of one transmission ``delta_db`` above its MCS's 10 % threshold."""
    x = BLER_SLOPE_PER_DB * delta_db
    return 1.0 / (1.0 + 9.0 * math.exp(x if x < 700.0 else 700.0))


def _check(name: str, ok: bool, what: str) -> None:
    if not ok:
        raise ValueError(f"lte: {name} {what}")


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _cells(value: Any) -> list[Vec3]:
    _check("cells_ned_m", isinstance(value, (list, tuple)) and len(value) > 0,
           f"must be a non-empty list of [north, east, down] positions in metres, got {value!r}")
    cells = []
    for i, cell in enumerate(value):
        _check(f"cells_ned_m[{i}]", isinstance(cell, (list, tuple)) and len(cell) == 3
               and all(_number(x) for x in cell), f"must be 3 numbers [north, east, down] in "
               f"metres, got {cell!r}")
        cells.append((float(cell[0]), float(cell[1]), float(cell[2])))
    return cells


class _ShadowMap:
    """Σ sqrt(2/K)·σ·cos(k·p + φ) over K sinusoids: Gaussian correlation exp(−Δ²/d²) when each
    component of k ~ N(0, 2/d²)."""

    def __init__(self, stream: UniformStream, sigma_db: float, decorrelation_m: float) -> None:
        self.amplitude_db = sigma_db * math.sqrt(2.0 / SHADOW_SINUSOIDS)
        s = math.sqrt(2.0) / decorrelation_m
        self.waves = [(s * _normal(stream.next()), s * _normal(stream.next()),
                       s * _normal(stream.next()), 2.0 * math.pi * stream.next())
                      for _ in range(SHADOW_SINUSOIDS)]

    def __call__(self, p: Vec3) -> float:
        n, e, d = p
        return self.amplitude_db * sum(math.cos(kn * n + ke * e + kd * d + phase)
                                       for kn, ke, kd, phase in self.waves)


@register_model("lte", positional=True)
class LteModel:
    def __init__(self, rng: UniformStream, mobility: Any, src: str, dst: str, *,
                 cells_ned_m: Sequence[Sequence[float]] = ((0.0, 0.0, -30.0),),
                 enb_tx_power_dbm: float = 46.0, ue_tx_power_dbm: float = 23.0,
                 bandwidth_prbs: int = 50, dl_prbs: int = 25, ul_prbs: int = 5,
                 ue_noise_figure_db: float = 9.0, enb_noise_figure_db: float = 5.0,
                 ul_noise_rise_db: float = 3.0, interference_load: float = 0.5,
                 path_loss_exponent: float = 3.76, ref_loss_db: float = 15.3,
                 min_distance_m: float = 10.0, shadowing_sigma_db: float = 6.0,
                 shadowing_decorrelation_m: float = 50.0, fading_sigma_db: float = 2.0,
                 min_rsrp_dbm: float = -124.0, min_sinr_db: float = -12.0,
                 harq_max_tx: int = 4, rlc_max_retx: int = 4, rlc_retx_delay_s: float = 0.04,
                 sr_period_s: float = 0.01, grant_delay_s: float = 0.008,
                 dl_scheduling_ttis: int = 3, rx_processing_s: float = 0.0015,
                 core_latency_s: float = 0.005,
                 handover_hysteresis_db: float = 3.0, handover_ttt_s: float = 0.32,
                 handover_gap_s: float = 0.04, handover_loss: float = 0.0,
                 measurement_period_s: float = 0.04, measurement_sigma_db: float = 2.0,
                 l3_filter_k: int = 4, in_order: bool = True) -> None:
        self.cells = _cells(cells_ned_m)
        for name, value in (("enb_tx_power_dbm", enb_tx_power_dbm),
                            ("ue_tx_power_dbm", ue_tx_power_dbm),
                            ("ue_noise_figure_db", ue_noise_figure_db),
                            ("enb_noise_figure_db", enb_noise_figure_db),
                            ("ul_noise_rise_db", ul_noise_rise_db), ("ref_loss_db", ref_loss_db),
                            ("min_rsrp_dbm", min_rsrp_dbm), ("min_sinr_db", min_sinr_db)):
            _check(name, _number(value) and abs(value) <= MAX_DB,
                   f"must be a number between -{MAX_DB:g} and {MAX_DB:g} dB, got {value!r}")
        _check("bandwidth_prbs", bandwidth_prbs in LTE_PRBS and isinstance(bandwidth_prbs, int),
               f"must be one of {', '.join(map(str, LTE_PRBS))}, got {bandwidth_prbs!r}")
        for name, value in (("dl_prbs", dl_prbs), ("ul_prbs", ul_prbs)):
            _check(name, isinstance(value, int) and not isinstance(value, bool)
                   and 1 <= value <= bandwidth_prbs,
                   f"must be an integer 1..bandwidth_prbs ({bandwidth_prbs}), got {value!r}")
        _check("interference_load", _number(interference_load) and 0 <= interference_load <= 1,
               f"must be between 0 and 1, got {interference_load!r}")
        _check("handover_loss", _number(handover_loss) and 0 <= handover_loss <= 1,
               f"must be a probability between 0 and 1, got {handover_loss!r}")
        _check("path_loss_exponent", _number(path_loss_exponent)
               and 1.0 <= path_loss_exponent <= 8.0, f"must be in [1, 8], got "
               f"{path_loss_exponent!r}")
        for name, value in (("min_distance_m", min_distance_m),
                            ("shadowing_decorrelation_m", shadowing_decorrelation_m),
                            ("sr_period_s", sr_period_s),
                            ("measurement_period_s", measurement_period_s)):
            _check(name, _number(value) and value > 0, f"must be > 0, got {value!r}")
        _check("sr_period_s", sr_period_s <= 1.0, f"must be at most 1 s, got {sr_period_s!r}")
        _check("measurement_period_s", measurement_period_s >= TTI_S,
               f"must be at least 1 ms, got {measurement_period_s!r}")
        for name, value in (("shadowing_sigma_db", shadowing_sigma_db),
                            ("fading_sigma_db", fading_sigma_db),
                            ("measurement_sigma_db", measurement_sigma_db),
                            ("handover_hysteresis_db", handover_hysteresis_db)):
            _check(name, _number(value) and 0 <= value <= 30, f"must be in [0, 30] dB, "
                   f"got {value!r}")
        for name, value, low, high in (("harq_max_tx", harq_max_tx, 1, 8),
                                       ("rlc_max_retx", rlc_max_retx, 0, 32),
                                       ("dl_scheduling_ttis", dl_scheduling_ttis, 1, 1000),
                                       ("l3_filter_k", l3_filter_k, 0, 19)):
            _check(name, isinstance(value, int) and not isinstance(value, bool)
                   and low <= value <= high, f"must be an integer {low}..{high}, got {value!r}")
        for name, value in (("rlc_retx_delay_s", rlc_retx_delay_s),
                            ("grant_delay_s", grant_delay_s),
                            ("rx_processing_s", rx_processing_s),
                            ("core_latency_s", core_latency_s), ("handover_ttt_s", handover_ttt_s),
                            ("handover_gap_s", handover_gap_s)):
            _check(name, _number(value), f"must be a number of seconds, got {value!r}")
            check_delay("lte", name, value)
        _check("in_order", isinstance(in_order, bool), f"must be true or false, got {in_order!r}")
        if mobility is None:
            raise ValueError("lte: needs positions (a mobility), it is a positional model")

        self._rng = rng
        self._mobility = mobility
        self.uplink = bool(_VEHICLE.match(src)) or not _VEHICLE.match(dst)
        self.vehicle = src if self.uplink else dst
        self.min_distance_m = float(min_distance_m)
        self._ref_loss_db = float(ref_loss_db)
        self._ten_n = 10.0 * path_loss_exponent
        self._enb_re_dbm = enb_tx_power_dbm - 10.0 * math.log10(12 * bandwidth_prbs)
        self._ue_re_dbm = ue_tx_power_dbm - 10.0 * math.log10(12 * ul_prbs)
        thermal_re_dbm = THERMAL_DBM_PER_HZ + 10.0 * math.log10(SUBCARRIER_HZ)
        self._ue_noise_mw = 10.0 ** ((thermal_re_dbm + ue_noise_figure_db) / 10.0)
        self._enb_noise_dbm = thermal_re_dbm + enb_noise_figure_db + ul_noise_rise_db
        self.interference_load = float(interference_load)
        self.min_rsrp_dbm = float(min_rsrp_dbm)
        self.min_sinr_db = float(min_sinr_db)
        self.fading_sigma_db = float(fading_sigma_db)
        self._combining_db = [10.0 * math.log10(i) for i in range(1, harq_max_tx + 1)]
        self.harq_max_tx = harq_max_tx
        self.rlc_max_retx = rlc_max_retx
        self._rlc_round_s = harq_max_tx * HARQ_RTT_S + rlc_retx_delay_s
        self._bits_per_tti = [eff * DATA_RE_PER_PRB * (ul_prbs if self.uplink else dl_prbs)
                              for eff in CQI_EFFICIENCY]
        self._access_span_s = sr_period_s if self.uplink else dl_scheduling_ttis * TTI_S
        self._fixed_s = ((grant_delay_s if self.uplink else 0.0) + rx_processing_s
                         + core_latency_s)
        self._radio_offset_s = 0.0 if self.uplink else float(core_latency_s)
        self.handover_loss = float(handover_loss)
        self.handover_gap_s = float(handover_gap_s)
        self.handover_ttt_s = float(handover_ttt_s)
        self.handover_hysteresis_db = float(handover_hysteresis_db)
        self.measurement_period_s = float(measurement_period_s)
        self._measurement_sigma_db = float(measurement_sigma_db)
        self._l3_a = 1.0 / 2.0 ** (l3_filter_k / 4.0)
        self.in_order = in_order
        self._last_arrival_s = -math.inf

        shadow_stream = rng.sibling("lte/shadowing") if shadowing_sigma_db > 0 else None
        self._shadow = ([_ShadowMap(shadow_stream, shadowing_sigma_db, shadowing_decorrelation_m)
                         for _ in self.cells] if shadow_stream is not None else [])
        self._measurements = rng.sibling(f"lte/measurements/{self.vehicle}")
        # Radio state for the last position seen.
        self._position: Vec3 | None = None
        self._rsrp_dbm: list[float] = []
        # Handover state: the last measurement step evaluated, the filtered RSRPs, the serving
        # cell, the A3 candidate and since when it holds, the last gap, and a log of handovers.
        self._step = -1
        self._filtered: list[float] = []
        self.serving = -1
        self._candidate = -1
        self._candidate_since_s = 0.0
        self._gap_start_s = -math.inf
        self._gap_end_s = -math.inf
        # The last handovers (start_s, from cell, to cell), bounded for long ping-pong runs.
        self.handovers: deque[tuple[float, int, int]] = deque(maxlen=1000)
        self.handover_count = 0

    # --- radio
    def _update_position(self) -> None:
        p = self._mobility.positions.get(self.vehicle, (0.0, 0.0, 0.0))
        if p == self._position:
            return
        self._position = p
        rsrp = []
        for i, cell in enumerate(self.cells):
            d = math.dist(p, cell)
            loss = self._ref_loss_db + self._ten_n * math.log10(max(d, self.min_distance_m))
            if self._shadow:
                loss += self._shadow[i](p)
            rsrp.append(self._enb_re_dbm - loss)
        self._rsrp_dbm = rsrp

    def rsrp_dbm(self) -> list[float]:
        """Mean RSRP of every cell at the vehicle's current position (shadowing included)."""
        self._update_position()
        return list(self._rsrp_dbm)

    def sinr_db(self, cell: int) -> float:
        """This direction's SINR with ``cell`` serving, at the vehicle's current position."""
        self._update_position()
        rsrp = self._rsrp_dbm
        if self.uplink:
            return self._ue_re_dbm - (self._enb_re_dbm - rsrp[cell]) - self._enb_noise_dbm
        interference = sum(10.0 ** (r / 10.0) for i, r in enumerate(rsrp) if i != cell)
        return rsrp[cell] - 10.0 * math.log10(self._ue_noise_mw
                                              + self.interference_load * interference)

    # --- handover
    def _measure_until(self, t_s: float) -> None:
        last = math.floor(t_s / self.measurement_period_s)
        if last <= self._step:
            return
        rsrp = self._rsrp_dbm
        sigma, a, draw = self._measurement_sigma_db, self._l3_a, self._measurements.next
        while self._step < last:
            self._step += 1
            t_k = self._step * self.measurement_period_s
            samples = [r + sigma * _normal(draw()) for r in rsrp]
            if self.serving < 0:
                self._filtered = samples
                self.serving = max(range(len(samples)), key=samples.__getitem__)
                continue
            f = self._filtered
            for i, m in enumerate(samples):
                f[i] += a * (m - f[i])
            serving = self.serving
            best = max((i for i in range(len(f)) if i != serving), key=f.__getitem__,
                       default=-1)
            if best < 0 or f[best] <= f[serving] + self.handover_hysteresis_db:
                self._candidate = -1
            elif best != self._candidate:
                self._candidate, self._candidate_since_s = best, t_k
            if self._candidate >= 0 and t_k - self._candidate_since_s >= self.handover_ttt_s:
                self.handovers.append((t_k, serving, best))
                self.handover_count += 1
                log.debug("lte %s %s: handover from cell %d to cell %d at %.2f s",
                          self.vehicle, "uplink" if self.uplink else "downlink", serving, best,
                          t_k)
                self.serving, self._candidate = best, -1
                self._gap_start_s, self._gap_end_s = t_k, t_k + self.handover_gap_s

    # --- per packet
    def transit(self, size_bytes: int, now_s: float) -> float | Drop:
        rng = self._rng
        u_fade = rng.next()
        u_rounds = rng.next()
        u_attempt = rng.next()
        u_access = rng.next()
        u_handover = rng.next()
        self._update_position()
        t_radio = now_s + self._radio_offset_s
        self._measure_until(t_radio)
        wait = 0.0
        if self._gap_start_s <= t_radio < self._gap_end_s:
            if u_handover < self.handover_loss:
                return Drop.LOSS
            wait = self._gap_end_s - t_radio
        cell = self.serving
        if self._rsrp_dbm[cell] < self.min_rsrp_dbm:
            return Drop.RANGE
        sinr = self.sinr_db(cell)
        if sinr < self.min_sinr_db:
            return Drop.RANGE
        cqi = 0
        while cqi + 1 < len(CQI_SINR_DB) and CQI_SINR_DB[cqi + 1] <= sinr:
            cqi += 1
        delta = sinr - CQI_SINR_DB[cqi] - self.fading_sigma_db * _normal(u_fade)
        fails = [bler(delta + g) for g in self._combining_db]
        q = math.prod(fails)
        rounds = 0
        if q >= 1.0:
            return Drop.LOSS
        if q > 0.0:
            # Failed RLC rounds before a good one, geometric: P(rounds >= j) = q^j.
            rounds = int(math.log(1.0 - u_rounds) / math.log(q))
            if rounds > self.rlc_max_retx:
                return Drop.LOSS
        # The attempt that succeeds in the good round: P(j) ∝ p_1…p_{j−1}·(1 − p_j).
        target = u_attempt * (1.0 - q)
        attempt, reach, cumulative = 0, 1.0, 0.0
        for p in fails:
            cumulative += reach * (1.0 - p)
            if target < cumulative:
                break
            reach *= p
            attempt += 1
        attempt = min(attempt, self.harq_max_tx - 1)
        ttis = max(1, math.ceil(8 * (size_bytes + HEADER_BYTES) / self._bits_per_tti[cqi]))
        delay = (wait + u_access * self._access_span_s + ttis * TTI_S + attempt * HARQ_RTT_S
                 + rounds * self._rlc_round_s + self._fixed_s)
        if self.in_order:
            if now_s + delay < self._last_arrival_s:
                delay = self._last_arrival_s - now_s
            self._last_arrival_s = now_s + delay
        return delay
