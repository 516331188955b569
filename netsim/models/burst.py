"""The burst model: Gilbert–Elliott two-state loss, for the bursty losses of a fading radio.

A hidden Markov chain with a Good and a Bad state advances once per packet (not per unit of
time: a link that sends nothing does not move, so the burst length is counted in packets, as in
Gilbert's and Elliott's papers and netem's ``loss gemodel``). For each packet, in this order:
1. the state moves: Good → Bad with ``p_good_to_bad``, Bad → Good with ``p_bad_to_good``;
2. the packet is lost with ``loss_good`` or ``loss_bad`` depending on the (new) state;
3. a delivered packet is delayed by latency_s + U(−jitter_s, +jitter_s), clipped at 0.
Three draws per packet whatever the parameters. The initial state is drawn from the stationary
distribution (one draw at construction), so the expected loss is the stationary one from the
first packet:  πB = p_good_to_bad / (p_good_to_bad + p_bad_to_good),  πG = 1 − πB,
loss = πG·loss_good + πB·loss_bad; the mean Bad burst lasts 1 / p_bad_to_good packets.
"""

from __future__ import annotations

from netsim.models.base import Drop, check_delay, register_model
from netsim.rng import UniformStream


@register_model("burst")
class BurstModel:
    def __init__(self, rng: UniformStream, p_good_to_bad: float = 0.01,
                 p_bad_to_good: float = 0.3, loss_good: float = 0.0, loss_bad: float = 1.0,
                 latency_s: float = 0.0, jitter_s: float = 0.0) -> None:
        for name, p in (("p_good_to_bad", p_good_to_bad), ("p_bad_to_good", p_bad_to_good),
                        ("loss_good", loss_good), ("loss_bad", loss_bad)):
            if not 0.0 <= p <= 1.0:
                raise ValueError(f"burst: {name} must be a probability in [0, 1], got {p!r}")
        check_delay("burst", "latency_s", latency_s)
        check_delay("burst", "jitter_s", jitter_s)
        self.p_good_to_bad = p_good_to_bad
        self.p_bad_to_good = p_bad_to_good
        self.loss_good = loss_good
        self.loss_bad = loss_bad
        self.latency_s = latency_s
        self.jitter_s = jitter_s
        self._rng = rng
        self.bad = rng.next() < self.stationary_bad()

    def stationary_bad(self) -> float:
        """πB, the long-run fraction of packets that find the chain in the Bad state."""
        total = self.p_good_to_bad + self.p_bad_to_good
        return self.p_good_to_bad / total if total > 0 else 0.0

    def stationary_loss(self) -> float:
        pi_bad = self.stationary_bad()
        return (1.0 - pi_bad) * self.loss_good + pi_bad * self.loss_bad

    def transit(self, size_bytes: int, now_s: float) -> float | Drop:
        rng = self._rng
        u_move = rng.next()
        u_loss = rng.next()
        u_jitter = rng.next()
        if self.bad:
            if u_move < self.p_bad_to_good:
                self.bad = False
        elif u_move < self.p_good_to_bad:
            self.bad = True
        if u_loss < (self.loss_bad if self.bad else self.loss_good):
            return Drop.LOSS
        delay = self.latency_s + (2.0 * u_jitter - 1.0) * self.jitter_s
        return delay if delay > 0.0 else 0.0
