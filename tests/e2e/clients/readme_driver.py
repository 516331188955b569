"""Runs README's quick start in the current directory (tests/e2e/test_readme.py): starts the
daemon as `make run` does, waits for its ready line, runs each command with a time-out, prints
"PASS <command>" or "FAIL <command>" and its output, stops the daemon. Exit 0 if every command
passed; 3 (and why, last line) if the daemon's ports cannot be had here.

Usage: python readme_driver.py '{"daemon": [...], "commands": [...], "timeout_s": N}'
"""

import json
import os
import shlex
import signal
import subprocess
import sys

from gateway.ci.launcher import CornetDaemon
from gateway.ci.ports import daemon_ports, udp_free


def run(command: str, timeout_s: float) -> tuple[bool, str]:
    """``command`` in a session of its own: on time-out the whole session goes (a MAVSDK
    script's mavsdk_server too, which would otherwise keep the client ports and the gRPC port
    for the next command)."""
    proc = subprocess.Popen(shlex.split(command), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, stdin=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout_s)
        return proc.returncode == 0, f"exit {proc.returncode}\n{out}"
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
        return False, f"timed out after {timeout_s} s\n{out}"
    finally:
        try:  # what the command left running (a script that exits early leaves its server)
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


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
            ok, text = run(command, plan["timeout_s"])
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
