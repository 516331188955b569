"""Link models: each decides, per packet, a delay or a drop. They never see packet contents.

The interface and the registry live in base.py; importing this package registers the built-in
models (each module registers itself with ``register_model``). See README.md beside this file
for how to add one.
"""

from netsim.models import burst, fixed, lte, outage, queue, wireless  # noqa: F401 (registers them)
from netsim.models.base import (
    Drop,
    LinkModel,
    ModelFactory,
    make_model,
    model_names,
    register_model,
)

__all__ = ["Drop", "LinkModel", "ModelFactory", "make_model", "model_names", "register_model"]
