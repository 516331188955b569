"""1,000,000 fuzzed datagrams at a flying vehicle (issue 6, acceptance 2), in lockstep.

Every datagram is malformed by construction — a real frame the vehicle would act on, with one
bit flipped (CRC-16 catches every single-bit error), cut short, or given a lying length byte;
or junk without a frame start — so none may act on the vehicle, each must be counted once as a
bad datagram, and the mission must fly as it does without them. Seeded: the same datagrams and
the same flight every run.
"""

from __future__ import annotations

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as M

from gateway.ci.lockstep import Sim
from gateway.mavlink.session import LinkKind
from tests.unit.test_testing_sim import fly_square

pytestmark = pytest.mark.slow

TOTAL = 1_000_000
PER_TICK = 400  # datagrams injected every 20 ms of simulated time: 20,000 per simulated second


def real_frames() -> list[bytes]:
    """Frames a client sends that would change the flight if they got through."""
    mav = M.MAVLink(None, srcSystem=245, srcComponent=190)
    nan = float("nan")
    msgs = [mav.command_long_encode(1, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 21196, 0, 0, 0, 0,
                                    0),
            mav.command_long_encode(1, 1, M.MAV_CMD_NAV_LAND, 0, nan, nan, nan, nan, nan, nan,
                                    nan),
            mav.command_long_encode(1, 1, M.MAV_CMD_DO_SET_MODE, 0, 1, 4, 3, 0, 0, 0, 0),
            mav.param_set_encode(1, 1, b"MPC_XY_CRUISE", 1.0, M.MAV_PARAM_TYPE_REAL32),
            mav.mission_clear_all_encode(1, 1, 0),
            mav.set_position_target_local_ned_encode(0, 1, 1, 1, 0b110111111000, 0, 0, -50, 0, 0,
                                                     0, 0, 0, 0, 0, 0)]
    return [m.pack(mav) for m in msgs]


def fuzzed(rng: np.random.Generator, frames: list[bytes], n: int) -> list[bytes]:
    out = []
    for _ in range(n):
        f = bytearray(frames[int(rng.integers(len(frames)))])
        kind = int(rng.integers(4))
        if kind == 0:  # one bit flipped anywhere: the CRC (or the framing) fails
            i = int(rng.integers(len(f)))
            f[i] ^= 1 << int(rng.integers(8))
        elif kind == 1:  # cut short
            del f[int(rng.integers(1, len(f))):]
        elif kind == 2:  # the payload length lies
            f[1] = (f[1] + int(rng.integers(1, 255))) & 0xFF
        else:  # junk with no frame start in it
            f = bytearray(rng.integers(0, 0xFD, int(rng.integers(1, 280)), dtype=np.uint8))
        out.append(bytes(f))
    return out


def test_a_million_fuzzed_datagrams_at_a_flying_vehicle_are_counted_and_change_nothing():
    rng = np.random.default_rng(20261122)
    frames = real_frames()
    sent = [0]
    with Sim(1) as sim:
        session = sim.simulation.links[(0, LinkKind.API)].session
        stats = session.stats

        def inject(now: float) -> None:
            k = sent[0]
            if k >= TOTAL:
                return
            n = min(PER_TICK, TOTAL - k)
            for datagram in fuzzed(rng, frames, n):  # a million distinct draws
                sim.simulation.inject(0, LinkKind.API, datagram, ("fuzzer", 6666))
            sent[0] = k + n

        sim.every(0.02, inject)
        fly_square(sim)
        # keep going until every fuzzed datagram went in (the mission may end first)
        sim.run_until(lambda: sent[0] >= TOTAL, timeout_s=120)
        sim.advance(1.0)
        assert sent[0] == TOTAL
        assert sim.simulation.internal_errors == 0
        bad = stats.rx_bad_datagrams
        client_datagrams = stats.rx_datagrams - TOTAL  # the API client's own traffic
        assert bad == TOTAL, (bad, stats)
        assert client_datagrams > 0 and stats.rx_frames > 0
        reached = {m.seq for m in sim.api().messages("MISSION_ITEM_REACHED")}
        assert reached == set(range(6))
        assert sim.status().landed_state.name == "ON_GROUND" and not sim.status().armed
        assert sim.vehicles[0].params["MPC_XY_CRUISE"] != 1.0
