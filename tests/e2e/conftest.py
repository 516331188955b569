import pytest

from gateway.ci.launcher import start_daemon


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
