"""The state bus: per-vehicle state published on ZeroMQ, and `cornet watch` that reads it."""
