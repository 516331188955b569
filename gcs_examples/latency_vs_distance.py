"""Fig. 6 of the CORNET paper: round-trip latency and loss grow with the distance to the AP.

Runs ``cornet run`` itself, once per network backend: the embedded wireless model
(scenario fig6-embedded) and the real ns-3 (scenario fig6-ns3; skipped, with a note,
if the ns-3 build is missing). In each run one vehicle takes off next to the access point (a 10 m
mast at home, where vehicle 1 spawns) and flies straight north to --max-distance (a DO_REPOSITION
at --speed-mps), while this script, as a pymavlink ground station on the GCS link, sends TIMESYNC
requests (tc1 = 0, ts1 = its clock) --rate times a second and matches the vehicle's answers (ts1
echoed): round-trip time, or lost when no answer comes within --timeout. The vehicle's distance to
the AP comes from the daemon's ZeroMQ state stream (world frame, so it is never lost on the
radio), and the network's own one-way latencies from its link statistics (docs/zmq.md).

Writes a PNG (mean RTT and loss per distance bin, one line per backend) and prints a table.

    .venv/bin/python gcs_examples/latency_vs_distance.py            # both backends, ~1.5 min each
    .venv/bin/python gcs_examples/latency_vs_distance.py --backends embedded --max-distance 200

On the embedded LTE model (scenario lte; distances to its first cell, the x axis still
says "access point"), e.g. out to the second cell and past the handover:

    .venv/bin/python gcs_examples/latency_vs_distance.py --backends embedded \
        --embedded-scenario lte --max-distance 1200 --speed-mps 12 --bin 50 \
        --out lte.png
"""

from __future__ import annotations

import argparse
import contextlib
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
import tomllib
import zmq
from pymavlink import mavutil

from gateway.ci.launcher import free_tcp_port, start_daemon
from gateway.data import scenario_path
from vehicles.geodesy import reproject

ROOT = Path(__file__).resolve().parent.parent
NS3_BINARY = ROOT / "netsim" / "ns3" / "build" / "cornet-ns3"
TAKEOFF_ALT_M = 10.0
LTE_DEFAULT_CELL_NED_M = [0.0, 0.0, -30.0]  # netsim/models/lte.py's cells_ned_m default

BACKENDS = {
    "embedded": ("embedded wireless model (802.11n MCS0)",
                 ROOT / "scenarios" / "fig6-embedded.toml"),
    "ns3": ("ns-3 3.37 (802.11g 6 Mbit/s, Rayleigh)",
            ROOT / "scenarios" / "fig6-ns3.toml"),
}


# --- one run
@dataclass
class Run:
    backend: str
    label: str
    ap_ned_m: tuple[float, float, float]
    backend_lost_at_m: float = math.nan  # where the daemon reported its network engine lost
    samples: list[tuple[float, float]] = field(default_factory=list)  # (distance m, rtt ms or NaN)
    # per 1 s of link statistics: (distance m, up one-way ms, down one-way ms), network's own share
    net: list[tuple[float, float, float]] = field(default_factory=list)
    counters: dict[str, tuple[int, int, dict]] = field(default_factory=dict)  # whole run, per link
    log_path: Path | None = None


