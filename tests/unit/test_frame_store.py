"""The lockstep client's received frames: compact, indexed by arrival, optionally a bounded window."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from gateway.ci.frame_store import FrameStore
from gateway.testing import Sim

frames = st.lists(st.tuples(st.floats(0, 1.0), st.integers(0, 2**24 - 1),
                            st.binary(min_size=12, max_size=280)), max_size=60)


@given(frames)
def test_it_returns_what_a_list_of_tuples_would(received):
    store, plain, t = FrameStore(), [], 0.0
    for dt, msgid, frame in received:
        t += dt
        assert store.append(t, msgid, frame) == len(plain)
        plain.append((t, msgid, frame))
    assert len(store) == len(plain) and list(store) == plain
    assert store[1:] == plain[1:] and store[-1:] == plain[-1:] and store[::2] == plain[::2]
    for i, (t_i, msgid, frame) in enumerate(plain):
        assert store[i] == plain[i] and store[i - len(plain)] == plain[i]
        assert (store.time_s(i), store.msgid(i), store.frame(i)) == (t_i, msgid, frame)
    for msgid in {m for _, m, _ in plain}:
        want = [i for i, (_, m, _) in enumerate(plain) if m == msgid]
        assert list(store.find(frozenset((msgid,)), 0)) == want
        assert list(store.find(frozenset((msgid,)), 3, 9)) == [i for i in want if 3 <= i < 9]
        assert list(store.last(msgid)) == want[::-1]
    with pytest.raises(IndexError, match="not received yet"):
        store.frame(len(plain))


@given(frames, st.floats(0.05, 2.0))
def test_a_window_forgets_only_frames_older_than_history(received, history_s):
    store, plain, t = FrameStore(history_s), [], 0.0
    for dt, msgid, frame in received:
        t += dt
        store.append(t, msgid, frame)
        plain.append((t, msgid, frame))
        # Forgotten: only frames older than the window. Kept: none older than 1.5 windows (the
        # store forgets in batches).
        assert all(plain[i][0] < t - history_s for i in range(store.first))
        assert all(store[i] == plain[i] and plain[i][0] >= t - 1.5 * history_s - 1e-9
                   for i in range(store.first, len(plain)))
    assert len(store) == len(plain) and list(store) == plain[store.first:]
    if store.first:
        with pytest.raises(IndexError, match="forgotten"):
            store[store.first - 1]


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan])
def test_a_window_must_be_positive(bad):
    with pytest.raises(ValueError, match="history_s"):
        FrameStore(bad)


def test_a_lockstep_client_with_a_window_keeps_a_bounded_tail_that_still_answers():
    with Sim(1, history_s=5.0) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        sim.advance(30.0)
        kept = len(api.frames) - api.frames.first
        assert api.frames.first > 0 and kept < 8.0 * 450  # ~420 frames per second, ≤ 7.5 s
        assert api.last("HEARTBEAT") is not None
        assert len(api.messages("HEARTBEAT")) in range(5, 9)  # 1 Hz over the last 5-7.5 s
        assert api.arm() == 0  # the command round trip reads frames received after the cut
        assert api.takeoff() == 0
