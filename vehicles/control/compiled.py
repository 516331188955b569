"""numba's ``njit`` with its on-disk cache, when there is somewhere to keep it.

numba caches compiled code next to the source (``__pycache__``), else in the user's cache
directory, or in ``$NUMBA_CACHE_DIR``. With none writable (a read-only install and no home, say)
``njit(cache=True)`` refuses at import; then the function is compiled at every start instead
(a few seconds) and its name is listed in ``UNCACHED`` so that the World can say how to fix it.
"""

from __future__ import annotations

from typing import Any

from numba import njit

UNCACHED: list[str] = []


def njit_cached(fn: Any) -> Any:
    try:
        return njit(cache=True)(fn)
    except RuntimeError:  # numba: "cannot cache function …: no locator available"
        UNCACHED.append(fn.__qualname__)
        return njit(fn)