class Gcs:
    """A pymavlink ground station on the GCS link, plus the daemon's ZeroMQ subscriber."""

    def __init__(self, port: int, zmq_endpoint: str) -> None:
        self.mav = mavutil.mavlink_connection(f"udpin:0.0.0.0:{port}", source_system=255,
                                              source_component=190, dialect="common")
        self.sub = zmq.Context.instance().socket(zmq.SUB)
        self.sub.setsockopt(zmq.LINGER, 0)
        self.sub.connect(zmq_endpoint)
        self.sub.setsockopt(zmq.SUBSCRIBE, b"cornet.state")
        self.sub.setsockopt(zmq.SUBSCRIBE, b"cornet.links")
        self.state: dict | None = None  # vehicle 1's latest cornet.state entry
        self.links: list[tuple[tuple[float, float, float], dict]] = []
        self.links_times: list[float] = []  # when each cornet.links message arrived (monotonic s)
        self.pending: dict[int, float] = {}  # ts1 → send time (monotonic s)
        self.answers: list[tuple[int, float]] = []  # (ts1, rtt s)
        self.acks: dict[int, int] = {}
        self._last_hb = 0.0

    def close(self) -> None:
        self.mav.close()
        self.sub.close(0)

    def poll(self, timeout_s: float) -> None:
        """Read everything that arrives within timeout_s (MAVLink and ZeroMQ)."""
        end = time.monotonic() + timeout_s
        while True:
            now = time.monotonic()
            if now - self._last_hb >= 1.0:
                self._last_hb = now
                self.mav.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                                            mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            while self.sub.poll(0):
                topic, body = self.sub.recv_multipart()
                msg = json.loads(body)
                if topic == b"cornet.state":
                    self.state = msg["vehicles"][0]
                elif self.state is not None:
                    self.links.append((self.distance_source(), msg["links"]))
                    self.links_times.append(time.monotonic())
            while (m := self.mav.recv_match(blocking=False)) is not None:
                kind = m.get_type()
                if kind == "TIMESYNC" and m.tc1 != 0 and m.ts1 in self.pending:
                    rtt = time.monotonic() - self.pending.pop(m.ts1)
                    self.answers.append((m.ts1, rtt))
                elif kind == "COMMAND_ACK":
                    self.acks[m.command] = m.result
            left = end - time.monotonic()
            if left <= 0:
                return
            select.select([self.mav.port], [], [], min(left, 0.005))

    def distance_source(self) -> tuple[float, float, float]:
        return tuple(self.state["world_ned_m"]) if self.state else (math.nan,) * 3

    def command(self, cmd: int, *params: float, timeout_s: float = 10.0) -> None:
        """COMMAND_LONG with retries until ACCEPTED."""
        params = list(params) + [0.0] * (7 - len(params))
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.acks.pop(cmd, None)
            self.mav.mav.command_long_send(1, 1, cmd, 0, *params)
            t_end = time.monotonic() + 1.0
            while time.monotonic() < t_end and cmd not in self.acks:
                self.poll(0.05)
            if self.acks.get(cmd) == mavutil.mavlink.MAV_RESULT_ACCEPTED:
                return
            self.poll(0.5)
        raise RuntimeError(f"command {cmd} not accepted (last result {self.acks.get(cmd)})")

    def wait_state(self, what: str, predicate, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while not (self.state is not None and predicate(self.state)):
            if time.monotonic() > deadline:
                raise RuntimeError(f"timed out waiting for {what}")
            self.poll(0.1)

    def take_off_and_head_north(self, to_north_m: float, speed_mps: float, label: str) -> None:
        """Wait for the vehicle and its position, arm, take off to TAKEOFF_ALT_M and fly north
        (DO_REPOSITION at ``speed_mps``) to ``to_north_m`` from where it took off."""
        if self.mav.wait_heartbeat(timeout=20) is None:
            raise RuntimeError("no HEARTBEAT from the vehicle")
        self.wait_state("a position estimate", lambda s: s["rel_alt_m"] is not None, 20)
        home_lat, home_lon = self.state["lat_deg"], self.state["lon_deg"]
        home_alt = self.state["alt_amsl_m"] - self.state["rel_alt_m"]
        self.poll(1.5)
        print(f"{label}arming, taking off to {TAKEOFF_ALT_M:.0f} m")
        self.command(mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        self.command(mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan,
                     math.nan)
        self.wait_state("the takeoff altitude", lambda s: s["rel_alt_m"] > TAKEOFF_ALT_M - 0.5,
                        40)
        lat, lon = reproject(home_lat, home_lon, to_north_m, 0.0)
        self.command(mavutil.mavlink.MAV_CMD_DO_REPOSITION, speed_mps, 1, 0, math.nan, lat, lon,
                     home_alt + TAKEOFF_ALT_M)


def fly_and_measure(run: Run, scenario: Path, args: argparse.Namespace, log_dir: Path) -> None:
    zmq_endpoint = f"tcp://127.0.0.1:{free_tcp_port()}"
    speed = args.speed_mps
    params = [f"MIS_TAKEOFF_ALT={TAKEOFF_ALT_M}", f"MPC_XY_CRUISE={speed}",
              f"MPC_XY_VEL_MAX={max(12.0, speed)}"]
    flags = ["--scenario", str(scenario), "--zmq-pub", zmq_endpoint, "--log-level", "warning"]
    for p in params:
        flags += ["--param", p]
    print(f"[{run.backend}] starting cornet run --scenario {scenario.relative_to(ROOT)} ...")
    daemon = start_daemon(*flags, cwd=ROOT, output_file=log_dir / f"cornet-{run.backend}.log",
                          ready_timeout_s=60)
    run.log_path = daemon.output_file
    gcs = None
    try:
        gcs = Gcs(daemon.gcs_port(), zmq_endpoint)
        print(f"[{run.backend}] daemon ready (port offset {daemon.offset}); "
              "waiting for the vehicle")
        # Straight north, past the last bin, so the vehicle is still at cruise speed there.
        print(f"[{run.backend}] flying north to {args.max_distance:.0f} m from the AP at "
              f"{speed:g} m/s, {args.rate:g} TIMESYNC requests/s on the GCS link")
        gcs.take_off_and_head_north(args.max_distance + 30.0, speed, f"[{run.backend}] ")
        measure(run, gcs, args)
    finally:
        if gcs is not None:
            gcs.close()
        code = daemon.stop()
        print(f"[{run.backend}] daemon stopped (exit {code}); log: {daemon.output_file}")
    if code != 0:
        raise RuntimeError(f"daemon exited {code}:\n{daemon.log_tail()}")


def backend_lost(links: dict) -> bool:
    return any(st.get("dropped", {}).get("backend", 0) > 0 for st in links.values())


def gcs_log_tail(run: Run) -> str:
    path = run.log_path
    if path is None:
        return "(no log)"
    with contextlib.suppress(OSError):
        lines = [ln for ln in Path(path).read_text().splitlines() if "pybullet build" not in ln]
        return "\n".join(lines[-4:])
    return "(no log)"


def ap_distance(run: Run, ned: tuple[float, float, float]) -> float:
    return math.dist(ned, run.ap_ned_m)


def measure(run: Run, gcs: Gcs, args: argparse.Namespace) -> None:
    period = 1.0 / args.rate
    sent: dict[int, tuple[float, float]] = {}  # ts1 → (send time, distance then)
    next_send = time.monotonic()
    next_print = time.monotonic() + 5.0
    gcs.links.clear()
    gcs.links_times.clear()
    valid_until = math.inf  # requests sent after this (monotonic s) met a lost network engine
    t_start = time.monotonic()
    max_time = 2.0 * args.max_distance / args.speed_mps + 30.0
    while True:
        now = time.monotonic()
        dist = ap_distance(run, gcs.distance_source())
        if dist >= args.max_distance:
            break
        if now - t_start > max_time:
            print(f"[{run.backend}] gave up at {dist:.0f} m after {now - t_start:.0f} s")
            break
        if now >= next_send:
            ts1 = time.monotonic_ns()
            gcs.pending[ts1] = now
            sent[ts1] = (now, dist)
            gcs.mav.mav.timesync_send(0, ts1)
            next_send += period
        if math.isinf(valid_until) and gcs.links and backend_lost(gcs.links[-1][1]):
            # The external engine (ns-3) died: the daemon drops every packet with reason
            # 'backend' from then on. That is no radio loss: stop, and keep only what came before
            # the last link statistics without it (minus one time-out for packets in flight).
            good = [t for t, (_, links) in zip(gcs.links_times, gcs.links)
                    if not backend_lost(links)]
            valid_until = (good[-1] if good else t_start) - args.timeout
            run.backend_lost_at_m = dist
            print(f"[{run.backend}] the daemon lost its network engine near {dist:.0f} m "
                  f"(packets dropped with reason 'backend'); stopping this run. Daemon log:")
            print("    " + gcs_log_tail(run).replace("\n", "\n    "))
            break
        if now >= next_print:
            next_print += 5.0
            recent = [r for t, r in gcs.answers[-int(5 * args.rate):]]
            print(f"[{run.backend}]   t={now - t_start:5.1f} s  distance {dist:6.1f} m  "
                  f"answers {len(gcs.answers)}/{len(sent)}  recent mean RTT "
                  f"{1e3 * np.mean(recent) if recent else math.nan:6.1f} ms")
        gcs.poll(max(0.0, min(next_send, next_print) - time.monotonic()))
    gcs.poll(args.timeout)  # the last answers
    rtts = dict(gcs.answers)
    for ts1, (t_sent, dist) in sent.items():
        if t_sent >= valid_until:
            continue
        rtt = rtts.get(ts1)
        run.samples.append((dist, 1e3 * rtt if rtt is not None and rtt <= args.timeout
                            else math.nan))
    if gcs.links:
        last = gcs.links[-1][1]
        for name in ("v1/gcs/up", "v1/gcs/down"):
            st = last.get(name, {})
            run.counters[name] = (st.get("sent", 0), st.get("delivered", 0),
                                  dict(st.get("dropped", {})))
    # The network's own share: per second of link statistics (cumulative), the mean one-way delay
    # of the datagrams delivered in that second on v1/gcs/up and v1/gcs/down.
    key = "net_latency_mean_ms" if run.backend == "ns3" else "latency_mean_ms"
    for (ned0, l0), (ned1, l1) in zip(gcs.links, gcs.links[1:]):
        one_way = []
        for name in ("v1/gcs/up", "v1/gcs/down"):
            a, b = l0.get(name, {}), l1.get(name, {})
            n = b.get("delivered", 0) - a.get("delivered", 0)
            s = b.get(key, 0) * b.get("delivered", 0) - a.get(key, 0) * a.get("delivered", 0)
            one_way.append(s / n if n > 0 else math.nan)
        d = ap_distance(run, tuple((x + y) / 2 for x, y in zip(ned0, ned1)))
        run.net.append((d, *one_way))


# --- results
def _mean(values: np.ndarray) -> float:
    values = values[~np.isnan(values)]
    return float(values.mean()) if len(values) else math.nan


def binned(run: Run, bin_m: float, max_m: float) -> list[dict]:
    d = np.array([s[0] for s in run.samples])
    r = np.array([s[1] for s in run.samples])
    nd = np.array([x[0] for x in run.net]) if run.net else np.zeros(0)
    nup = np.array([x[1] for x in run.net]) if run.net else np.zeros(0)
    ndn = np.array([x[2] for x in run.net]) if run.net else np.zeros(0)
    rows = []
    for lo in np.arange(0.0, max_m, bin_m):
        m = (d >= lo) & (d < lo + bin_m)
        if not m.any():
            continue
        ok = r[m][~np.isnan(r[m])]
        nm = (nd >= lo) & (nd < lo + bin_m)
        rows.append({
            "lo": lo, "mid": lo + bin_m / 2, "sent": int(m.sum()), "answered": len(ok),
            "loss": 1.0 - len(ok) / m.sum(),
            "rtt_mean": float(ok.mean()) if len(ok) else math.nan,
            "rtt_p50": float(np.median(ok)) if len(ok) else math.nan,
            "rtt_p95": float(np.percentile(ok, 95)) if len(ok) else math.nan,
            "net_rtt": _mean(nup[nm]) + _mean(ndn[nm]),
        })
    return rows


def print_table(run: Run, rows: list[dict], bin_m: float) -> None:
    print(f"\n{run.label}  (AP at {list(run.ap_ned_m)} m NED; RTT = client round trip, "
          f"net = the network's own up+down latency from the daemon's link stats)")
    if not math.isnan(run.backend_lost_at_m):
        print(f"  the network engine was lost near {run.backend_lost_at_m:.0f} m: no data beyond")
    for name, (sent, delivered, dropped) in run.counters.items():
        what = "GCS -> vehicle" if name.endswith("/up") else "vehicle -> GCS"
        print(f"  {name} ({what}, whole run): {sent} datagrams sent, {delivered} delivered, "
              f"dropped {dropped or 0}")
    print(f"  {'distance m':>11} {'sent':>5} {'lost %':>7} {'RTT mean':>9} {'p50':>7} "
          f"{'p95':>7} {'net ms':>7}")
    for row in rows:
        print(f"  {row['lo']:4.0f}-{row['lo'] + bin_m:<6.0f} {row['sent']:5d} "
              f"{100 * row['loss']:7.1f} {row['rtt_mean']:9.2f} {row['rtt_p50']:7.2f} "
              f"{row['rtt_p95']:7.2f} {row['net_rtt']:7.3f}")


def plot(runs: list[Run], tables: list[list[dict]], out: Path, bin_m: float, note: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, (ax_rtt, ax_loss) = plt.subplots(2, 1, figsize=(8.5, 8), sharex=True,
                                          gridspec_kw={"height_ratios": [3, 2]})
    colors = {"embedded": "tab:blue", "ns3": "tab:orange"}
    for run, rows in zip(runs, tables):
        x = [r["mid"] for r in rows]
        c = colors.get(run.backend, None)
        ax_rtt.plot(x, [r["rtt_mean"] for r in rows], "o-", color=c, ms=4,
                    label=f"{run.label}: client RTT (mean)")
        ax_rtt.fill_between(x, [r["rtt_p50"] for r in rows], [r["rtt_p95"] for r in rows],
                            color=c, alpha=0.15, lw=0)
        ax_rtt.plot(x, [r["net_rtt"] for r in rows], "s--", color=c, ms=3, lw=1,
                    label=f"{run.label}: network share (up + down)")
        ax_loss.plot(x, [100 * r["loss"] for r in rows], "o-", color=c, ms=4, label=run.label)
        if not math.isnan(run.backend_lost_at_m):
            for ax in (ax_rtt, ax_loss):
                ax.axvline(run.backend_lost_at_m, color=c, ls="-.", lw=1.2)
            ax_loss.text(run.backend_lost_at_m + 3, 50, f"{run.backend} engine crashed here:\n"
                         "no data beyond (not radio loss)", color=c, fontsize=8, va="center")
    ax_rtt.set_yscale("log")
    low, high = ax_rtt.get_ylim()
    plain = matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}")
    ax_rtt.yaxis.set_major_formatter(plain)
    ax_rtt.yaxis.set_minor_formatter(plain if high / low < 20 else matplotlib.ticker.NullFormatter())
    ax_rtt.set_ylabel("round-trip time (ms, log)")
    ax_rtt.set_title("CORNET Fig. 6: latency and loss vs distance to the access point\n"
                     "TIMESYNC round trips on the GCS link; band = median..p95 of the client RTT",
                     fontsize=10)
    ax_rtt.grid(True, which="both", alpha=0.3)
    ax_rtt.legend(fontsize=7.5, loc="upper left")
    ax_loss.set_ylabel("requests without answer (%)")
    ax_loss.set_xlabel(f"distance to the access point (m), {bin_m:g} m bins")
    ax_loss.set_ylim(-3, 103)
    ax_loss.grid(True, alpha=0.3)
    ax_loss.legend(fontsize=8, loc="upper left")
    if note:
        fig.text(0.01, 0.005, note, fontsize=8, color="tab:red")
    fig.tight_layout(rect=(0, 0.02 if note else 0, 1, 1))
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def main() -> int:
    parser = argparse.ArgumentParser(
        description="CORNET Fig. 6: fly a vehicle away from the Wi-Fi access point and measure "
        "TIMESYNC round trips and loss versus distance, on the embedded wireless model and on "
        "the real ns-3. Starts `cornet run` itself (one run per backend).")
    parser.add_argument("--backends", default="embedded,ns3",
                        help="comma-separated: embedded, ns3 (default both)")
    parser.add_argument("--max-distance", type=float, default=300.0, metavar="M",
                        help="fly until this far from the AP (default 300 m)")
    parser.add_argument("--speed-mps", type=float, default=6.0, metavar="V",
                        help="cruise speed (default 6 m/s; sets MPC_XY_CRUISE)")
    parser.add_argument("--rate", type=float, default=20.0, metavar="HZ",
                        help="TIMESYNC requests per second (default 20)")
    parser.add_argument("--timeout", type=float, default=1.5, metavar="S",
                        help="a request without answer after this long is lost (default 1.5 s)")
    parser.add_argument("--bin", type=float, default=10.0, metavar="M",
                        help="distance bin width (default 10 m)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "fig6_latency_vs_distance.png",
                        help="PNG to write (default docs/fig6_latency_vs_distance.png)")
    parser.add_argument("--embedded-scenario", type=Path, default=BACKENDS["embedded"][1],
                        metavar="FILE",
                        help="scenario of the embedded run (default fig6-embedded)")
    parser.add_argument("--ns3-scenario", type=Path, default=BACKENDS["ns3"][1], metavar="FILE",
                        help="scenario of the ns-3 run (default fig6-ns3)")
    args = parser.parse_args()
    wanted = [b.strip() for b in args.backends.split(",") if b.strip()]
    for b in wanted:
        if b not in BACKENDS:
            parser.error(f"--backends: unknown backend {b!r} (embedded, ns3)")
    if args.speed_mps <= 0 or args.max_distance <= 0 or args.rate <= 0 or args.bin <= 0:
        parser.error("--speed-mps, --max-distance, --rate and --bin must be > 0")

    # SIGTERM (e.g. from a test runner) unwinds like Ctrl-C, so every daemon is stopped.
    signal.signal(signal.SIGTERM, _interrupt)
    signal.signal(signal.SIGINT, signal.default_int_handler)  # even if started in background
    note = ""
    runs: list[Run] = []
    log_dir = Path(tempfile.mkdtemp(prefix="cornet-fig6-"))
    try:
        for backend in wanted:
            scenario = (args.embedded_scenario if backend == "embedded" else args.ns3_scenario)
            scenario = scenario_path(scenario).resolve()
            cfg = tomllib.loads(scenario.read_text())
            net = cfg.get("network", {})
            if net.get("backend", "embedded") == "ns3" and not NS3_BINARY.exists():
                note = "ns-3 build missing: run `make ns3`"
                print(f"[{backend}] {note} (skipping the ns-3 run)")
                continue
            label = BACKENDS[backend][0]
            radio = net.get("radio", {})
            if net.get("backend", "embedded") == "ns3":
                ap = net.get("ns3", {}).get("nodes", {}).get("ap", {}).get("position", [0, 0, 0])
            elif radio.get("model") == "lte":
                # The embedded LTE model's cells are its own: distances are to the first one.
                ap = radio.get("cells_ned_m", [LTE_DEFAULT_CELL_NED_M])[0]
                label = "embedded LTE model (first cell)"
            else:
                ap = net.get("ap", {}).get("position_ned_m", [0.0, 0.0, -10.0])
            run = Run(backend, label, tuple(float(v) for v in ap))
            t0 = time.monotonic()
            fly_and_measure(run, scenario, args, log_dir)
            print(f"[{backend}] {len(run.samples)} requests in {time.monotonic() - t0:.0f} s")
            runs.append(run)
    except KeyboardInterrupt:
        print("interrupted: daemon stopped, no figure written", file=sys.stderr)
        return 130
    except RuntimeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    if not runs:
        print("nothing measured", file=sys.stderr)
        return 1
    tables = [binned(run, args.bin, args.max_distance) for run in runs]
    for run, rows in zip(runs, tables):
        print_table(run, rows, args.bin)
    plot(runs, tables, args.out, args.bin, note)
    print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
