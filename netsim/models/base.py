"""The link-model interface and registry: each model decides, per packet, a delay or a drop.
Models never see packet contents.

A model is any object with ``transit(size_bytes, now_s) -> float | Drop``: a delay in seconds
(>= 0) or a ``Drop`` naming why the packet was lost. Models are made by name from config through
``make_model`` so that scenarios can choose them; each gets its own named random stream.
See README.md beside this file for how to add one.
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from typing import Any, Protocol

from netsim.rng import UniformStream


class Drop(str, enum.Enum):
    """Why a packet did not arrive. The value is the counter name in link statistics."""

    LOSS = "loss"  # random loss drawn by the model
    QUEUE = "queue"  # queue overflow
    RANGE = "range"  # out of radio range
    OUTAGE = "outage"  # scheduled blackout
    LATE = "late"  # delivered after its sync cycle (co-simulation late policy)


# Bounds of a model's parameters: beyond them a scenario is a mistake, and a delay of 1e300 s
# would leave packets in the event heap for ever.
MAX_DELAY_S = 60.0
MAX_RATE_BPS = 1e12
MAX_QUEUE = 10**9
# Powers, losses and gains in dB(m): the models take 10^(x/10) of sums of them, which overflows a
# float past ~3080 dB; a radio's real values are within a few hundred.
MAX_DB = 300.0


def check_delay(model: str, name: str, value: float) -> float:
    """``value`` if it is a delay in [0, MAX_DELAY_S] seconds, else ValueError naming it."""
    if not 0.0 <= value <= MAX_DELAY_S:
        raise ValueError(f"{model}: {name} must be between 0 and {MAX_DELAY_S:g} s, got {value!r}")
    return value


class LinkModel(Protocol):
    def transit(self, size_bytes: int, now_s: float) -> float | Drop: ...


ModelFactory = Callable[..., LinkModel]
_REGISTRY: dict[str, ModelFactory] = {}
_POSITIONAL: set[str] = set()


def register_model(name: str, *, positional: bool = False
                   ) -> Callable[[ModelFactory], ModelFactory]:
    """Register a model factory. A ``positional`` model is also given ``mobility`` (a
    netsim.backend.Mobility), ``src`` and ``dst`` (node names), to look up where its hop's ends
    are; the others never see positions."""

    def deco(factory: ModelFactory) -> ModelFactory:
        _REGISTRY[name] = factory
        if positional:
            _POSITIONAL.add(name)
        return factory

    return deco


def model_names() -> list[str]:
    return sorted(_REGISTRY)


def make_model(name: str, params: dict[str, Any], *, seed: int, stream_name: str,
               mobility: Any = None, src: str = "", dst: str = "") -> LinkModel:
    """Build model ``name`` with ``params``; ``stream_name`` names its random stream."""
    try:
        factory = _REGISTRY[name]
    except KeyError:
        known = ", ".join(model_names())
        raise ValueError(f"unknown link model {name!r} (known: {known})") from None
    rng = UniformStream(seed, stream_name)
    try:
        if name in _POSITIONAL:
            return factory(rng=rng, mobility=mobility, src=src, dst=dst, **params)
        return factory(rng=rng, **params)
    except TypeError as exc:  # an unknown or missing parameter name
        raise ValueError(f"link model {name!r}: {exc}") from None
