"""The wireless model: one 802.11n (2.4 GHz, 20 MHz, one stream) hop whose ends move.

Per packet, in this order (three uniform draws per packet whatever happens, so two hops with the
same stream see the same channel realisations — a farther hop is then worse packet by packet):

1. distance d = max(mobility.distance_m(src, dst), min_distance_m), read at send time. Beyond
   ``range_m``, or when the *mean* received power is below ``rx_sensitivity_dbm`` (the frame is
   not even detected) → ``Drop.RANGE``.
2. log-distance path loss with log-normal shadowing:
       PL(d) = ref_loss_db + 10·n·log10(d / ref_distance_m) + X,   X ~ N(0, shadowing_sigma_db)
   SNR = tx_power_dbm − PL(d) − noise_floor_dbm.
   X is drawn once per packet and held over its retries: the retries of one frame take a few
   milliseconds, shorter than the channel's coherence time, so a frame caught in a fade stays in
   it; packets sent further apart see independent fades. (A per-link constant X would only shift
   the range; per packet it turns the range edge into the gradual rise measured outdoors.)
3. bit error rate of the MCS's modulation in AWGN with Es/N0 = SNR (Gray-coded, per bit):
       BPSK  Q(√(2γ)),  QPSK  Q(√γ),  M-QAM  (4/k)(1 − 1/√M)·Q(√(3γ/(M−1))),  k = log2 M,
   with γ raised by an effective coding gain for the convolutional code (K=7, soft Viterbi):
   5.0 dB at rate 1/2, 4.0 dB at 2/3, 3.5 dB at 3/4, 3.0 dB at 5/6 (Proakis, Digital
   Communications, ch. 8: asymptotic gain 10·log10(R·d_free) minus ~2 dB at BER 1e-5). Then
       PER = 1 − (1 − BER)^(8·(size + frame_overhead_bytes)).
   This puts PER = 10 % for a 166-byte frame at ≈ 3.5 dB SNR for MCS 0 and ≈ 23 dB for MCS 7,
   within a couple of dB of measured 802.11n receivers.
4. MAC retries (DCF): attempts fail independently with probability PER (the fade is held).
   The number of failures before success is geometric, drawn with one uniform u as
   floor(ln u / ln PER); more than ``retry_limit`` failures → ``Drop.LOSS``.
5. delay = Σ attempts (DIFS + data airtime + SIFS + ACK) + backoff + d/c + latency_s.
   A failed attempt costs the same as a good one (the sender waits out the ACK timeout).
   Backoff: attempt i draws from a contention window CW_i = min((cw_min+1)·2^i − 1, cw_max)
   slots; the total over the attempts made is drawn as one uniform in [0, Σ CW_i] slots (same
   mean as one draw per attempt, one draw per packet).

Airtime (HT-mixed format): 36 µs preamble + ceil((16 + 8·bytes + 6) / N_DBPS) symbols of 4 µs
+ 6 µs signal extension (2.4 GHz); the ACK is 14 bytes at the 6 Mbit/s legacy rate (50 µs).

Defaults (802.11n at 2.4 GHz outdoors, a small drone radio): 20 dBm transmit power, 40 dB loss at
1 m (Friis at 2.44 GHz), exponent 3.0, 4 dB shadowing, −95 dBm noise floor (thermal −101 dBm in
20 MHz + 6 dB noise figure), MCS 0 (6.5 Mbit/s), 7 retries, −101 dBm detection threshold.
Mean SNR is then 75 − 30·log10(d) dB: 45 dB at 10 m, 15 dB at 100 m, 0.7 dB at 300 m. For a
100-byte datagram (measured, bench seed): loss 0 at 10–50 m, 0.04 % at 100 m, 2 % at 150 m,
12 % at 200 m, 32 % at 250 m, 55 % at 300 m; mean latency of the delivered ones 0.41 ms up to
100 m, 0.44 ms at 150 m, 0.60 ms at 200 m, 1.1 ms at 300 m as retries set in (the paper's Fig. 6
trend); ``Drop.RANGE`` beyond ~500 m (mean power under −101 dBm).
"""

from __future__ import annotations

import math
from statistics import NormalDist
from typing import Any

from netsim.models.base import MAX_DB, Drop, register_model
from netsim.rng import UniformStream

