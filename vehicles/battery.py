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

import math

from vehicles.types import BatteryState

# Not PX4 params: model constants for an X500-class 4S quad.
HOVER_CURRENT_A = 18.0
AVIONICS_CURRENT_A = 0.4


class BatterySim:
    def __init__(self, params, hover_thrust_norm: float) -> None:
        self._params = params
        self._params_version = -1  # the parameters below are read when first needed
        self._enabled = False
        self._drain_s = self._min_remaining = self._load_drop_v = 0.0
        self._cells = 0
        self._v_empty = self._v_full = 0.0
        self._hover = hover_thrust_norm
        self._remaining = 1.0
        self._consumed_mah = 0.0
        self._last_s: float | None = None
        self._current_a = 0.0
        self._force_empty = False
        self._state: BatteryState | None = None  # ``state()`` until something it shows changes

    def _update_params(self) -> None:
        p = self._params
        self._params_version = p.version
        self._enabled = bool(int(p["SIM_BAT_ENABLE"]))
        self._drain_s = float(p["SIM_BAT_DRAIN"])
        self._min_remaining = float(p["SIM_BAT_MIN_PCT"]) / 100.0
        self._cells = int(p["BAT1_N_CELLS"])
        self._v_empty, self._v_full = float(p["BAT1_V_EMPTY"]), float(p["BAT1_V_CHARGED"])
        self._load_drop_v = float(p["BAT1_V_LOAD_DROP"])
        self._state = None

    @property
    def force_empty(self) -> bool:
        return self._force_empty

    @force_empty.setter
    def force_empty(self, empty: bool) -> None:
        self._force_empty = empty
        self._state = None

    def update(self, now_s: float, armed: bool, thrust_norm: float) -> None:
        # (max(·, 0.0) as comparisons, the same values: every 50 Hz tick)
        dt = 0.0 if self._last_s is None else now_s - self._last_s
        dt = 0.0 if 0.0 > dt else dt
        self._last_s = now_s
        if self._params.version != self._params_version:
            self._update_params()
        if not self._enabled:
            return
        self._state = None
        ratio = (0.0 if 0.0 > thrust_norm else thrust_norm) / self._hover
        self._current_a = AVIONICS_CURRENT_A + HOVER_CURRENT_A * ratio**1.5 if armed else 0.0
        self._consumed_mah += self._current_a * dt / 3.6
        if armed:
            # BatterySimulator::Run divides in float: SIM_BAT_DRAIN = 0 (PX4 stores it as given)
            # makes the step inf (0/0: NaN) ...
            drain = self._drain_s
            self._remaining -= dt / drain if drain else math.inf if dt else math.nan
        else:
            self._remaining = 1.0
        # ... and math::max(a, b), (a > b) ? a : b, turns either into SIM_BAT_MIN_PCT.
        r = self._remaining
        self._remaining = r if r > self._min_remaining else self._min_remaining

    @property
    def remaining(self) -> float:
        """``state().remaining`` without building the state."""
        if self._force_empty:
            return 0.0
        r = self._remaining
        return 0.0 if r < 0.0 else (1.0 if r > 1.0 else r)

    def state(self) -> BatteryState:
        if self._params.version != self._params_version:
            self._update_params()
        if self._state is None:
            r = self.remaining
            v_empty = self._v_empty
            cell_v = v_empty + (self._v_full - v_empty) * r
            if self._force_empty:
                cell_v = v_empty - self._load_drop_v
            self._state = BatteryState(voltage_v=self._cells * cell_v, current_a=self._current_a,
                                       remaining=r, consumed_mah=self._consumed_mah,
                                       cell_count=self._cells)
        return self._state
