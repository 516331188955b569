"""Runs README's quick start in the current directory (tests/e2e/test_readme.py): starts the
daemon as `make run` does, waits for its ready line, runs each command with a time-out, prints
"PASS <command>" or "FAIL <command>" and its output, stops the daemon. Exit 0 if every command
passed; 3 (and why, last line) if the daemon's ports cannot be had here.

Usage: python readme_driver.py '{"daemon": [...], "commands": [...], "timeout_s": N}'
"""

import json
import shlex
import subprocess
import sys

from gateway.ci.launcher import CornetDaemon
from gateway.ci.ports import daemon_ports, udp_free


def main(plan: dict) -> int:
    if not all(udp_free(p) for p in daemon_ports(0, 1)):
        print("PX4 SITL's default ports are taken in this network namespace")
        return 3
    cmd = plan["daemon"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            stdin=subprocess.DEVNULL)
    daemon = CornetDaemon(proc, cmd, 0, 1, None)
    failed = 0
    try:
        if not daemon.wait_ready(120):
            print(f"FAIL daemon: {' '.join(cmd)}\n{daemon.log_tail()}")
            return 1
        for command in plan["commands"]:
            try:
                out = subprocess.run(shlex.split(command), capture_output=True, text=True,
                                     timeout=plan["timeout_s"], stdin=subprocess.DEVNULL)
                ok, text = out.returncode == 0, f"exit {out.returncode}\n{out.stdout}{out.stderr}"
            except subprocess.TimeoutExpired as exc:
                ok, text = False, f"timed out after {exc.timeout} s"
            print(f"{'PASS' if ok else 'FAIL'} {command}", flush=True)
            if not ok:
                failed += 1
                print(text[-4000:], flush=True)
    finally:
        code = daemon.stop()
        if code != 0:
            print(f"FAIL daemon exit code {code}\n{daemon.log_tail()}")
            failed += 1
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(json.loads(sys.argv[1])))
