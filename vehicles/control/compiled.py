"""numba's ``njit`` with its on-disk cache, when there is somewhere to keep it.

numba caches compiled code next to the source (``__pycache__``), else in the user's cache
directory, or in ``$NUMBA_CACHE_DIR``. With none writable (a read-only install and no home, say)
``njit(cache=True)`` refuses at import; then the function is compiled at every start instead
(a few seconds) and its name is listed in ``UNCACHED`` so that the World can say how to fix it.

numba invalidates a cached function only when its own file changes, not when a function it
inlines from another file does (the controllers' ``register_jitable`` functions, constants of
vehicles/types.py). So every cached function is also stamped with a digest of all of
vehicles/'s sources: any change there (a pull, an edit) drops the cached code and it is
compiled again once, never run stale.
"""

from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path
from typing import Any, Literal

from numba import njit

UNCACHED: list[str] = []
# Float division as in PX4's C++: x/0 is ±inf and 0/0 NaN, never an exception. A parameter PX4
# stores as given (MPC_JERK_AUTO = 0, MPC_XY_VEL_P_ACC = 0) then makes a setpoint non-finite and
# the controllers take PX4's path for that (PositionControl's failsafe setpoint), as PX4 does.
ERROR_MODEL: Literal["numpy"] = "numpy"
_SOURCES = Path(__file__).resolve().parents[1]  # the vehicles package


@functools.lru_cache(maxsize=1)
def sources_digest() -> str:
    """A digest of every Python source of the vehicles package (names and contents)."""
    h = hashlib.sha256()
    for path in sorted(_SOURCES.rglob("*.py")):
        h.update(str(path.relative_to(_SOURCES)).encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:20]


def njit_cached(fn: Any) -> Any:
    try:
        dispatcher = njit(cache=True, error_model=ERROR_MODEL)(fn)
    except RuntimeError:  # numba: "cannot cache function …: no locator available"
        UNCACHED.append(fn.__qualname__)
        return njit(error_model=ERROR_MODEL)(fn)
    _drop_if_stale(dispatcher, fn)
    return dispatcher


def _drop_if_stale(dispatcher: Any, fn: Any) -> None:
    """Flush ``dispatcher``'s cache unless it was compiled from the present sources."""
    cache = dispatcher._cache  # numba's FunctionCache (cache=True)
    marker = os.path.join(cache._cache_path, f"{fn.__module__}.{fn.__qualname__}.sources")
    digest = sources_digest()
    try:
        with open(marker) as f:
            if f.read().strip() == digest:
                return
    except OSError:
        pass
    cache.flush()
    try:
        os.makedirs(cache._cache_path, exist_ok=True)
        with open(marker, "w") as f:
            f.write(digest + "\n")
    except OSError:
        pass  # numba could not keep its cache there either; it compiles as it must