# 802.11n HT, 20 MHz, one spatial stream, 800 ns guard interval (IEEE 802.11-2012 Table 20-30).
# mcs: (bits per subcarrier k, code rate, data bits per OFDM symbol)
MCS_TABLE: dict[int, tuple[int, str, int]] = {
    0: (1, "1/2", 26),
    1: (2, "1/2", 52),
    2: (2, "3/4", 78),
    3: (4, "1/2", 104),
    4: (4, "3/4", 156),
    5: (6, "2/3", 208),
    6: (6, "3/4", 234),
    7: (6, "5/6", 260),
}
CODING_GAIN_DB = {"1/2": 5.0, "2/3": 4.0, "3/4": 3.5, "5/6": 3.0}

SYMBOL_S = 4e-6
HT_PREAMBLE_S = 36e-6  # L-STF 8 + L-LTF 8 + L-SIG 4 + HT-SIG 8 + HT-STF 4 + HT-LTF 4 µs
SIGNAL_EXTENSION_S = 6e-6  # OFDM at 2.4 GHz
SERVICE_TAIL_BITS = 16 + 6
SLOT_S = 9e-6  # short slot (no 802.11b stations)
SIFS_S = 10e-6
DIFS_S = SIFS_S + 2 * SLOT_S
ACK_S = 20e-6 + math.ceil((SERVICE_TAIL_BITS + 8 * 14) / 24) * SYMBOL_S + SIGNAL_EXTENSION_S
SPEED_OF_LIGHT_MPS = 299_792_458.0

_inv_normal = NormalDist().inv_cdf


def _check(name: str, ok: bool, what: str) -> None:
    if not ok:
        raise ValueError(f"wireless: {name} {what}")


