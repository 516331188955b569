"""Fig. 6 over LTE: round-trip latency and loss vs distance from eNB 1, through a handover.

Runs ``cornet run --scenario ns3-lte`` itself (the real ns-3's LTE, `make ns3`):
one vehicle, a UE of two eNBs (enb1 at home, enb2 1 km north). It takes off and flies straight
north past enb2 (a DO_REPOSITION at --speed-mps) while this script, a pymavlink ground station
on the GCS link (a remote host behind the PGW), sends TIMESYNC requests --rate times a second
and matches the answers: round-trip time, or lost when none comes within --timeout. The
vehicle's position comes from the daemon's ZeroMQ state stream; the serving cell and the
handovers (with their simulated times) from the ``network`` field of its link statistics
(docs/zmq.md), so the figure marks where the serving cell changed.

Writes a PNG (every round trip, the mean and loss per distance bin, the handover) and prints a
table.

    .venv/bin/python gcs_examples/lte_latency_vs_distance.py       # ~2.5 min
    .venv/bin/python gcs_examples/lte_latency_vs_distance.py --max-distance 800 --speed-mps 12
"""

from __future__ import annotations

import argparse
import bisect
import json
import math
import signal
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import tomllib
from latency_vs_distance import TAKEOFF_ALT_M, Gcs  # the Fig. 6 script's ground station

from gateway.ci.launcher import free_tcp_port, start_daemon
from gateway.data import scenario_path

ROOT = Path(__file__).resolve().parent.parent
NS3_BINARY = ROOT / "netsim" / "ns3" / "build" / "cornet-ns3"
SCENARIO = ROOT / "scenarios" / "ns3-lte.toml"


class _Tap:
    """The ZeroMQ subscriber, handing each message to `seen` before the Fig. 6 ground station
    reads it (which keeps only the latest state)."""

    def __init__(self, sock, seen) -> None:
        self.sock, self.seen = sock, seen

    def poll(self, timeout_ms: int) -> int:
        return self.sock.poll(timeout_ms)

    def recv_multipart(self) -> list[bytes]:
        frames = self.sock.recv_multipart()
        self.seen(*frames)
        return frames

    def close(self, linger: int) -> None:
        self.sock.close(linger)


class LteGcs(Gcs):
    """The Fig. 6 ground station, also keeping the vehicle's track (simulated time -> NED) and
    the LTE network's cells and handovers from the daemon's ZeroMQ stream."""

    def __init__(self, port: int, zmq_endpoint: str) -> None:
        super().__init__(port, zmq_endpoint)
        self.track: list[tuple[float, tuple[float, float, float]]] = []
        self.network: dict = {}
        self.sub = _Tap(self.sub, self._seen)

    def _seen(self, topic: bytes, body: bytes) -> None:
        msg = json.loads(body)
        if topic == b"cornet.state":
            self.track.append((msg["t"], tuple(msg["vehicles"][0]["world_ned_m"])))
        elif "network" in msg:
            self.network = msg["network"]

    def position_at(self, t_s: float) -> tuple[float, float, float]:
        """The vehicle's NED position at simulated time t (linear between state messages)."""
        times = [t for t, _ in self.track]
        i = bisect.bisect_left(times, t_s)
        if i == 0:
            return self.track[0][1]
        if i == len(times):
            return self.track[-1][1]
        (t0, p0), (t1, p1) = self.track[i - 1], self.track[i]
        f = (t_s - t0) / (t1 - t0) if t1 > t0 else 0.0
        return tuple(a + f * (b - a) for a, b in zip(p0, p1))


