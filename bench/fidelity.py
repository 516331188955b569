#!/usr/bin/env python3
"""Fly like PX4: fixed manoeuvres flown in lockstep (one vehicle, PX4 default parameters), each
figure printed beside what PX4's own algorithms give for the same inputs, with plots.

- takeoff to MIS_TAKEOFF_ALT: time to 90 % of the altitude after the command (given at arming);
  PX4's profile is COM_SPOOLUP_TIME at idle, then the MPC_TKO_RAMP_T ramp (TakeoffHandling),
  then the climb at MPC_TKO_SPEED, and from NAV_MC_ALT_RAD below the altitude Loiter's approach
  (PositionSmoothing); the reference runs those and PositionControl (PX4's gains,
  MPC_THR_HOVER) on a point mass with the x500's thrust curve and instant motors;
- fly-through squares with 50 m sides, 90° and 150° corners: the greatest distance outside the
  polygon at a corner, the lowest speed near each corner (PositionSmoothing alone, perfectly
  tracked, on the same waypoints and NAV_ACC_RAD is PX4's figure) and the greatest leg speed
  (MPC_XY_CRUISE);
- a 30 m goto: overshoot (PX4's smoothing arrives without overshoot: 0 m);
- hover with the sensors of PX4's Gazebo x500 (vehicles/estimation.py; seeded): the IMU's noise
  (measured less true) and whole signal beside the models' σ, the position estimate's σ beside
  the σ of sensor_gps_sim's white position noise, the estimate's error; then hover in a 5 m/s wind:
  the greatest drift and the wind the estimator reports (WIND_COV).

The takeoff, square and goto figures fly exact sensors (a scenario's ``[sensors] noise = 0``),
so that they show the trajectory generation alone.

    .venv/bin/python bench/fidelity.py [--plots docs/fidelity]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.unit.test_vehicles_estimation import hovering, specific_force_frd  # noqa: E402
from tests.unit.test_vehicles_flight import Sim  # noqa: E402
from tests.unit.test_vehicles_trajectory import fly_goto, fly_mission  # noqa: E402
from vehicles.control.position_smoothing import PositionSmoothing, ideal_track  # noqa: E402
from vehicles.control.takeoff import TakeoffHandling  # noqa: E402
from vehicles.types import CommandResult  # noqa: E402

DT = 0.02
ALT = 10.0


def smoothing(p) -> PositionSmoothing:
    s = PositionSmoothing()
    s.set_max_jerk(float(p["MPC_JERK_AUTO"]))
    acc = float(p["MPC_ACC_HOR"])
    s.set_max_acceleration((acc, acc, float(p["MPC_ACC_UP_MAX"])))
    cruise = float(p["MPC_XY_CRUISE"])
    s.set_max_velocity((cruise, cruise, float(p["MPC_Z_V_AUTO_UP"])))
    s.max_allowed_horizontal_error, s.vertical_acceptance_radius = 2.0, float(p["NAV_MC_ALT_RAD"])
    s.cruise_speed, s.horizontal_trajectory_gain = cruise, float(p["MPC_XY_TRAJ_P"])
    s.target_acceptance_radius = float(p["NAV_ACC_RAD"])
    return s


# --- PX4's figures from its algorithms ----------------------------------------------------------
def px4_takeoff_time(p) -> float:
    """PX4's algorithms (TakeoffHandling, PositionSmoothing, PositionControl with PX4's gains
    and MPC_THR_HOVER) on a point mass with the x500's mass and static thrust curve and instant
    motors, resting on the ground until the thrust lifts it, Takeoff handing over to Loiter at
    NAV_MC_ALT_RAD below the altitude: the time to 90 % of MIS_TAKEOFF_ALT after the command,
    given at arming. No hover-thrust estimator: the controller keeps MPC_THR_HOVER."""
    from vehicles.airframe import X500
    from vehicles.control.position_control import (
        PositionControl,
        PositionControlGains,
        PositionSetpoint,
    )
    from vehicles.types import GRAVITY_MPS2

    hover = float(p["MPC_THR_HOVER"])
    gains = PositionControlGains.from_params(p, hover_thrust=hover)
    pc = PositionControl(gains)
    tk = TakeoffHandling(float(p["COM_SPOOLUP_TIME"]), float(p["MPC_TKO_RAMP_T"]),
                         float(p["MPC_Z_VEL_P_ACC"]))
    s = smoothing(p)
    s.set_max_velocity((5.0, 5.0, float(p["MPC_TKO_SPEED"])))
    # FlightTaskAuto::_updateTrajConstraints, a takeoff below MPC_LAND_ALT1 climbing: at most
    # MPC_TKO_SPEED / MPC_TKO_RAMP_T, and the altitude setpoint held at the vehicle's
    # (forceSetPosition) while the velocity turns round from reActivate's descent
    acc_hor = float(p["MPC_ACC_HOR"])
    s.set_max_acceleration((acc_hor, acc_hor, min(float(p["MPC_ACC_UP_MAX"]), float(p["MPC_TKO_SPEED"])
                                          / float(p["MPC_TKO_RAMP_T"]))))
    land_alt1 = float(p["MPC_LAND_ALT1"])
    alt = float(p["MIS_TAKEOFF_ALT"])
    z = vz = t = 0.0
    landed, loiter = True, False
    tilt_lnd = math.radians(float(p["MPC_TILTMAX_LND"]))
    while t < 60.0:
        state = tk.update_state(True, landed, True, t)
        target = ((0.0, 0.0, 0.0), (0.0, 0.0, -alt), (0.0, 0.0, -alt))
        if state < 3:  # not taken off: no setpoint, the task restarts (reActivate)
            s.reset((0.0,) * 3, (0.0, 0.0, 0.7), (0.0, 0.0, -z))
            sp = PositionSetpoint(acceleration_ned_mps2=(0.0, 0.0, 100.0))
            pc.reset_integral()
        else:
            # takeoff.cpp: the takeoff is complete NAV_MC_ALT_RAD below its altitude; Loiter
            # then holds the takeoff point, a waypoint of another type: FlightTaskAuto's climb
            # constraints become MPC_Z_V_AUTO_UP / MPC_ACC_UP_MAX, no forceSetPosition
            loiter = loiter or z > alt - float(p["NAV_MC_ALT_RAD"])
            if loiter:
                s.set_max_velocity((5.0, 5.0, float(p["MPC_Z_V_AUTO_UP"])))
                s.set_max_acceleration((acc_hor, acc_hor, float(p["MPC_ACC_UP_MAX"])))
            elif z < land_alt1:
                s.force_set_position_z(-z)
            out = s.generate((0.0, 0.0, -z), target, (math.nan,) * 3, DT, single_waypoint=True)
            sp = PositionSetpoint(out.position, out.velocity, 0.0, (0.0, 0.0, math.nan))
        # the controller's climb constraint: at least MPC_Z_VEL_MAX_UP and 1.2 x MPC_Z_V_AUTO_UP
        # (FlightTaskAuto::_updateTrajConstraints), the ramp clipped at MPC_Z_VEL_MAX_UP
        speed_up = max(gains.vel_max_up_mps, 1.2 * float(p["MPC_Z_V_AUTO_UP"]))
        up = min(tk.update_ramp(DT, speed_up), gains.vel_max_up_mps)
        pc.set_limits(up, gains.thrust_min if state >= 4 else 0.0, tilt_lnd)
        thrust = -pc.update(DT, (0.0, 0.0, -z), (0.0, 0.0, -vz), (0.0, 0.0, 0.0), sp).thrust_ned[2]
        acc = X500.rotor_count * X500.rotor_thrust_n(thrust) / X500.mass_kg - GRAVITY_MPS2
        vz += acc * DT
        if z <= 0.0 and vz <= 0.0:  # the ground holds the vehicle up
            vz = 0.0
        z = max(0.0, z + vz * DT)
        # The land detector: in the air once the thrust is no longer minimal.
        thr_min = float(p["MPC_THR_MIN"])
        landed = landed and thrust <= thr_min + (hover - thr_min) * 0.3
        t += DT
        if z >= 0.9 * alt:
            return t
    return math.nan


def px4_corner_speeds(p, corners) -> list[float]:
    pts = [(0.0, 0.0, -ALT)] + [(n, e, -ALT) for n, e in corners] + [(0.0, 0.0, -ALT)]
    track = ideal_track(smoothing(p), pts, float(p["NAV_ACC_RAD"]), DT)
    return [min(v for (n, e, _), v in track if math.hypot(n - cn, e - ce) < 3.0)
            for cn, ce in corners]


# --- ours ---------------------------------------------------------------------------------------
def fly_takeoff() -> tuple[float, list]:
    sim = Sim()
    try:
        v = sim.v
        sim.run(1.2)
        assert v.arm(sim.t) is CommandResult.ACCEPTED and v.takeoff(sim.t) is CommandResult.ACCEPTED
        t0, alt = sim.t, float(v.params["MIS_TAKEOFF_ALT"])
        trace, t90 = [], math.nan
        while sim.t - t0 < 20.0:
            sim.run(DT)
            z = -float(v.state.position_ned_m[2])
            trace.append((sim.t - t0, z))
            if math.isnan(t90) and z >= 0.9 * alt:
                t90 = sim.t - t0
        return t90, trace
    finally:
        sim.close()


def fly_polygon(corners) -> tuple[list, float, float, list]:
    track = [(t, n, e, s) for t, (n, e), s in fly_mission(corners, ALT)]
    speeds = [min(s for _, n, e, s in track if math.hypot(n - cn, e - ce) < 3.0)
              for cn, ce in corners]
    outside = max((_outside_distance((n, e), corners) for _, n, e, _ in track
                   if min(math.hypot(n - cn, e - ce) for cn, ce in corners) < 10.0), default=0.0)
    return speeds, outside, max(s for *_, s in track), track


def _outside_distance(pt, corners) -> float:
    """Distance of ``pt`` outside the polygon (0 inside), polygon = home + corners."""
    poly = [(0.0, 0.0)] + list(corners)
    inside = False
    n = len(poly)
    for i in range(n):
        (x1, y1), (x2, y2) = poly[i], poly[(i + 1) % n]
        if (y1 > pt[1]) != (y2 > pt[1]) and pt[0] < (x2 - x1) * (pt[1] - y1) / (y2 - y1) + x1:
            inside = not inside
    if inside:
        return 0.0
    best = math.inf
    for i in range(n):
        (x1, y1), (x2, y2) = poly[i], poly[(i + 1) % n]
        dx, dy = x2 - x1, y2 - y1
        t = max(0.0, min(1.0, ((pt[0] - x1) * dx + (pt[1] - y1) * dy) / (dx * dx + dy * dy)))
        best = min(best, math.hypot(pt[0] - x1 - t * dx, pt[1] - y1 - t * dy))
    return best


def fly_hover(seconds: float = 20.0) -> dict[str, tuple]:
    """Hover with PX4's simulated sensors: noise and estimate figures (module docstring)."""
    import statistics

    from gateway.sim import scenario
    from gateway.testing import Sim as FullSim
    from vehicles import estimation as est

    out: dict[str, tuple] = {}
    with FullSim() as sim:
        hovering(sim)
        dt = sim.simulation.world.dt_s
        rows = []
        for _ in range(int(seconds / dt)):
            sim.advance(dt)
            v = sim.vehicles[0]
            rows.append((v.sensors, v.truth, v.kinematics))
    noise = [statistics.pstdev(s[est.S_ACC + i] - specific_force_frd(t)[i] for s, t, _ in rows)
             for i in range(3)]
    signal = [statistics.pstdev(s[est.S_ACC + i] for s, _, _ in rows) for i in range(3)]
    gyro = [statistics.pstdev(s[est.S_GYRO + i] - t.rates_frd_radps[i] for s, t, _ in rows)
            for i in range(3)]
    pos = [statistics.pstdev(k.position_ned_m[i] for _, _, k in rows) for i in range(2)]
    err = math.sqrt(statistics.fmean(math.dist(k.position_ned_m, t.position_ned_m) ** 2
                                     for _, t, k in rows))
    out.update(noise=tuple(noise), signal=tuple(signal), gyro=tuple(gyro), pos=tuple(pos), err=(err,))
    windy = scenario.parse({"environment": {"wind_speed_mps": 5.0, "wind_from_deg": 270.0}})
    with FullSim(scenario=windy) as sim:
        hovering(sim)
        sim.advance(10.0)
        start = sim.vehicles[0].truth.position_ned_m
        drift = 0.0
        for _ in range(200):
            sim.advance(0.1)
            drift = max(drift, math.dist(start, sim.vehicles[0].truth.position_ned_m))
        e = sim.vehicles[0].estimator
        out.update(drift=(drift,), wind=(e[est.E_WIND], e[est.E_WIND + 1]))
    return out


