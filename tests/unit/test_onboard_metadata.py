"""Component metadata as PX4 serves it: COMPONENT_METADATA (and COMPONENT_INFORMATION) point at
mftp://etc/extras/component_general.json.xz; that file names parameters.json.xz,
all_events.json.xz and actuators.json.xz, each with the CRC of its compressed bytes; all are read
over MAVLink FTP (burst read, as QGC and MAVSDK do) and decompress to PX4's schema; the ROMFS
part is read-only."""

from __future__ import annotations

import errno
import json
import lzma
import struct

import pytest
from pymavlink.dialects.v20 import common as M
from test_onboard_ftp import Ftp

from gateway.mavlink import ftp
from gateway.onboard import metadata
from gateway.testing import Sim
from vehicles.params import param_table


def fetch(f: Ftp, path: bytes) -> bytes:
    op, data = f.one(ftp.OP_OPEN_RO, path)
    assert op == ftp.OP_ACK
    size = struct.unpack("<I", data)[0]
    got = b""
    while True:  # as MAVSDK: bursts from where the last one stopped (burst_complete), to EOF
        burst = f.call(ftp.OP_BURST, offset=len(got), size=239)
        got += b"".join(r[4] for r in burst if r[1] == ftp.OP_ACK)
        if burst[-1][1] == ftp.OP_NAK:
            assert burst[-1][4] == bytes((ftp.ERR_EOF,))
            break
        assert burst[-1][5] == 1
    # The next request numbered after the stream (as QGC does): one numbered just before the
    # stream's last reply would be taken for a resend of the request it answered (PX4's
    # _last_reply), and get that EOF again.
    f.seq = burst[-1][0]
    assert f.one(ftp.OP_TERMINATE)[0] == ftp.OP_ACK
    assert len(got) == size
    return got


def raw_payloads(api, msg_id: int, since: int) -> list[bytes]:
    """Payloads of a message pymavlink's dialect does not know (it cannot decode them)."""
    return [bytes(raw[10:10 + raw[1]]) for _, mid, raw in api.frames[since:] if mid == msg_id]


