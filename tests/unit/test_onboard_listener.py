"""``listener``'s printing against uORB's orb_print_message_internal (PX4 uORB.cpp)."""

import math

from gateway.onboard.listener import print_message

NESTED = {"esc_report": (("uint64_t", "timestamp"), ("int32_t", "esc_rpm"))}


def lines(fields, values, now_us=2_500_000):
    return print_message(fields, iter(values), now_us, NESTED).splitlines()


def test_scalars_arrays_and_the_annotations_uorb_adds():
    out = lines((("uint64_t", "timestamp"), ("uint64_t", "timestamp_sample"), ("float", "x"),
                 ("double", "lat"), ("bool", "valid"), ("float[3]", "v"),
                 ("uint16_t", "health_flags"), ("uint8_t", "fault_flags"),
                 ("float[4]", "q"), ("float", "nan")),
                (2_000_000, 1_999_000, 1.0 / 3.0, 47.3977419, True, 1.0, -2.0, math.inf,  # flat
                 0x21, 0, 1.0, 0.0, 0.0, 0.0, math.nan))
    assert out == [
        "    timestamp: 2000000 (0.500000 seconds ago)",
        "    timestamp_sample: 1999000 (1000 us before timestamp)",
        "    x: 0.33333",
        "    lat: 47.397742",
        "    valid: True",
        "    v: [1.00000, -2.00000, inf]",
        "    health_flags: 33 (0b10'0001)",  # a ' between nibbles, from the low bit
        "    fault_flags: 0",  # no bits: no annotation
        "    q: [1.00000, 0.00000, 0.00000, 0.00000] (Roll: 0.0 deg, Pitch: 0.0 deg, Yaw: 0.0 deg)",
        "    nan: nan",
    ]


def test_a_zero_timestamp_has_no_age_and_nested_messages_print_by_element():
    out = lines((("uint64_t", "timestamp"), ("uint8_t", "esc_count"),
                 ("esc_report[2]", "esc")), (0, 2, 2_500_000, 900, 0, 0))
    assert out == ["    timestamp: 0", "    esc_count: 2",
                   "  esc[0] (esc_report):", "    timestamp: 2500000 (0.000000 seconds ago)",
                   "    esc_rpm: 900",
                   "  esc[1] (esc_report):", "    timestamp: 0", "    esc_rpm: 0"]


def test_padding_is_not_printed():
    """orb_print_message_internal skips ``_padding*`` fields; a record has no trailing one."""
    out = lines((("uint64_t", "timestamp"), ("float", "tilt_limit"), ("uint8_t", "takeoff_state"),
                 ("uint8_t[3]", "_padding0")), (2_000_000, 0.5, 2))
    assert out == ["    timestamp: 2000000 (0.500000 seconds ago)", "    tilt_limit: 0.50000",
                   "    takeoff_state: 2"]
