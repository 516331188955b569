"""A vehicle with two radios is one system to a QGC-like GCS and to MAVSDK; losing one radio
keeps the vehicle connected on the other."""

from __future__ import annotations

import asyncio
import logging
import re
import subprocess
import time

import pytest
from pymavlink.dialects.v20 import common as M

from tests.e2e.gcs import MultiLinkGcs
from tests.e2e.persona import first

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

# Vehicle 1 carries its primary radio (the star's Wi-Fi: links v1/gcs/*, v1/api/*) and an LTE
# modem (links v1/lte/*) with its own path to the GCS.
SCENARIO = """\
[vehicles]
count = 1
params = {{NAV_DLL_ACT = 2}}   # a lost GCS would make the vehicle return

[network]
topology = "star"
seed = 5
{outages}

[[network.extra_radios]]
name = "lte"
radio = {{model = "fixed", latency_s = 0.04, jitter_s = 0.005}}
position_ned_m = [0.0, 500.0, -30.0]
{faults}
"""


def scenario_text(outages: str = "", faults: str = "") -> str:
    return SCENARIO.format(outages=outages, faults=faults)


def write_scenario(tmp_path, outages: str = "", faults: str = "") -> str:
    path = tmp_path / "two-radios.toml"
    path.write_text(scenario_text(outages, faults))
    return str(path)


def since_ready(d) -> float:
    """Roughly the daemon's simulated time (speed 1: its clock starts at the ready line)."""
    return time.monotonic() - d.ready_at


def command_over(g: MultiLinkGcs, addr, command: int, *params: float,
                 timeout_s: float = 6.0) -> int | None:
    """COMMAND_LONG to vehicle 1 over one link, resent with a higher confirmation until its
    COMMAND_ACK comes back on that link; the MAV_RESULT, None on time-out."""
    p = list(params) + [0.0] * (7 - len(params))
    deadline = time.monotonic() + timeout_s
    confirmation = 0
    while time.monotonic() < deadline:
        g.send_to(addr, M.MAVLink_command_long_message(1, 1, command, min(confirmation, 255), *p))
        confirmation += 1
        resend = time.monotonic() + 0.5
        while time.monotonic() < resend:
            for src, msg in g.recv(0.1):
                if msg.get_type() == "COMMAND_ACK" and msg.command == command:
                    assert src == addr, f"the ACK came back on {src}, not on {addr}"
                    return msg.result
    return None


def test_cornet_check_lists_the_radios_ports_and_refuses_them_on_ns3(tmp_path):
    from gateway.ci.launcher import cornet_command

    ok = subprocess.run(cornet_command() + ["check", write_scenario(tmp_path)],
                        capture_output=True, text=True, timeout=30)
    assert ok.returncode == 0 and "extra radio lte:" in ok.stdout and \
        "vehicle i binds 19570+i, talks to 14550" in ok.stdout, ok.stdout + ok.stderr
    ns3 = tmp_path / "ns3.toml"
    ns3.write_text(scenario_text().replace('topology = "star"', 'backend = "ns3"'))
    out = subprocess.run(cornet_command() + ["check", str(ns3)], capture_output=True, text=True,
                         timeout=30)
    assert out.returncode == 2 and "network.extra_radios: only the embedded backend" in \
        out.stderr, out.stderr


