"""Battery simulation after PX4 ``src/modules/simulation/battery_simulator``.

Rules: while armed the charge falls linearly from 100 % to 0 % over SIM_BAT_DRAIN seconds but never
below SIM_BAT_MIN_PCT, and disarmed it is 100 % again (BatterySimulator::Run: a fresh battery
for every flight); voltage = cells × interpolate(remaining, BAT1_V_EMPTY, BAT1_V_CHARGED).
PX4 reports no current in simulation (-1 A); we model one from the collective thrust so that
BATTERY_STATUS looks alive: HOVER_CURRENT_A at hover thrust, ∝ thrust^1.5 (momentum theory), plus
an avionics draw, while armed; disarmed the current is 0. consumed_mah integrates that current.
Failure injection (battery off, ``force_empty``): the voltage is BAT1_V_EMPTY less
BAT1_V_LOAD_DROP per cell whatever the charge, as the battery simulator's forced empty battery,
so PX4's voltage-based remaining reads 0 and the low-battery failsafes follow. Time is an
argument.
"""

from __future__ import annotations

from vehicles.types import BatteryState

# Not PX4 params: model constants for an X500-class 4S quad.
HOVER_CURRENT_A = 18.0
AVIONICS_CURRENT_A = 0.4


class BatterySim:
    def __init__(self, params, hover_thrust_norm: float) -> None:
        self._params = params
        self._hover = hover_thrust_norm
        self._remaining = 1.0
        self._consumed_mah = 0.0
        self._last_s: float | None = None
        self._current_a = 0.0
        self.force_empty = False

    def update(self, now_s: float, armed: bool, thrust_norm: float) -> None:
        dt = 0.0 if self._last_s is None else max(now_s - self._last_s, 0.0)
        self._last_s = now_s
        p = self._params
        if not int(p["SIM_BAT_ENABLE"]):
            return
        ratio = max(thrust_norm, 0.0) / self._hover
        self._current_a = AVIONICS_CURRENT_A + HOVER_CURRENT_A * ratio**1.5 if armed else 0.0
        self._consumed_mah += self._current_a * dt / 3.6
        if armed:
            self._remaining -= dt / float(p["SIM_BAT_DRAIN"])
        else:
            self._remaining = 1.0
        self._remaining = max(self._remaining, float(p["SIM_BAT_MIN_PCT"]) / 100.0)

    def state(self) -> BatteryState:
        p = self._params
        cells = int(p["BAT1_N_CELLS"])
        v_empty, v_full = float(p["BAT1_V_EMPTY"]), float(p["BAT1_V_CHARGED"])
        r = 0.0 if self.force_empty else min(max(self._remaining, 0.0), 1.0)
        cell_v = v_empty + (v_full - v_empty) * r
        if self.force_empty:
            cell_v = v_empty - float(p["BAT1_V_LOAD_DROP"])
        return BatteryState(
            voltage_v=cells * cell_v,
            current_a=self._current_a,
            remaining=r,
            consumed_mah=self._consumed_mah,
            cell_count=cells,
        )
