"""Flight logs (gateway/sim/flightlog.py): tlog format, frame splitting, flushing, mavlogdump."""

import struct
import subprocess
import sys
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink2

from gateway.ci.lockstep import LOCKSTEP_EPOCH_UNIX_S, Sim, mission_item
from gateway.mavlink.session import LinkKind
from gateway.sim.flightlog import (
    STATE_COLUMNS,
    FlightLog,
    frame_msgid,
    new_run_dir,
    read_tlog,
    split_frames,
)
from vehicles.plan_types import MavCmd
from vehicles.types import PX4_SITL_HOME

M = mavlink2


def frames_v1_v2():
    v2 = M.MAVLink(None, 245, 190)
    v1 = M.MAVLink(None, 245, 190)
    v1.WIRE_PROTOCOL_VERSION = "1.0"
    a = v2.heartbeat_encode(6, 8, 0, 0, 4).pack(v2)
    b = v2.command_long_encode(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0).pack(v2)
    c = M.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(v1, force_mavlink1=True)
    return a, b, c


def test_split_frames_by_length_fields_and_skips_garbage():
    a, b, c = frames_v1_v2()
    assert c[0] == 0xFE and a[0] == 0xFD
    assert split_frames(a + b + c) == [a, b, c]
    assert split_frames(b"\x00junk" + a + b"\x01" + b) == [a, b]
    assert split_frames(a + b[:-3]) == [a]  # a truncated last frame is dropped
    assert [frame_msgid(f) for f in (a, b, c)] == [0, 76, 0]
    # One frame per datagram (PX4's way), signed or not, and the same with a byte after it
    signed = bytes([a[0], a[1], a[2] | 1]) + a[3:] + bytes(13)
    for one in (a, b, signed):
        assert split_frames(one) == [one]
        assert split_frames(one + b"\x00") == [one]
        assert split_frames(one[:-1]) == []


def test_tlog_records_are_big_endian_microseconds_then_the_frame(tmp_path):
    a, b, _ = frames_v1_v2()
    log = FlightLog(tmp_path, boot_unix_s=1000.0)
    log.record_datagram("up", 0, LinkKind.API, a + b, 2.5)
    log.record_frame("down", 0, LinkKind.API, a, 3.0)
    log.close()
    data = (tmp_path / "v1-api.tlog").read_bytes()
    assert data[:8] == struct.pack(">Q", 1_002_500_000) and data[8:8 + len(a)] == a
    assert [(t, f) for t, f in read_tlog(tmp_path / "v1-api.tlog")] == [
        (1002.5, a), (1002.5, b), (1003.0, a)]
    assert log.frames == {"up": 2, "down": 1}


def test_new_run_dir_never_reuses_a_directory(tmp_path):
    first = new_run_dir(tmp_path, "run-x")
    second = new_run_dir(tmp_path, "run-x")
    assert first.name == "run-x" and second.name == "run-x-2" and second.is_dir()


def flown_log(run_dir: Path, seconds: float = 3.0) -> Sim:
    sim = Sim(1, log_dir=run_dir)
    g = PX4_SITL_HOME.offset_ned(20, 0, 0)
    sim.run_until(lambda: sim.status().position_valid, 5)
    sim.api().upload_mission([mission_item(MavCmd.NAV_TAKEOFF, g.lat_deg, g.lon_deg, 5),
                              mission_item(MavCmd.NAV_WAYPOINT, g.lat_deg, g.lon_deg, 5)])
    sim.advance(seconds)
    return sim


def test_logs_are_flushed_every_simulated_second_before_close(tmp_path):
    sim = flown_log(tmp_path, 2.5)
    try:  # not closed: what a crash would leave on disk
        state = (tmp_path / "state.csv").read_text().splitlines()
        assert state[0].split(",") == list(STATE_COLUMNS)
        assert len(state) - 1 >= 20  # 10 Hz, flushed at t = 1, 2, 3 s
        assert (tmp_path / "packets.trace").stat().st_size > 0
        assert len(list(read_tlog(tmp_path / "v1-api.tlog"))) > 100
    finally:
        sim.close()
    assert sim.flightlog.closed


def test_mavlogdump_reads_the_tlog(tmp_path):
    flown_log(tmp_path).close()
    tool = Path(sys.executable).parent / "mavlogdump.py"
    out = subprocess.run([sys.executable, str(tool), "--types", "HEARTBEAT,MISSION_ITEM_INT",
                          str(tmp_path / "v1-api.tlog")], capture_output=True, text=True,
                         timeout=60, check=True).stdout.splitlines()
    items = [line for line in out if "MISSION_ITEM_INT" in line]
    beats = [line for line in out if "HEARTBEAT" in line]
    assert len(items) == 2 and "command : 22" in items[0]
    assert len(beats) >= 6  # the vehicle's (1 Hz) and the client's (1 Hz) for ~4 s
    assert out[0].startswith("2026-01-01 00:00:00")  # LOCKSTEP_EPOCH_UNIX_S + simulated time
    assert LOCKSTEP_EPOCH_UNIX_S == 1_767_225_600.0