def gps_noise_sigma_m() -> float:
    """σ of sensor_gps_sim's horizontal position noise (white, per fix)."""
    from vehicles import estimation as est

    return est.GPS_POS_NOISE_M[0]


def plot(out_dir: Path, takeoff_trace, square_track, square_corners) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    out_dir.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(11, 4))
    FigureCanvasAgg(fig)
    ax1, ax2, ax3 = fig.subplots(1, 3)
    ax1.plot([t for t, _ in takeoff_trace], [z for _, z in takeoff_trace])
    ax1.set(title="takeoff", xlabel="s since the command", ylabel="altitude (m)")
    poly = [(0.0, 0.0)] + list(square_corners) + [(0.0, 0.0)]
    ax2.plot([e for _, e in poly], [n for n, _ in poly], "k--", label="plan")
    ax2.plot([e for _, _, e, _ in square_track], [n for _, n, _, _ in square_track], label="flown")
    ax2.set(title="fly-through square", xlabel="east (m)", ylabel="north (m)", aspect="equal")
    ax2.legend()
    ax3.plot([t for t, *_ in square_track], [s for *_, s in square_track])
    ax3.set(title="square: speed", xlabel="s", ylabel="horizontal speed (m/s)")
    fig.tight_layout()
    fig.savefig(out_dir / "fidelity.png", dpi=90)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plots", type=Path, default=None, help="write fidelity.png here")
    args = parser.parse_args()
    t0 = time.perf_counter()
    from vehicles.params import ParamStore

    p = ParamStore()
    square = [(50.0, 0.0), (50.0, 50.0), (0.0, 50.0)]
    sharp = [(50.0, 0.0), (50.0 - 50.0 * math.cos(math.radians(30)), 50.0 * math.sin(math.radians(30)))]
    t90, trace = fly_takeoff()
    sq_speeds, sq_out, sq_max, sq_track = fly_polygon(square)
    sh_speeds, sh_out, sh_max, _ = fly_polygon(sharp)
    overshoot = max(fly_goto()[0], 0.0)
    from vehicles import estimation as est

    hover = fly_hover()

    def three(values, fmt="{:.5f}") -> str:
        return ", ".join(fmt.format(x) for x in values)

    rows = [
        ("takeoff: time to 90 % of MIS_TAKEOFF_ALT", f"{t90:.2f} s", f"{px4_takeoff_time(p):.2f} s"),
        ("square (90°): outside at the corners", f"{sq_out:.2f} m", "0 m (cuts inside)"),
        ("square (90°): corner speeds", ", ".join(f"{s:.2f}" for s in sq_speeds) + " m/s",
         ", ".join(f"{s:.2f}" for s in px4_corner_speeds(p, square)) + " m/s"),
        ("square: greatest leg speed", f"{sq_max:.2f} m/s", f"{float(p['MPC_XY_CRUISE']):.2f} m/s"),
        ("150° corner: outside", f"{sh_out:.2f} m", "0 m (cuts inside)"),
        ("150° corner: corner speed", f"{sh_speeds[0]:.2f} m/s",
         f"{px4_corner_speeds(p, sharp)[0]:.2f} m/s"),
        ("30 m goto: overshoot", f"{overshoot:.2f} m", "0 m"),
        ("hover: accelerometer noise σ x, y, z (m/s²)", three(hover["noise"]),
         three([est.ACCEL_NOISE_MPS2] * 3)),
        ("hover: accelerometer signal σ x, y, z (m/s²)", three(hover["signal"]),
         three([est.ACCEL_NOISE_MPS2] * 3)),
        ("hover: gyro noise σ x, y, z (rad/s)", three(hover["gyro"]),
         three([est.GYRO_NOISE_RADPS] * 3)),
        ("hover: position estimate σ north, east (m)", three(hover["pos"], "{:.4f}"),
         three([gps_noise_sigma_m()] * 2, "{:.4f}") + " (GPS)"),
        ("hover: estimate − truth, RMS (m)", f"{hover['err'][0]:.4f}", "—"),
        ("hover in 5 m/s wind: greatest drift", f"{hover['drift'][0]:.2f} m", "≤ 0.5 m"),
        ("hover in 5 m/s wind: WIND_COV north, east", three(hover["wind"], "{:.2f}") + " m/s",
         "0.00, 5.00 m/s"),
    ]
    width = max(len(r[0]) for r in rows)
    print(f"{'figure':<{width}}  {'CORNET':>22}  {'PX4 algorithms':>22}")
    for name, ours, px4 in rows:
        print(f"{name:<{width}}  {ours:>22}  {px4:>22}")
    if args.plots is not None:
        plot(args.plots, trace, sq_track, square)
        print(f"wrote {args.plots / 'fidelity.png'}")
    print(f"({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
