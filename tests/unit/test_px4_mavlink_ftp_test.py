"""PX4's own unit tests of its MAVLink FTP server, run against CORNET's FtpService.

Source: PX4 src/modules/mavlink/mavlink_tests/mavlink_ftp_test.cpp and mavlink_ftp_test.h
(the 2014-2021 version in which every case runs: PX4_STORAGEDIR paths, Linux readdir's "." and
".." counted, reads asking for ``payload.size`` bytes), with the data of mavlink_ftp_test_data.py
(test_238/239/240.data: bytes counting up from 0). One test per PX4 case, named after it; each
builds what PX4's ``_init`` builds in a tmp_path that is the FTP root.

How PX4's harness maps here:
- The server is sysid 50 (MavlinkFtpTest::serverSystemId), the client sysid 1, compid 0; every
  reply must target the client (network 0) and carry the next sequence number: the client
  numbers its requests 0, 2, 4 …, the server answers each with request + 1, a burst's packets
  count on from there (``_decode_message``).
- SITL's paths: PX4_MAVLINK_TEST_DATA_DIR is ``ftp_unit_test_data`` (empty_dir and the three
  data files), PX4_STORAGEDIR is ``.``; PX4 resolves them against the SITL working directory,
  CORNET against the vehicle root. Where PX4 splits NuttX from Linux, the Linux answer is the
  one SITL gives and the one expected here.
- ``_ftp_server->send()`` (burst packets) is ``handle_timer`` at ``due_s``.

Nothing is skipped: all fourteen cases of PX4's run_tests() apply.
"""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.mavlink import ftp
from gateway.mavlink.codec import Encoder
from gateway.mavlink.ftp import FtpService
from gateway.mavlink.link import LinkContext, LinkKind, SessionStats
from gateway.onboard.files import VehicleFiles

SERVER_SYSID, SERVER_COMPID = 50, 1
CLIENT_SYSID, CLIENT_COMPID = 1, 0
HEADER = struct.Struct("<HBBBBBBI")  # seq, session, opcode, size, req_opcode, burst_complete, pad, offset
MAX_DATA_LEN = 251 - HEADER.size  # 239

DATA_DIR = "ftp_unit_test_data"
TEST_FILES = [f"{DATA_DIR}/test_{n}.data" for n in (238, 239, 240)]
# (file, length, single packet read, exactly fills a packet): _rgDownloadTestCases
DOWNLOADS = [(TEST_FILES[0], MAX_DATA_LEN - 1, True, False),
             (TEST_FILES[1], MAX_DATA_LEN, True, True),
             (TEST_FILES[2], MAX_DATA_LEN + 1, False, False)]
MICROSD_DIR = "./ftp_unit_test_dir"  # PX4_STORAGEDIR "/ftp_unit_test_dir"
MICROSD_FILE = "./ftp_unit_test_dir/file"


class Reply:
    def __init__(self, msg: M.MAVLink_file_transfer_protocol_message) -> None:
        raw = bytes(msg.payload)
        (self.seq, self.session, self.opcode, self.size, self.req_opcode, self.burst_complete,
         _, self.offset) = HEADER.unpack_from(raw)
        self.data = raw[HEADER.size:HEADER.size + self.size]
        self.msg = msg


