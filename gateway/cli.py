"""``cornet`` command line. Bad flags exit with code 2 and say what to fix."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import gc
import logging
import os
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from gateway.cli_args import LOG_LEVELS, env_home, env_speed, gcs_partner
from gateway.cli_args import delay_ms as _delay_ms
from gateway.cli_args import duration as _duration
from gateway.cli_args import endpoint as _endpoint
from gateway.cli_args import ipv4 as _ipv4
from gateway.cli_args import list_scenarios as _list_scenarios
from gateway.cli_args import non_negative as _non_negative
from gateway.cli_args import parse_params as _parse_params
from gateway.cli_args import path_arg as _path_arg
from gateway.cli_args import probability as _probability
from gateway.cli_args import speed as _speed
from gateway.cli_args import vehicle_params as _vehicle_params
from gateway.cli_args import version as _version
from gateway.cli_args import writable_dir as _writable_dir
from gateway.cli_args import writable_file as _writable_file
from gateway.web.address import WebListenError, add_web_parser, listen_arg

SIGNING_CREDENTIAL = "signing.key"  # $CREDENTIALS_DIRECTORY/signing.key: the unit's key


def build_parser() -> argparse.ArgumentParser:
    from gateway.ci import flags

    parser = argparse.ArgumentParser(
        prog="cornet",
        description="MAVLink SITL gateway: simulated PX4 quadrotors behind a simulated network.",
    )
    parser.add_argument("--version", action="version", version=f"cornet {_version()}",
                        help="print cornet's version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    run = sub.add_parser(
        "run",
        help="start the daemon",
        description="Start N simulated PX4 vehicles. Vehicle i binds UDP 18570+i (GCS link, "
        "talks to 14550) and 14580+i (API link, talks to 14540+i), like PX4 SITL; a scenario's "
        "extra radio r binds 18570+1000*r+i (talks to 14550 or its remote_port).",
    )
    run.add_argument("--config", type=_path_arg("--config"), default=None, metavar="FILE",
                     help="the daemon's configuration file (TOML): a scenario file whose [daemon] "
                     "table sets what the flags below set (a flag given wins); SIGHUP re-reads its "
                     "network. Example: the shipped systemd/cornet.toml (`cornet scenarios` says where)")
    run.add_argument("--scenario", type=_path_arg("--scenario"), default=None, metavar="FILE|NAME",
                     help="a scenario file (TOML: vehicles, network topology and models, sync "
                     "period, late policy), or a shipped scenario's name (`cornet scenarios` "
                     "lists them); see docs/scenarios.md. The same format as --config: give one "
                     "of them")
    run.add_argument("--bind", type=_ipv4, default=None, metavar="ADDR",
                     help="the address the vehicles' ports bind to (default 127.0.0.1; 0.0.0.0: "
                     "every interface)")
    run.add_argument("--gcs", type=gcs_partner, default=None, metavar="HOST[:PORT]",
                     help="where the GCS links talk first (default 127.0.0.1:14550): a ground "
                     "station on another machine, as PX4's partner address (mavlink start -t); "
                     "with --param MAV_BROADCAST=1 they also broadcast while no ground station is connected")
    run.add_argument("--vehicles", type=int, default=None, metavar="N",
                     help="number of vehicles (default 1, or the scenario's)")
    run.add_argument("--latency-ms", type=_delay_ms("--latency-ms"), default=0.0,
                     metavar="X", help="one-way network latency in ms on every link (default 0)")
    run.add_argument("--jitter-ms", type=_delay_ms("--jitter-ms"), default=0.0,
                     metavar="Y", help="uniform jitter +-Y ms (default 0)")
    run.add_argument("--loss", type=_probability, default=0.0, metavar="P",
                     help="packet loss probability per datagram, 0..1 (default 0)")
    run.add_argument("--speed", type=_speed, default=None, metavar="X",
                     help="simulated seconds per wall second (default 1): physics, telemetry "
                     "rates and network all scale, and client time-outs (COM_*_LOSS_T) are "
                     "scaled as PX4 does with PX4_SIM_SPEED_FACTOR; 'max' runs flat out (for "
                     "runs without clients). Without it (or the file's), PX4_SIM_SPEED_FACTOR "
                     "in the environment sets it, as in PX4 SITL; PX4_HOME_LAT/LON/ALT move the "
                     "home unless the scenario sets one")
    run.add_argument("--duration", type=_duration, default=None, metavar="S",
                     help="stop once S simulated seconds have run (every event up to S, none "
                     "after), as on SIGTERM: logs closed, exit 0. With --speed max, a fixed "
                     "--seed and no clients, two runs write the same logs (default: run until "
                     "SIGINT/SIGTERM)")
    run.add_argument("--seed", type=_non_negative(int, "--seed"), default=None, metavar="S",
                     help="seed of every random stream (default 0, or the scenario's)")
    run.add_argument("--port-offset", type=_non_negative(int, "--port-offset"), default=None,
                     metavar="K", help="shift every local and remote port by K (default 0)")
    run.add_argument("--log-level", choices=LOG_LEVELS, default=None, metavar="L",
                     help=f"one of {', '.join(LOG_LEVELS)} (default info, or the scenario's)")
    run.add_argument("--state-dir", type=_path_arg("--state-dir"), default=None, metavar="DIR",
                     help="keep what clients change in each vehicle's parameters, mission, geofence "
                     "and rally points in DIR/vehicle-<sysid>/ across restarts (default: not kept)")
    run.add_argument("--ignore-bad-state", action="store_true",
                     help="start a vehicle whose state file cannot be read with defaults (the "
                     "file is kept as NAME.unreadable); without it such a file stops the start")
    run.add_argument("--zmq-pub", type=_endpoint("--zmq-pub"), default=None, metavar="ENDPOINT",
                     help="publish vehicle states, link statistics and packet events on a "
                     "ZeroMQ PUB socket, e.g. tcp://127.0.0.1:5556 (schema: docs/zmq.md)")
    run.add_argument("--log-dir", type=_path_arg("--log-dir"), default=None, metavar="DIR",
                     help="record every run in DIR/run-<date>-<time>/: a .tlog per vehicle link "
                     "(QGC/MAVProxy format), the vehicles' state (state.csv) and the packet trace; "
                     "flushed every simulated second; `cornet plot DIR` draws it")
    run.add_argument("--packet-trace", type=_path_arg("--packet-trace"), default=None, metavar="FILE",
                     help="write the packet trace (one line per datagram event: time, send/drop/"
                     "recv, link, size, delay or drop reason) to FILE")
    run.add_argument("--signing-key", type=_path_arg("--signing-key"), default=None, metavar="FILE",
                     help="MAVLink 2 signing: every frame sent is signed and unsigned or badly "
                     "signed frames are refused (counted). FILE: 32 raw bytes, 64 hex digits, or a "
                     "passphrase (its SHA-256, as MAVProxy and QGC derive it)")
    run.add_argument("--metrics-port", type=_non_negative(int, "--metrics-port"), default=None,
                     metavar="PORT",
                     help="serve the daemon's counters in the Prometheus text format on "
                     "http://BIND:PORT/metrics")
    run.add_argument("--web", type=listen_arg("--web"), default=None, metavar="[ADDR:]PORT",
                     help="serve the live view (map, links, drops) on http://ADDR:PORT/ "
                     "(ADDR default 127.0.0.1; docs/web.md)")
    run.add_argument("--shards", type=_non_negative(int, "--shards"), default=1, metavar="K",
                     help="split the vehicles across K worker processes kept in lockstep: an MPI "
                     "job of K+1 ranks, started with mpiexec (pip install 'cornet[mpi]'; "
                     "embedded network only; see gateway/daemon/shard/)")
    run.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                     help="set a PX4 parameter on every vehicle at start (repeatable); "
                     "PX4_PARAM_<NAME>=VALUE in the environment does the same, as in PX4 SITL")
    run.add_argument("--param-file", action="append", default=[], metavar="[N:]FILE",
                     help="PX4 parameters from a QGroundControl .params file (QGC's Save to "
                     "file): each line to the vehicle of its Vehicle-Id column, or with N: every "
                     "line to vehicle N (repeatable; --param and PX4_PARAM_* still win)")
    check = sub.add_parser("check", help="validate a scenario or configuration file and say what "
                           "it sets up",
                           description="Validate a scenario file or the daemon's configuration "
                           "file (--config). Exit 0 and a summary if it is good; exit 2 and the "
                           "key that is wrong if not.")
    check.add_argument("scenario", type=_path_arg("FILE|NAME"), metavar="FILE|NAME",
                       help="the file, or a shipped scenario's name")
    sub.add_parser("scenarios", help="list the shipped scenarios (name and what it sets up)",
                   description="List the scenarios shipped with cornet: `--scenario NAME` and "
                   "`cornet check NAME` take these names. Also says where the shipped files "
                   "(scenarios, example plans, the systemd unit and its configuration) are.")
    fly = sub.add_parser("fly", help="fly a QGroundControl .plan headless, as fast as possible, "
                         "and judge it (exit 0 pass, 1 fail)",
                         description="Fly a QGroundControl .plan (mission, geofence, rally "
                         "points) on one vehicle in lockstep on the simulated clock, through the "
                         "same MAVLink sessions as the daemon, and judge it: mission finished, "
                         "landed, geofence never breached, optional path deviation limit.")
    fly.add_argument("plan", type=_path_arg("PLAN"), metavar="PLAN",
                     help="a QGroundControl .plan file, or a shipped plan's name (square, breach)")
    fly.add_argument("--scenario", type=_path_arg("--scenario"), default=None, metavar="FILE|NAME",
                     help="fly through a scenario's network, wind and faults (a file or a "
                     "shipped scenario's name)")
    fly.add_argument("--latency-ms", type=_delay_ms("--latency-ms"), default=None,
                     metavar="X", help="one-way network latency in ms on every link (default 0)")
    fly.add_argument("--jitter-ms", type=_delay_ms("--jitter-ms"), default=None,
                     metavar="Y", help="uniform jitter +-Y ms (default 0)")
    fly.add_argument("--loss", type=_probability, default=None, metavar="P",
                     help="packet loss probability per datagram, 0..1 (default 0)")
    fly.add_argument("--seed", type=_non_negative(int, "--seed"), default=None, metavar="S",
                     help="the network's seed, also of sensor noise and wind (default: the "
                     "scenario's, else 0)")
    fly.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                     help="set a PX4 parameter at start (repeatable; PX4_PARAM_<NAME> too)")
    fly.add_argument("--time-limit", type=_non_negative(float, "--time-limit"), default=None,
                     metavar="S", help="simulated seconds before giving up (default 900)")
    fly.add_argument("--max-deviation", type=_non_negative(float, "--max-deviation"),
                     default=None, metavar="M", help="fail if the path deviates more (metres)")
    fly.add_argument("--log-dir", type=_path_arg("--log-dir"), default=Path("logs"), metavar="DIR",
                     help="record the flight (tlogs, state.csv, packet trace, ULog) in DIR "
                     "(default logs, replaced by every flight; `cornet plot DIR` draws it)")
    fly.add_argument("--no-log", action="store_true", help="do not record the flight")
    flags.add_fly_flags(fly)
    flags.add_sweep_arguments(sub.add_parser(
        "sweep", help="fly a .plan over a grid of network conditions, seeds, scenarios and "
        "parameters in parallel: CSV, PNGs, reports (exit 0 all pass, 1 some fail)"))
    add_web_parser(sub)
    plot = sub.add_parser("plot", help="draw a recorded run: track vs plan, altitude and speed, "
                          "link latency and loss (PNGs)")
    plot.add_argument("log_dir", type=_path_arg("LOGDIR"), metavar="LOGDIR",
                      help="a run directory (it holds meta.json), or a directory of runs (the "
                      "newest is drawn); the PNGs are written into the run directory")
    plot.add_argument("--plan", type=_path_arg("--plan"), default=None, metavar="FILE",
                      help="a .plan to draw as the planned track")
    for name, helptext in (("watch", "live table of vehicles and link quality from --zmq-pub"),
                           ("stats", "print every link's counters once, from --zmq-pub")):
        p = sub.add_parser(name, help=helptext, description=helptext)
        p.add_argument("--zmq", type=_endpoint("--zmq"), default=None, metavar="ENDPOINT",
                       help="the daemon's --zmq-pub endpoint (default tcp://127.0.0.1:5556)")
        if name == "watch":
            p.add_argument("--duration", type=_non_negative(float, "--duration"), default=None,
                           metavar="S", help="stop after S seconds (default: until Ctrl-C)")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "run":
        # The daemon builds long-lived objects only until it serves, and then freezes them out
        # of the collector and turns it on (gateway.daemon.heap.settle_heap).
        gc.disable()
        try:
            return _run(parser, args, sys.argv[1:] if argv is None else argv)
        except (SystemExit, Exception) as exc:  # in a rank, the whole job ends (shard.launch)
            from gateway.daemon.shard.launch import end_job_if_rank

            end_job_if_rank(exc)
            raise
        finally:
            gc.enable()
    if args.command == "fly":
        return _fly(_subparser(parser, "fly"), args)
    if args.command == "sweep":
        from gateway.ci import sweep

        return sweep.main(args, lambda flags: _parse_params(_subparser(parser, "sweep"), flags, {}))
    if args.command == "plot":
        try:
            from gateway.ci import plot
        except ModuleNotFoundError as exc:  # matplotlib is a dependency; a stripped install
            missing = (exc.name or "matplotlib").split(".")[0]
            print(f"cornet plot: needs {missing}, which is not installed: pip install {missing}",
                  file=sys.stderr)
            return 2
        return plot.main(args.log_dir, args.plan)
    if args.command == "scenarios":
        return _list_scenarios()
    if args.command == "check":
        from gateway.sim.scenario import ScenarioError, describe, load

        try:
            print(describe(load(args.scenario)))
        except ScenarioError as exc:
            print(f"cornet check: {exc}", file=sys.stderr)
            return 2
        return 0
    if args.command == "web":
        from gateway.web import main as web_main

        return web_main(args.zmq, args.listen)
    if args.command in ("watch", "stats"):
        from gateway.bus import watch

        endpoint = args.zmq or watch.DEFAULT_ENDPOINT
        try:
            if args.command == "watch":
                return watch.watch(endpoint, duration_s=args.duration)
            return watch.stats(endpoint)
        except watch.zmq.ZMQError as exc:  # e.g. tcp://no-such-host:5556
            print(f"cornet {args.command}: --zmq {endpoint}: {exc}", file=sys.stderr)
            return 2
    parser.error(f"unknown command {args.command!r}")
    return 2


def _fly(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    from gateway.ci import regress
    from gateway.ci.baseline import Tolerances
    from gateway.daemon.progress import ProgressLine
    from gateway.sim.scenario import ScenarioError, load

    if args.scenario is not None:
        try:
            load(args.scenario)
        except ScenarioError as exc:
            parser.error(str(exc))
    if args.overlay is not None and args.baseline is None:
        parser.error("--overlay draws the flight over its baseline: give --baseline DIR too")
    log_dir = None if args.no_log else args.log_dir
    for flag, path in (("--log-dir", log_dir), ("--save-baseline", args.save_baseline)):
        if path is not None:
            _writable_dir(parser, path, flag)
    for flag, path in (("--junit-xml", args.junit_xml), ("--summary", args.summary)):
        if path is not None:  # written after the flight: a bad one must not cost the flight
            _writable_file(parser, path, flag)
    logging.basicConfig(level="WARNING", format="%(levelname)s %(name)s: %(message)s")
    overrides = {k: v for k, v in (("latency_ms", args.latency_ms), ("jitter_ms", args.jitter_ms),
                                   ("loss", args.loss), ("seed", args.seed),
                                   ("time_limit_s", args.time_limit), ("control", args.control),
                                   ("max_deviation_m", args.max_deviation),
                                   ("scenario", args.scenario and str(args.scenario)),
                                   ("params", _parse_params(parser, args.param, dict(os.environ))
                                    or None)) if v is not None}
    return regress.main(args.plan, overrides, baseline=args.baseline,
                        save_baseline=args.save_baseline, overlay=args.overlay,
                        tolerances=Tolerances(args.tol_track_m, args.tol_time_s, args.tol_loss),
                        junit_xml=args.junit_xml, summary=args.summary, log_dir=log_dir,
                        progress=ProgressLine(sys.stderr))


def _subparser(parser: argparse.ArgumentParser, name: str) -> argparse.ArgumentParser:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices[name]
    raise KeyError(name)


def _first(*values: Any) -> Any:
    """The first value that is set: a flag given, else the file's, else the default."""
    return next((v for v in values if v is not None), None)


