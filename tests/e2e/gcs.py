"""pymavlink GCS helpers, as QGC or a script would talk to the GCS port."""

import time

from pymavlink import mavutil


def gcs(port: int):
    return mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255,
                                      source_component=190, dialect="common")


def heartbeats_by_sysid(conn, want: set[int], timeout_s: float = 15.0) -> dict[int, object]:
    seen = {}
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and set(seen) != want:
        msg = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
        if msg is not None and msg.get_srcComponent() == 1:
            seen[msg.get_srcSystem()] = msg
    return seen


def read_all_params(conn, sysid: int, timeout_s: float = 30.0) -> tuple[int, dict[int, object]]:
    """PARAM_REQUEST_LIST, then re-request missing indices like QGC does."""
    conn.mav.param_request_list_send(sysid, 1)
    got: dict[int, object] = {}
    count = None
    deadline = time.monotonic() + timeout_s
    last_rx = time.monotonic()
    while time.monotonic() < deadline:
        msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.3)
        if msg is not None and msg.get_srcSystem() == sysid:
            last_rx = time.monotonic()
            if msg.param_id == "_HASH_CHECK":
                continue
            assert count is None or msg.param_count == count, "param_count changed"
            count = msg.param_count
            got[msg.param_index] = msg
        if count is not None and len(got) == count:
            break
        if count is not None and time.monotonic() - last_rx > 0.5:
            for idx in [i for i in range(count) if i not in got][:10]:
                conn.mav.param_request_read_send(sysid, 1, b"", idx)
    return count, got


def upload_mission(conn, sysid: int, items: list[tuple[int, int, float, float, float]],
                   mission_type: int = 0, timeout_s: float = 15.0) -> int:
    """MISSION_COUNT → MISSION_REQUEST_INT … → MISSION_ACK; items are (command, frame, lat, lon,
    alt). Returns the MISSION_ACK result."""
    conn.mav.mission_count_send(sysid, 1, len(items), mission_type)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        msg = conn.recv_match(type=["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"],
                              blocking=True, timeout=0.5)
        if msg is None or msg.get_srcSystem() != sysid:
            continue
        if msg.get_type() == "MISSION_ACK":
            return msg.type
        command, frame, lat, lon, alt = items[msg.seq]
        conn.mav.mission_item_int_send(sysid, 1, msg.seq, frame, command, int(msg.seq == 0), 1,
                                       0, 0, 0, float("nan"), int(lat * 1e7), int(lon * 1e7), alt,
                                       mission_type)
    raise AssertionError("mission upload timed out")


def command_long(conn, command: int, *params: float, timeout_s: float = 6.0,
                 target: int = 1) -> int | None:
    """COMMAND_LONG to vehicle ``target`` (component 1), resent with a higher confirmation every
    0.5 s as MAVSDK does, until its COMMAND_ACK or ``timeout_s``. Returns MAV_RESULT, None on
    time-out."""
    p = list(params) + [0.0] * (7 - len(params))
    deadline = time.monotonic() + timeout_s
    confirmation = 0
    while time.monotonic() < deadline:
        conn.mav.command_long_send(target, 1, command, min(confirmation, 255), *p)
        confirmation += 1
        ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.5,
                              condition=f"COMMAND_ACK.command=={command}")
        if ack is not None:
            return ack.result
    return None


def arm_and_take_off(conn, above_m: float, timeout_s: float = 20.0, target: int = 1) -> None:
    """Arm vehicle ``target`` (retrying while pre-arm checks settle), NAV_TAKEOFF to the default
    altitude, and wait until its GLOBAL_POSITION_INT shows it ``above_m`` over home."""
    arm, takeoff = 400, 22  # MAV_CMD_COMPONENT_ARM_DISARM, MAV_CMD_NAV_TAKEOFF
    deadline = time.monotonic() + timeout_s
    while command_long(conn, arm, 1, target=target) != 0:
        assert time.monotonic() < deadline, "could not arm"
        time.sleep(0.5)
    assert command_long(conn, takeoff, *([float("nan")] * 7), target=target) == 0
    deadline = time.monotonic() + timeout_s
    while True:
        pos = conn.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=1)
        if pos is not None and pos.get_srcSystem() == target and pos.relative_alt > above_m * 1000:
            return
        assert time.monotonic() < deadline, "did not climb"


class MultiLinkGcs:
    """A GCS on one UDP port that tells its vehicles' links apart by their source address, as
    QGC's UDP link does (one vehicle heard from two ports: one system over two links). Each
    datagram's frames are parsed with the address they came from; ``send_to`` answers one
    link only (QGC's priority link)."""

    def __init__(self, port: int) -> None:
        import socket

        from pymavlink.dialects.v20 import common

        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", port))
        self.sock.settimeout(0.2)
        self.mav = common.MAVLink(None, srcSystem=255, srcComponent=190)
        self.mav.robust_parsing = True
        self._parsers: dict[tuple[str, int], object] = {}

    def recv(self, timeout_s: float = 0.5) -> list[tuple[tuple[str, int], object]]:
        """(source address, message) for every frame of the datagrams that arrive within
        ``timeout_s`` (at least one datagram's worth if any arrives)."""
        from pymavlink.dialects.v20 import common

        out: list[tuple[tuple[str, int], object]] = []
        deadline = time.monotonic() + timeout_s
        while not out and time.monotonic() < deadline:
            try:
                data, addr = self.sock.recvfrom(65535)
            except TimeoutError:
                continue
            parser = self._parsers.setdefault(addr, common.MAVLink(None))
            parser.robust_parsing = True  # type: ignore[attr-defined]
            for msg in parser.parse_buffer(data) or []:  # type: ignore[attr-defined]
                if msg.get_type() != "BAD_DATA":
                    out.append((addr, msg))
        return out

    def send_to(self, addr: tuple[str, int], msg) -> None:
        self.sock.sendto(msg.pack(self.mav), addr)

    def heartbeat(self):
        from pymavlink.dialects.v20 import common

        return common.MAVLink_heartbeat_message(common.MAV_TYPE_GCS, common.MAV_AUTOPILOT_INVALID,
                                               0, 0, 0, 3)

    def close(self) -> None:
        self.sock.close()
