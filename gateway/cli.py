"""``cornet`` command line. Bad flags exit with code 2 and say what to fix."""

from __future__ import annotations

import argparse
import asyncio
import logging
import sys

LOG_LEVELS = ("debug", "info", "warning", "error")
MAX_VEHICLES = 1000
MAX_PORT = 65535


def _non_negative(kind: type, what: str):
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be a number, got {text!r}") from None
        if not value >= 0:  # also NaN
            raise argparse.ArgumentTypeError(f"{what} must be >= 0, got {text!r}")
        return value

    return parse


def _probability(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"loss must be a probability, got {text!r}") from None
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"loss must be between 0 and 1 (e.g. 0.2), got {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="cornet",
        description="MAVLink SITL gateway: simulated PX4 quadrotors behind a simulated network.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    run = sub.add_parser(
        "run",
        help="start the daemon",
        description="Start N simulated PX4 vehicles. Vehicle i binds UDP 18570+i (GCS link, "
        "talks to 14550) and 14580+i (API link, talks to 14540+i), like PX4 SITL.",
    )
    run.add_argument("--vehicles", type=int, default=1, metavar="N",
                     help="number of vehicles (default 1)")
    run.add_argument("--latency-ms", type=_non_negative(float, "--latency-ms"), default=0.0,
                     metavar="X", help="one-way network latency in ms on every link (default 0)")
    run.add_argument("--jitter-ms", type=_non_negative(float, "--jitter-ms"), default=0.0,
                     metavar="Y", help="uniform jitter +-Y ms (default 0)")
    run.add_argument("--loss", type=_probability, default=0.0, metavar="P",
                     help="packet loss probability per datagram, 0..1 (default 0)")
    run.add_argument("--seed", type=int, default=0, metavar="S",
                     help="seed of every random stream (default 0)")
    run.add_argument("--port-offset", type=_non_negative(int, "--port-offset"), default=0,
                     metavar="K", help="shift every local and remote port by K (default 0)")
    run.add_argument("--log-level", choices=LOG_LEVELS, default="info", metavar="L",
                     help=f"one of {', '.join(LOG_LEVELS)} (default info)")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "run":
        return _run(parser, args)
    parser.error(f"unknown command {args.command!r}")
    return 2


def _run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    if not 1 <= args.vehicles <= MAX_VEHICLES:
        parser.error(f"--vehicles must be between 1 and {MAX_VEHICLES}, got {args.vehicles}")
    highest = 18570 + args.vehicles - 1 + args.port_offset
    if highest > MAX_PORT:
        parser.error(f"--port-offset {args.port_offset} with {args.vehicles} vehicles needs "
                     f"port {highest} > {MAX_PORT}; use a smaller offset")
    logging.basicConfig(
        level=args.log_level.upper(),
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    # Imported here so that `cornet --help` and flag errors stay fast.
    from gateway.app import PortInUse, RunConfig, serve
    from gateway.sim import NetworkConfig

    config = RunConfig(
        vehicles=args.vehicles,
        network=NetworkConfig.from_flags(args.latency_ms, args.jitter_ms, args.loss, args.seed),
        port_offset=args.port_offset,
    )
    try:
        return asyncio.run(serve(config))
    except PortInUse as exc:
        print(f"cornet: {exc}; is another cornet or PX4 SITL running? "
              f"Stop it or choose another --port-offset.", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 0


if __name__ == "__main__":
    sys.exit(main())
