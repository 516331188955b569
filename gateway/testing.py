"""``gateway.testing.Sim``: the lockstep API under its public name (it lives in gateway/ci/lockstep.py)."""

from gateway.ci.lockstep import *  # noqa: F403
from gateway.ci.lockstep import __all__  # noqa: F401