def test_the_metadata_flow_qgc_and_mavsdk_follow(tmp_path):
    with Sim(log_dir=tmp_path) as sim:
        sim.advance(1.0)
        api = sim.api(0)
        since = len(api.frames)
        api.send(M.MAVLink_command_long_message(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0, 397,
                                                0, 0, 0, 0, 0, 0))
        sim.advance(0.2)
        answer = raw_payloads(api, 397, since)
        ack = api.messages("COMMAND_ACK", since)
        assert len(answer) == 1 and [a.result for a in ack] == [M.MAV_RESULT_ACCEPTED]
        boot_ms, crc, uri = struct.unpack("<II100s", answer[0].ljust(108, b"\0"))
        assert uri.rstrip(b"\0") == b"mftp://etc/extras/component_general.json.xz"
        assert abs(boot_ms - 1000 * sim.now) < 300

        f = Ftp(sim)
        assert b"Detc\0" in f.one(ftp.OP_LIST, b"/")[1] and \
            b"Dlog\0" in f.one(ftp.OP_LIST, b"/")[1]
        listing = f.one(ftp.OP_LIST, b"/etc/extras")[1]
        for name in (b"component_general", b"parameters", b"all_events", b"actuators"):
            assert b"F" + name + b".json.xz\t" in listing
        general_raw = lzma.decompress(fetch(f, b"etc/extras/component_general.json.xz"))
        assert metadata.mavlink_crc32(general_raw) == crc  # generate_crc.py: uncompressed
        general = json.loads(general_raw)
        assert general["version"] == 1
        ptype, etype, atype = general["metadataTypes"]
        assert ptype["type"] == 1 and ptype["uri"] == "mftp://etc/extras/parameters.json.xz"
        assert etype["type"] == 4 and etype["uri"] == "mftp://etc/extras/all_events.json.xz"
        assert atype["type"] == 5 and atype["uri"] == "mftp://etc/extras/actuators.json.xz"
        # generate_component_general.py: each fileCrc is over the served (compressed) file
        events_xz = fetch(f, b"/etc/extras/all_events.json.xz")
        assert metadata.mavlink_crc32(events_xz) == etype["fileCrc"]
        assert json.loads(lzma.decompress(events_xz))["components"]["1"]["namespace"] == "px4"
        actuators_xz = fetch(f, b"/etc/extras/actuators.json.xz")
        assert metadata.mavlink_crc32(actuators_xz) == atype["fileCrc"]
        assert json.loads(lzma.decompress(actuators_xz))["version"] == 1
        params_xz = fetch(f, b"/etc/extras/parameters.json.xz")
        assert metadata.mavlink_crc32(params_xz) == ptype["fileCrc"]
        params = json.loads(lzma.decompress(params_xz))
        assert params["version"] == 1
        by_name = {p["name"]: p for p in params["parameters"]}
        assert set(by_name) == {i.name for i in param_table()}
        cruise = by_name["MPC_XY_CRUISE"]
        assert cruise["type"] == "Float" and cruise["units"] == "m/s" and cruise["default"] == 5.0
        assert cruise["shortDesc"] and cruise["group"]
        assert by_name["COM_RC_IN_MODE"]["type"] == "Int32"
        assert isinstance(by_name["COM_RC_IN_MODE"]["default"], int)

        # PX4's ROMFS is read-only; a missing file there is ENOENT, sent as FileNotFound
        erofs = bytes((ftp.ERR_FAIL_ERRNO, errno.EROFS))
        assert f.one(ftp.OP_CREATE, b"/etc/extras/x.json")[1] == erofs
        assert f.one(ftp.OP_REMOVE, b"/etc/extras/parameters.json.xz")[1] == erofs
        assert f.one(ftp.OP_RENAME, b"/etc/extras/parameters.json.xz\0/p.xz")[1] == erofs
        assert f.one(ftp.OP_OPEN_RO, b"/etc/extras/nope")[1] == bytes((ftp.ERR_FILE_NOT_FOUND,))
        op, data = f.one(ftp.OP_CRC32, b"/etc/extras/component_general.json.xz")
        assert op == ftp.OP_ACK and struct.unpack("<I", data)[0] == \
            metadata.mavlink_crc32(metadata.shared().files["component_general.json.xz"])

        # the older COMPONENT_INFORMATION (what QGC before COMPONENT_METADATA asks for)
        since = len(api.frames)
        api.send(M.MAVLink_command_long_message(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0, 395,
                                                0, 0, 0, 0, 0, 0))
        sim.advance(0.2)
        [info] = raw_payloads(api, 395, since)
        _, general_crc, _, general_uri, _ = struct.unpack("<III100s100s",
                                                          info.ljust(212, b"\0"))
        assert general_crc == crc and general_uri.rstrip(b"\0") == uri.rstrip(b"\0")
        assert sim.simulation.internal_errors == 0


def test_reboot_required_parameters_say_so():
    """jsonout.py's rebootRequired, from PX4's @reboot_required / reboot_required: QGC asks for a
    reboot after changing one (EKF2_HGT_REF, SYS_AUTOSTART, MAV_SYS_ID...), not after others."""
    from gateway.onboard.metadata import parameter_entry
    from vehicles.params import param_table

    entries = {i.name: parameter_entry(i) for i in param_table()}
    for name in ("EKF2_HGT_REF", "SYS_AUTOSTART", "MAV_SYS_ID", "EKF2_GPS_DELAY", "SDLOG_MODE"):
        assert entries[name]["rebootRequired"] is True, name
    for name in ("MPC_XY_VEL_MAX", "EKF2_BARO_NOISE", "COM_RC_OVERRIDE", "EKF2_GPS_CTRL"):
        assert "rebootRequired" not in entries[name], name


def test_the_metadata_defaults_are_the_firmwares_the_vehicle_boots_with_sitls():
    """parameters.json's default is the PARAM_DEFINE's (jsonout.py), while the vehicle boots
    with, and resets to, what SITL's start-up sets with ``param set-default`` (4001_gz_x500:
    four rotors on ESCs 1..4): QGC then shows those as changed from their defaults, as it
    does against PX4 SITL."""
    doc = json.loads(metadata.parameters_json(param_table()))
    default = {p["name"]: p["default"] for p in doc["parameters"]}
    store = {i.name: i.default for i in param_table()}
    for name, firmware, sitl in (("CA_ROTOR_COUNT", 0, 4), ("SIM_GZ_EC_FUNC1", 0, 101),
                                 ("SIM_GZ_EC_MIN2", 0, 150), ("SIM_GZ_EN", 0, 1),
                                 ("CA_ROTOR1_PY", 0.0, -0.2)):
        assert default[name] == firmware and store[name] == pytest.approx(sitl), name
    assert default["CA_METHOD"] == store["CA_METHOD"] == 2  # the same: one value
