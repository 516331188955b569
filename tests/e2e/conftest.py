import pytest

from gateway.ci import launcher
from gateway.ci.launcher import start_daemon


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
        assert took < 2.0, f"daemon took {took:.2f} s to stop"
