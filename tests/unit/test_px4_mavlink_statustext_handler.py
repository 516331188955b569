"""PX4 v1.15.2's MavlinkStatustextHandlerTest.cpp, run against gateway/mavlink/statustext_in.py:
its inputs, and its expectations as written (all seven cases)."""

from __future__ import annotations

from gateway.mavlink.statustext_in import TEXT_SIZE, Statustext, StatustextHandler

SOME_TIME, SOME_OTHER_TIME = 12345678, 99999999
SOME_TEXT, SOME_OTHER_TEXT = b"Some short text", b"Some more short text"
SOME_SEVERITY, SOME_OTHER_SEVERITY = 2, 6  # MAV_SEVERITY_CRITICAL, MAV_SEVERITY_INFO


def st(text: bytes, severity: int = 0, id: int = 0, chunk_seq: int = 0) -> Statustext:
    return Statustext(severity, text[:50].ljust(50, b"\0"), id, chunk_seq)


def test_singles():
    h = StatustextHandler()
    s1 = st(SOME_TEXT, SOME_SEVERITY)
    assert not h.should_publish_previous(s1)
    assert h.should_publish_current(s1, SOME_TIME)
    assert (h.message, h.severity, h.timestamp_us) == (SOME_TEXT.decode(), SOME_SEVERITY, SOME_TIME)
    s2 = st(SOME_OTHER_TEXT, SOME_OTHER_SEVERITY)
    assert not h.should_publish_previous(s2)
    assert h.should_publish_current(s2, SOME_OTHER_TIME)
    assert (h.message, h.severity, h.timestamp_us) == (SOME_OTHER_TEXT.decode(),
                                                        SOME_OTHER_SEVERITY, SOME_OTHER_TIME)


def test_multiple():
    h = StatustextHandler()
    s1 = st(b"a" * 50, SOME_SEVERITY, 1, 0)
    s2 = st(b"b" * 25, SOME_SEVERITY, 1, 1)
    assert not h.should_publish_previous(s1)
    assert not h.should_publish_current(s1, SOME_TIME)
    assert not h.should_publish_previous(s2)
    assert h.should_publish_current(s2, SOME_OTHER_TIME)
    assert len(h.message) == 75 and h.message[30] == "a" and h.message[60] == "b"
    assert (h.severity, h.timestamp_us) == (SOME_SEVERITY, SOME_TIME)


def test_too_many():
    h = StatustextHandler()
    chunks = [st(b"a" * 50, 0, 1, 0), st(b"b" * 50, 0, 1, 1), st(b"c" * 49, 0, 1, 2)]
    for k, c in enumerate(chunks[:2]):
        assert not h.should_publish_previous(c)
        assert not h.should_publish_current(c, SOME_TIME + k)
    assert not h.should_publish_previous(chunks[2])
    assert h.should_publish_current(chunks[2], SOME_TIME + 2)
    assert len(h.message) == TEXT_SIZE - 1


def test_last_missing():
    h = StatustextHandler()
    s1 = st(b"a" * 50, 0, 1, 0)
    assert not h.should_publish_previous(s1)
    assert not h.should_publish_current(s1, SOME_TIME)
    s2 = st(b"b" * 10, 0, 0)
    assert h.should_publish_previous(s2)
    assert len(h.message) == 50 + 15 and h.message[25] == "a"
    assert h.should_publish_previous(s2)
    assert h.should_publish_current(s2, SOME_OTHER_TIME)
    assert len(h.message) == 10 and h.message[5] == "b"


def test_first_missing():
    h = StatustextHandler()
    s2 = st(b"b" * 35, 0, 1, 1)
    assert not h.should_publish_previous(s2)
    assert h.should_publish_current(s2, SOME_TIME)
    assert len(h.message) == 15 + 35 and h.message[20] == "b"


def test_middle_missing():
    h = StatustextHandler()
    s1, s3 = st(b"a" * 50, 0, 1, 0), st(b"c" * 25, 0, 1, 2)
    assert not h.should_publish_previous(s1)
    assert not h.should_publish_current(s1, SOME_TIME)
    assert not h.should_publish_previous(s3)
    assert h.should_publish_current(s3, SOME_TIME + 2)
    assert len(h.message) == 50 + 25 + 15
    assert h.message[20] == "a" and h.message[70] == "c"


def test_no_garbage_after_zero_termination():
    h = StatustextHandler()
    long_text, short_text = b"Some rather long text, ramble ramble", b"Short short"
    for text, severity, now in ((long_text, SOME_SEVERITY, SOME_TIME),
                                (short_text, SOME_OTHER_SEVERITY, SOME_OTHER_TIME)):
        s = st(text, severity)
        assert not h.should_publish_previous(s)
        assert h.should_publish_current(s, now)
        assert h.message == text.decode()
        assert all(b == 0 for b in h.text[len(text):])