def test_qgc_like_gcs_keeps_the_vehicle_over_the_surviving_radio(daemon_factory, tmp_path):
    # The primary radio goes dark at t = 8 s for the rest of the test: a fault-timeline event.
    scenario = write_scenario(tmp_path, faults="""
[[faults]]
at_s = 8.0
link = "v1/gcs/*"
event = "outage"
duration_s = 300.0
""")
    d = daemon_factory("--scenario", scenario)
    primary = ("127.0.0.1", d.vehicle_port(0, "gcs"))
    lte = ("127.0.0.1", d.radio_port(0, 1))
    assert f"lte {lte[1]}->{d.gcs_port()}" in d.ready_line
    g = MultiLinkGcs(d.gcs_port())
    try:
        # Both radios: HEARTBEATs of system 1, component 1, from two source ports.
        sources: set[tuple[str, int]] = set()
        deadline = time.monotonic() + 10
        while sources != {primary, lte} and time.monotonic() < deadline:
            for src, msg in g.recv():
                if msg.get_type() == "HEARTBEAT":
                    assert (msg.get_srcSystem(), msg.get_srcComponent()) == (1, 1)
                    sources.add(src)
        assert sources == {primary, lte}
        assert since_ready(d) < 8.0, "too slow to see both radios before the outage"

        # The outage: from then on only the LTE radio is heard; QGC's link keeps the vehicle.
        beats = {primary: 0, lte: 0}
        while since_ready(d) < 10.0:
            g.recv(0.2)
        t_end = time.monotonic() + 4.0
        while time.monotonic() < t_end:
            for link in (primary, lte):  # QGC sends its heartbeat to every link it knows
                g.send_to(link, g.heartbeat())
            for src, msg in g.recv(0.3):
                if msg.get_type() == "HEARTBEAT" and src in beats:
                    beats[src] += 1
        assert beats[primary] == 0 and beats[lte] >= 3, beats

        # Commands over the surviving radio reach the vehicle; the ACK comes back on it.
        assert command_over(g, lte, M.MAV_CMD_REQUEST_MESSAGE,
                            M.MAVLINK_MSG_ID_AUTOPILOT_VERSION) == M.MAV_RESULT_ACCEPTED
        assert command_over(g, primary, M.MAV_CMD_REQUEST_MESSAGE,
                            M.MAVLINK_MSG_ID_AUTOPILOT_VERSION, timeout_s=1.5) is None
        deadline = time.monotonic() + 15
        while command_over(g, lte, M.MAV_CMD_COMPONENT_ARM_DISARM, 1) != M.MAV_RESULT_ACCEPTED:
            assert time.monotonic() < deadline, "could not arm over the LTE radio"
            time.sleep(0.5)
        armed = False
        deadline = time.monotonic() + 5
        while not armed and time.monotonic() < deadline:
            for src, msg in g.recv(0.3):
                if msg.get_type() == "HEARTBEAT" and src == lte:
                    armed = bool(msg.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)
        assert armed, "the LTE radio's HEARTBEAT did not say armed"
        assert command_over(g, lte, M.MAV_CMD_COMPONENT_ARM_DISARM, 0) == M.MAV_RESULT_ACCEPTED
    finally:
        g.close()
    assert d.stop() == 0
    log = "\n".join(d.stderr_lines)
    assert "fault at t=8.000 s" in log
    table = {m.group(1): m.group(2) for m in re.finditer(r"^(v1/\w+/\w+) +\d+ +\d+ +(\S+)",
                                                          log, re.M)}
    assert table["v1/gcs/down"].startswith("outage=") and table["v1/lte/down"] == "0", table


def test_a_radio_with_its_own_remote_port_is_a_second_gcs_link(daemon_factory, tmp_path):
    # QGC with a second UDP link on 14551: the LTE radio talks there, the primary to 14550.
    scenario = tmp_path / "second-link.toml"
    scenario.write_text(scenario_text().replace('name = "lte"',
                                                'name = "lte"\nremote_port = 14551'))
    d = daemon_factory("--scenario", str(scenario))
    assert f"lte {d.radio_port(0, 1)}->{d.gcs_port() + 1}" in d.ready_line
    links = {port: MultiLinkGcs(port) for port in (d.gcs_port(), d.gcs_port() + 1)}
    try:
        heard: dict[int, set] = {port: set() for port in links}
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and not all(heard.values()):
            for port, g in links.items():
                for src, msg in g.recv(0.1):
                    if msg.get_type() == "HEARTBEAT":
                        heard[port].add((src[1], msg.get_srcSystem()))
        time.sleep(1.5)
        for port, g in links.items():  # what else came meanwhile
            for src, msg in g.recv(0.1):
                if msg.get_type() == "HEARTBEAT":
                    heard[port].add((src[1], msg.get_srcSystem()))
        # One vehicle (system 1) on two links, one radio each.
        assert heard == {d.gcs_port(): {(d.vehicle_port(0, "gcs"), 1)},
                         d.gcs_port() + 1: {(d.radio_port(0, 1), 1)}}
        second = links[d.gcs_port() + 1]
        assert command_over(second, ("127.0.0.1", d.radio_port(0, 1)),
                            M.MAV_CMD_REQUEST_MESSAGE,
                            M.MAVLINK_MSG_ID_AUTOPILOT_VERSION) == M.MAV_RESULT_ACCEPTED
    finally:
        for g in links.values():
            g.close()


