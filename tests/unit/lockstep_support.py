"""What the lockstep tests of one vehicle share (gateway.testing.Sim, a pymavlink client): the
``sim`` fixture, a vehicle whose position estimate is valid, and small readers."""

import pytest

from gateway.testing import Sim
from vehicles.types import PX4_SITL_HOME


def geo(n: float, e: float) -> tuple[float, float]:
    """(lat, lon) of the point ``n`` m north and ``e`` m east of PX4 SITL's home."""
    g = PX4_SITL_HOME.offset_ned(n, e, 0.0)
    return g.lat_deg, g.lon_deg


@pytest.fixture
def sim():
    with Sim(1) as s:
        assert s.run_until(lambda: s.status(0).position_valid, timeout_s=5)
        yield s


def height(sim) -> float:
    return -sim.state(0).position_ned_m[2]


def texts(api, mark=0):
    return [m.text for m in api.messages("STATUSTEXT", since=mark)]
