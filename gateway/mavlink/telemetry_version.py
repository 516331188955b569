"""AUTOPILOT_VERSION and STORAGE_INFORMATION as PX4 SITL sends them: on request
(command_requests.py) and as streams at a rate a client sets (streams.py).

Source: PX4 mavlink_main.cpp send_autopilot_capabilities (streams/AUTOPILOT_VERSION.hpp sends it
at every interval), streams/STORAGE_INFORMATION.hpp (a stream object's _storage_id is 0: the
first storage).
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.codec import Encoder, payload_of
from gateway.mavlink.identity import px4_guid, uid
from gateway.mavlink.snapshot import Snapshot

# STORAGE_INFORMATION of the storage directory's file system (MiB): a host's in PX4 SITL
STORAGE_TOTAL_MIB = 102400.0
STORAGE_FREE_MIB = 51200.0

# AUTOPILOT_VERSION as PX4 SITL fills it (MAVLink FTP included: gateway/mavlink/ftp.py).
CAPABILITIES = 59647
FLIGHT_SW_VERSION = 0x010F02FF  # v1.15.2 release
# PX4_GIT_VERSION_BINARY is the first 16 hex digits of the build's git commit as a uint64; ours is
# a fixed one (the start of SHA-1("CORNET")). mavlink_main.cpp send_autopilot_capabilities keeps
# its top 5 bytes, puts the vendor version (0 for a release build) in the low 3 and copies the
# uint64 little-endian. MAVSDK's flight_sw_git_hash prints bytes 3..7 back to front in hex, and
# (info_impl.cpp swap_and_translate_binary_to_str, its buffer one short) loses the last digit to
# the terminating NUL, with PX4 as with us: "3fccf9453\0".
GIT_VERSION_BINARY = 0x3FCCF9453A2543FF
FLIGHT_CUSTOM_VERSION = list((GIT_VERSION_BINARY & 0xFFFFFFFFFF000000).to_bytes(8, "little"))
MIDDLEWARE_CUSTOM_VERSION = FLIGHT_CUSTOM_VERSION  # the same masked hash, no vendor version

_AUTOPILOT_VERSION = payload_of(M.MAVLink_autopilot_version_message)
_STORAGE_INFORMATION = payload_of(M.MAVLink_storage_information_message)


def autopilot_version_payload(sysid: int) -> bytes:
    return _AUTOPILOT_VERSION(CAPABILITIES, FLIGHT_SW_VERSION, FLIGHT_SW_VERSION, 0, 0,
                              FLIGHT_CUSTOM_VERSION, MIDDLEWARE_CUSTOM_VERSION, [0] * 8, 0, 0,
                              uid(sysid), px4_guid(sysid))


def autopilot_version(enc: Encoder, s: Snapshot) -> bytes:
    """AUTOPILOT_VERSION.hpp: send_autopilot_capabilities at every interval."""
    return autopilot_version_payload(enc.sysid)


def storage_information(enc: Encoder, s: Snapshot) -> bytes:
    """STORAGE_INFORMATION.hpp's send() for storage 0 or 1: the file system holding PX4's
    storage directory, as statfs tells (SITL: the host's disk; here a fixed STORAGE_TOTAL_MIB
    with STORAGE_FREE_MIB free), storage 1 of 1, status 2 (available, formatted)."""
    used = STORAGE_TOTAL_MIB - STORAGE_FREE_MIB
    return _STORAGE_INFORMATION(s.time_boot_ms, 1, 1, 2, STORAGE_TOTAL_MIB, used,
                                STORAGE_FREE_MIB, 0.0, 0.0, 0, b"", 0)