def _run_settings(args: argparse.Namespace,
                  flag_params: dict[str, float]) -> tuple[dict[str, Any], str]:
    """``cornet run``'s settings from its flags over its configuration file: keyword arguments
    of ``gateway.daemon.app.RunConfig`` and the log level. Raises ScenarioError naming the key or flag.
    Called at start and again on SIGHUP (the file may have changed; the flags have not)."""
    from gateway.sim.scenario import (
        MAX_VEHICLES,
        NetworkConfig,
        Scenario,
        ScenarioError,
        check_ports,
        load,
    )
    from vehicles.types import PX4_SITL_HOME

    source = _first(args.config, args.scenario)
    which = "--config" if args.config is not None else "--scenario"
    if source is not None:
        scenario = load(source)
        flags = [f for f, v in (("--latency-ms", args.latency_ms), ("--jitter-ms", args.jitter_ms),
                                ("--loss", args.loss)) if v]
        if flags:
            raise ScenarioError(f"{', '.join(flags)}: {source} defines the network; set it "
                                f"there (or drop {which})")
        network = scenario.network
        if args.seed is not None:
            network = replace(network, seed=args.seed)
    else:
        scenario = Scenario(source="flags")
        network = NetworkConfig.from_flags(args.latency_ms, args.jitter_ms, args.loss,
                                           args.seed or 0)
    d = scenario.daemon
    try:  # PX4 SITL's variables: below the flags and the file
        speed = _first(args.speed, d.speed, env_speed(dict(os.environ)))
        home = scenario.home
        environment: tuple[str, ...] = ()
        if home == PX4_SITL_HOME:
            home, environment = env_home(dict(os.environ), home)
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None
    if args.speed is None and d.speed is None and speed is not None:
        environment = ("PX4_SIM_SPEED_FACTOR", *environment)
    vehicles = _first(args.vehicles, scenario.vehicles)
    if not 1 <= vehicles <= MAX_VEHICLES:
        raise ScenarioError(f"--vehicles must be between 1 and {MAX_VEHICLES} (one MAVLink network: "
                            f"system ids 1..{MAX_VEHICLES}), got {vehicles}; run more as another "
                            "daemon on other ports (--port-offset)")
    port_offset = _first(args.port_offset, d.port_offset, 0)
    check_ports(vehicles, port_offset, "--port-offset" if args.port_offset is not None
                else f"{source}: daemon.port_offset", network.radios)
    settings = {
        "vehicles": vehicles,
        "network": network,
        "home": home,
        "environment": environment,
        "gcs": _first(args.gcs, d.gcs),
        "wind": scenario.wind,
        "sensors": scenario.sensors,
        "faults": scenario.faults,
        "spawn_ned_m": scenario.spawn_ned_m,
        "commands": scenario.commands,
        "bind": _first(args.bind, d.bind, "127.0.0.1"),
        "port_offset": port_offset,
        "speed": _first(speed, 1.0),
        "state_dir": _first(args.state_dir, d.state_dir),
        "log_dir": _first(args.log_dir, d.log_dir),
        "zmq_pub": _first(args.zmq_pub, d.zmq_pub),
        "packet_trace": _first(args.packet_trace, d.packet_trace),
        "params": {**scenario.params, **flag_params},
        "vehicle_params": _vehicle_params(scenario.vehicle_params, args.param_file, vehicles,
                                          flag_params),
        "metrics_port": _first(args.metrics_port, d.metrics_port),
        "shards": args.shards,
        "duration": args.duration,
        "ignore_bad_state": args.ignore_bad_state,
        "web": _first(args.web, d.web),
    }
    key_path = _first(args.signing_key, d.signing_key)
    what = "--signing-key" if args.signing_key is not None else f"{source}: daemon.signing_key"
    credentials = os.environ.get("CREDENTIALS_DIRECTORY")
    if key_path is None and credentials:
        # systemd's LoadCredential=signing.key:… (the unit's SetCredential= default "off"
        # when the operator has no key file: signing stays off).
        credential = Path(credentials) / SIGNING_CREDENTIAL
        with contextlib.suppress(OSError):
            if credential.read_bytes().strip().lower() not in (b"", b"off"):
                key_path, what = credential, f"systemd credential {SIGNING_CREDENTIAL}"
    if key_path is not None:
        from gateway.mavlink.signing import SigningKey

        try:
            settings["signing_key"] = SigningKey.load(key_path)
        except (OSError, ValueError) as exc:
            raise ScenarioError(f"{what} {key_path}: {exc}") from None
    port = settings["metrics_port"]
    if port is not None and not 1 <= port <= 65535:
        raise ScenarioError(f"--metrics-port must be between 1 and 65535, got {port}")
    return settings, _first(args.log_level, scenario.log_level, "info")


