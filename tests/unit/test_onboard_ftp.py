"""MAVLink FTP as PX4's MavlinkFTP over the vehicle's root: list, open/read, burst read, create,
write, CRC32, rename, remove, mkdir/rmdir; PX4's NAKs; no path leaves the root."""

from __future__ import annotations

import struct
import zlib

from pymavlink.dialects.v20 import common as M

from gateway.mavlink import ftp
from gateway.testing import Sim

HEADER = struct.Struct("<HBBBBBBI")


class Ftp:
    def __init__(self, sim: Sim) -> None:
        self.sim, self.api, self.seq = sim, sim.api(0), 0

    def call(self, op: int, data: bytes = b"", offset: int = 0, session: int = 0,
             size: int | None = None) -> list:
        since = len(self.api.frames)
        self.seq += 1
        payload = HEADER.pack(self.seq, session, op, len(data) if size is None else size, 0, 0, 0,
                              offset) + data
        self.api.send(M.MAVLink_file_transfer_protocol_message(0, 1, 1,
                                                               list(payload.ljust(251, b"\0"))))
        self.sim.advance(0.2)
        out = []
        for m in self.api.messages("FILE_TRANSFER_PROTOCOL", since):
            raw = bytes(m.payload)
            seq, sess, opcode, sz, req, burst, _, ofs = HEADER.unpack_from(raw)
            out.append((seq, opcode, req, ofs, raw[12:12 + sz], burst))
        return out

    def one(self, op: int, data: bytes = b"", **kw) -> tuple[int, bytes]:
        replies = self.call(op, data, **kw)
        assert len(replies) == 1 and replies[0][0] == self.seq + 1 and replies[0][2] == op
        return replies[0][1], replies[0][4]


def test_ftp_over_the_vehicle_root(tmp_path):
    with Sim(log_dir=tmp_path) as sim:
        sim.advance(1.0)
        root = tmp_path / "vehicle-1"
        (root / "notes.txt").write_bytes(b"hello " * 100)
        f = Ftp(sim)
        op, data = f.one(ftp.OP_LIST, b"/")
        assert op == ftp.OP_ACK and b"Dlog\0" in data and b"Fnotes.txt\t600\0" in data
        assert f.one(ftp.OP_LIST, b"/", offset=99) == (ftp.OP_NAK, bytes((ftp.ERR_EOF,)))
        op, data = f.one(ftp.OP_OPEN_RO, b"/notes.txt")
        assert op == ftp.OP_ACK and struct.unpack("<I", data)[0] == 600
        assert f.one(ftp.OP_OPEN_RO, b"/notes.txt")[1] == bytes((ftp.ERR_NO_SESSIONS,))
        op, data = f.one(ftp.OP_READ, offset=239, size=239)
        assert op == ftp.OP_ACK and data == (b"hello " * 100)[239:478]
        assert f.one(ftp.OP_READ, offset=600, size=239)[1] == bytes((ftp.ERR_EOF,))
        burst = f.call(ftp.OP_BURST, offset=0, size=239)
        assert b"".join(r[4] for r in burst[:-1]) == b"hello " * 100
        assert [r[1] for r in burst] == [ftp.OP_ACK] * 3 + [ftp.OP_NAK]
        assert burst[-1][4] == bytes((ftp.ERR_EOF,)) and not any(r[5] for r in burst)
        assert f.one(ftp.OP_TERMINATE)[0] == ftp.OP_ACK
        # write a file, check its CRC, rename, remove
        assert f.one(ftp.OP_CREATE, b"/new.bin")[0] == ftp.OP_ACK
        assert f.one(ftp.OP_WRITE, b"abcdef", offset=0)[0] == ftp.OP_ACK
        assert f.one(ftp.OP_RESET)[0] == ftp.OP_ACK
        op, data = f.one(ftp.OP_CRC32, b"/new.bin")
        # PX4's crc32part: start at 0, no final XOR (MAVSDK computes the same)
        assert struct.unpack("<I", data)[0] == ~zlib.crc32(b"abcdef", 0xFFFFFFFF) & 0xFFFFFFFF
        assert f.one(ftp.OP_RENAME, b"/new.bin\0/moved.bin")[0] == ftp.OP_ACK
        assert (root / "moved.bin").read_bytes() == b"abcdef"
        assert f.one(ftp.OP_REMOVE, b"/moved.bin")[0] == ftp.OP_ACK
        assert f.one(ftp.OP_REMOVE, b"/moved.bin")[1] == bytes((ftp.ERR_FILE_NOT_FOUND,))
        assert f.one(ftp.OP_MKDIR, b"/d")[0] == ftp.OP_ACK
        assert f.one(ftp.OP_MKDIR, b"/d")[1] == bytes((ftp.ERR_FILE_EXISTS,))
        assert f.one(ftp.OP_RMDIR, b"/d")[0] == ftp.OP_ACK
        # hostile input: escapes, missing files, unknown opcodes, oversize, bad sessions
        assert f.one(ftp.OP_LIST, b"/../..")[1] == bytes((ftp.ERR_FILE_PROTECTED,))
        assert f.one(ftp.OP_OPEN_RO, b"/log/../../../etc/passwd")[1] == \
            bytes((ftp.ERR_FILE_PROTECTED,))
        assert f.one(ftp.OP_OPEN_RO, b"/nope")[1] == bytes((ftp.ERR_FILE_NOT_FOUND,))
        assert f.one(99)[1] == bytes((ftp.ERR_UNKNOWN_COMMAND,))
        assert f.one(ftp.OP_READ, size=240)[1] == bytes((ftp.ERR_INVALID_DATA_SIZE,))
        assert f.one(ftp.OP_READ, session=7, size=10)[1] == bytes((ftp.ERR_INVALID_SESSION,))
        assert f.one(ftp.OP_READ, offset=2**32 - 1, size=10)[1] == \
            bytes((ftp.ERR_INVALID_SESSION,))
        assert sim.simulation.internal_errors == 0


