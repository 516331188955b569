"""The ideal and fixed link models.

fixed: delay = latency + U(-jitter, +jitter), clipped at 0; Bernoulli loss with probability
``loss``. Units on the wire of the config are seconds and a probability in [0, 1].
"""

from __future__ import annotations

from netsim.models.base import Drop, check_delay, register_model
from netsim.rng import UniformStream


@register_model("ideal")
class IdealModel:
    """No delay, no loss."""

    def __init__(self, rng: UniformStream | None = None) -> None:
        del rng

    def transit(self, size_bytes: int, now_s: float) -> float | Drop:
        return 0.0


@register_model("fixed")
class FixedModel:
    def __init__(self, rng: UniformStream, latency_s: float = 0.0, jitter_s: float = 0.0,
                 loss: float = 0.0) -> None:
        check_delay("fixed", "latency_s", latency_s)
        check_delay("fixed", "jitter_s", jitter_s)
        if not 0.0 <= loss <= 1.0:
            raise ValueError(f"fixed: loss must be a probability in [0, 1], got {loss!r}")
        self.latency_s = latency_s
        self.jitter_s = jitter_s
        self.loss = loss
        self._rng = rng

    def transit(self, size_bytes: int, now_s: float) -> float | Drop:
        # Two draws per packet whatever the parameters, so changing the loss rate does not
        # reshuffle the jitter sequence (and vice versa).
        u_loss = self._rng.next()
        u_jitter = self._rng.next()
        if u_loss < self.loss:
            return Drop.LOSS
        delay = self.latency_s + (2.0 * u_jitter - 1.0) * self.jitter_s
        return delay if delay > 0.0 else 0.0