def _run(parser: argparse.ArgumentParser, args: argparse.Namespace, argv: list[str]) -> int:
    parser = _subparser(parser, "run")  # errors then show `cornet run` usage
    from gateway.sim.scenario import ScenarioError

    if args.config is not None and args.scenario is not None:
        parser.error("--config and --scenario both name a configuration file; give one of them")
    source = _first(args.config, args.scenario)
    flag_params = _parse_params(parser, args.param, dict(os.environ))
    try:
        settings, log_level = _run_settings(args, flag_params)
    except ScenarioError as exc:
        parser.error(str(exc))

    def where(key: str) -> str:  # what set a setting: its flag, or the file's [daemon] key
        flag = "--" + key.replace("_", "-")
        return flag if getattr(args, key) is not None or source is None \
            else f"{source}: daemon.{key}"

    for key in ("state_dir", "log_dir"):
        if settings[key] is not None:
            _writable_dir(parser, settings[key], where(key))
    if settings["packet_trace"] is not None:
        _writable_file(parser, settings["packet_trace"], where("packet_trace"))
    logging.basicConfig(
        level=log_level.upper(),
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    # Imported here so that `cornet --help` and flag errors stay fast, and the simulation only
    # where it runs: not in the launcher of a sharded run, nor in its coordinator.
    from gateway.daemon.config import RunConfig

    config = RunConfig(**settings)
    from gateway.daemon.shard import check as check_shards

    problem = check_shards(config)
    if problem is not None:
        parser.error(problem)
    reload = None
    if source is not None:
        def reload() -> RunConfig:  # SIGHUP: the file again, under the same flags
            return RunConfig(**_run_settings(args, flag_params)[0])

    if config.shards > 1:
        from gateway.daemon import shard

        # Outside an MPI job this process becomes `mpiexec ... cornet run <argv>` (same
        # arguments); inside one it is a rank (gateway/daemon/shard/).
        try:
            if not shard.in_mpi_job():
                return shard.launch(config.shards, argv)
            return shard.serve_rank(config, log_level, reload)
        except shard.ShardError as exc:
            print(f"cornet: {exc}", file=sys.stderr)
            return exc.code
        except KeyboardInterrupt:
            return 0
    import zmq

    from gateway.daemon.app import MetricsPortError, PortInUse, serve
    from gateway.daemon.state import StateError

    try:
        return asyncio.run(serve(config, reload=reload))
    except zmq.ZMQError as exc:
        print(f"cornet: {where('zmq_pub')} {config.zmq_pub}: {exc}", file=sys.stderr)
        return 2
    except MetricsPortError as exc:
        print(f"cornet: {exc}; choose a free port", file=sys.stderr)
        return 2
    except WebListenError as exc:
        print(f"cornet: {exc}", file=sys.stderr)
        return 2
    except StateError as exc:
        print(f"cornet: {where('state_dir')}: {exc}", file=sys.stderr)
        return 2
    except PortInUse as exc:  # in use, or --bind not an address of this machine
        fix = (f"is another cornet or PX4 SITL running? Stop it or choose another "
               f"{where('port_offset')}." if exc.in_use else f"choose another {where('bind')}.")
        print(f"cornet: {exc}; {fix}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 0
    except Exception as exc:
        from netsim.ns3.bridge import Ns3BuildMissing, Ns3Error

        if not isinstance(exc, Ns3Error):
            raise
        # A missing ns-3 build, or a lost engine with `strict = true`: say why, no traceback.
        print(f"cornet: network backend: {exc}", file=sys.stderr)
        return 2 if isinstance(exc, Ns3BuildMissing) else 1


if __name__ == "__main__":
    sys.exit(main())