@register_model("wireless", positional=True)
class WirelessModel:
    def __init__(self, rng: UniformStream, mobility: Any, src: str, dst: str, *,
                 tx_power_dbm: float = 20.0, noise_floor_dbm: float = -95.0,
                 path_loss_exponent: float = 3.0, ref_loss_db: float = 40.0,
                 ref_distance_m: float = 1.0, shadowing_sigma_db: float = 4.0,
                 mcs: int = 0, retry_limit: int = 7, frame_overhead_bytes: int = 66,
                 range_m: float = math.inf, rx_sensitivity_dbm: float = -101.0,
                 min_distance_m: float = 1.0, latency_s: float = 0.0,
                 cw_min: int = 15, cw_max: int = 1023) -> None:
        _check("path_loss_exponent", 1.0 <= path_loss_exponent <= 8.0, "must be in [1, 8]")
        _check("ref_distance_m", ref_distance_m > 0, "must be > 0")
        _check("shadowing_sigma_db", 0 <= shadowing_sigma_db <= 30,
               f"must be in [0, 30] dB, got {shadowing_sigma_db!r}")
        _check("mcs", isinstance(mcs, int) and mcs in MCS_TABLE, "must be an integer 0..7")
        _check("retry_limit", isinstance(retry_limit, int) and 0 <= retry_limit <= 64,
               "must be an integer in [0, 64]")
        _check("frame_overhead_bytes", isinstance(frame_overhead_bytes, int)
               and frame_overhead_bytes >= 0, "must be an integer >= 0")
        _check("range_m", range_m > 0, "must be > 0")
        _check("min_distance_m", min_distance_m > 0, "must be > 0")
        _check("latency_s", latency_s >= 0, "must be >= 0")
        _check("cw_min", isinstance(cw_min, int) and cw_min >= 1, "must be an integer >= 1")
        _check("cw_max", isinstance(cw_max, int) and cw_max >= cw_min,
               "must be an integer >= cw_min")
        for name, value in (("tx_power_dbm", tx_power_dbm), ("noise_floor_dbm", noise_floor_dbm),
                            ("ref_loss_db", ref_loss_db),
                            ("rx_sensitivity_dbm", rx_sensitivity_dbm)):
            _check(name, isinstance(value, (int, float)) and math.isfinite(value)
                   and abs(value) <= MAX_DB, f"must be a number between -{MAX_DB:g} and "
                   f"{MAX_DB:g} dB, got {value!r}")
        if mobility is None:
            raise ValueError("wireless: needs positions (a mobility), it is a positional model")
        self._rng = rng
        self._mobility = mobility
        self.src, self.dst = src, dst
        self.mcs = mcs
        self.retry_limit = retry_limit
        self.range_m = float(range_m)
        self.min_distance_m = float(min_distance_m)
        self.shadowing_sigma_db = float(shadowing_sigma_db)
        self.overhead_bytes = frame_overhead_bytes
        # Mean SNR(d) = snr0_db − 10·n·log10(d); rx power(d) = snr(d) + noise floor.
        self._snr0_db = tx_power_dbm - ref_loss_db - noise_floor_dbm + \
            10.0 * path_loss_exponent * math.log10(ref_distance_m)
        self._ten_n = 10.0 * path_loss_exponent
        self._min_snr_db = rx_sensitivity_dbm - noise_floor_dbm
        k, rate, ndbps = MCS_TABLE[mcs]
        self._ndbps = ndbps
        # BER = a · Q(√(b·γ)) = a/2 · erfc(√(b·γ/2)), γ = 10^(snr_db/10) · coding gain.
        m = 1 << k
        if k == 1:
            a, b = 1.0, 2.0
        elif k == 2:
            a, b = 1.0, 1.0
        else:
            a, b = (4.0 / k) * (1.0 - 1.0 / math.sqrt(m)), 3.0 / (m - 1)
        self._ber_a = a / 2.0
        self._ber_b = b / 2.0 * 10.0 ** (CODING_GAIN_DB[rate] / 10.0)
        # Fixed part of one attempt, and the cumulative backoff window after i+1 attempts.
        self._attempt_fixed_s = DIFS_S + HT_PREAMBLE_S + SIGNAL_EXTENSION_S + SIFS_S + ACK_S
        windows, total = [], 0
        for i in range(retry_limit + 1):
            total += min((cw_min + 1) * (1 << min(i, 30)) - 1, cw_max)
            windows.append(total * SLOT_S)
        self._backoff_span_s = windows
        self._latency_s = float(latency_s)
        self._cached_d = -1.0
        self._cached_snr_db = 0.0

    def mean_snr_db(self, distance_m: float) -> float:
        d = distance_m if distance_m > self.min_distance_m else self.min_distance_m
        return self._snr0_db - self._ten_n * math.log10(d)

    def airtime_s(self, size_bytes: int) -> float:
        """Data frame airtime at this MCS, preamble included."""
        bits = SERVICE_TAIL_BITS + 8 * (size_bytes + self.overhead_bytes)
        return HT_PREAMBLE_S + -(-bits // self._ndbps) * SYMBOL_S + SIGNAL_EXTENSION_S

    def packet_error_rate(self, snr_db: float, size_bytes: int) -> float:
        """PER of one attempt at this SNR (dB) for a datagram of ``size_bytes``."""
        gamma = 10.0 ** (snr_db / 10.0)
        ber = self._ber_a * math.erfc(math.sqrt(self._ber_b * gamma))
        if ber >= 0.5:
            return 1.0
        return -math.expm1(8 * (size_bytes + self.overhead_bytes) * math.log1p(-ber))

    def transit(self, size_bytes: int, now_s: float) -> float | Drop:
        rng = self._rng
        u_shadow = rng.next()
        u_attempts = rng.next()
        u_backoff = rng.next()
        d = self._mobility.distance_m(self.src, self.dst)
        if d < self.min_distance_m:
            d = self.min_distance_m
        if d > self.range_m:
            return Drop.RANGE
        if d != self._cached_d:
            self._cached_d = d
            self._cached_snr_db = self._snr0_db - self._ten_n * math.log10(d)
        snr_db = self._cached_snr_db
        if snr_db < self._min_snr_db:
            return Drop.RANGE
        if self.shadowing_sigma_db > 0.0:
            # u in [0, 1): keep it inside the open interval the inverse CDF needs.
            snr_db -= self.shadowing_sigma_db * _inv_normal(u_shadow if u_shadow > 0.0
                                                            else 1e-300)
        per = self.packet_error_rate(snr_db, size_bytes)
        if per <= 0.0:
            failures = 0
        elif per >= 1.0:
            return Drop.LOSS
        else:
            # Failures before the first success, geometric: P(failures >= j) = per^j.
            failures = int(math.log(1.0 - u_attempts) / math.log(per))
            if failures > self.retry_limit:
                return Drop.LOSS
        bits = SERVICE_TAIL_BITS + 8 * (size_bytes + self.overhead_bytes)
        attempt_s = self._attempt_fixed_s + -(-bits // self._ndbps) * SYMBOL_S
        return ((failures + 1) * attempt_s + u_backoff * self._backoff_span_s[failures]
                + d / SPEED_OF_LIGHT_MPS + self._latency_s)
