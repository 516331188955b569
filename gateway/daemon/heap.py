"""The daemon's heap once it serves: long-lived objects out of the cyclic collector."""

from __future__ import annotations

import gc

YOUNG_GC_THRESHOLD = 20_000  # allocations (net of frees) between two young-generation passes


def settle_heap() -> None:
    """Everything built so far (modules, PyBullet, parameter tables, the vehicles) lives as long
    as the process: keep it out of the cyclic collector's passes, which would otherwise stall
    the loop for milliseconds at a time as the simulation allocates. ``cornet run`` starts with
    the collector off (gateway/cli.py), since its passes over a growing heap of long-lived
    objects are up to 40 % of building many vehicles; this turns it on, with a young generation
    of YOUNG_GC_THRESHOLD: every vehicle's latest state (measurement, setpoints, command) is
    always young, so at CPython's 700 a pass walks ~35 objects per vehicle and comes at every
    burst of a step's allocations (4-5 % of a process's CPU at 240 vehicles)."""
    gc.freeze()
    gc.set_threshold(YOUNG_GC_THRESHOLD, *gc.get_threshold()[1:])
    gc.enable()