def fly(args: argparse.Namespace, enb1: tuple[float, float, float], log_dir: Path):
    """Returns (samples [(distance m, rtt ms or NaN, serving cell)], handovers [(distance m,
    event)], final network stats)."""
    zmq_endpoint = f"tcp://127.0.0.1:{free_tcp_port()}"
    speed = args.speed_mps
    flags = ["--scenario", str(args.scenario), "--zmq-pub", zmq_endpoint, "--log-level",
             "warning", "--param", f"MIS_TAKEOFF_ALT={TAKEOFF_ALT_M}", "--param",
             f"MPC_XY_CRUISE={speed}", "--param", f"MPC_XY_VEL_MAX={max(12.0, speed)}"]
    print(f"starting cornet run --scenario {args.scenario} ...")
    daemon = start_daemon(*flags, cwd=ROOT, output_file=log_dir / "cornet-lte.log",
                          ready_timeout_s=60)
    gcs = None
    try:
        gcs = LteGcs(daemon.gcs_port(), zmq_endpoint)
        print(f"flying north to {args.max_distance:.0f} m from enb1 at {speed:g} m/s, "
              f"{args.rate:g} TIMESYNC requests/s on the GCS link (through LTE)")
        gcs.take_off_and_head_north(args.max_distance + 50.0, speed, "")
        timed = measure(gcs, args, enb1)
        network = dict(gcs.network)
        links = gcs.links[-1][1] if gcs.links else {}
        network["gcs_link"] = {name: (st.get("sent", 0), st.get("delivered", 0),
                                      dict(st.get("dropped", {})))
                               for name, st in links.items() if name.startswith("v1/gcs/")}
        events = [e for e in network.get("cell_events", []) if e["node"] == "v1"]
        handovers = [(math.dist(gcs.position_at(e["time_s"]), enb1), e) for e in events
                     if e["event"].startswith("handover") or e["event"] == "radio_link_failure"]
        # The serving cell at each request's send time, from the cell events.
        changes = [(e["time_s"], e.get("cell")) for e in events
                   if e["event"] in ("handover_end", "connected", "radio_link_failure")]
        first = next((e["from"] for e in events if e["event"] == "handover_start"),
                     network.get("serving", {}).get("v1"))
        samples = []
        for dist, rtt, t_s in timed:
            cell = first
            for t_change, to in changes:
                if t_change <= t_s:
                    cell = to
            samples.append((dist, rtt, str(cell)))
    finally:
        if gcs is not None:
            gcs.close()
        code = daemon.stop()
        print(f"daemon stopped (exit {code}); log: {daemon.output_file}")
    if code != 0:
        raise RuntimeError(f"daemon exited {code}:\n{daemon.log_tail()}")
    return samples, handovers, network


def measure(gcs: LteGcs, args: argparse.Namespace, enb1) -> list[tuple[float, float, float]]:
    """[(distance m, rtt ms or NaN, simulated time of the send)]"""
    period = 1.0 / args.rate
    sent: dict[int, tuple[float, float]] = {}  # ts1 -> (distance, simulated time) then
    next_send = next_print = time.monotonic()
    t_start = time.monotonic()
    max_time = 2.0 * args.max_distance / args.speed_mps + 30.0
    while True:
        now = time.monotonic()
        dist = math.dist(gcs.distance_source(), enb1)
        if dist >= args.max_distance or now - t_start > max_time:
            break
        if now >= next_send:
            ts1 = time.monotonic_ns()
            gcs.pending[ts1] = now
            sent[ts1] = (dist, gcs.track[-1][0] if gcs.track else 0.0)
            gcs.mav.mav.timesync_send(0, ts1)
            next_send += period
        if now >= next_print:
            next_print += 5.0
            recent = [r for _, r in gcs.answers[-int(5 * args.rate):]]
            print(f"  t={now - t_start:5.1f} s  {dist:6.0f} m from enb1  serving "
                  f"{gcs.network.get('serving', {}).get('v1')}  answers "
                  f"{len(gcs.answers)}/{len(sent)}  recent mean RTT "
                  f"{1e3 * np.mean(recent) if recent else math.nan:6.1f} ms")
        gcs.poll(max(0.0, min(next_send, next_print) - time.monotonic()))
    gcs.poll(args.timeout)  # the last answers
    rtts = dict(gcs.answers)
    out = []
    for ts1, (dist, t_s) in sent.items():
        rtt = rtts.get(ts1)
        out.append((dist, 1e3 * rtt if rtt is not None and rtt <= args.timeout else math.nan,
                    t_s))
    return out


