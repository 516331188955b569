"""The live view (gateway/web/): the address flag, the model the bus feeds, the HTTP server
on a real socket (page, static files, server-sent events, drop-oldest for slow pages), and
the command line's one-line errors."""

import asyncio
import json
import socket

import aiohttp
import pytest

from gateway import cli
from gateway.sim.scenario import ScenarioError, parse
from gateway.web import server as web_server
from gateway.web.address import WebListenError, parse_listen
from gateway.web.model import LiveModel, classify
from gateway.web.server import WebServer


# --- [ADDR:]PORT --------------------------------------------------------------------------------
@pytest.mark.parametrize("text, want", [
    ("8080", ("127.0.0.1", 8080)), ("0.0.0.0:80", ("0.0.0.0", 80)),
    ("localhost:9000", ("localhost", 9000)), ("[::1]:8080", ("::1", 8080)),
])
def test_listen_addresses(text, want):
    assert parse_listen(text) == want


@pytest.mark.parametrize("text, says", [
    ("http", r"expected \[ADDR:\]PORT"), ("70000", "between 1 and 65535"), ("0", "between 1"),
    ("example.org:80", "not an IP address"), ("1.2.3:80", "not an IP address"),
])
def test_bad_listen_addresses_say_what_to_write(text, says):
    with pytest.raises(ValueError, match=says):
        parse_listen(text)


@pytest.mark.parametrize("value, want", [
    ("0.0.0.0:8080", ("0.0.0.0", 8080)), (8080, ("127.0.0.1", 8080)), ("[::1]:80", ("::1", 80)),
])
def test_the_configuration_file_sets_the_live_view(value, want):
    assert parse({"daemon": {"web": value}}).daemon.web == want


@pytest.mark.parametrize("value", ["", "host:80", True, 70000, [8080]])
def test_a_bad_daemon_web_names_the_key(value):
    with pytest.raises(ScenarioError, match=r"^daemon\.web: "):
        parse({"daemon": {"web": value}})


