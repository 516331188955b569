import asyncio
import socket

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.daemon.admission import (
    CHEAP_COST,
    EXPENSIVE_COST,
    Admission,
    Buckets,
    datagram_cost,
)
from gateway.daemon.endpoint import MAX_BATCH, UdpEndpoint


def test_token_bucket_allows_the_burst_then_the_rate():
    lim = Buckets(rate_per_s=100.0, burst=10.0)
    assert sum(lim.allow("a", 0.0) for _ in range(50)) == 10
    assert sum(lim.allow("a", 0.5) for _ in range(100)) == 10  # 50 tokens, capped at the burst
    assert sum(lim.allow("a", 0.55) for _ in range(100)) == 5
    assert lim.allow("b", 0.55)  # another source has its own bucket


def test_sources_are_bounded_least_recently_heard_forgotten():
    lim = Buckets(rate_per_s=1.0, burst=1.0, max_keys=3)
    for src in ("a", "b", "c"):
        assert lim.allow(src, 0.0)
    assert not lim.allow("a", 0.0)  # a is now the most recent
    assert lim.allow("d", 0.0)  # b forgotten
    assert len(lim) == 3
    assert lim.allow("b", 0.0)  # b starts again with a full bucket


def test_bad_limits_are_refused():
    with pytest.raises(ValueError):
        Buckets(rate_per_s=0.0, burst=1.0)
    with pytest.raises(ValueError):
        UdpEndpoint("x", ("127.0.0.1", 9), lambda d, a: None, admission=Admission())


def _frame(msg) -> bytes:
    return msg.pack(M.MAVLink(None, srcSystem=255, srcComponent=190))


def test_cost_is_read_from_the_frame_headers():
    hb = _frame(M.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3))
    ps = _frame(M.MAVLink_param_set_message(1, 1, b"MPC_XY_CRUISE", 5.0, 9))
    cmd = _frame(M.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0))
    assert datagram_cost(hb) == CHEAP_COST
    assert datagram_cost(ps) == EXPENSIVE_COST and datagram_cost(cmd) == EXPENSIVE_COST
    assert datagram_cost(hb + ps + hb) == 2 * CHEAP_COST + EXPENSIVE_COST
    assert datagram_cost(b"garbage") == CHEAP_COST
    assert datagram_cost(b"") == CHEAP_COST


def test_expensive_floods_are_shed_by_source_host_and_port():
    ps = _frame(M.MAVLink_param_set_message(1, 1, b"MPC_XY_CRUISE", 5.0, 9))
    hb = _frame(M.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3))
    adm = Admission(per_source=(100.0, 100.0), per_host=(200.0, 200.0), per_port=(300.0, 300.0))
    # one source: its own budget, 100 units = 10 PARAM_SETs
    assert sum(adm.admit(("10.0.0.1", 1), ps, 0.0) for _ in range(50)) == 10
    assert adm.stats.shed_source == 40
    # the same host rotating over source ports: the host budget (200) caps it
    assert sum(adm.admit(("10.0.0.1", 1000 + k), ps, 0.0) for k in range(100)) == 10
    assert adm.stats.shed_host > 0
    # many hosts: the port's budget (300) caps them all together
    assert sum(adm.admit((f"10.0.1.{k}", 1), ps, 0.0) for k in range(100)) == 10
    assert adm.stats.shed_port > 0
    # a second later the budgets have refilled: a quiet client's heartbeat gets through
    assert adm.admit(("10.0.2.1", 5), hb, 1.0)


def _client() -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    return s


def test_a_flooding_source_is_limited_and_a_quiet_one_still_gets_through():
    async def main():
        loop = asyncio.get_running_loop()
        got: list[tuple[bytes, tuple]] = []
        clock = [0.0]
        ep = UdpEndpoint("t", ("127.0.0.1", 9), lambda d, a: got.append((d, a)),
                         admission=Admission(per_source=(100.0, 50.0)),
                         clock=lambda: clock[0])
        ep.open(loop, ("127.0.0.1", 0))
        flood, quiet = _client(), _client()
        try:
            for i in range(2000):
                flood.sendto(b"x%d" % i, ("127.0.0.1", ep.local_port))
            quiet.sendto(b"hello", ("127.0.0.1", ep.local_port))
            for _ in range(200):
                await asyncio.sleep(0)
            await asyncio.sleep(0.05)
            st = ep.stats
            from_flood = [d for d, a in got if a == flood.getsockname()]
            assert len(from_flood) == 50  # the burst, then nothing: the clock did not move
            assert (b"hello", quiet.getsockname()) in got
            assert st.rx_datagrams == 51
            assert st.rx_rate_limited + st.rx_kernel_dropped == 2000 - 50
            # replies go to the address given, or the preset remote
            ep.send(b"reply", quiet.getsockname())
            assert quiet.recvfrom(100)[0] == b"reply"
            assert ep.stats.tx_datagrams == 1
        finally:
            ep.close()
            flood.close()
            quiet.close()

    asyncio.run(main())


def test_one_wake_up_reads_at_most_a_batch():
    async def main():
        loop = asyncio.get_running_loop()
        got = []
        ep = UdpEndpoint("t", ("127.0.0.1", 9), lambda d, a: got.append(d))
        ep.open(loop, ("127.0.0.1", 0))
        c = _client()
        try:
            for i in range(3 * MAX_BATCH):
                c.sendto(b"%d" % i, ("127.0.0.1", ep.local_port))
            ep._readable()
            assert len(got) == MAX_BATCH
            await asyncio.sleep(0.05)
            assert len(got) == 3 * MAX_BATCH  # the rest on later turns of the loop
        finally:
            ep.close()
            c.close()

    asyncio.run(main())


def test_port_in_use_raises_and_closes():
    async def main():
        loop = asyncio.get_running_loop()
        a = UdpEndpoint("a", ("127.0.0.1", 9), lambda d, addr: None)
        a.open(loop, ("127.0.0.1", 0))
        b = UdpEndpoint("b", ("127.0.0.1", 9), lambda d, addr: None)
        with pytest.raises(OSError):
            b.open(loop, ("127.0.0.1", a.local_port))
        assert b.sock is None
        a.close()

    asyncio.run(main())
