import pytest

from gateway.ci import launcher
from gateway.ci.launcher import start_daemon

STOP_BOUND_S = 5.0


@pytest.fixture(autouse=True)
def no_traceback_in_any_daemon_log():
    """Whatever a test does to it, a daemon logs failures as lines, never as tracebacks."""
    before = set(launcher.STARTED)
    yield
    for d in set(launcher.STARTED) - before:
        found = d.tracebacks()
        assert not found, f"{' '.join(d.command)} logged a traceback:\n" + "\n\n".join(found)


@pytest.fixture
def daemon_factory():
    started = []

    def make(*args, vehicles=1):
        d = start_daemon(*args, vehicles=vehicles)
        started.append(d)
        return d

    yield make
    for d in started:
        code = d.stop()
        took = d.stop_took_s
        assert code == 0, f"daemon exit code {code}\n{d.log_tail()}"
        # A bound on hanging, not a measurement: a sharded daemon stops an MPI job of three
        # processes, which on a loaded 2-core machine takes a little over 2 s.
        assert took < STOP_BOUND_S, f"daemon took {took:.2f} s to stop"