def binned(samples, bin_m: float, max_m: float) -> list[dict]:
    d = np.array([s[0] for s in samples])
    r = np.array([s[1] for s in samples])
    rows = []
    for lo in np.arange(0.0, max_m, bin_m):
        m = (d >= lo) & (d < lo + bin_m)
        if not m.any():
            continue
        ok = r[m][~np.isnan(r[m])]
        rows.append({"lo": lo, "mid": lo + bin_m / 2, "sent": int(m.sum()), "answered": len(ok),
                     "loss": 1.0 - len(ok) / m.sum(),
                     "rtt_mean": float(ok.mean()) if len(ok) else math.nan,
                     "rtt_max": float(ok.max()) if len(ok) else math.nan})
    return rows


def plot(samples, rows, handovers, enbs: dict[str, float], out: Path, bin_m: float,
         late: int) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, (ax_rtt, ax_loss) = plt.subplots(2, 1, figsize=(9, 8), sharex=True,
                                          gridspec_kw={"height_ratios": [3, 2]})
    colors = {"enb1": "tab:blue", "enb2": "tab:orange"}
    for cell in sorted({s[2] for s in samples}):
        pts = [(d, r) for d, r, c in samples if c == cell and not math.isnan(r)]
        if pts:
            ax_rtt.plot([p[0] for p in pts], [p[1] for p in pts], ".", ms=2, alpha=0.35,
                        color=colors.get(cell, "tab:gray"),
                        label=f"one round trip, served by {cell}")
    x = [r["mid"] for r in rows]
    ax_rtt.plot(x, [r["rtt_mean"] for r in rows], "k-", lw=1.2, label=f"mean per {bin_m:g} m")
    ax_loss.bar(x, [100 * r["loss"] for r in rows], width=bin_m * 0.9, color="tab:red",
                alpha=0.7, label="requests without answer")
    for name, d in enbs.items():
        for ax in (ax_rtt, ax_loss):
            ax.axvline(d, color=colors.get(name, "gray"), ls=":", lw=1)
        ax_rtt.text(d, 1.0, f" {name}", transform=ax_rtt.get_xaxis_transform(), va="top",
                    fontsize=8, color=colors.get(name, "gray"))
    for d, event in handovers:
        if event["event"] == "handover_start":
            for ax in (ax_rtt, ax_loss):
                ax.axvline(d, color="tab:green", lw=1.5)
            ax_rtt.annotate(f"handover {event['from']} → {event['to']}\nat {d:.0f} m "
                            f"(t = {event['time_s']:.2f} s)", (d, 0.75),
                            xycoords=("data", "axes fraction"), xytext=(8, 0),
                            textcoords="offset points", fontsize=8, color="tab:green")
        elif event["event"] == "radio_link_failure":
            ax_rtt.axvline(d, color="tab:red", ls="--", lw=1)
    ax_rtt.set_yscale("log")
    plain = matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}")
    ax_rtt.yaxis.set_major_formatter(plain)
    ax_rtt.yaxis.set_minor_formatter(plain)
    ax_rtt.set_ylabel("TIMESYNC round trip (ms, log)")
    ax_rtt.set_title("CORNET Fig. 6 over LTE (ns-3 3.37 LENA, EPC, two eNBs 1 km apart, "
                     "A3-RSRP handover)\nround trips on the GCS link (a remote host behind "
                     "the PGW) vs distance from enb1", fontsize=10)
    ax_rtt.grid(True, which="both", alpha=0.3)
    ax_rtt.legend(fontsize=8, loc="upper left", markerscale=4)
    ax_loss.set_ylabel("lost (%)")
    ax_loss.set_xlabel(f"distance from enb1 (m), {bin_m:g} m bins")
    ax_loss.set_ylim(0, max(10.0, 1.2 * max((100 * r["loss"] for r in rows), default=0)))
    ax_loss.grid(True, alpha=0.3)
    ax_loss.legend(fontsize=8, loc="upper left")
    if late:
        fig.text(0.01, 0.005, f"{late} datagrams on the GCS link came back from ns-3 after their "
                 "time (a busy CPU in real time) and were dropped as late: not radio loss",
                 fontsize=8, color="tab:red")
    fig.tight_layout(rect=(0, 0.02 if late else 0, 1, 1))
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def main() -> int:
    parser = argparse.ArgumentParser(
        description="Fig. 6 over LTE: fly from eNB 1 past eNB 2 through the real ns-3's LTE and "
        "plot TIMESYNC round trips and loss vs distance, with the handover marked. Starts "
        "`cornet run` itself.")
    parser.add_argument("--scenario", type=Path, default=SCENARIO, metavar="FILE",
                        help="an ns-3 lte scenario (default ns3-lte)")
    parser.add_argument("--max-distance", type=float, default=1300.0, metavar="M",
                        help="fly until this far from enb1 (default 1300 m)")
    parser.add_argument("--speed-mps", type=float, default=15.0, metavar="V",
                        help="cruise speed (default 15 m/s; sets MPC_XY_CRUISE)")
    parser.add_argument("--rate", type=float, default=20.0, metavar="HZ",
                        help="TIMESYNC requests per second (default 20)")
    parser.add_argument("--timeout", type=float, default=1.5, metavar="S",
                        help="a request without answer after this long is lost (default 1.5 s)")
    parser.add_argument("--bin", type=float, default=25.0, metavar="M",
                        help="distance bin width (default 25 m)")
    parser.add_argument("--out", type=Path,
                        default=ROOT / "docs" / "fig6_lte_latency_vs_distance.png",
                        help="PNG to write (default docs/fig6_lte_latency_vs_distance.png)")
    args = parser.parse_args()
    if args.speed_mps <= 0 or args.max_distance <= 0 or args.rate <= 0 or args.bin <= 0:
        parser.error("--speed-mps, --max-distance, --rate and --bin must be > 0")
    if not NS3_BINARY.exists():
        print("ns-3 build missing: run `make ns3`", file=sys.stderr)
        return 1
    args.scenario = scenario_path(args.scenario).resolve()
    ns3 = tomllib.loads(args.scenario.read_text()).get("network", {}).get("ns3", {})
    if ns3.get("topology") != "lte":
        parser.error(f"--scenario: {args.scenario} is not an ns-3 lte scenario")
    positions = {name: tuple(float(v) for v in spec.get("position", (0.0, 0.0, 0.0)))
                 for name, spec in ns3.get("nodes", {}).items() if name.startswith("enb")}
    enb1 = positions.get("enb1", (0.0, 0.0, 0.0))
    # Where each eNB is along the path (the vehicle flies north from home, 10 m up).
    enbs = {name: math.dist((p[0], 0.0, -TAKEOFF_ALT_M), enb1) for name, p in positions.items()}

    signal.signal(signal.SIGTERM, _interrupt)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    log_dir = Path(tempfile.mkdtemp(prefix="cornet-fig6-lte-"))
    try:
        samples, handovers, network = fly(args, enb1, log_dir)
    except KeyboardInterrupt:
        print("interrupted: daemon stopped, no figure written", file=sys.stderr)
        return 130
    except RuntimeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    rows = binned(samples, args.bin, args.max_distance)
    print(f"\nLTE (ns-3), {len(samples)} requests; serving at the end: {network.get('serving')}, "
          f"handovers: {network.get('handovers')}")
    for name, (sent, delivered, dropped) in network["gcs_link"].items():
        print(f"  {name} (whole run): {sent} datagrams sent, {delivered} delivered, dropped "
              f"{dropped or 0}")
        if dropped.get("late"):
            print("    late: ns-3 delivered them after their time in real time (a busy CPU), "
                  "not radio loss (netsim/ns3/README.md, \"Timing\")")
    for d, event in handovers:
        print(f"  {event['event']} at t = {event['time_s']:.3f} s, {d:.0f} m from enb1: "
              f"{ {k: v for k, v in event.items() if k not in ('time_s', 'event', 'node')} }")
    print(f"  {'distance m':>11} {'sent':>5} {'lost %':>7} {'RTT mean':>9} {'max':>8}")
    for row in rows:
        print(f"  {row['lo']:4.0f}-{row['lo'] + args.bin:<6.0f} {row['sent']:5d} "
              f"{100 * row['loss']:7.1f} {row['rtt_mean']:9.2f} {row['rtt_max']:8.2f}")
    late = sum(dropped.get("late", 0) for _, _, dropped in network["gcs_link"].values())
    plot(samples, rows, handovers, enbs, args.out, args.bin, late)
    print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