def test_bad_web_flag_exits_2_with_one_line(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(["run", "--web", "localhost:http"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].endswith("--web: expected [ADDR:]PORT, e.g. --web 8080 or --web 127.0.0.1:8080; "
                            "got 'localhost:http'"), err


# --- the model ----------------------------------------------------------------------------------
def link(sent, delivered, dropped=None, mean_ms=10.0, late=0):
    return {"sent": sent, "delivered": delivered, "dropped": dropped or {}, "in_flight": 0,
            "latency_mean_ms": mean_ms, "late_delivered": late}


def state(t, *positions, nodes=()):
    return {"v": 1, "t": t, "home": {"lat_deg": 47.0, "lon_deg": 8.0, "alt_amsl_m": 400.0},
            "nodes": list(nodes),
            "vehicles": [{"sysid": k + 1, "world_ned_m": [n, e, -1.0], "mode": "Hold"}
                         for k, (n, e) in enumerate(positions)]}


@pytest.mark.parametrize("sent, delivered, loss, latency, want", [
    (0, 0, 0.0, None, "idle"), (100, 99, 0.01, 20.0, "good"), (100, 90, 0.1, 20.0, "degraded"),
    (100, 99, 0.01, 150.0, "degraded"), (100, 40, 0.6, 20.0, "lost"), (10, 0, 1.0, None, "lost"),
    (10, 0, 0.0, None, "idle"),  # all still in flight
])
def test_link_states(sent, delivered, loss, latency, want):
    assert classify(sent, delivered, loss, latency) == want


def test_trails_grow_by_moves_of_half_a_metre():
    model = LiveModel()
    for k, n in enumerate([0.0, 0.1, 0.2, 0.6, 0.7, 2.0]):
        model.ingest("cornet.state", state(0.1 * k, (n, 0.0)))
    assert list(model.trails[1]) == [(0.0, 0.0), (0.6, 0.0), (2.0, 0.0)]
    snap = model.snapshot()
    assert snap["trails"] == {"1": [[0.0, 0.0], [0.6, 0.0], [2.0, 0.0]]}
    assert snap["vehicles"][0]["world_ned_m"] == [2.0, 0.0, -1.0] and snap["t"] == 0.5


def test_links_over_the_last_interval_and_the_timeline():
    model = LiveModel()
    model.ingest("cornet.links", {"v": 1, "t": 1.0, "links": {
        "v1/gcs/down": link(100, 100), "v1/gcs/up": link(0, 0)}})
    assert model.links["v1/gcs"]["state"] == "good"
    # The next second: 50 more sent, none delivered (an outage), 5 late but delivered.
    model.ingest("cornet.links", {"v": 1, "t": 2.0, "links": {
        "v1/gcs/down": link(150, 100, {"outage": 50}, late=5), "v1/gcs/up": link(0, 0)}})
    gcs = model.links["v1/gcs"]
    assert (gcs["state"], gcs["sent"], gcs["delivered"], gcs["loss"]) == ("lost", 50, 0, 1.0)
    assert gcs["dropped"] == {"outage": 50} and gcs["latency_ms"] is None and gcs["late"] == 5
    assert list(model.timeline) == [{"t": 1.0, "dropped": {}, "late": 0},
                                    {"t": 2.0, "dropped": {"outage": 50}, "late": 5}]
    assert [e["text"] for e in model.events] == ["v1/gcs lost"]
    model.ingest("cornet.links", {"v": 1, "t": 3.0, "links": {
        "v1/gcs/down": link(250, 200, {"outage": 50}, mean_ms=10.0, late=5),
        "v1/gcs/up": link(0, 0)}})
    assert model.links["v1/gcs"]["state"] == "good"
    assert model.links["v1/gcs"]["latency_ms"] == pytest.approx(10.0)
    assert [e["text"] for e in model.events] == ["v1/gcs lost", "v1/gcs good"]


def test_faults_other_versions_and_restarts():
    model = LiveModel()
    assert not model.ingest("cornet.state", {**state(1.0, (0, 0)), "v": 2})
    assert model.ignored == 1 and model.vehicles == {}
    model.ingest("cornet.state", state(50.0, (0, 0)))
    model.ingest("cornet.fault", {"v": 1, "t": 50.0, "fault": "link v1 outage for 15 s"})
    assert model.events[-1] == {"t": 50.0, "kind": "fault", "text": "link v1 outage for 15 s"}
    model.ingest("cornet.state", state(0.1, (3, 3)))  # time went back: a new daemon
    assert [e["kind"] for e in model.events] == ["restart"] and model.t == 0.1
    assert list(model.trails[1]) == [(3, 3)]


# --- the server ---------------------------------------------------------------------------------
async def read_event(response) -> tuple[str, dict]:
    kind, data = "", ""
    while True:
        line = (await response.content.readline()).decode()
        if line.startswith("event: "):
            kind = line[7:].strip()
        elif line.startswith("data: "):
            data += line[6:]
        elif line == "\n" and data:
            return kind, json.loads(data)


@pytest.mark.asyncio
async def test_page_static_files_state_and_events():
    server = WebServer("127.0.0.1", 0, frame_period_s=0.01)
    await server.start()
    try:
        async with aiohttp.ClientSession() as http:
            async with http.get(server.url) as r:
                assert r.status == 200 and "CORNET live view" in await r.text()
            for name in ("live.js", "live.css"):
                async with http.get(f"{server.url}static/{name}") as r:
                    assert r.status == 200 and len(await r.read()) > 1000
            server.publish(b"cornet.state", state(1.0, (1.0, 2.0)))
            async with http.get(f"{server.url}state.json") as r:
                snap = await r.json()
            assert snap["type"] == "snapshot" and snap["vehicles"][0]["world_ned_m"][:2] == [1, 2]
            async with http.get(f"{server.url}events") as r:
                assert r.headers["Content-Type"] == "text/event-stream"
                kind, first = await read_event(r)
                assert kind == "snapshot" and first["trails"] == {"1": [[1.0, 2.0]]}
                server.publish(b"cornet.state", state(1.1, (5.0, 2.0)))
                for _ in range(5):  # a frame of the old state may already be on its way
                    kind, frame = await read_event(r)
                    assert kind == "frame"
                    if frame["vehicles"][0]["world_ned_m"][0] == 5.0:
                        break
                assert frame["vehicles"][0]["world_ned_m"][0] == 5.0
                assert "trails" not in frame and frame["server"]["pages"] == 1
    finally:
        await server.close()


def test_a_page_that_does_not_keep_up_loses_its_oldest_frames():
    page = web_server._Page()
    frames = [f"frame {k}".encode() for k in range(web_server.QUEUE_FRAMES + 3)]
    pushed_out = [page.offer(f) for f in frames]
    assert pushed_out.count(True) == 3 and page.dropped == 3
    assert list(page.frames) == frames[3:]


@pytest.mark.asyncio
async def test_broadcast_counts_what_slow_pages_lose():
    server = WebServer("127.0.0.1", 0)
    slow, fast = web_server._Page(), web_server._Page()
    server.pages |= {slow, fast}
    for k in range(web_server.QUEUE_FRAMES + 2):
        server.publish(b"cornet.state", state(k, (k, 0)))
        server.broadcast()
        fast.frames.clear()
    assert server.frames_dropped == 2 and slow.dropped == 2 and fast.dropped == 0
    assert server.frames_sent == web_server.QUEUE_FRAMES + 2


@pytest.mark.asyncio
async def test_a_taken_port_is_a_one_line_error():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        from gateway.web.run import _start

        with pytest.raises(WebListenError) as err:
            await _start(WebServer("127.0.0.1", port), "--web")
    assert str(err.value) == (f"--web 127.0.0.1:{port}: Address already in use; "
                              "choose a free port")


def test_cornet_web_on_a_taken_port_exits_2(capsys):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        code = cli.main(["web", "--zmq", "tcp://127.0.0.1:1", "--listen", f"127.0.0.1:{port}"])
    assert code == 2
    assert capsys.readouterr().err.strip() == (f"cornet web: --listen 127.0.0.1:{port}: Address "
                                               "already in use; choose a free port")


def test_cornet_web_with_a_bad_endpoint_exits_2(capsys):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    code = cli.main(["web", "--zmq", "nonsense", "--listen", f"127.0.0.1:{port}"])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cornet web: --zmq nonsense: ") and "\n" not in err


def test_events_stream_is_fed_in_process_by_the_daemon_publisher():
    from gateway.bus.zmq_pub import Publisher

    async def main():
        pub = Publisher(None)
        from gateway.web.run import attach

        server = await attach(("127.0.0.1", 0), pub)
        try:
            pub.publish(b"cornet.fault", {"t": 3.0, "fault": "vehicle 1 gps off"})
            return server.model.events[-1]
        finally:
            await server.close()

    assert asyncio.run(main())["text"] == "vehicle 1 gps off"


@pytest.mark.asyncio
async def test_cornet_web_is_fed_from_a_zeromq_bus():

    from gateway.bus.zmq_pub import Publisher
    from gateway.web.server import zmq_feed, zmq_subscribe

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        endpoint = f"tcp://127.0.0.1:{s.getsockname()[1]}"
    pub = Publisher(endpoint)
    sock = zmq_subscribe(endpoint)
    server = WebServer("127.0.0.1", 0)
    feed = asyncio.create_task(zmq_feed(server, sock))
    try:
        # A subscription takes a moment to reach the publisher: publish until one arrives.
        for _ in range(500):
            pub.publish(b"cornet.state", state(1.0, (7.0, 0.0)))
            pub.publish(b"cornet.packet", {"t": 1.0, "event": "send"})  # not for the page
            await asyncio.sleep(0.01)
            if server.model.vehicles:
                break
        assert server.model.vehicles[1]["world_ned_m"] == [7.0, 0.0, -1.0]
        assert server.model.ignored == 0
    finally:
        feed.cancel()
        with pytest.raises(asyncio.CancelledError):
            await feed
        sock.close(0)
        pub.close()


def test_frames_are_json_a_browser_parses_even_with_a_nan():
    body = {"vehicles": [{"battery_remaining": float("nan"), "xs": [1.0, float("inf")]}]}
    data = web_server._event("frame", body).decode()
    assert data.startswith("event: frame\ndata: ") and data.endswith("\n\n")
    assert json.loads(data.split("data: ", 1)[1]) == {
        "vehicles": [{"battery_remaining": None, "xs": [1.0, None]}]}


@pytest.mark.asyncio
async def test_a_page_that_stops_reading_never_holds_up_the_feed_or_other_pages():
    """A browser that stops reading: its socket fills, its queue keeps the newest frames and
    counts the rest, while messages are taken in and another page gets every frame."""
    server = WebServer("127.0.0.1", 0, frame_period_s=3600.0)  # frames by hand below
    await server.start()
    stalled = socket.socket()
    stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # a small window
    stalled.connect(("127.0.0.1", server.port))
    try:
        stalled.sendall(b"GET /events HTTP/1.1\r\nHost: x\r\n\r\n")  # and never reads
        async with aiohttp.ClientSession() as http, http.get(f"{server.url}events") as reader:
            await read_event(reader)  # its snapshot
            for _ in range(1000):
                if len(server.pages) == 2:
                    break
                await asyncio.sleep(0.01)
            assert len(server.pages) == 2
            # Big frames (about 300 kB), so that the stalled socket's buffers fill soon.
            many = state(0.0, *[(float(k), 0.0) for k in range(2000)])
            for v in many["vehicles"]:
                v["mode"] = "Hold" + " " * 100
            sent = 0
            while server.frames_dropped == 0 and sent < 500:  # the kernel's buffers, then drops
                server.publish(b"cornet.state", {**many, "t": float(sent)})
                server.broadcast()
                kind, frame = await read_event(reader)
                assert kind == "frame" and frame["t"] == float(sent)
                sent += 1
            assert server.frames_dropped > 0 and server.frames_sent == sent
            (slow,) = [p for p in server.pages if p.dropped]
            assert len(slow.frames) == web_server.QUEUE_FRAMES
            assert server.model.messages == sent
    finally:
        stalled.close()
        await server.close()
