"""Topics PX4's logger writes from the commander and the navigator's RTL (logged_topics.py has
the rules): actuator_armed and rtl_time_estimate.

Source: PX4 1.15 msg/ActuatorArmed.msg, RtlTimeEstimate.msg; Commander.cpp (actuator_armed,
getPrearmState), rtl.cpp (publishRemainingTimeEstimate: every ~2 s), logged_topics.cpp
(actuator_armed at every publication, rtl_time_estimate at 1 s).
"""

from __future__ import annotations

from typing import Any

from gateway.onboard.topic import COMMANDER_REPUBLISH_S, B, F, Topic
from vehicles.types import NavState

PREARM_ALWAYS = 2  # COM_PREARM_MODE PrearmedMode::ALWAYS
PREARM_AFTER_BOOT_US = 5_000_000  # ALWAYS: prearmed once 5 s have passed since boot
RTL_ESTIMATE_PERIOD_S = 2.0  # RTL publishes more than 2 s after its last time


def _actuator_armed(v: Any, now_us: int) -> tuple:
    """Commander's actuator_armed: prearmed only with COM_PREARM_MODE 2 after 5 s (SITL has no
    safety button), ready_to_arm the pre-flight checks (or armed), lockdown and force_failsafe
    in Termination; no kill switch, no ESC calibration."""
    commander = v.autopilot.commander  # what status has (logged_topics.py)
    mode = v.params.get("COM_PREARM_MODE", 1)
    prearmed = mode == PREARM_ALWAYS and now_us > PREARM_AFTER_BOOT_US
    terminated = commander.nav_state is NavState.TERMINATION
    armed = commander.armed
    return (bool(armed), prearmed, bool(armed or commander.prearm_ok()), terminated, False,
            terminated, False)


def _rtl_time_estimate(v: Any, now_us: int) -> tuple | None:
    """The last estimate RTL published (none before the first, ~2 s after boot)."""
    published = getattr(v, "rtl_time_estimate", None)
    if published is None or published[0] == 0:
        return None
    estimate = published[1]
    return (estimate.valid, estimate.time_estimate_s, estimate.safe_time_estimate_s)


ACTUATOR_ARMED = Topic("actuator_armed", tuple((B, name) for name in (
    "armed", "prearmed", "ready_to_arm", "lockdown", "manual_lockdown", "force_failsafe",
    "in_esc_calibration_mode")), 0.0, _actuator_armed, on_change=True,
    republish_s=COMMANDER_REPUBLISH_S)
RTL_TIME_ESTIMATE = Topic("rtl_time_estimate", ((B, "valid"), (F, "time_estimate"),
                                                (F, "safe_time_estimate")), 1.0,
                          _rtl_time_estimate, period_s=RTL_ESTIMATE_PERIOD_S)
