"""Cost-aware admission at a vehicle's UDP port: what a flood may cost the daemon.

A datagram costs the sum of its MAVLink frames' costs, read from the frame headers only (no
CRC, no decode): services that do real work per message — PARAM_SET and the parameter, mission,
command, FTP, log and shell protocols — cost EXPENSIVE_COST; the rest (HEARTBEAT, setpoints,
sticks, PING, TIMESYNC) one unit; bytes that are no frame one unit per datagram.

Three token buckets in cost units must all have room, or the datagram is shed before anything
parses it, and counted by the bucket that refused it:
- per source address (ip, port): one client;
- per source host (ip): a client rotating over source ports shares one budget;
- per port (all sources together): the most one vehicle link may take from the event loop,
  whatever the number of sources.
The budgets are far above what MAVSDK, QGC or MAVProxy send (a parameter download is one
request; a mission upload a few hundred items; setpoints and sticks 20-100 per second).

Pure: ``now`` (seconds, any monotonic clock) is an argument.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Hashable
from dataclasses import asdict, dataclass

# MAVLink message ids whose handling is expensive (common.xml).
EXPENSIVE_MSGIDS = frozenset({
    11,  # SET_MODE
    20, 21, 23,  # PARAM_REQUEST_READ, PARAM_REQUEST_LIST, PARAM_SET
    37, 38, 39, 40, 41, 43, 44, 45, 47, 51, 73,  # MISSION_* (partial lists, items, requests …)
    75, 76,  # COMMAND_INT, COMMAND_LONG
    110,  # FILE_TRANSFER_PROTOCOL
    117, 119, 121, 122,  # LOG_REQUEST_LIST, LOG_REQUEST_DATA, LOG_ERASE, LOG_REQUEST_END
    126,  # SERIAL_CONTROL (the shell)
    256,  # SETUP_SIGNING
})
EXPENSIVE_COST = 10.0
CHEAP_COST = 1.0
MAX_FRAMES_SCANNED = 64  # a datagram of more frames is charged as expensive for the rest

# (rate in cost units per second, burst) per bucket.
PER_SOURCE = (2000.0, 1000.0)
PER_HOST = (4000.0, 2000.0)
PER_PORT = (6000.0, 3000.0)
MAX_KEYS = 256  # remembered per bucket set; the least recently heard is forgotten first

_STX_V2, _STX_V1 = 0xFD, 0xFE


def datagram_cost(data: bytes) -> float:
    """What handling ``data`` may cost, from its frame headers."""
    cost = 0.0
    i, n, frames = 0, len(data), 0
    while i < n:
        stx = data[i]
        if stx == _STX_V2 and i + 10 <= n:
            length = data[i + 1]
            msgid = data[i + 7] | data[i + 8] << 8 | data[i + 9] << 16
            i += 12 + length + (13 if data[i + 2] & 1 else 0)
        elif stx == _STX_V1 and i + 6 <= n:
            msgid = data[i + 5]
            i += 8 + data[i + 1]
        else:
            return cost + CHEAP_COST  # not (or no longer) frames: the decoder skips the rest
        frames += 1
        if frames > MAX_FRAMES_SCANNED:
            return cost + EXPENSIVE_COST * (1 + (n - i) // 12)
        cost += EXPENSIVE_COST if msgid in EXPENSIVE_MSGIDS else CHEAP_COST
    return cost if cost > 0 else CHEAP_COST


class Buckets:
    """Token buckets by key; ``room`` and ``take`` let several buckets be checked first."""

    def __init__(self, rate_per_s: float, burst: float, max_keys: int = MAX_KEYS) -> None:
        if not rate_per_s > 0 or not burst >= 1:
            raise ValueError("rate must be > 0 and burst >= 1")
        self.rate = rate_per_s
        self.burst = burst
        self.max_keys = max_keys
        self._buckets: OrderedDict[Hashable, list[float]] = OrderedDict()

    def room(self, key: Hashable, now: float) -> list[float]:
        """The bucket of ``key``, refilled to ``now`` ([tokens, last time])."""
        b = self._buckets.get(key)
        if b is None:
            if len(self._buckets) >= self.max_keys:
                self._buckets.popitem(last=False)
            b = self._buckets[key] = [self.burst, now]
        else:
            self._buckets.move_to_end(key)
            tokens = b[0] + (now - b[1]) * self.rate
            b[0] = tokens if tokens < self.burst else self.burst
            b[1] = now
        return b

    def allow(self, key: Hashable, now: float, cost: float = 1.0) -> bool:
        b = self.room(key, now)
        if b[0] >= cost:
            b[0] -= cost
            return True
        return False

    def __len__(self) -> int:
        return len(self._buckets)


@dataclass
class AdmissionStats:
    shed_source: int = 0  # datagrams refused by their source address's budget
    shed_host: int = 0  # … by their source host's budget (ports rotated)
    shed_port: int = 0  # … by the port's budget (all sources together)
    shed_cost: float = 0.0  # cost units refused

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


class Admission:
    """The three budgets of one vehicle port."""

    def __init__(self, per_source: tuple[float, float] = PER_SOURCE,
                 per_host: tuple[float, float] = PER_HOST,
                 per_port: tuple[float, float] = PER_PORT) -> None:
        self.sources = Buckets(*per_source)
        self.hosts = Buckets(*per_host)
        self.port = Buckets(*per_port, max_keys=1)
        self.stats = AdmissionStats()

    def admit(self, addr: tuple, data: bytes, now: float) -> bool:
        cost = datagram_cost(data)
        src = self.sources.room(addr, now)
        host = self.hosts.room(addr[0], now)
        port = self.port.room(None, now)
        st = self.stats
        if src[0] < cost:
            st.shed_source += 1
        elif host[0] < cost:
            st.shed_host += 1
        elif port[0] < cost:
            st.shed_port += 1
        else:
            src[0] -= cost
            host[0] -= cost
            port[0] -= cost
            return True
        st.shed_cost += cost
        return False
