"""The daemon's heap once it serves (gateway.daemon.heap): the objects built so far frozen out of
the collector, the collector on, its young generation at YOUNG_GC_THRESHOLD."""

import gc

from gateway.daemon.heap import YOUNG_GC_THRESHOLD, settle_heap


def test_settle_heap_freezes_and_widens_the_young_generation():
    before, enabled = gc.get_threshold(), gc.isenabled()
    gc.disable()  # as ``cornet run`` builds its vehicles
    try:
        settle_heap()
        assert gc.isenabled()
        assert gc.get_freeze_count() > 0
        assert gc.get_threshold() == (YOUNG_GC_THRESHOLD, *before[1:])
    finally:
        gc.unfreeze()
        gc.set_threshold(*before)
        (gc.enable if enabled else gc.disable)()
