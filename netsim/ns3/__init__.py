"""The ns-3 network backend: a real ns-3 802.11 or LTE network (or a reference engine speaking the
same protocol) driven in lockstep over ZMQ. See README.md beside this file."""

from netsim.ns3.bridge import (
    BINARY,
    DROP_BACKEND,
    ENGINES,
    LATE_POLICIES,
    Ns3Backend,
    Ns3BuildMissing,
    Ns3Error,
    Ns3LinkStats,
    build_missing_message,
)

__all__ = ["BINARY", "DROP_BACKEND", "ENGINES", "LATE_POLICIES", "Ns3Backend", "Ns3BuildMissing",
           "Ns3Error", "Ns3LinkStats", "build_missing_message"]