class _MavsdkServerLog(logging.Handler):
    """What mavsdk_server says (MAVSDK-Python forwards it to the "mavsdk_server" logger)."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(record.getMessage())


@pytest.mark.asyncio
async def test_mavsdk_sees_one_system_and_flies_through_a_blackout_of_each_radio(
        daemon_factory, tmp_path):
    from mavsdk import System

    from gateway.ci.launcher import free_tcp_port

    # LTE dark while the vehicle arms and climbs, the primary radio from the hover on: never
    # both at once.
    scenario = write_scenario(tmp_path, outages="""outages = [
  {link = "v1/lte/*", start_s = 4.0, duration_s = 10.0},
  {link = "v1/gcs/*", start_s = 16.0, duration_s = 60.0},
]""")
    server_log = _MavsdkServerLog()
    logger = logging.getLogger("mavsdk_server")
    level = logger.level
    logger.setLevel(logging.DEBUG)
    logger.addHandler(server_log)
    d = daemon_factory("--scenario", scenario)
    drone = System(port=free_tcp_port())
    texts: list[str] = []
    states: list[bool] = []

    async def collect_texts():
        async for t in drone.telemetry.status_text():
            texts.append(t.text)

    async def collect_states():
        async for s in drone.core.connection_state():
            states.append(s.is_connected)

    tasks: list[asyncio.Future] = []
    try:
        # QGC's port: both radios' GCS-mode instances talk to it.
        await drone.connect(system_address=f"udpin://0.0.0.0:{d.gcs_port()}")
        tasks = [asyncio.ensure_future(collect_texts()), asyncio.ensure_future(collect_states())]
        await first(drone.core.connection_state(), lambda s: s.is_connected, 30, "connection")
        await first(drone.telemetry.health(),
                    lambda h: h.is_global_position_ok and h.is_home_position_ok, 30, "health")
        await drone.action.arm()
        await drone.action.takeoff()
        took_off_at = since_ready(d)
        await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 2.3, 30,
                    "takeoff altitude")
        while since_ready(d) < 18.0:  # hover into the primary radio's outage
            await asyncio.sleep(0.2)
        await drone.action.land()
        await first(drone.telemetry.in_air(), lambda x: not x, 60, "landed")
        await first(drone.telemetry.armed(), lambda a: not a, 15, "auto-disarm")
        landed_at = since_ready(d)
    finally:
        for task in tasks:
            task.cancel()
        drone._stop_mavsdk_server()
        logger.removeHandler(server_log)
        logger.setLevel(level)
    # The flight spanned both outages: LTE dark during the climb, the primary for the landing.
    assert took_off_at < 14.0 and 18.0 <= landed_at < 76.0, (took_off_at, landed_at)
    assert states and all(states[states.index(True):]), "MAVSDK lost the vehicle"
    assert "Connection to ground station lost" not in " ".join(texts), texts
    # One system: heard from two ports, always as system 1, with one autopilot.
    heard = [re.search(r"New system on: [\d.]+:(\d+) \(system ID: (\d+)\)", line)
             for line in server_log.lines]
    found = {(int(m.group(1)), int(m.group(2))) for m in heard if m}
    assert found == {(d.vehicle_port(0, "gcs"), 1), (d.radio_port(0, 1), 1)}, server_log.lines
    added = [line for line in server_log.lines if line.startswith("Component Autopilot")]
    assert len(added) == 1, server_log.lines
    stats = d.stop()
    assert stats == 0
    log = "\n".join(d.stderr_lines)
    table = {m.group(1): m.group(2) for m in re.finditer(r"^(v1/\w+/\w+) +\d+ +\d+ +(\S+)",
                                                          log, re.M)}
    assert table["v1/lte/down"].startswith("outage=") and table["v1/gcs/down"].startswith(
        "outage="), table
