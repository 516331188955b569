"""sd_notify(3) over $NOTIFY_SOCKET: the datagram protocol, abstract socket names, the watchdog
environment (sd_watchdog_enabled semantics), never raising, never blocking; and the daemon's
watchdog policy (ping only while simulated time advances and the network is not lost)."""

import logging
import os
import socket
import tempfile
import time
import uuid

import pytest

from gateway.daemon.sdnotify import Notifier, socket_address, watchdog_usec


def parse(datagram: bytes) -> dict[str, str]:
    return dict(line.split("=", 1) for line in datagram.decode().split("\n"))


@pytest.fixture
def listener(tmp_path):
    """A filesystem socket where systemd would be: (NOTIFY_SOCKET value, receiving socket)."""
    path = str(tmp_path / "notify")
    if len(path) >= 100:  # sockaddr_un holds 108 bytes
        path = os.path.join(tempfile.gettempdir(), f"cornet-notify-{uuid.uuid4().hex}")
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(path)
    sock.settimeout(2.0)
    yield path, sock
    sock.close()
    if os.path.exists(path):
        os.unlink(path)


@pytest.mark.parametrize("name, address", [
    ("/run/systemd/notify", "/run/systemd/notify"),
    ("@cornet/notify", "\0cornet/notify"),
    ("@", None),
    ("relative/path", None),
    ("vsock:2:1234", None),
    ("", None),
])
def test_socket_address(name, address):
    assert socket_address(name) == address


@pytest.mark.parametrize("environ, usec", [
    ({}, None),
    ({"WATCHDOG_USEC": "10000000"}, 10_000_000),
    ({"WATCHDOG_USEC": "10000000", "WATCHDOG_PID": "4242"}, 10_000_000),  # ours
    ({"WATCHDOG_USEC": "10000000", "WATCHDOG_PID": "1"}, None),  # our parent's, inherited
    ({"WATCHDOG_USEC": "10000000", "WATCHDOG_PID": "x"}, None),
    ({"WATCHDOG_USEC": "0"}, None),
    ({"WATCHDOG_USEC": "-5"}, None),
    ({"WATCHDOG_USEC": "10s"}, None),
    ({"WATCHDOG_PID": "4242"}, None),
])
def test_watchdog_env_follows_sd_watchdog_enabled(environ, usec):
    assert watchdog_usec(environ, pid=4242) == usec


def test_no_notify_socket_is_a_quiet_no_op():
    n = Notifier.from_env({"WATCHDOG_USEC": "1000000"}, pid=1)
    assert not n.enabled
    assert n.watchdog_interval_s is None  # no socket: nobody to ping
    assert not n.ready("x") and not n.watchdog() and not n.stopping() and not n.reloading()
    assert n.send_errors == 0
    n.close()


def test_watchdog_interval_is_half_the_period(listener):
    path, _ = listener
    n = Notifier.from_env({"NOTIFY_SOCKET": path, "WATCHDOG_USEC": "3000000"}, pid=7)
    assert n.watchdog_interval_s == pytest.approx(1.5)
    other = Notifier.from_env({"NOTIFY_SOCKET": path, "WATCHDOG_USEC": "3000000",
                               "WATCHDOG_PID": "8"}, pid=7)
    assert other.enabled and other.watchdog_interval_s is None


def test_the_protocol_on_a_path_socket(listener):
    path, sock = listener
    n = Notifier.from_env({"NOTIFY_SOCKET": path}, pid=1)
    assert n.ready("serving 1 vehicle(s)")
    assert sock.recv(4096) == b"READY=1\nSTATUS=serving 1 vehicle(s)"
    assert n.watchdog()
    assert sock.recv(4096) == b"WATCHDOG=1"
    assert n.status("two\nlines")  # a newline would start a bogus assignment
    assert sock.recv(4096) == b"STATUS=two lines"
    assert n.reloading(monotonic_usec=123456789)
    assert parse(sock.recv(4096)) == {"RELOADING": "1", "MONOTONIC_USEC": "123456789"}
    assert n.stopping()
    assert sock.recv(4096) == b"STOPPING=1"
    assert n.sent == 5 and n.send_errors == 0
    n.close()


