"""MAVProxy, driven through its prompt as a user types: parameters, Hold/Return, the mission."""

import os
import shutil
import subprocess
import sys
import threading
import time

import pytest
from pymavlink import mavutil

from tests.e2e.gcs import gcs, heartbeats_by_sysid, upload_mission

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

HOME = (47.397742, 8.545594)


def mavproxy_exe() -> str:
    exe = os.path.join(os.path.dirname(sys.executable), "mavproxy.py")
    if not os.path.exists(exe):
        exe = shutil.which("mavproxy.py") or ""
    if not exe:
        pytest.skip("MAVProxy missing: `pip install mavproxy` (the test extra installs it)")
    return exe


class Prompt:
    def __init__(self, args: list[str], cwd) -> None:
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, cwd=cwd)
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._pump, daemon=True)
        self._reader.start()

    def _pump(self) -> None:
        try:
            for line in self.proc.stdout:
                self.lines.append(line.rstrip())
        except ValueError:  # the pipe closed by ``close`` after a 5 s wait: reading is over
            return

    def wait_for(self, text: str, timeout_s: float = 30.0, since: int = 0) -> str:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for line in self.lines[since:]:
                if text in line:
                    return line
            time.sleep(0.1)
        raise AssertionError(f"MAVProxy never printed {text!r}:\n" + "\n".join(self.lines[-30:]))

    def type(self, command: str) -> int:
        mark = len(self.lines)
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()
        return mark

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        # The reader ends at the pipe's EOF; closing the pipe under it first would make its
        # loop raise "I/O operation on closed file" in the thread.
        self._reader.join(timeout=5)
        self.proc.stdout.close()
        self.proc.stdin.close()


def test_mavproxy_params_modes_and_mission(daemon_factory, tmp_path):
    exe = mavproxy_exe()
    d = daemon_factory()
    # A mission to read back, uploaded beforehand on the API link by a pymavlink script.
    api = gcs(d.api_port())
    try:
        assert heartbeats_by_sysid(api, {1})
        wps = [(16, 6, HOME[0] + 2e-4 * (i + 1), HOME[1], 10.0) for i in range(3)]
        assert upload_mission(api, 1, wps) == mavutil.mavlink.MAV_MISSION_ACCEPTED
    finally:
        api.close()

    mp = Prompt([sys.executable, exe, f"--master=udpin:127.0.0.1:{d.gcs_port()}", "--no-state"],
                cwd=tmp_path)
    try:
        mp.wait_for("online system 1")
        mark = mp.type("param fetch")
        line = mp.wait_for("Received", 60, mark)
        assert int(line.split("Received")[1].split()[0]) >= 100, line
        mark = mp.type("param show MIS_TAKEOFF_ALT")
        assert "2.5" in mp.wait_for("MIS_TAKEOFF_ALT", 10, mark)
        mp.type("param set MIS_TAKEOFF_ALT 4")
        for _ in range(20):  # the echo of the set refreshes MAVProxy's cache
            time.sleep(0.5)
            mark = mp.type("param show MIS_TAKEOFF_ALT")
            if "4.0" in mp.wait_for("MIS_TAKEOFF_ALT", 10, mark):
                break
        else:
            raise AssertionError("MIS_TAKEOFF_ALT never became 4")

        mark = mp.type("wp list")
        mp.wait_for("Requesting 3 waypoints", 15, mark)
        mp.wait_for(f"16 6 {HOME[0] + 6e-4:.10f}", 15, mark)  # the last item, printed

        # MAVProxy's `mode NAME` cannot switch PX4 modes (it hands pymavlink's set_mode a tuple);
        # its `long` command sends the same DO_SET_MODE that QGC does.
        mark = mp.type("arm throttle")
        mp.wait_for("ARMED", 15, mark)
        mark = mp.type("long DO_SET_MODE 1 4 2")  # Takeoff
        mp.wait_for("TAKEOFF", 15, mark)
        mark = mp.type("long DO_SET_MODE 1 4 3")  # Hold
        mp.wait_for("LOITER", 30, mark)
        mark = mp.type("long DO_SET_MODE 1 4 5")  # Return
        mp.wait_for("RTL", 15, mark)
        mp.wait_for("DISARMED", 60, mark)
    finally:
        mp.close()


def test_mavproxy_log_list_and_ftp_list(daemon_factory, tmp_path):
    """MAVProxy's log and ftp modules (loaded by default): `log list` gets PX4's LOG_ENTRY list,
    `ftp list /` the vehicle's root with its log directory (--state-dir)."""
    exe = mavproxy_exe()
    d = daemon_factory("--state-dir", str(tmp_path / "state"))
    mp = Prompt([sys.executable, exe, f"--master=udpin:127.0.0.1:{d.gcs_port()}", "--no-state"],
                cwd=tmp_path)
    try:
        mp.wait_for("online system 1")
        mark = mp.type("log list")
        mp.wait_for("numLogs 1", 20, mark)  # SDLOG_MODE 1: the log since boot
        mark = mp.type("ftp list /")
        mp.wait_for(" D log", 20, mark)
    finally:
        mp.close()


def test_mavproxy_nsh_is_the_mavlink_shell(daemon_factory, tmp_path):
    """MAVProxy's nsh module (SERIAL_CONTROL, device SHELL, as PX4's Tools/mavlink_shell.py
    speaks it): `ver all`, `param show` and `listener -n` answer as PX4's pxh, `.` leaves the
    shell."""
    exe = mavproxy_exe()
    d = daemon_factory()
    mp = Prompt([sys.executable, exe, f"--master=udpin:127.0.0.1:{d.gcs_port()}", "--no-state"],
                cwd=tmp_path)
    try:
        mp.wait_for("online system 1")
        mp.type("module load nsh")
        mp.wait_for("Loaded module nsh", 20)
        mark = mp.type("nsh start")
        mark = mp.type("ver all")
        mp.wait_for("HW arch: PX4_SITL", 20, mark)
        mark = mp.type("param show MPC_XY_CRUISE")
        mp.wait_for("MPC_XY_CRUISE [", 20, mark)
        mark = mp.type("listener vehicle_local_position -n 3 -r 2")  # over 1 s, as PX4's
        mp.wait_for("TOPIC: vehicle_local_position instance 0 #3", 20, mark)
        mark = mp.type("nosuchcommand")
        mp.wait_for("Invalid command: nosuchcommand", 20, mark)
        mp.type(".")
    finally:
        mp.close()
