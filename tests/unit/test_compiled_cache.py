"""Compiled code is never run stale: a change anywhere in vehicles/ drops numba's cache."""

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import sys
    sys.path.insert(0, sys.argv[2])
    import vehicles.control.compiled as compiled
    compiled.sources_digest = lambda: sys.argv[1]  # stands in for an edit of vehicles/
    import cached_mod
    assert cached_mod.f(1) == 2
    print(sum(cached_mod.f.stats.cache_hits.values()), sum(cached_mod.f.stats.cache_misses.values()))
""")


def run(digest, where):
    out = subprocess.run([sys.executable, "-c", SCRIPT, digest, str(where)], check=True,
                         capture_output=True, text=True).stdout.split()
    return int(out[0]), int(out[1])


def test_cache_is_reused_then_dropped_when_the_sources_change(tmp_path):
    (tmp_path / "cached_mod.py").write_text(textwrap.dedent("""
        from vehicles.control.compiled import njit_cached

        @njit_cached
        def f(x):
            return x + 1
    """))
    assert run("a", tmp_path) == (0, 1)  # compiled
    assert run("a", tmp_path) == (1, 0)  # loaded from the cache
    assert run("b", tmp_path) == (0, 1)  # the sources changed: compiled again
    assert run("b", tmp_path) == (1, 0)