def test_reloading_stamps_clock_monotonic(listener):
    path, sock = listener
    n = Notifier(socket_address(path))
    before = time.clock_gettime_ns(time.CLOCK_MONOTONIC) // 1000
    n.reloading(status="reloading")
    after = time.clock_gettime_ns(time.CLOCK_MONOTONIC) // 1000
    fields = parse(sock.recv(4096))
    assert fields["RELOADING"] == "1" and fields["STATUS"] == "reloading"
    assert before <= int(fields["MONOTONIC_USEC"]) <= after
    n.close()


def test_abstract_socket_name():
    name = f"cornet-test-{uuid.uuid4().hex}"
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind("\0" + name)
    sock.settimeout(2.0)
    try:
        n = Notifier.from_env({"NOTIFY_SOCKET": "@" + name}, pid=1)
        assert n.address == "\0" + name
        assert n.ready()
        assert sock.recv(4096) == b"READY=1"
        n.close()
    finally:
        sock.close()


def test_send_errors_never_raise_and_are_logged_once(tmp_path, caplog):
    n = Notifier.from_env({"NOTIFY_SOCKET": str(tmp_path / "nobody-listens")}, pid=1)
    with caplog.at_level(logging.WARNING, logger="gateway.daemon.sdnotify"):
        results = [n.ready(), n.watchdog(), n.watchdog(), n.stopping()]
    assert results == [False] * 4
    assert n.send_errors == 4 and n.sent == 0
    assert len([r for r in caplog.records if "cannot notify systemd" in r.message]) == 1
    n.close()


def test_a_full_queue_does_not_block(listener):
    """systemd not reading (or a test peer asleep): sends fail fast instead of stalling the
    event loop that runs the physics."""
    path, sock = listener
    n = Notifier(socket_address(path))
    t0 = time.monotonic()
    results = [n.watchdog() for _ in range(5000)]  # far more than net.unix.max_dgram_qlen
    assert time.monotonic() - t0 < 2.0
    assert not all(results) and n.send_errors > 0
    n.close()


def test_unsupported_socket_name_disables_notifications(caplog):
    with caplog.at_level(logging.WARNING, logger="gateway.daemon.sdnotify"):
        n = Notifier.from_env({"NOTIFY_SOCKET": "vsock:2:1", "WATCHDOG_USEC": "1000000"}, pid=1)
    assert not n.enabled and n.watchdog_interval_s is None
    assert "vsock:2:1" in caplog.text


# --- the daemon's watchdog policy (gateway/daemon/sdnotify.py Watchdog) -----------------------------------

class FakeNotifier:
    def __init__(self) -> None:
        self.pings = 0

    def watchdog(self) -> bool:
        self.pings += 1
        return True


class FakeBackend:
    lost = None


class FakeSim:
    def __init__(self) -> None:
        self.now = 0.0
        self.backend = FakeBackend()


def make_watchdog():
    from gateway.daemon.sdnotify import Watchdog

    clock = [100.0]
    notifier, sim = FakeNotifier(), FakeSim()
    return Watchdog(notifier, sim, 0.5, lambda: clock[0]), notifier, sim, clock


def test_watchdog_pings_every_interval_while_sim_time_advances():
    dog, notifier, sim, clock = make_watchdog()
    dog.poll()
    assert notifier.pings == 0  # simulated time has not moved since the start
    for _ in range(40):  # 2 s of a 50 ms pacer loop
        clock[0] += 0.05
        sim.now += 0.05
        dog.poll()
    assert notifier.pings == 4  # every 0.5 s, not every loop


def test_watchdog_stops_when_sim_time_is_stuck_and_resumes(caplog):
    dog, notifier, sim, clock = make_watchdog()
    clock[0] += 0.5
    sim.now = 0.5
    dog.poll()
    assert notifier.pings == 1
    with caplog.at_level(logging.ERROR, logger="gateway.daemon.app"):
        for _ in range(20):
            clock[0] += 0.5
            dog.poll()
    assert notifier.pings == 1
    assert len([r for r in caplog.records if "not feeding" in r.message]) == 1  # said once
    sim.now = 0.6
    dog.poll()
    assert notifier.pings == 2


def test_watchdog_stops_when_the_network_backend_is_lost():
    dog, notifier, sim, clock = make_watchdog()
    sim.backend.lost = "engine exited with code -9"
    for _ in range(10):
        clock[0] += 0.5
        sim.now += 0.5
        dog.poll()
    assert notifier.pings == 0
    assert "lost" in dog.problem()
