"""PX4's onboard services: the logger (ULog) and its files, the MAVLink shell's interpreter."""

from __future__ import annotations

from typing import Any

from gateway.onboard.shell import Pxh

VERSION = "1.15.0 0 (17760511)"  # what AUTOPILOT_VERSION says (v1.15.0 release)


def attach_shells(sim: Any) -> None:
    """Every link of every vehicle gets PX4's MAVLink shell (a pxh per shell session)."""
    for link in sim.links.values():
        vehicle = link.session.vehicle
        link.session.serial.terminal_factory = lambda v=vehicle: Pxh(v, VERSION)