def test_without_storage_only_px4s_etc_extras_is_there():
    with Sim() as sim:
        sim.advance(0.5)
        f = Ftp(sim)
        assert f.one(ftp.OP_LIST, b"/") == (ftp.OP_ACK, b"S\0S\0Detc\0")
        assert f.one(ftp.OP_LIST, b"/log")[1] == bytes((ftp.ERR_FILE_NOT_FOUND,))
        assert f.one(ftp.OP_OPEN_RO, b"/notes.txt")[1] == bytes((ftp.ERR_FILE_NOT_FOUND,))
        assert f.one(ftp.OP_CREATE, b"/new.bin")[1] == bytes((ftp.ERR_FILE_NOT_FOUND,))


def test_a_long_burst_ends_as_px4s_does(tmp_path):
    """PX4 mavlink_ftp.cpp send() on a SITL UDP link: 56 packets per 10 ms wake-up (a budget of
    15000 bytes, 266 per frame); the wake-up's last packet once more than 35000 bytes went out
    (the 168th) has burst_complete and the burst ends; the client asks again from there, and
    a NAK EOF follows the file's last byte."""
    with Sim(log_dir=tmp_path) as sim:
        sim.advance(1.0)
        content = bytes(i * 7 & 0xFF for i in range(50_000))
        (tmp_path / "vehicle-1" / "big.bin").write_bytes(content)
        f = Ftp(sim)
        assert f.one(ftp.OP_OPEN_RO, b"/big.bin")[0] == ftp.OP_ACK
        first = f.call(ftp.OP_BURST, offset=0, size=100)
        assert len(first) == 168 and [r[5] for r in first] == [0] * 167 + [1]
        assert [r[0] for r in first] == list(range(f.seq + 1, f.seq + 169))
        assert [r[3] for r in first] == [239 * i for i in range(168)]
        rest = f.call(ftp.OP_BURST, offset=168 * 239, size=239)
        assert rest[-1][1] == ftp.OP_NAK and rest[-1][4] == bytes((ftp.ERR_EOF,))
        assert rest[-1][3] == len(content) and not any(r[5] for r in rest)
        assert b"".join(r[4] for r in first + rest[:-1]) == content


