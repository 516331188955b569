"""``from vehicles.world import World`` (the name the gateway uses); the backend is physics.py."""

from vehicles.physics import World

__all__ = ["World"]