class MavlinkFtpTest:
    """PX4's MavlinkFtpTest fixture: ``_init`` (a fresh server, the test files) and its
    ``_send_receive_msg`` / ``_decode_message``."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.out: list[bytes] = []
        ctx = LinkContext(None, LinkKind.API, SERVER_SYSID,  # type: ignore[arg-type]
                          Encoder(SERVER_SYSID, SERVER_COMPID), SessionStats(),
                          self.out.append, lambda: None)
        self.server = FtpService(ctx)
        self.server.root = VehicleFiles(root)
        self.client = M.MAVLink(None, CLIENT_SYSID, CLIENT_COMPID)
        self.parser = M.MAVLink(None)
        self.expected_seq = 0
        self.now_s = 0.0
        # _create_test_files: three files of bytes counting up, and an empty directory
        (root / DATA_DIR / "empty_dir").mkdir(parents=True)
        for path, length, _, _ in DOWNLOADS:
            (root / path).write_bytes(bytes(i & 0xFF for i in range(length)))

    def file_bytes(self, path: str) -> bytes:
        return (self.root / path).read_bytes()

    def send(self, opcode: int, data: bytes = b"", *, size: int | None = None, offset: int = 0,
             session: int = 0) -> None:
        """``_setup_ftp_msg`` + ``handle_message``: the request gets the next sequence number."""
        payload = HEADER.pack(self.expected_seq, session, opcode,
                              len(data) if size is None else size, 0, 0, 0, offset) + data
        self.expected_seq += 1
        msg = M.MAVLink_file_transfer_protocol_message(0, SERVER_SYSID, SERVER_COMPID,
                                                       list(payload.ljust(251, b"\0")))
        frame = msg.pack(self.client)
        self.server.on_file_transfer_protocol(self.parser.decode(bytearray(frame)), self.now_s)

    def replies(self) -> list[Reply]:
        """Every reply sent since the last call, each checked as ``_decode_message`` does."""
        out = []
        for frame in self.out:
            msg = self.parser.decode(bytearray(frame))
            assert msg.get_srcSystem() == SERVER_SYSID and msg.get_srcComponent() == SERVER_COMPID
            assert (msg.target_network, msg.target_system, msg.target_component) == \
                (0, CLIENT_SYSID, CLIENT_COMPID)
            reply = Reply(msg)
            assert reply.seq == self.expected_seq, "Sequence number mismatch"
            self.expected_seq += 1
            out.append(reply)
        self.out.clear()
        return out

    def call(self, opcode: int, data: bytes = b"", **kw: int) -> Reply:
        """``_send_receive_msg``: one request, exactly one reply."""
        self.send(opcode, data, **kw)
        (reply,) = self.replies()
        assert reply.req_opcode == opcode
        return reply

    def run_burst(self) -> list[Reply]:
        """``_ftp_server->send()`` until the stream is done (get_size() == 0)."""
        for _ in range(1000):
            if not self.server.streaming:
                break
            self.now_s = max(self.now_s, self.server.due_s)
            self.server.handle_timer(self.now_s)
        assert not self.server.streaming, "All packets should have been sent"
        return self.replies()


def cstr(path: str) -> bytes:
    return path.encode() + b"\0"  # PX4 sends strlen(path) + 1 bytes


def nak(reply: Reply, size: int, code: int) -> None:
    assert reply.opcode == ftp.OP_NAK, "Didn't get Nak back"
    assert reply.size == size, "Incorrect payload size"
    assert reply.data[0] == code, "Incorrect error code"


def ack(reply: Reply, size: int) -> None:
    assert reply.opcode == ftp.OP_ACK, "Didn't get Ack back"
    assert reply.size == size, "Incorrect payload size"


@pytest.fixture
def t(tmp_path: Path) -> MavlinkFtpTest:
    return MavlinkFtpTest(tmp_path)


def test_ack_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _ack_test: kCmdNone → Ack with no data."""
    ack(t.call(ftp.OP_NONE), 0)


def test_bad_opcode_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _bad_opcode_test: opcode 0xFF → Nak kErrUnknownCommand."""
    nak(t.call(0xFF), 1, ftp.ERR_UNKNOWN_COMMAND)


def test_bad_datasize_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _bad_datasize_test: ListDirectory whose size field is one more than
    the whole payload (251 + 1) → Nak kErrInvalidDataSize."""
    nak(t.call(ftp.OP_LIST, size=251 + 1), 1, ftp.ERR_INVALID_DATA_SIZE)