def test_a_resent_request_gets_the_same_answer_and_is_not_run_again(tmp_path):
    """MavlinkFTP keeps its last reply if its data is at most 4 bytes: a request numbered just
    before it is a resend (the answer was lost) and gets it again. An OpenFileRO resent after
    its ACK was lost must not find its own session taken."""
    with Sim(log_dir=tmp_path) as sim:
        sim.advance(1.0)
        (tmp_path / "vehicle-1" / "a.txt").write_bytes(b"x" * 10)
        f = Ftp(sim)
        first = f.one(ftp.OP_OPEN_RO, b"/a.txt")
        f.seq -= 1  # the same request again
        assert f.one(ftp.OP_OPEN_RO, b"/a.txt") == first == (ftp.OP_ACK, struct.pack("<I", 10))
        op, data = f.one(ftp.OP_READ, size=239)  # 10 bytes of data: not kept
        f.seq -= 1
        assert f.one(ftp.OP_READ, size=239) == (op, data)  # run again, same bytes
        assert f.one(ftp.OP_TERMINATE)[0] == ftp.OP_ACK


def test_open_for_writing_create_and_write_answer_as_px4(tmp_path):
    with Sim(log_dir=tmp_path) as sim:
        sim.advance(1.0)
        root = tmp_path / "vehicle-1"
        f = Ftp(sim)
        # OpenFileWO creates a missing file (O_CREAT), its size before: 0
        assert f.one(ftp.OP_OPEN_WO, b"/new.bin") == (ftp.OP_ACK, struct.pack("<I", 0))
        assert f.one(ftp.OP_WRITE, b"abc", offset=0) == (ftp.OP_ACK, struct.pack("<I", 3))
        assert f.one(ftp.OP_TERMINATE)[0] == ftp.OP_ACK
        assert (root / "new.bin").read_bytes() == b"abc"
        # CreateFile answers the size before and empties the file (O_TRUNC)
        assert f.one(ftp.OP_CREATE, b"/new.bin") == (ftp.OP_ACK, struct.pack("<I", 3))
        assert f.one(ftp.OP_TERMINATE)[0] == ftp.OP_ACK
        assert (root / "new.bin").read_bytes() == b""
        # no folder is made on the way (open(2) with O_CREAT)
        assert f.one(ftp.OP_CREATE, b"/nodir/x.bin") == (ftp.OP_NAK, bytes((ftp.ERR_FILE_NOT_FOUND,)))
        # writing on a read-only session: write(2)'s EBADF
        f.one(ftp.OP_OPEN_RO, b"/new.bin")
        assert f.one(ftp.OP_WRITE, b"z") == (ftp.OP_NAK, bytes((ftp.ERR_FAIL_ERRNO, 9)))


def test_requests_to_another_component_are_ignored(tmp_path):
    with Sim(log_dir=tmp_path) as sim:
        sim.advance(1.0)
        api = sim.api(0)
        since = len(api.frames)
        payload = ftp.HEADER.pack(1, 0, ftp.OP_LIST, 2, 0, 0, 0, 0) + b"/\0"
        for component in (100, 0):  # a camera's, then the broadcast address
            api.send(M.MAVLink_file_transfer_protocol_message(0, 1, component,
                                                              list(payload.ljust(251, b"\0"))))
            sim.advance(0.2)
        assert len(api.messages("FILE_TRANSFER_PROTOCOL", since)) == 1


def test_a_session_left_open_is_closed_after_ten_seconds_without_requests(tmp_path):
    """MavlinkFTP::send() closes a session that saw no request for 10 s: a client that went away
    mid-download does not leave the next one with NoSessionsAvailable."""
    with Sim(log_dir=tmp_path) as sim:
        sim.advance(1.0)
        (tmp_path / "vehicle-1" / "a.txt").write_bytes(b"x" * 10)
        f = Ftp(sim)
        assert f.one(ftp.OP_OPEN_RO, b"/a.txt")[0] == ftp.OP_ACK
        sim.advance(5.0)
        assert f.one(ftp.OP_OPEN_RO, b"/a.txt") == (ftp.OP_NAK, bytes((ftp.ERR_NO_SESSIONS,)))
        sim.advance(9.0)  # 9.4 s after that request: still open
        assert f.one(ftp.OP_READ, size=239)[0] == ftp.OP_ACK
        sim.advance(10.5)
        assert f.one(ftp.OP_OPEN_RO, b"/a.txt")[0] == ftp.OP_ACK
