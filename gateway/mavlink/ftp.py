"""MAVLink FTP (FILE_TRANSFER_PROTOCOL) server, as PX4's MavlinkFTP.

Source: PX4 src/modules/mavlink/mavlink_ftp.cpp, mavlink_ftp.h; the MAVLink FTP spec.
Rules:
- Payload: seq (uint16), session, opcode, size, req_opcode, burst_complete, padding (uint8),
  offset (uint32), data[239]. Every answer is ACK (128) or NAK (129) with ``seq + 1`` and the
  request's opcode in req_opcode; a NAK's data[0] is the error (data[1] errno for FailErrno).
  As PX4's _process_request: an error whose errno is EEXIST is sent as FileExists, a FailErrno
  with ENOENT as FileNotFound (one byte each), so a missing file is never FailErrno.
- Requests to this system and its autopilot component (or 0) only. A request whose sequence
  number comes just before the last reply's is a resend (the reply was lost): the last reply
  goes out again, unexecuted, if its data was at most 4 bytes (PX4 keeps only those: the larger
  ones are reads, safe to run again).
- OpenFileRO / OpenFileWO / CreateFile answer the file's size before opening (4 bytes; 0 for a
  new file): WO creates a missing file, CreateFile also empties an existing one. WriteFile
  answers the count written (4 bytes); on a read-only session FailErrno EBADF.
- One session at a time (PX4's single ``_session_info``), closed after SESSION_IDLE_S without a
  request (a client that went away mid-transfer leaves nothing open): Open* while one is open →
  NoSessionsAvailable; Read/Write/Burst with another session id → InvalidSession.
- ListDirectory at ``offset`` entries (readdir's, "." and ".." included): "F<name>\\t<size>" for a
  file, "D<name>" for a directory, a bare "S" for anything else ("." and "..", a symlink), each
  NUL-ended, as many as fit; none left → NAK EOF. Read at or past the end → NAK EOF.
- BurstReadFile answers nothing at once: every ``PERIOD_S`` ``handle_timer`` sends ACKs of
  DATA_LEN bytes (whatever size was asked; seq counting on from the request's + 1, session 0)
  while PX4's UDP budget lasts; a NAK EOF after the last byte ends the stream. burst_complete
  is set only on the last packet of a wake-up once more than CHUNK bytes went out in this
  burst, which then ends (the client asks again from there).
- The files are the vehicle's root (``root``, a ``FileRoot`` the shell attaches: its logs,
  parameters and plans); a path that leaves the root is refused (FileProtected); without a
  root every path is FileNotFound. Unknown opcodes → NAK UnknownCommand; a size larger than the
  data → InvalidDataSize.
"""

from __future__ import annotations

import math
import struct
from errno import EBADF, EEXIST, ENOENT
from typing import Any, Protocol

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.link import LinkContext

DATA_LEN = 239
HEADER = struct.Struct("<HBBBBBBI")
PERIOD_S = 0.01  # MavlinkReceiver::run calls MavlinkFTP::send() every 10 ms
TX_BUDGET = 15000  # Mavlink::get_free_tx_buf() on a POSIX UDP link: 1500 * 10
FRAME_LEN = 254 + 12  # MavlinkFTP::get_size(): FILE_TRANSFER_PROTOCOL + MAVLink 2 framing
CHUNK = 35000  # bytes after which a wake-up's last packet has burst_complete
SESSION_IDLE_S = 10.0  # MavlinkFTP::send(): a session without a request this long is closed

(OP_NONE, OP_TERMINATE, OP_RESET, OP_LIST, OP_OPEN_RO, OP_READ, OP_CREATE, OP_WRITE, OP_REMOVE,
 OP_MKDIR, OP_RMDIR, OP_OPEN_WO, OP_TRUNCATE, OP_RENAME, OP_CRC32, OP_BURST) = range(16)
OP_ACK, OP_NAK = 128, 129
(ERR_NONE, ERR_FAIL, ERR_FAIL_ERRNO, ERR_INVALID_DATA_SIZE, ERR_INVALID_SESSION,
 ERR_NO_SESSIONS, ERR_EOF, ERR_UNKNOWN_COMMAND, ERR_FILE_EXISTS, ERR_FILE_PROTECTED,
 ERR_FILE_NOT_FOUND) = range(11)


class FtpError(Exception):
    def __init__(self, code: int, errno: int = 0) -> None:
        super().__init__(code, errno)
        self.code, self.errno = code, errno


class FileRoot(Protocol):
    """The vehicle's files; every method raises FtpError (code, errno) on failure."""

    def list(self, path: str) -> list[tuple[str, str, int]]: ...  # (kind, name, size)

    def size(self, path: str) -> int: ...

    def read(self, path: str, offset: int, count: int) -> bytes: ...

    def write(self, path: str, offset: int, data: bytes) -> None: ...

    def create(self, path: str, exclusive: bool) -> None: ...

    def remove(self, path: str) -> None: ...

    def mkdir(self, path: str) -> None: ...

    def rmdir(self, path: str) -> None: ...

    def rename(self, old: str, new: str) -> None: ...

    def truncate(self, path: str, size: int) -> None: ...

    def crc32(self, path: str) -> int: ...


