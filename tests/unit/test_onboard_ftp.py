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
        assert b"".join(r[4] for r in burst) == b"hello " * 100 and burst[-1][5] == 1
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
