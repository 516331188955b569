"""Fig. 8 of the CORNET paper: a waypoint mission flown over a slow network drifts from its plan.

A ground-side waypoint controller closes the loop over the network: it reads the vehicle's
position from telemetry (pymavlink, LOCAL_POSITION_NED on the API link, as an offboard companion
on the ground would) and sends offboard velocity setpoints (SET_POSITION_TARGET_LOCAL_NED) towards
the current waypoint of a square, switching to the next one inside an acceptance radius. Latency
delays both what it sees and what it commands, so the flown track overshoots the corners and
wanders off the planned legs.

The script runs ``cornet run --latency-ms X`` itself, once per latency (default 0, 100, 300 ms one
way, every link), flies the same square with the same gains each time, records the true track
from the daemon's ZeroMQ state stream (world frame; vehicle 1's local origin is the world origin),
then plots planned vs flown tracks (top view) and prints the cross-track deviation from the
planned path (max, mean) and the time to complete. The control law is gateway/ci/ground.py's,
which ``cornet sweep --control ground`` runs in lockstep over a grid of network conditions.

    .venv/bin/python gcs_examples/trajectory_drift.py                 # ~1 min per latency
    .venv/bin/python gcs_examples/trajectory_drift.py --latencies 0,200 --side 40
"""

from __future__ import annotations

import argparse
import json
import math
import select
import signal
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import zmq
from pymavlink import mavutil

from gateway.ci.ground import VELOCITY_ONLY, velocity_towards
from gateway.ci.launcher import free_tcp_port, start_daemon

ROOT = Path(__file__).resolve().parent.parent
CONTROL_HZ = 20.0
PX4_MAIN_MODE_OFFBOARD = 6


# --- the ground-side controller
@dataclass
class Flight:
    latency_ms: float
    waypoints: list[tuple[float, float]]
    track: list[tuple[float, float, float]] = field(default_factory=list)  # (t s, north, east)
    switches: list[tuple[float, float]] = field(default_factory=list)  # true position at switch
    time_s: float = math.nan
    completed: bool = False
    max_dev_m: float = math.nan
    mean_dev_m: float = math.nan


class Client:
    """pymavlink on the API link (an offboard client) + the daemon's ZeroMQ state stream."""

    def __init__(self, port: int, zmq_endpoint: str) -> None:
        self.mav = mavutil.mavlink_connection(f"udpin:0.0.0.0:{port}", source_system=245,
                                              source_component=190, dialect="common")
        self.sub = zmq.Context.instance().socket(zmq.SUB)
        self.sub.setsockopt(zmq.LINGER, 0)
        self.sub.connect(zmq_endpoint)
        self.sub.setsockopt(zmq.SUBSCRIBE, b"cornet.state")
        self.truth: dict | None = None  # vehicle 1's latest cornet.state entry (ground truth)
        self.truth_t0: float | None = None
        self.on_truth = None
        self.local: tuple[float, float, float] | None = None  # latest LOCAL_POSITION_NED seen
        self.rel_alt_m: float | None = None
        self.custom_mode = None
        self.acks: dict[int, int] = {}
        self._last_hb = 0.0

    def close(self) -> None:
        self.mav.close()
        self.sub.close(0)

    def poll(self, timeout_s: float) -> None:
        end = time.monotonic() + timeout_s
        while True:
            now = time.monotonic()
            if now - self._last_hb >= 1.0:
                self._last_hb = now
                self.mav.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_ONBOARD_CONTROLLER,
                                            mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            while self.sub.poll(0):
                _, body = self.sub.recv_multipart()
                msg = json.loads(body)
                self.truth = msg["vehicles"][0]
                if self.on_truth is not None:
                    self.on_truth(msg["t"], self.truth)
            while (m := self.mav.recv_match(blocking=False)) is not None:
                kind = m.get_type()
                if kind == "LOCAL_POSITION_NED":
                    self.local = (m.x, m.y, m.z)
                elif kind == "GLOBAL_POSITION_INT":
                    self.rel_alt_m = m.relative_alt / 1000.0
                elif kind == "HEARTBEAT" and m.get_srcSystem() == 1:
                    self.custom_mode = m.custom_mode
                elif kind == "COMMAND_ACK":
                    self.acks[m.command] = m.result
            left = end - time.monotonic()
            if left <= 0:
                return
            select.select([self.mav.port], [], [], min(left, 0.005))

    def command(self, cmd: int, *params: float, timeout_s: float = 15.0,
                keep_alive=None) -> None:
        """COMMAND_LONG with retries until ACCEPTED (keep_alive() runs while waiting)."""
        params = list(params) + [0.0] * (7 - len(params))
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.acks.pop(cmd, None)
            self.mav.mav.command_long_send(1, 1, cmd, 0, *params)
            t_end = time.monotonic() + 1.5
            while time.monotonic() < t_end and cmd not in self.acks:
                if keep_alive:
                    keep_alive()
                self.poll(1.0 / CONTROL_HZ)
            if self.acks.get(cmd) == mavutil.mavlink.MAV_RESULT_ACCEPTED:
                return
        raise RuntimeError(f"command {cmd} not accepted (last result {self.acks.get(cmd)})")

    def velocity(self, vn: float, ve: float, vd: float) -> None:
        self.mav.mav.set_position_target_local_ned_send(
            0, 1, 1, mavutil.mavlink.MAV_FRAME_LOCAL_NED, VELOCITY_ONLY,
            0, 0, 0, vn, ve, vd, 0, 0, 0, 0, 0)


