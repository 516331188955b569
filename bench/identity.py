"""Byte-identity of the flight logs, for work that must not change behaviour (a speed-up, a
refactor): flies the 4-waypoint square in lockstep with flight logs three times — an ideal
network with the API and GCS links, a lossy one (50 ms, 10 ms jitter, 15 % loss, seed 7), and
three vehicles — and prints each flight's simulated time and a digest of every file it logged
(every datagram both ways with its time, packets.trace, state.csv, the ULog).

    bench/identity.py                 digests of this tree
    bench/identity.py --against REV   the same for git revision REV (a temporary worktree) and
                                      this tree, then the files that differ; exit 1 if any do

Digests are only comparable on one machine: another numpy, numba or libm may round
differently. Comparing against a revision, both sides run here and now."""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def file_digests(d: Path) -> dict[str, str]:
    return {str(p.relative_to(d)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(d.rglob("*")) if p.is_file()}


def digest(files: dict[str, str]) -> str:
    """One digest of a flight's logs: their names and contents in name order."""
    h = hashlib.sha256()
    for name, file_hash in sorted(files.items()):
        h.update(name.encode())
        h.update(bytes.fromhex(file_hash))
    return h.hexdigest()[:16]


def fly_all(tree: Path) -> dict[str, dict]:
    """{flight: {"t": simulated s, "files": {log: sha256}}}, flown with the code of ``tree``."""
    sys.path.insert(0, str(tree))
    from gateway.ci.lockstep import Sim
    from gateway.mavlink.session import LinkKind
    from tests.unit.test_testing_sim import LOSSY, fly_square

    flights = {}
    for label, network, n in (("ideal", None, 1), ("lossy", LOSSY, 1), ("three", None, 3)):
        with tempfile.TemporaryDirectory() as d:
            with Sim(n, network, log_dir=Path(d), links=(LinkKind.API, LinkKind.GCS)) as sim:
                fly_square(sim)
                t = sim.now
            flights[label] = {"t": round(t, 3), "files": file_digests(Path(d))}
    return flights


def run_in(tree: Path) -> dict[str, dict]:
    """``fly_all`` in a child Python with ``tree`` first on its path."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run([sys.executable, __file__, "--json", "--tree", str(tree)], cwd=tree,
                         env=env, check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def show(label: str, flights: dict[str, dict]) -> None:
    for name, flight in flights.items():
        print(f"{label:8} {name:6} {flight['t']:8.3f} s  {digest(flight['files'])}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", metavar="REV", help="compare with git revision REV")
    parser.add_argument("--tree", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.json:
        print(json.dumps(fly_all(args.tree or ROOT)))
        return 0
    if args.against is None:
        show("this", run_in(ROOT))
        return 0
    with tempfile.TemporaryDirectory() as parent:
        old = Path(parent) / "tree"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--quiet", "--detach",
                        str(old), args.against], check=True)
        try:
            before = run_in(old)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(old)],
                           check=False)
    after = run_in(ROOT)
    show(args.against[:8], before)
    show("this", after)
    differ = [f"{name}/{log}" for name in before
              for log in sorted(set(before[name]["files"]) | set(after[name]["files"]))
              if before[name]["files"].get(log) != after[name]["files"].get(log)]
    print("differ: " + ", ".join(differ) if differ else "identical: every log, byte for byte")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