class FtpService:
    def __init__(self, ctx: LinkContext) -> None:
        self.sysid = ctx.sysid
        self.encoder = ctx.encoder
        self.send = ctx.send
        self.root: FileRoot | None = None  # attached by the shell
        self._session: tuple[str, bool] | None = None  # (path, writable)
        self._burst: tuple[int, int, int, tuple[int, int]] | None = None  # seq, offset, chunk, to
        self.due_s = math.inf  # when ``handle_timer`` has work next (the burst, or closing an
        # idle session); inf: none
        # The last reply if its data was at most 4 bytes (MavlinkFTP's _last_reply): a request
        # with the sequence number before its own is a resend, answered with it again.
        self._last_reply: tuple[int, tuple[int, int], bytes] | None = None
        self._active_s = 0.0  # when the last request came

    # --- wire ---------------------------------------------------------------------------------
    def _reply(self, to: tuple[int, int], seq: int, session: int, req: int, offset: int,
               data: bytes = b"", nak: int | None = None, errno: int = 0,
               burst_complete: bool = False) -> None:
        if nak is not None:
            data = bytes((nak, errno)) if nak == ERR_FAIL_ERRNO else bytes((nak,))
        payload = HEADER.pack((seq + 1) & 0xFFFF, session, OP_NAK if nak is not None else OP_ACK,
                              len(data), req, int(burst_complete), 0, offset) + data
        if len(data) <= 4:
            self._last_reply = ((seq + 1) & 0xFFFF, to, payload)
        self._send_payload(to, payload)

    def _send_payload(self, to: tuple[int, int], payload: bytes) -> None:
        self.send(self.encoder.pack(M.MAVLink_file_transfer_protocol_message, 0, to[0], to[1],
                                    list(payload.ljust(251, b"\0"))))

    def on_file_transfer_protocol(self, msg: Any, now_s: float) -> None:
        if msg.target_system not in (0, self.sysid) or msg.target_component not in (
                0, M.MAV_COMP_ID_AUTOPILOT1):
            return
        raw = bytes(msg.payload)
        seq, session, opcode, size, _req, _burst, _pad, offset = HEADER.unpack_from(raw)
        self._active_s = now_s
        last = self._last_reply
        if size <= DATA_LEN and last is not None and (seq + 1) & 0xFFFF == last[0]:
            self._send_payload(last[1], last[2])  # our answer was lost: the same again
            return
        self._last_reply = None
        data = raw[HEADER.size:HEADER.size + DATA_LEN]
        to = (msg.get_srcSystem(), msg.get_srcComponent())

        def nak(code: int, errno: int = 0) -> None:
            if errno == EEXIST:
                code = ERR_FILE_EXISTS
            elif errno == ENOENT and code == ERR_FAIL_ERRNO:
                code = ERR_FILE_NOT_FOUND
            self._reply(to, seq, session, opcode, offset, nak=code, errno=errno)

        if size > DATA_LEN:
            nak(ERR_INVALID_DATA_SIZE)
            return
        arg = data[:size].split(b"\0", 1)[0].decode("utf-8", "replace")
        try:
            self._dispatch(to, seq, session, opcode, size, offset, data, arg, now_s)
        except FtpError as exc:
            nak(exc.code, exc.errno)
        if self._burst is None:
            self.due_s = self._idle_due()

    def _need_root(self) -> FileRoot:
        if self.root is None:
            raise FtpError(ERR_FILE_NOT_FOUND)
        return self.root

    def _need_session(self, session: int) -> tuple[str, bool]:
        if self._session is None or session != 0:
            raise FtpError(ERR_INVALID_SESSION)
        return self._session

    def _dispatch(self, to: tuple[int, int], seq: int, session: int, op: int, size: int,
                  offset: int, data: bytes, arg: str, now_s: float) -> None:
        ack = self._reply
        if op == OP_NONE:
            ack(to, seq, session, op, offset)
        elif op in (OP_TERMINATE, OP_RESET):
            if op == OP_TERMINATE and (self._session is None or session != 0):
                raise FtpError(ERR_INVALID_SESSION)
            self._session, self._burst, self.due_s = None, None, math.inf
            ack(to, seq, session, op, offset)
        elif op == OP_LIST:
            entries = self._need_root().list(arg)
            if offset >= len(entries):
                raise FtpError(ERR_EOF)
            out = b""
            for kind, name, fsize in entries[offset:]:
                item = {"D": f"D{name}", "F": f"F{name}\t{fsize}"}.get(kind, "S").encode() + b"\0"
                if len(out) + len(item) > DATA_LEN:
                    break
                out += item
            ack(to, seq, session, op, offset, out)
        elif op in (OP_OPEN_RO, OP_OPEN_WO, OP_CREATE):
            if self._session is not None:
                raise FtpError(ERR_NO_SESSIONS)
            root = self._need_root()
            if op == OP_OPEN_RO:
                fsize = root.size(arg)
            else:  # O_CREAT (CreateFile also O_TRUNC): the size before, 0 for a new file
                try:
                    fsize = root.size(arg)
                except FtpError:
                    fsize = 0
                    root.create(arg, exclusive=False)
                if op == OP_CREATE and fsize:
                    root.create(arg, exclusive=False)
            self._session = (arg, op != OP_OPEN_RO)
            ack(to, seq, 0, op, offset, struct.pack("<I", fsize))
        elif op == OP_READ:
            path, _ = self._need_session(session)
            chunk = self._need_root().read(path, offset, min(size or DATA_LEN, DATA_LEN))
            if not chunk:
                raise FtpError(ERR_EOF)
            ack(to, seq, session, op, offset, chunk)
        elif op == OP_BURST:
            self._need_session(session)
            self._burst = (seq, offset, 0, to)  # answered by handle_timer, as PX4's stream
            self.due_s = now_s
        elif op == OP_WRITE:
            path, writable = self._need_session(session)
            if not writable:  # write(2) on an O_RDONLY descriptor
                raise FtpError(ERR_FAIL_ERRNO, EBADF)
            self._need_root().write(path, offset, data[:size])
            ack(to, seq, session, op, offset, struct.pack("<I", size))
        elif op == OP_REMOVE:
            self._need_root().remove(arg)
            ack(to, seq, session, op, offset)
        elif op == OP_MKDIR:
            self._need_root().mkdir(arg)
            ack(to, seq, session, op, offset)
        elif op == OP_RMDIR:
            self._need_root().rmdir(arg)
            ack(to, seq, session, op, offset)
        elif op == OP_RENAME:
            parts = data[:size].split(b"\0")
            if len(parts) < 2 or not parts[0] or not parts[1]:
                raise FtpError(ERR_INVALID_DATA_SIZE)
            self._need_root().rename(parts[0].decode("utf-8", "replace"),
                                     parts[1].decode("utf-8", "replace"))
            ack(to, seq, session, op, offset)
        elif op == OP_TRUNCATE:
            self._need_root().truncate(arg, offset)
            ack(to, seq, session, op, offset)
        elif op == OP_CRC32:
            ack(to, seq, session, op, offset, struct.pack("<I", self._need_root().crc32(arg)))
        else:
            raise FtpError(ERR_UNKNOWN_COMMAND)

    # --- burst reads ----------------------------------------------------------------------------
    def get_timer(self) -> float:
        return self.due_s

    @property
    def streaming(self) -> bool:
        """A burst is being sent (PX4's stream_download)."""
        return self._burst is not None

    def _idle_due(self) -> float:
        """When an open session is closed for want of requests (inf: none is open)."""
        return self._active_s + SESSION_IDLE_S if self._session is not None else math.inf

    def handle_timer(self, now_s: float) -> None:
        """PX4's MavlinkFTP::send(): packets of up to DATA_LEN bytes while the UDP budget lasts
        (TX_BUDGET, FRAME_LEN each; the one that leaves less than two frames ends the wake-up,
        with burst_complete and the stream's end once more than CHUNK bytes went out); at the
        file's end, or on a read error, a NAK ends the stream."""
        if self._session is not None and now_s >= self._active_s + SESSION_IDLE_S:
            self._session, self._burst, self.due_s, self._last_reply = None, None, math.inf, None
            return
        if self._burst is None:
            self.due_s = self._idle_due()  # (a resent request was activity too)
            return
        if now_s < self.due_s:
            return
        seq, offset, chunk, to = self._burst
        if self._session is None or self.root is None:
            self._burst, self.due_s = None, math.inf
            return
        path, budget = self._session[0], TX_BUDGET
        while True:
            try:
                if offset >= self.root.size(path):
                    raise FtpError(ERR_EOF)
                data = self.root.read(path, offset, DATA_LEN)
            except FtpError as exc:
                self._reply(to, seq, 0, OP_BURST, offset, nak=exc.code, errno=exc.errno)
                self._burst, self.due_s = None, self._idle_due()
                return
            last = budget < 2 * FRAME_LEN
            complete = last and chunk + len(data) > CHUNK
            self._reply(to, seq, 0, OP_BURST, offset, data, burst_complete=complete)
            seq, offset, chunk = seq + 1, offset + len(data), chunk + len(data)
            if last:
                break
            budget -= FRAME_LEN
        if complete:
            self._burst, self.due_s = None, self._idle_due()
        else:
            self._burst, self.due_s = (seq, offset, chunk, to), now_s + PERIOD_S
