"""Fuzzing the two doors hostile input comes through: the wire (codec → session → services →
vehicle) and the scenario loader. Nothing may raise past the boundary, and no handler may fail
inside it (the simulation counts such failures in ``internal_errors``: they must stay 0).

Hypothesis drives it; examples are derandomized so ``make test`` is repeatable, and a found bug
is shrunk to a minimal datagram or document.
"""

from __future__ import annotations

import itertools
import math
import struct
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as M
from test_mavlink_support import FakeVehicle

from gateway.mavlink.codec import Decoder, DecodeStats
from gateway.mavlink.session import LinkKind, Session
from gateway.mavlink.signing import SigningConfig, SigningKey
from gateway.sim.scenario import ScenarioError, parse
from gateway.sim.simulation import Simulation
from vehicles.params import ParamStore

FUZZ = settings(max_examples=300, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

# --- values of every MAVLink field type, hostile ones included ---------------------------------
_INT_RANGES = {"int8_t": (-128, 127), "uint8_t": (0, 255), "int16_t": (-32768, 32767),
               "uint16_t": (0, 65535), "int32_t": (-2**31, 2**31 - 1), "uint32_t": (0, 2**32 - 1),
               "int64_t": (-2**63, 2**63 - 1), "uint64_t": (0, 2**64 - 1)}
_FLOATS = st.one_of(st.floats(width=32, allow_nan=True, allow_infinity=True),
                    st.sampled_from([0.0, -0.0, 1.0, -1.0, math.nan, math.inf, -math.inf, 1e38]))


def _value(ftype: str) -> st.SearchStrategy:
    if ftype in _INT_RANGES:
        lo, hi = _INT_RANGES[ftype]
        return st.one_of(st.integers(lo, hi), st.sampled_from([lo, hi, 0, 1]))
    if ftype == "float":
        return _FLOATS
    if ftype == "double":
        return st.floats(allow_nan=True, allow_infinity=True)
    raise AssertionError(ftype)


def _args(cls: type) -> st.SearchStrategy:
    """Constructor arguments of a pymavlink message class, each of its wire type."""
    parts = []
    for i, name in enumerate(cls.fieldnames):
        ftype = cls.fieldtypes[i]
        n = cls.array_lengths[cls.ordered_fieldnames.index(name)]
        if ftype == "char":
            parts.append(st.binary(max_size=max(n, 1)))
        elif n:
            parts.append(st.lists(_value(ftype), min_size=n, max_size=n))
        else:
            parts.append(_value(ftype))
    return st.tuples(*parts)



def _routed() -> list[type]:
    """Every message type a vehicle's session routes to a service (read from a Session with
    signing on, so SETUP_SIGNING is among them), in id order."""
    session = Session(FakeVehicle(), LinkKind.API,
                      signing=SigningConfig(SigningKey(bytes(32)), 1_750_000_000.0))
    return [M.mavlink_map[i] for i in sorted(session._routes)]


# What a vehicle's session routes, and a few it does not (counted as unhandled).
ROUTED = _routed()
NOT_ROUTED = [M.MAVLink_file_transfer_protocol_message, M.MAVLink_log_request_list_message,
              M.MAVLink_serial_control_message, M.MAVLink_param_ext_request_list_message]
COMMANDS = [M.MAV_CMD_COMPONENT_ARM_DISARM, M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_NAV_LAND,
            M.MAV_CMD_NAV_RETURN_TO_LAUNCH, M.MAV_CMD_DO_SET_MODE, M.MAV_CMD_DO_REPOSITION,
            M.MAV_CMD_MISSION_START, M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAV_CMD_REQUEST_MESSAGE,
            M.MAV_CMD_DO_CHANGE_SPEED, M.MAV_CMD_DO_SET_HOME, M.MAV_CMD_DO_FLIGHTTERMINATION,
            M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, M.MAV_CMD_PREFLIGHT_STORAGE,
            M.MAV_CMD_DO_PAUSE_CONTINUE, M.MAV_CMD_CONDITION_YAW, M.MAV_CMD_DO_SET_ROI_LOCATION,
            M.MAV_CMD_NAV_LOITER_UNLIM, M.MAV_CMD_DO_MOTOR_TEST, M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
            M.MAV_CMD_ACTUATOR_TEST, M.MAV_CMD_PREFLIGHT_CALIBRATION,
            M.MAV_CMD_REQUEST_FLIGHT_INFORMATION]
PARAM_NAMES = ["MIS_TAKEOFF_ALT", "MAV_SYS_ID", "COM_DL_LOSS_T", "NAV_DLL_ACT", "GF_ACTION",
               "MPC_XY_CRUISE", "SYS_AUTOSTART", "BAT1_N_CELLS", "RTL_RETURN_ALT", "MAV_TYPE"]


@st.composite
def hostile_frame(draw) -> bytes:
    """One well-formed MAVLink 2 frame (valid CRC) with hostile field values, for vehicle 1."""
    cls = draw(st.sampled_from(ROUTED + NOT_ROUTED))
    args = list(draw(_args(cls)))
    names = cls.fieldnames
    if "target_system" in names:  # mostly for us, so the frame reaches the services
        args[names.index("target_system")] = draw(st.sampled_from([1, 1, 1, 0, 2]))
    if "target_component" in names:
        args[names.index("target_component")] = draw(st.sampled_from([1, 0, 190]))
    if "command" in names and draw(st.booleans()):
        args[names.index("command")] = draw(st.sampled_from(COMMANDS))
    if "param_id" in names and draw(st.booleans()):
        args[names.index("param_id")] = draw(st.sampled_from(PARAM_NAMES)).encode()
    msg = cls(*args)
    mav = M.MAVLink(None, srcSystem=draw(st.integers(0, 255)),
                    srcComponent=draw(st.integers(0, 255)))
    return msg.pack(mav, force_mavlink1=False)


@st.composite
def mangled_datagram(draw) -> bytes:
    """Valid frames glued together, then cut, flipped, duplicated or padded with junk."""
    frames = draw(st.lists(hostile_frame(), min_size=1, max_size=4))
    data = bytearray(b"".join(frames))
    for _ in range(draw(st.integers(0, 4))):
        op = draw(st.sampled_from(["flip", "cut", "junk", "dup", "len"]))
        if not data:
            break
        i = draw(st.integers(0, len(data) - 1))
        if op == "flip":
            data[i] ^= 1 << draw(st.integers(0, 7))
        elif op == "cut":
            del data[i:]
        elif op == "junk":
            data[i:i] = draw(st.binary(min_size=1, max_size=32))
        elif op == "dup":
            data += data[i:]
        else:  # a lying payload length byte
            data[i] = draw(st.integers(0, 255))
    return bytes(data)


# One simulation for all examples: building a PyBullet world per example would dominate.
_SIM: list[Simulation] = []


_DOWN: list[bytes] = []  # what the vehicle sent since the last check
# Fields PX4 itself fills with NaN (no terrain estimate, unknown covariance): NaN is their value.
# HOME_POSITION.q: DO_SET_HOME with a yaw (param4) that is not finite sets home's yaw NaN
# (Commander.cpp), and HOME_POSITION.hpp sends Quatf(Eulerf(0, 0, home.yaw)).
NAN_BY_DESIGN = {("ALTITUDE", "bottom_clearance"), ("ALTITUDE", "altitude_terrain"),
                 ("ODOMETRY", "pose_covariance"), ("ODOMETRY", "velocity_covariance"),
                 ("HOME_POSITION", "q"),
                 # estimator_status: NaN for what EKF2 does not fuse (get_innovation_test_status)
                 ("ESTIMATOR_STATUS", "vel_ratio"), ("ESTIMATOR_STATUS", "pos_horiz_ratio"),
                 ("ESTIMATOR_STATUS", "pos_vert_ratio")}
# POSITION_TARGET_*: a setpoint PX4 does not have is NaN, with its IGNORE bit in type_mask.
_IGNORE_BITS = {"x": 1, "y": 2, "z": 4, "vx": 8, "vy": 16, "vz": 32, "afx": 64, "afy": 128,
                "afz": 256, "yaw": 1024, "yaw_rate": 2048}


def _ignored(msg, name: str) -> bool:
    if msg.get_type() == "POSITION_TARGET_GLOBAL_INT":  # PX4 copies the local setpoint's NaNs
        return name in _IGNORE_BITS
    bit = _IGNORE_BITS.get(name)
    return bit is not None and msg.get_type() == "POSITION_TARGET_LOCAL_NED" \
        and bool(msg.type_mask & bit)


def _sim() -> Simulation:
    if not _SIM:
        _SIM.append(Simulation(1))
        _SIM[0].on_downlink = lambda index, kind, datagram, peer: _DOWN.append(datagram)
        _SIM[0].run(until=1.0)
    return _SIM[0]


def non_finite_telemetry() -> list[str]:
    """Fields of what the vehicle sent since the last call that are not finite (and should
    be), as TYPE.field."""
    rx = M.MAVLink(None, 0, 0)
    rx.robust_parsing = True
    bad = []
    for datagram in _DOWN:
        for msg in rx.parse_buffer(datagram) or []:
            if msg.get_type() == "PARAM_VALUE" and msg.param_type != M.MAV_PARAM_TYPE_REAL32:
                continue  # an integer's bytes in a float (PARAM_ENCODE_BYTEWISE): any pattern
            for name in msg.get_fieldnames():
                value = getattr(msg, name)
                values = value if isinstance(value, list) else [value]
                if any(isinstance(v, float) and not math.isfinite(v) for v in values) \
                        and (msg.get_type(), name) not in NAN_BY_DESIGN \
                        and not _ignored(msg, name):
                    bad.append(f"{msg.get_type()}.{name}")
    _DOWN.clear()
    return bad


@pytest.fixture(scope="module", autouse=True)
def _close_sim():
    yield
    for sim in _SIM:
        sim.close()
    _SIM.clear()


@FUZZ
@given(st.binary(max_size=2048))
def test_decoder_never_raises_on_any_bytes(data):
    stats = DecodeStats()
    Decoder(stats).feed(data, 0.0)
    assert stats.rx_datagrams == 1 and stats.rx_bytes == len(data)


@settings(FUZZ, max_examples=1000)
@given(st.lists(hostile_frame(), min_size=1, max_size=3), st.sampled_from(list(LinkKind)))
def test_well_formed_hostile_frames_reach_the_services_and_nothing_fails(frames, kind):
    sim = _sim()
    before = sim.internal_errors
    for f in frames:
        sim.inject(0, kind, f, ("fuzz", 1))
    sim.run(until=sim.now + 0.05)
    assert sim.internal_errors == before
    state = sim.vehicles[0].kinematics
    assert all(math.isfinite(x) for x in state.position_ned_m + state.attitude_q)
    assert non_finite_telemetry() == []


def test_after_the_fuzzing_the_vehicle_still_answers_and_lands():
    """Run after the hostile frames (same simulation): a HEARTBEAT-level health check (it
    streams and answers a command) and a land command."""
    sim = _sim()
    _DOWN.clear()
    mav = M.MAVLink(None, 255, 190)
    land = M.MAVLink_command_long_message(1, 1, M.MAV_CMD_NAV_LAND, 0, 0, 0, 0, 0, math.nan,
                                          math.nan, math.nan).pack(mav)
    sim.inject(0, LinkKind.API, land, ("fuzz", 3))
    sim.run(until=sim.now + 1.0)
    rx = M.MAVLink(None, 0, 0)
    rx.robust_parsing = True
    got = [m for d in _DOWN for m in rx.parse_buffer(d) or []]
    assert any(m.get_type() == "HEARTBEAT" for m in got)
    assert any(m.get_type() == "COMMAND_ACK" and m.command == M.MAV_CMD_NAV_LAND for m in got)
    assert sim.internal_errors == 0


@FUZZ
@given(mangled_datagram())
def test_mangled_datagrams_are_counted_never_fatal(data):
    sim = _sim()
    before = sim.internal_errors
    link = sim.links[(0, LinkKind.API)]
    rx = link.session.stats.rx_datagrams
    sim.inject(0, LinkKind.API, data, ("fuzz", 2))
    sim.run(until=sim.now + 0.02)
    assert sim.internal_errors == before
    assert link.session.stats.rx_datagrams == rx + 1


# --- the scenario loader -----------------------------------------------------------------------
_SCALARS = st.one_of(st.integers(-10**6, 10**6), st.floats(allow_nan=True, allow_infinity=True),
                     st.text(max_size=12), st.booleans(),
                     st.sampled_from(["embedded", "ns3", "wireless", "fixed", "star", "adhoc",
                                      "drop", "deliver", "x500", "info"]))
_KEYS = st.sampled_from(["vehicles", "network", "logging", "count", "home", "airframe", "params",
                         "backend", "seed", "sync_period_s", "late_policy", "ns3", "link",
                         "model", "latency_s", "loss", "jitter_s", "topology", "up", "down",
                         "ap", "lat_deg", "lon_deg", "alt_amsl_m", "level", "hops", "channel",
                         "outages", "MIS_TAKEOFF_ALT", "MAV_SYS_ID", "bogus",
                         # the tables added since, and the ns-3 backend's
                         "daemon", "environment", "sensors", "faults", "commands", "bind",
                         "port_offset", "speed", "state_dir", "zmq_pub", "web", "gcs",
                         "wind_speed_mps", "noise", "at_s", "event", "vehicle", "nodes", "wifi",
                         "propagation", "wired", "position", "kind", "exponent", "warmup_s",
                         "timeout_s", "extra_radios", "radio", "tx_power_dbm", "spawn_ned_m",
                         "param_files"])
_DOCS = st.recursive(_SCALARS, lambda inner: st.one_of(
    st.dictionaries(_KEYS, inner, max_size=5), st.lists(inner, max_size=3)), max_leaves=20)


@FUZZ
@given(st.dictionaries(_KEYS, _DOCS, max_size=4))
def test_scenario_parse_accepts_or_names_the_problem(doc):
    try:
        parse(doc, "fuzz")
    except ScenarioError as exc:
        assert str(exc)  # says what to fix
    # any other exception fails the test


@FUZZ
@given(st.binary(max_size=512))
def test_scenario_load_of_any_file_is_a_scenario_error_or_a_scenario(tmp_path_factory, data):
    from gateway.sim.scenario import load

    path = tmp_path_factory.mktemp("fz") / "s.toml"
    path.write_bytes(data)
    try:
        load(path)
    except ScenarioError as exc:
        assert str(exc)


def test_param_store_refuses_what_the_wire_can_say():
    # PARAM_SET carries a float32 for every type: NaN, inf and out-of-range integers.
    store = ParamStore()
    for value in (math.nan, math.inf, -math.inf, 2.0**40):
        with pytest.raises(ValueError):
            store.set("MAV_SYS_ID", value)
    assert struct.unpack("<f", struct.pack("<f", 6.0))[0] == 6.0


def _served_commands() -> list[int]:
    """Every MAV_CMD the command service names (gateway/mavlink/commands.py)."""
    from pathlib import Path

    import gateway.mavlink.commands as commands

    text = Path(commands.__file__).read_text()
    return sorted({v for n, v in vars(M).items()
                   if n.startswith("MAV_CMD_") and isinstance(v, int) and f"M.{n}" in text})


def test_every_served_command_with_each_parameter_hostile_in_turn():
    """inf, -inf, NaN, ±3e38 and 1e12 in each of the seven parameters of every command served,
    as COMMAND_LONG and COMMAND_INT: each gets its ACK, nothing fails inside, no stream floods
    and the vehicle still answers (an inf SET_MESSAGE_INTERVAL once failed inside, and a 1 µs
    one made a stream outrun PX4's MAVLink loop, stalling every vehicle). What the values
    legitimately do stays done (PX4 too terminates on DO_FLIGHTTERMINATION p1 = inf)."""
    from gateway.ci.lockstep import Sim

    hostile = (math.inf, -math.inf, math.nan, 3e38, -3e38, 1e12)
    with Sim(1) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
        for cmd in _served_commands():
            for v, base in itertools.product(hostile, (0.0, 30.0)):  # 30: ATTITUDE's id
                for pos in range(7):
                    p = [base] * 7
                    p[pos] = v
                    xy = 0 if not math.isfinite(v) else int(max(-2**31, min(2**31 - 1, v)))
                    api.send(api.mav.command_long_encode(1, 1, cmd, 0, *p))
                    api.send(api.mav.command_int_encode(1, 1, 0, cmd, 0, 0, *p[:4], xy, xy,
                                                        p[6]))
                sim.advance(0.02)
        sim.advance(1.0)
        assert sim.simulation.internal_errors == 0
        assert len(api.messages("COMMAND_ACK")) >= len(_served_commands()) * len(hostile) * 14
        # No stream outruns PX4's MAVLink loop (one send per 1500 µs at most), and the vehicle
        # still answers.
        n0 = len(api.messages("ATTITUDE"))
        sim.advance(1.0)
        assert len(api.messages("ATTITUDE")) - n0 <= 1e6 / 1500 + 1
        assert api.command_long(M.MAV_CMD_REQUEST_MESSAGE,
                                M.MAVLINK_MSG_ID_AUTOPILOT_VERSION) == 0
        n0 = len(api.messages("HEARTBEAT"))
        sim.advance(2.0)
        assert len(api.messages("HEARTBEAT")) - n0 == 2


@pytest.mark.parametrize("alt_m", [1e12, 3e38, -1e12, 3.4028234663852886e38, -3.4028234663852886e38])
def test_a_reposition_to_a_hostile_altitude_never_stops_a_stream(alt_m):
    """DO_REPOSITION takes any finite altitude (PX4's navigator checks only that it is finite).
    The streams that carry the setpoint (POSITION_TARGET_GLOBAL_INT's float altitude) send it
    as it is; none of them may fail and fall silent."""
    from gateway.ci.lockstep import Sim

    with Sim(1) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        assert api.arm() == 0 and api.takeoff() == 0
        assert sim.run_until(lambda: sim.status(0).nav_state.name == "AUTO_LOITER", timeout_s=20)
        lat, lon = api.last("GLOBAL_POSITION_INT").lat * 1e-7, api.last("GLOBAL_POSITION_INT").lon * 1e-7
        assert api.command_long(M.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, lat, lon,
                                alt_m) == M.MAV_RESULT_ACCEPTED
        since = len(api.frames)
        sim.run_until(lambda: False, timeout_s=3)
        assert sim.simulation.internal_errors == 0
        assert len(api.messages("POSITION_TARGET_GLOBAL_INT", since)) >= 20
        alt = api.messages("POSITION_TARGET_GLOBAL_INT", since)[-1].alt
        assert math.isfinite(alt) and alt == pytest.approx(alt_m, rel=1e-6)


@pytest.mark.parametrize("alt_m", [math.inf, -math.inf, math.nan])
def test_a_takeoff_to_a_non_finite_altitude_takes_the_default(alt_m):
    """PX4's navigator reads NAV_TAKEOFF's param7 only when it is finite: inf climbs to
    MIS_TAKEOFF_ALT like NaN does (it had set a target at -inf, sent as an infinite
    POSITION_TARGET_GLOBAL_INT.alt)."""
    from gateway.ci.lockstep import Sim

    with Sim(1) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        assert api.arm() == 0
        assert api.command_long(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan,
                                alt_m) == M.MAV_RESULT_ACCEPTED
        since = len(api.frames)
        sim.run_until(lambda: False, timeout_s=2)
        target = sim.vehicles[0].targets.global_target_ned_m
        assert target is not None and target[2] == pytest.approx(-2.5, abs=0.05)  # MIS_TAKEOFF_ALT
        assert all(math.isfinite(t.alt) for t in api.messages("POSITION_TARGET_GLOBAL_INT", since))


# --- every shipped scenario, one value or table at a time made hostile ----------------------
_HOSTILE_VALUES = [math.nan, math.inf, -math.inf, -1, 1e308, -1e308, "", True, {}, [1.0] * 5]


def _shipped_docs() -> list[tuple[str, dict]]:
    import tomllib

    root = Path(__file__).resolve().parents[2]
    paths = sorted((root / "scenarios").glob("*.toml")) + [root / "systemd" / "cornet.toml"]
    return [(p.name, tomllib.loads(p.read_text())) for p in paths]


def _places(doc, path=()):
    """(path, value) of every table, list and value of a TOML document."""
    yield path, doc
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) \
        if isinstance(doc, list) else ()
    for key, value in items:
        yield from _places(value, (*path, key))