def test_list_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _list_test: "/bogus" → Nak kErrFileNotFound; the test data
    directory → its four entries and, on Linux, two skip entries ("S") for "." and "..":
    "Dempty_dir|Ftest_238.data\\t238|Ftest_239.data\\t239|Ftest_240.data\\t240|S|S", six
    entries, size strlen + 1 (the order is readdir's, so PX4 compares entries as a set)."""
    nak(t.call(ftp.OP_LIST, cstr("/bogus")), 1, ftp.ERR_FILE_NOT_FOUND)
    response = "Dempty_dir|Ftest_238.data\t238|Ftest_239.data\t239|Ftest_240.data\t240|S|S"
    reply = t.call(ftp.OP_LIST, cstr(DATA_DIR))
    ack(reply, len(response) + 1)
    entries = reply.data[:-1].decode().split("\0")
    assert all(entry in response.split("|") for entry in entries)
    assert len(entries) == 6


def test_list_eof_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _list_eof_test: ListDirectory of the test data directory at offset 6
    (3 files, 1 directory, "." and "..") → Nak kErrEOF."""
    nak(t.call(ftp.OP_LIST, cstr(DATA_DIR), offset=6), 1, ftp.ERR_EOF)



def test_open_badfile_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _open_badfile_test: OpenFileRO "/foo" (missing) → Nak
    kErrFileNotFound, one byte (ENOENT is not sent as kErrFailErrno)."""
    nak(t.call(ftp.OP_OPEN_RO, cstr("/foo")), 1, ftp.ERR_FILE_NOT_FOUND)


def test_open_terminate_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _open_terminate_test: OpenFileRO of each data file → Ack with the
    file size (uint32); TerminateSession on the session it gave → Ack, no data."""
    for path, length, _, _ in DOWNLOADS:
        reply = t.call(ftp.OP_OPEN_RO, cstr(path))
        ack(reply, 4)
        assert struct.unpack("<I", reply.data)[0] == length == (t.root / path).stat().st_size
        ack(t.call(ftp.OP_TERMINATE, session=reply.session), 0)


def test_terminate_badsession_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _terminate_badsession_test: TerminateSession on the open session's
    id + 1 → Nak kErrInvalidSession."""
    reply = t.call(ftp.OP_OPEN_RO, cstr(TEST_FILES[0]))
    assert reply.opcode == ftp.OP_ACK
    nak(t.call(ftp.OP_TERMINATE, session=reply.session + 1), 1, ftp.ERR_INVALID_SESSION)


def test_read_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _read_test: open each data file, then ReadFile from offset 0 asking
    for min(239, what is left) bytes (the size field) until the whole file is read: every Ack
    has the request's offset, the size asked for and the file's bytes; then Terminate → Ack."""
    for path, length, _, _ in DOWNLOADS:
        content = t.file_bytes(path)
        assert len(content) == length, "Test case data files are out of date"
        reply = t.call(ftp.OP_OPEN_RO, cstr(path))
        ack(reply, 4)
        size = struct.unpack("<I", reply.data)[0]
        offset = 0
        while offset < size:
            want = min(size - offset, MAX_DATA_LEN)
            reply = t.call(ftp.OP_READ, size=want, offset=offset, session=reply.session)
            assert reply.opcode == ftp.OP_ACK
            assert reply.offset == offset, "Offset incorrect"
            assert reply.size == want, "Payload size incorrect"
            assert reply.data == content[offset:offset + want], "Payload content differs"
            offset += reply.size
        assert offset == size
        ack(t.call(ftp.OP_TERMINATE, session=reply.session), 0)



def test_burst_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _burst_test and _receive_message_handler_burst: BurstReadFile
    (size 239) from offset 0 on each data file: an Ack at offset 0 with min(file, 239) bytes
    and burst_complete 0; for the 240-byte file a second Ack at offset 239 with the last byte,
    burst_complete 0; then a Nak (EOF) ends the stream, nothing after it. Terminate → Ack."""
    for path, length, single_packet, _ in DOWNLOADS:
        content = t.file_bytes(path)
        reply = t.call(ftp.OP_OPEN_RO, cstr(path))
        assert reply.opcode == ftp.OP_ACK
        session = reply.session
        t.send(ftp.OP_BURST, size=MAX_DATA_LEN, offset=0, session=session)
        burst = t.run_burst()
        first = burst[0]
        assert (first.opcode, first.offset, first.burst_complete) == (ftp.OP_ACK, 0, 0)
        expected = length if single_packet else MAX_DATA_LEN
        assert first.size == expected and first.data == content[:expected]
        if not single_packet:
            last = burst[1]
            assert (last.opcode, last.offset, last.burst_complete) == \
                (ftp.OP_ACK, MAX_DATA_LEN, 0)
            assert last.size == length - MAX_DATA_LEN
            assert last.data == content[MAX_DATA_LEN:]
        end = burst[-1]
        assert len(burst) == (2 if single_packet else 3)
        nak(end, 1, ftp.ERR_EOF)
        assert (end.req_opcode, end.offset) == (ftp.OP_BURST, length)
        ack(t.call(ftp.OP_TERMINATE, session=session), 0)


def test_read_badsession_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _read_badsession_test: ReadFile on the open session's id + 1 → Nak
    kErrInvalidSession."""
    reply = t.call(ftp.OP_OPEN_RO, cstr(TEST_FILES[0]))
    assert reply.opcode == ftp.OP_ACK
    nak(t.call(ftp.OP_READ, session=reply.session + 1), 1, ftp.ERR_INVALID_SESSION)


def test_removedirectory_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _removedirectory_test (Linux): with ftp_unit_test_dir holding a
    file, RemoveDirectory "/bogus" → Nak kErrFileNotFound (1 byte); the non-empty directory →
    Nak kErrFailErrno (2 bytes); the file → kErrFailErrno; the directory once the file is
    unlinked → Ack, no data."""
    (t.root / MICROSD_DIR).mkdir()
    (t.root / MICROSD_FILE).touch()
    nak(t.call(ftp.OP_RMDIR, cstr("/bogus")), 1, ftp.ERR_FILE_NOT_FOUND)
    nak(t.call(ftp.OP_RMDIR, cstr(MICROSD_DIR)), 2, ftp.ERR_FAIL_ERRNO)
    nak(t.call(ftp.OP_RMDIR, cstr(MICROSD_FILE)), 2, ftp.ERR_FAIL_ERRNO)
    (t.root / MICROSD_FILE).unlink()
    ack(t.call(ftp.OP_RMDIR, cstr(MICROSD_DIR)), 0)
    assert not (t.root / MICROSD_DIR).exists()



def test_createdirectory_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _createdirectory_test (Linux): CreateDirectory ftp_unit_test_dir →
    Ack; again → Nak kErrFailFileExists (1 byte); ftp_unit_test_data/bogus/bogus (missing
    parent, ENOENT on Linux) → Nak kErrFileNotFound (1 byte)."""
    ack(t.call(ftp.OP_MKDIR, cstr(MICROSD_DIR)), 0)
    assert (t.root / MICROSD_DIR).is_dir()
    nak(t.call(ftp.OP_MKDIR, cstr(MICROSD_DIR)), 1, ftp.ERR_FILE_EXISTS)
    nak(t.call(ftp.OP_MKDIR, cstr(f"{DATA_DIR}/bogus/bogus")), 1, ftp.ERR_FILE_NOT_FOUND)


def test_removefile_test(t: MavlinkFtpTest) -> None:
    """mavlink_ftp_test.cpp, _removefile_test (Linux): RemoveFile "/bogus" → Nak
    kErrFileNotFound; the directory → Nak kErrFailErrno (2 bytes); the file → Ack; the file
    again → Nak kErrFileNotFound."""
    (t.root / MICROSD_DIR).mkdir()
    (t.root / MICROSD_FILE).touch()
    nak(t.call(ftp.OP_REMOVE, cstr("/bogus")), 1, ftp.ERR_FILE_NOT_FOUND)
    nak(t.call(ftp.OP_REMOVE, cstr(MICROSD_DIR)), 2, ftp.ERR_FAIL_ERRNO)
    ack(t.call(ftp.OP_REMOVE, cstr(MICROSD_FILE)), 0)
    assert not (t.root / MICROSD_FILE).exists()
    nak(t.call(ftp.OP_REMOVE, cstr(MICROSD_FILE)), 1, ftp.ERR_FILE_NOT_FOUND)