def fly(flight: Flight, args: argparse.Namespace, log_dir: Path) -> None:
    zmq_endpoint = f"tcp://127.0.0.1:{free_tcp_port()}"
    tag = f"[{flight.latency_ms:g} ms]"
    flags = ["--latency-ms", str(flight.latency_ms), "--zmq-pub", zmq_endpoint,
             "--log-level", "warning", "--param", f"MIS_TAKEOFF_ALT={args.altitude}"]
    print(f"{tag} starting cornet run --latency-ms {flight.latency_ms:g} ...")
    daemon = start_daemon(*flags, cwd=ROOT, output_file=log_dir / f"cornet-{flight.latency_ms:g}ms.log",
                          ready_timeout_s=60)
    client = None
    try:
        client = Client(daemon.api_port(), zmq_endpoint)
        if client.mav.wait_heartbeat(timeout=20) is None:
            raise RuntimeError("no HEARTBEAT from the vehicle")
        deadline = time.monotonic() + 20
        while client.local is None or client.truth is None or client.truth["rel_alt_m"] is None:
            if time.monotonic() > deadline:
                raise RuntimeError("no position estimate")
            client.poll(0.1)
        client.poll(1.5)
        print(f"{tag} arming, taking off to {args.altitude:g} m")
        client.command(mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        client.command(mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan,
                       math.nan, math.nan)
        deadline = time.monotonic() + 40
        while client.truth["rel_alt_m"] < args.altitude - 0.3:
            if time.monotonic() > deadline:
                raise RuntimeError("takeoff did not reach its altitude")
            client.poll(0.1)
        client.poll(1.0)
        fly_square(flight, client, args, tag)
    finally:
        if client is not None:
            client.close()
        code = daemon.stop()
        print(f"{tag} daemon stopped (exit {code})")
    if code != 0:
        raise RuntimeError(f"daemon exited {code}:\n{daemon.log_tail()}")


def fly_square(flight: Flight, client: Client, args: argparse.Namespace, tag: str) -> None:
    alt_d = -args.altitude
    # Hold position setpoints first: PX4 enters offboard only with a fresh setpoint stream.
    def hold() -> None:
        client.velocity(0.0, 0.0, 0.0)
    for _ in range(int(CONTROL_HZ)):
        hold()
        client.poll(1.0 / CONTROL_HZ)
    client.command(mavutil.mavlink.MAV_CMD_DO_SET_MODE,
                   mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, PX4_MAIN_MODE_OFFBOARD, 0,
                   keep_alive=hold)
    print(f"{tag} offboard: flying the {args.side:g} m square at up to {args.speed_mps:g} m/s "
          f"(kp {args.kp:g}/s, acceptance {args.acceptance:g} m)")

    def record(t: float, state: dict) -> None:
        n, e, _ = state["world_ned_m"]
        flight.track.append((t, n, e))
    client.on_truth = record
    t_start = time.monotonic()
    index = 0
    next_tick = time.monotonic()
    while index < len(flight.waypoints):
        now = time.monotonic()
        if now - t_start > args.max_time:
            print(f"{tag} not done after {args.max_time:g} s: giving up")
            break
        n, e, d = client.local  # what the ground sees: latency-old
        wn, we = flight.waypoints[index]
        dn, de = wn - n, we - e
        dist = math.hypot(dn, de)
        if dist < args.acceptance:
            truth = client.truth["world_ned_m"]
            flight.switches.append((truth[0], truth[1]))
            print(f"{tag}   t={now - t_start:5.1f} s  waypoint {index + 1} ({wn:g}, {we:g}) "
                  f"reached (seen at {n:5.1f}, {e:5.1f}; "
                  f"truly at {truth[0]:5.1f}, {truth[1]:5.1f})")
            index += 1
            continue
        client.velocity(*velocity_towards((n, e, d), (wn, we, alt_d), args.speed_mps, args.kp))
        next_tick += 1.0 / CONTROL_HZ
        client.poll(max(0.0, next_tick - time.monotonic()))
    else:
        flight.completed = True
    flight.time_s = time.monotonic() - t_start
    # Settle: the vehicle still flies the last setpoints that are in flight; keep recording.
    for _ in range(int(CONTROL_HZ * 2)):
        hold()
        client.poll(1.0 / CONTROL_HZ)
    client.on_truth = None


# --- deviation and plots
def cross_track(points: np.ndarray, path: list[tuple[float, float]]) -> np.ndarray:
    """Distance of each point to the nearest segment of the planned polyline."""
    best = np.full(len(points), np.inf)
    for (an, ae), (bn, be) in zip(path, path[1:]):
        a, b = np.array([an, ae]), np.array([bn, be])
        ab = b - a
        t = np.clip(((points - a) @ ab) / (ab @ ab), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(points - (a + t[:, None] * ab), axis=1))
    return best


def plot(flights: list[Flight], path: list[tuple[float, float]], out: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(flights), figsize=(4.6 * len(flights), 5.2), squeeze=False,
                             sharex=True, sharey=True)
    pe = [p[1] for p in path]
    pn = [p[0] for p in path]
    colors = ["tab:green", "tab:orange", "tab:red", "tab:purple", "tab:brown"]
    for ax, flight, color in zip(axes[0], flights, colors * 3):
        ax.plot(pe, pn, "k--", lw=1.2, label="planned")
        ax.plot(pe[1:], pn[1:], "ks", ms=5)
        tr = np.array([(n, e) for _, n, e in flight.track])
        if len(tr):
            ax.plot(tr[:, 1], tr[:, 0], "-", color=color, lw=1.6, label="flown")
        if flight.switches:
            sw = np.array(flight.switches)
            ax.plot(sw[:, 1], sw[:, 0], "x", color=color, ms=7, mew=1.5,
                    label="true position at waypoint switch")
        done = f"{flight.time_s:.1f} s" if flight.completed else "not completed"
        ax.set_title(f"{flight.latency_ms:g} ms one-way latency\n"
                     f"cross-track max {flight.max_dev_m:.1f} m, mean {flight.mean_dev_m:.2f} m; "
                     f"{done}", fontsize=9)
        ax.set_xlabel("east (m)")
        ax.set_aspect("equal")
        ax.grid(True, alpha=0.3)
    axes[0][0].set_ylabel("north (m)")
    axes[0][0].legend(fontsize=7.5, loc="center")
    fig.suptitle("CORNET Fig. 8: a ground-side waypoint controller over a slow network "
                 "(offboard velocity, top view)", fontsize=10)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120, bbox_inches="tight")
    plt.close(fig)


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def main() -> int:
    parser = argparse.ArgumentParser(
        description="CORNET Fig. 8: fly a square of waypoints with a ground-side controller "
        "(telemetry in, offboard velocity setpoints out) over links of several one-way "
        "latencies, and plot planned vs flown tracks. Starts `cornet run` itself per latency.")
    parser.add_argument("--latencies", default="0,100,300", metavar="MS,MS,...",
                        help="one-way latencies in ms, every link (default 0,100,300)")
    parser.add_argument("--side", type=float, default=30.0, metavar="M",
                        help="side of the square (default 30 m)")
    parser.add_argument("--altitude", type=float, default=10.0, metavar="M",
                        help="flight altitude (default 10 m)")
    parser.add_argument("--speed-mps", type=float, default=5.0, metavar="V",
                        help="speed limit of the controller (default 5 m/s)")
    parser.add_argument("--kp", type=float, default=1.0, metavar="K",
                        help="proportional gain, 1/s: speed = min(limit, kp·distance) (default 1)")
    parser.add_argument("--acceptance", type=float, default=1.0, metavar="M",
                        help="acceptance radius of a waypoint (default 1 m)")
    parser.add_argument("--max-time", type=float, default=120.0, metavar="S",
                        help="give up on a square after this long (default 120 s)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "fig8_trajectory_drift.png",
                        help="PNG to write (default docs/fig8_trajectory_drift.png)")
    args = parser.parse_args()
    try:
        latencies = [float(x) for x in args.latencies.split(",") if x.strip()]
    except ValueError:
        parser.error("--latencies: comma-separated numbers, e.g. 0,100,300")
    if not latencies or any(x < 0 for x in latencies):
        parser.error("--latencies: at least one, none negative")
    if min(args.side, args.altitude, args.speed_mps, args.kp, args.acceptance) <= 0:
        parser.error("--side, --altitude, --speed-mps, --kp and --acceptance must be > 0")

    signal.signal(signal.SIGTERM, _interrupt)
    signal.signal(signal.SIGINT, signal.default_int_handler)  # even if started in background
    s = args.side
    waypoints = [(s, 0.0), (s, s), (0.0, s), (0.0, 0.0)]
    path = [(0.0, 0.0)] + waypoints
    flights: list[Flight] = []
    log_dir = Path(tempfile.mkdtemp(prefix="cornet-fig8-"))
    try:
        for latency in latencies:
            flight = Flight(latency, waypoints)
            fly(flight, args, log_dir)
            flights.append(flight)
    except KeyboardInterrupt:
        print("interrupted: daemon stopped, no figure written", file=sys.stderr)
        return 130
    except RuntimeError as exc:
        print(f"error: {exc} (daemon logs in {log_dir})", file=sys.stderr)
        return 1

    print(f"\nsquare {s:g} m × 4 legs at {args.altitude:g} m, speed limit {args.speed_mps:g} m/s, "
          f"kp {args.kp:g}/s, acceptance {args.acceptance:g} m")
    print(f"  {'one-way latency':>15} {'max dev m':>10} {'mean dev m':>11} {'time s':>7}")
    for flight in flights:
        pts = np.array([(n, e) for _, n, e in flight.track]) if flight.track else np.zeros((0, 2))
        dev = cross_track(pts, path) if len(pts) else np.array([math.nan])
        flight.max_dev_m, flight.mean_dev_m = float(dev.max()), float(dev.mean())
        done = f"{flight.time_s:7.1f}" if flight.completed else "  (not completed)"
        print(f"  {flight.latency_ms:12g} ms {flight.max_dev_m:10.2f} {flight.mean_dev_m:11.2f} "
              f"{done}")
    plot(flights, path, args.out)
    print(f"\nwrote {args.out}")
    return 0 if all(f.completed for f in flights) else 1


if __name__ == "__main__":
    sys.exit(main())