def _with(doc: dict, path: tuple, change) -> dict:
    import copy

    out = copy.deepcopy(doc)
    inner = out
    for key in path[:-1]:
        inner = inner[key]
    change(inner, path[-1])
    return out


@pytest.mark.parametrize("name, doc", _shipped_docs())
def test_each_value_of_a_shipped_scenario_made_hostile_is_refused_by_key_or_taken(name, doc):
    """Found this way: network.ns3.nodes = nan raised AttributeError, and wireless/lte dB values
    of 1e308 passed the loader and overflowed when the first packet crossed (or at load)."""
    for path, _ in _places(doc):
        if not path:
            continue
        for bad in _HOSTILE_VALUES:
            def put(inner, key, bad=bad):
                inner[key] = bad
            try:
                parse(_with(doc, path, put), name, base_dir=Path("/nonexistent"))
            except ScenarioError as exc:
                assert str(exc)


@pytest.mark.parametrize("name, doc", _shipped_docs())
def test_an_unknown_key_in_any_table_of_a_shipped_scenario_is_named(name, doc):
    """A typo is reported, never ignored: the ns-3 tables (nodes, wifi, propagation) took any."""
    import copy

    for path, table in _places(doc):
        if isinstance(table, dict):
            changed = copy.deepcopy(doc)
            inner = changed
            for key in path:
                inner = inner[key]
            inner["bogus_key"] = 1
            with pytest.raises(ScenarioError, match="bogus_key"):
                parse(changed, name, base_dir=Path("/nonexistent"))
