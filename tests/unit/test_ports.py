"""Free ports for side-by-side daemons and MAVSDK servers (gateway/ci/ports.py)."""

import contextlib
import socket

from gateway.ci import ports


def test_tcp_ports_are_new_at_each_call_and_outside_the_ephemeral_range():
    """mavsdk_server binds its gRPC port a second or two after the test picked it: a port from
    the ephemeral range could be taken by any connection meanwhile, and two calls before the
    first server binds must not give the same port."""
    got = [ports.free_tcp_port() for _ in range(20)]
    assert len(set(got)) == 20
    assert all(ports.TCP_PORTS_FROM <= p < ports._ephemeral_low() for p in got)


def test_a_bound_tcp_port_is_skipped(monkeypatch):
    # A block no worker of this run uses (the workers' own may be in use right now).
    monkeypatch.setattr(ports, "_tcp_next", [])
    monkeypatch.setenv("PYTEST_XDIST_WORKER", "gw50")
    first = ports.TCP_PORTS_FROM + 50 * ports.TCP_BLOCK
    with contextlib.closing(socket.socket()) as taken:
        taken.bind(("0.0.0.0", first))
        taken.listen()
        assert first < ports.free_tcp_port() < first + ports.TCP_BLOCK


def test_each_xdist_worker_has_a_block_of_its_own(monkeypatch):
    firsts = []
    for worker in ("gw0", "gw1", "gw2"):
        monkeypatch.setattr(ports, "_tcp_next", [])
        monkeypatch.setenv("PYTEST_XDIST_WORKER", worker)
        firsts.append(ports.free_tcp_port())
    assert len({p // ports.TCP_BLOCK for p in firsts}) == 3
