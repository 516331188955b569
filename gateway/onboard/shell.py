"""The MAVLink shell's interpreter, as PX4 SITL's pxh (the POSIX shell behind MavlinkShell).

Source: PX4 platforms/posix/src/px4/common/px4_daemon/pxh.cpp (run_remote_pxh, process_line,
the "pxh> " prompt) and the output of the modules' own commands (param, commander, navigator,
ekf2, gps, listener, logger, mavlink, failure, ver).
Rules:
- Bytes in, bytes out (``write``): every byte above 3 is echoed and added to the line; a newline
  echoes "\\n", runs the line and prints the prompt. Nothing is printed before the first newline
  (clients send one to get the prompt). Lines longer than ``MAX_LINE`` are cut.
- Unknown commands: "Invalid command: X\\ntype 'help' for a list of commands"; a command that
  fails: "Command 'X' failed, returned N.".
- The commands act on the vehicle through the same calls as MAVLink (arm, takeoff, modes,
  parameters, failure injection). ``commander status``, ``navigator status`` and ``ekf2 status``
  print what Commander::print_status, Navigator::print_status (with Geofence::printStatus) and
  EKF2::print_status say, without their perf counters (a module's CPU time per cycle, which a
  simulated vehicle does not have). ``gps status``: SITL never starts the gps driver (sensor_gps
  comes from sensor_gps_sim), so ModuleBase says "not running". ``listener`` prints the
  logger's topics (logged_topics.py) with PX4's topic and field names, once or, with -n/-r/-i,
  over time (the prompt waits for its end; any key ends it). ``logger on|off|status``
  drives the vehicle's logger (logger.py) as logger.cpp's commands do. ``mavlink status
  [streams]`` and ``mavlink stream`` show and set the vehicle's links (mavlink_status.py).
"""

from __future__ import annotations

import fnmatch
import math
import os
import re
from collections.abc import Callable, Sequence
from typing import Any

from gateway.mavlink.available_modes import NAV_STATE_NAMES
from gateway.mavlink.identity import px4_guid
from gateway.mavlink.telemetry_version import GIT_VERSION_BINARY
from gateway.onboard import mavlink_status
from gateway.onboard.listener import Listening
from gateway.onboard.listener_command import listener
from gateway.onboard.mavlink_status import Instance
from gateway.sim.simulation import PHYSICS_DT_S
from vehicles.faults import TYPES, UNITS
from vehicles.params import ParamType
from vehicles.types import CommandResult, NavState

# ver.cpp: a release (type byte 0xFF) prints "Release"; the rest as a v1.15.2 SITL build says it:
# the git hash whose first 16 digits AUTOPILOT_VERSION carries, the tag's date (__DATE__ pads
# the day), the toolchain of PX4's Ubuntu 22.04 build image
VERSION = "Release 1.15.2 (17761023)"  # what AUTOPILOT_VERSION says (v1.15.2 release)
GIT_HASH = f"{GIT_VERSION_BINARY:016x}e4dfa60d81f7845d2eec36c1"
BUILD_DATETIME = "Nov  6 2024 12:20:00"
GCC_VERSION = "11.4.0"
PROMPT = "pxh> "
MAX_LINE = 4096
MODES = {"manual": NavState.MANUAL, "altctl": NavState.ALTCTL, "posctl": NavState.POSCTL,
         "position:slow": NavState.POSITION_SLOW,
         "auto:mission": NavState.AUTO_MISSION, "auto:loiter": NavState.AUTO_LOITER,
         "auto:rtl": NavState.AUTO_RTL, "auto:takeoff": NavState.AUTO_TAKEOFF,
         "auto:land": NavState.AUTO_LAND, "auto:precland": NavState.AUTO_PRECLAND,
         "acro": NavState.ACRO, "offboard": NavState.OFFBOARD, "stabilized": NavState.STAB}


class Pxh:
    def __init__(self, vehicle: Any, version: str, logger: Any = None,
                 instances: Sequence[Instance] = (), ekf_dt_s: float = PHYSICS_DT_S) -> None:
        self.vehicle = vehicle
        self.ekf_dt_s = ekf_dt_s  # the estimator's update period (the physics step's)
        self.version = version
        self.logger = logger  # the vehicle's VehicleLogger; None: no storage, no logger
        self.instances = tuple(Instance(i.session, i.transport) for i in instances)  # its links
        self._line = bytearray()
        self._commands: dict[str, Callable[[list[str], float], int]] = {
            "commander": self._commander, "ekf2": self._ekf2, "failure": self._failure,
            "gps": self._gps, "listener": self._listener, "logger": self._logger,
            "mavlink": self._mavlink, "navigator": self._navigator, "param": self._param,
            "ver": self._ver,
        }
        self._out: list[str] = []
        self._listening: Listening | None = None  # a ``listener -n`` running

    def print(self, text: str) -> None:
        self._out.append(text)

    def write(self, data: bytes, now_s: float) -> bytes:
        for b in data:
            if self._listening is not None:  # listener reads a byte: any one ends it
                self._listening = None
                self.print(PROMPT)
            elif b == 0x0A:
                self.print("\n")
                self.run(self._line.decode("utf-8", "replace"), now_s)
                self._line.clear()
                if self._listening is None:  # else the prompt waits for its end
                    self.print(PROMPT)
            elif b > 3:
                self.print(chr(b) if b < 0x80 else "?")
                if len(self._line) < MAX_LINE:
                    self._line.append(b)
        out = "".join(self._out).encode("utf-8", "replace")
        self._out.clear()
        return out

    def run(self, line: str, now_s: float) -> int:
        words = line.split()
        if not words or words[0].startswith("#"):
            return 0
        name = words[0]
        if name == "help":
            self.print("Builtin Commands:\n" + "".join(f"  {c}\n" for c in sorted(self._commands)))
            return 0
        command = self._commands.get(name)
        if command is None:
            self.print(f"Invalid command: {name}\ntype 'help' for a list of commands\n")
            return -1
        ret = command(words[1:], now_s)
        if ret:
            self.print(f"Command '{name}' failed, returned {ret}.\n")
        return ret

    # --- commands -------------------------------------------------------------------------------
    def _ver(self, args: list[str], now_s: float) -> int:
        if not args:
            self.print("Usage: ver <command>\n  hw, hwcmp, git, bdate, gcc, all, uid, mfguid, "
                       "uri, px4guid\n")
            return 1
        arg, show_all, out = args[0], args[0] == "all", []
        if show_all or arg == "hw":
            out.append("HW arch: PX4_SITL")
        if show_all or arg == "git":  # the git-hash, PX4's version, the host's kernel (posix)
            release = [int(m) for m in re.findall(r"\d+", os.uname().release)[:3]]
            major, minor, patch = (release + [0, 0, 0])[:3]
            os_ver = (major << 24 | minor << 16 | patch << 8 | 0xFF) & 0xFFFFFFFF
            out += [f"PX4 git-hash: {GIT_HASH}", f"PX4 version: {self.version}", "OS: Linux",
                    f"OS version: Release {major}.{minor}.{patch} ({os_ver})"]
        if show_all or arg == "bdate":
            out.append(f"Build datetime: {BUILD_DATETIME}")
        if show_all or arg == "uri":
            out.append("Build uri: localhost")
        if show_all:
            out.append("Build variant: default")
        if show_all or arg == "gcc":
            out.append(f"Toolchain: GNU GCC, {GCC_VERSION}")
        if show_all or arg == "px4guid":
            sysid = int(self.vehicle.params.get("MAV_SYS_ID", 1) or 1)
            out.append(f"PX4GUID: {bytes(px4_guid(sysid)).hex()}")
        if show_all or arg == "mcu":
            out.append("UNKNOWN MCU")  # posix: board_mcu_version is -1
        if not out:
            self.print("ERROR [ver] unknown command\n")
            return 1
        self.print("".join(line + "\n" for line in out))
        return 0

    def _param(self, args: list[str], now_s: float) -> int:
        params = self.vehicle.params
        if not args:
            self.print("Usage: param <command> [arguments...]\n")
            return 1
        cmd, rest = args[0], args[1:]
        if cmd == "show":  # param_main's show [-c | -a | -q NAME | PATTERN]
            if rest[:1] == ["-q"]:
                if len(rest) < 2 or rest[1] not in params:
                    return 1
                self.print(_param_text(params.info(rest[1]).type, params[rest[1]]) + "\n")
                return 0
            only_changed = rest[:1] == ["-c"]
            pattern = None if rest[:1] == ["-a"] else (rest[1:2] if only_changed else rest[:1])
            self.print("Symbols: x = used, + = saved, * = unsaved\n")
            for i, (info, value) in enumerate(params.items()):
                changed = value != params.default_of(info.name)
                if (only_changed and not changed) or (
                        pattern and not self._param_matches(pattern[0], info.name)):
                    continue
                mark = "+" if changed else " "  # SITL saves a change at once
                self.print(f"x {mark} {info.name} [{i},{i}] : "
                           f"{_param_text(info.type, value)}\n")
            self.print(f"\n {len(params)} parameters total, {len(params)} used.\n"
                       if rest[:1] == ["-a"] else f"\n {len(params)}/{len(params)} parameters used.\n")
            return 0
        if cmd in ("compare", "greater"):  # do_compare: 0 when one of the values matches
            silent = rest[:1] == ["-s"] and len(rest) >= 3
            if silent:
                name, values = rest[1], rest[2:]
            else:
                name, values = (rest[0] if rest else ""), rest[1:]
            if not values:
                self.print(f"ERROR [param] not enough arguments.\nTry 'param {cmd} "
                           f"{name or 'PARAM_NAME'} 3'\n")
                return 1
            if name not in params:
                if not silent:
                    self.print(f"ERROR [param] Parameter {name} not found\n")
                return 1
            current, is_int = params[name], params.info(name).type is ParamType.INT32
            for text in values:
                try:  # strtol / strtod: what does not parse is 0
                    value = float(int(float(text))) if is_int else float(text)
                except (ValueError, OverflowError):
                    value = 0.0
                if (current > value) if cmd == "greater" else (
                        current == value if is_int else abs(current - value) < 1e-7):
                    return 0
            return 1
        if cmd == "set" and len(rest) >= 2:
            name = rest[0]
            if name not in params:
                self.print(f"ERROR [param] Parameter {name} not found.\n")
                return 1
            info = params.info(name)
            try:
                new = float(rest[1])
            except ValueError:
                self.print(f"ERROR [param] Parameter {name}: bad value {rest[1]}\n")
                return 1
            old = params[name]
            if not params.set(name, new):
                self.print(f"ERROR [param] Parameter {name}: value {rest[1]} refused\n")
                return 1
            self.print(f"  {name}: curr: {_param_text(info.type, old)} -> new: "
                       f"{_param_text(info.type, params[name])}\n")
            return 0
        if cmd == "reset" and rest:  # param_reset_specific: names, "*" wildcards allowed
            params.reset(lambda n: any(fnmatch.fnmatchcase(n, p) for p in rest))
            return 0
        if cmd == "reset_all":  # param_reset_excludes: all but the names given
            params.reset(lambda n: not any(fnmatch.fnmatchcase(n, p) for p in rest))
            return 0
        if cmd in ("save", "load", "status"):
            if cmd == "status":
                self.print(f"summary: {len(params.changed_from_default())} changed from "
                           f"default, {len(params)} parameters\n")
            return 0
        self.print(f"ERROR [param] unknown command: {cmd}\n")
        return 1

    def _param_matches(self, pattern: str, name: str) -> bool:
        """param.cpp do_show_print's search: case-insensitive, a ``*`` only at the end (one
        elsewhere is warned about for each name it is reached in, and matches nothing)."""
        ss, pp = 0, 0
        while ss < len(pattern) and pp < len(name):
            if pattern[ss].upper() == name[pp]:
                ss += 1
                pp += 1
            elif pattern[ss] == "*":
                if ss + 1 < len(pattern):
                    self.print("WARN  [param] * symbol only allowed at end of search string\n")
                    return False
                pp += 1
            else:
                return False
        return (ss == len(pattern) or pattern[ss] == "*") and pp == len(name)

    def _commander(self, args: list[str], now_s: float) -> int:
        """Commander::custom_command: ``arm``, ``disarm``, ``takeoff``, ``land`` and ``mode``
        publish a vehicle_command and return 0 without a word; the answer (an arming refusal,
        a rejected mode) reaches the console and the links as commander's own texts, not this
        shell session. ``takeoff`` arms once NAV_TAKEOFF is accepted
        (wait_for_vehicle_command_reply)."""
        v = self.vehicle
        if not args:
            self.print("Usage: commander <command> [arguments...]\n")
            return 1
        cmd = args[0]
        if cmd == "arm":
            # Commander's custom_command sends an internal vehicle_command: "Armed by internal
            # command", as PX4's shell reports it.
            v.arm(now_s, forced="-f" in args[1:2], internal=True)
            return 0
        if cmd == "disarm":
            v.disarm(now_s, forced="-f" in args[1:2], internal=True)
            return 0
        if cmd == "takeoff":
            if v.takeoff(now_s) is CommandResult.ACCEPTED:
                v.arm(now_s, internal=True)
            return 0
        if cmd == "land":
            v.land(now_s)
            return 0
        if cmd == "lockdown":  # DO_FLIGHTTERMINATION 2 (on) or 0 (off): terminates if armed
            if len(args) < 2:
                self.print("WARN  [commander] not enough arguments, missing [on, off]\n\n"
                           "Usage: commander <command> [arguments...]\n")
                return 1
            if args[1] != "off":
                v.terminate(now_s)
            return 0
        if cmd == "mode" and len(args) > 1:
            mode = MODES.get(args[1])
            if mode is None:
                self.print(f"ERROR [commander] argument {args[1]} unsupported.\n")
            else:
                v.set_nav_state(now_s, mode)
            return 0
        if cmd == "calibrate" and len(args) > 1:
            if args[1] not in ("gyro", "mag", "accel", "level", "baro", "esc"):
                self.print(f"ERROR [commander] argument {args[1]} unsupported.\n")
                return 1
            quick = args[1] == "accel" and args[2:3] == ["quick"]  # param5 4
            v.calibrate(now_s, "accel_quick" if quick else args[1])
            return 0
        if cmd == "check":  # Commander's custom_command "check" (runs the pre-arm checks)
            ok = v.status.prearm_ok
            self.print(f"INFO  [commander] Preflight check: {'OK' if ok else 'FAILED'}\n")
            return 0
        if cmd == "status":  # Commander::print_status (no external modes registered)
            c = v.autopilot.commander
            self.print(f"INFO  [commander] {'Armed' if c.armed else 'Disarmed'}\n"
                       f"INFO  [commander] navigation mode: {NAV_STATE_NAMES[c.nav_state]}\n"
                       "INFO  [commander] user intended navigation mode: "
                       f"{NAV_STATE_NAMES[c.user_nav_state]}\n"
                       f"INFO  [commander] in failsafe: {'yes' if c.failsafe.in_failsafe else 'no'}"
                       "\n")
            return 0
        if cmd in ("mode", "calibrate"):
            self.print("ERROR [commander] missing argument\n")
        self.print("WARN  [commander] unknown command\n\nUsage: commander <command> "
                   "[arguments...]\n")
        return 1

    def _navigator(self, args: list[str], now_s: float) -> int:
        """Navigator::print_status: "Running" and Geofence::printStatus's counts of the areas
        it kept (a circle has no vertices)."""
        if args[:1] != ["status"]:
            self.print("Usage: navigator <command> [arguments...]\n Commands:\n   start\n"
                       "   fencefile     load a geofence file from SD card, stored at "
                       "etc/geofence.txt\n   fake_traffic  publishes 4 fake transponder_report_s "
                       "uORB messages\n   stop\n   status        print status info\n")
            return 1
        areas = self.vehicle.autopilot.geofence.areas
        polygons = [a for a in areas if a.polygon]
        circles = [a for a in areas if not a.polygon]
        self.print("INFO  [navigator] Running\n"
                   f"INFO  [navigator] Geofence: {sum(a.inclusion for a in polygons)} inclusion, "
                   f"{sum(not a.inclusion for a in polygons)} exclusion polygons, "
                   f"{sum(a.inclusion for a in circles)} inclusion circles, "
                   f"{sum(not a.inclusion for a in circles)} exclusion circles, "
                   f"{sum(a.vertex_count for a in polygons)} total vertices\n")
        return 0

    def _ekf2(self, args: list[str], now_s: float) -> int:
        """ekf2_main's ``status``: one instance (multi-EKF is off in SITL), EKF2::print_status's
        line: the filter period and whether attitude, local and global position are valid."""
        if args[:1] != ["status"]:
            self.print("Usage: ekf2 <command> [arguments...]\n Commands:\n   start\n"
                       "   stop\n   status        print status info\n     [-v]        "
                       "verbose (print all states and full covariance matrix)\n")
            return 1
        valid = int(bool(self.vehicle.autopilot.commander.position_valid))
        self.print(f"\nekf2:0 EKF dt: {self.ekf_dt_s:.4f}s, attitude: 1, local position: {valid}, "
                   f"global position: {valid}\n")
        return 0

    def _gps(self, args: list[str], now_s: float) -> int:
        """The gps driver is built into SITL but never started (sensor_gps_sim publishes)."""
        if args[:1] == ["status"]:
            self.print("INFO  [gps] not running\n")
            return -1
        self.print("WARN  [gps] not running\n")
        return 1

    def _failure(self, args: list[str], now_s: float) -> int:
        if len(args) < 2:
            self.print("Usage: failure <component> <failure_type> [-i <instance>]\n")
            return 1
        if int(self.vehicle.params.get("SYS_FAILURE_EN", 0) or 0) != 1:
            self.print("WARN  [failure] this requires param SYS_FAILURE_EN=1\n")
            return 1
        unit, kind = UNITS.get(args[0]), TYPES.get(args[1])
        inject = getattr(self.vehicle, "inject_failure", None)
        if unit is None or kind is None or inject is None:
            self.print(f"ERROR [failure] {args[0]} {args[1]}: not supported\n")
            return 1
        return 0 if inject(now_s, unit, kind, 0) is CommandResult.ACCEPTED else 1

    def _listener(self, args: list[str], now_s: float) -> int:
        """listener_command.py; a listening over time holds the prompt until it ends."""
        ret, self._listening = listener(args, now_s, self.vehicle, self.logger.links
                                        if self.logger is not None else (), self.print)
        return ret

    @property
    def next_s(self) -> float:
        """When a running ``listener -n`` looks for its topic next (inf: none runs)."""
        return self._listening.due_s if self._listening is not None else math.inf

    def poll(self, now_s: float) -> bytes:
        """A running listener's output since the last call, and the prompt once it ends."""
        if self._listening is not None and now_s >= self._listening.due_s:
            text, done = self._listening.poll(now_s)
            self.print(text)
            if done:
                self._listening = None
                self.print(PROMPT)
        out = "".join(self._out).encode("utf-8", "replace")
        self._out.clear()
        return out

    def _logger(self, args: list[str], now_s: float) -> int:
        """logger's custom_command and print_status (logger.cpp)."""
        usage = ("\n### Description\nSystem logger which logs a configurable set of uORB topics "
                 "and system printf messages\n\nUsage: logger <command> [arguments...]\n"
                 " Commands:\n   start\n   on            start logging now, override arming "
                 "(logger must be running)\n   off           stop logging now, override arming "
                 "(logger must be running)\n   stop\n   status        print status info\n")
        if self.logger is None:
            self.print("WARN  [logger] logger not running\n" + usage
                       if args and args[0] != "status" else "INFO  [logger] not running\n")
            return 1
        cmd = args[0] if args else ""
        if cmd == "status":
            for line in self.logger.status(now_s):
                self.print(f"INFO  [logger] {line}\n")
            return 0
        if cmd == "on":
            self.logger.on(now_s)
            return 0
        if cmd == "off":
            self.logger.off(now_s)
            return 0
        self.print(("WARN  [logger] unknown command\n" if cmd else "") + usage)
        return 1

    def _mavlink(self, args: list[str], now_s: float) -> int:
        if args and args[0] == "status":
            self.print(mavlink_status.status(self.instances, now_s, args[1:2] == ["streams"]))
            return 0
        if args and args[0] == "stream":
            ret, text = mavlink_status.stream(self.instances, args[1:], now_s)
            self.print(text)
            return ret
        self.print(mavlink_status.USAGE)
        return 1


def _param_text(kind: ParamType, value: float) -> str:
    """A value as param.cpp prints it: "%ld" for INT32, "%4.4f" for FLOAT."""
    return f"{int(value)}" if kind is ParamType.INT32 else f"{value:.4f}"


def attach_shells(sim: Any, loggers: Callable[[int], Any] | None = None,
                  transport: Callable[[int, Any], Any] | None = None) -> None:
    """Every link of every vehicle gets PX4's MAVLink shell (a pxh per shell session);
    ``loggers(sysid)``: the vehicle's logger (``logger`` commands), None without storage;
    ``transport(index, tag)``: a link's (local port, remote port, broadcast) for ``mavlink
    status``, None without sockets."""
    links: dict[int, list[Instance]] = {}
    dt_s = sim.world.dt_s
    for (index, tag), link in sim.links.items():
        get = (lambda i=index, t=tag: transport(i, t)) if transport is not None else \
            (lambda: None)
        links.setdefault(index, []).append(Instance(link.session, get))
    for (index, _tag), link in sim.links.items():
        vehicle = link.session.vehicle
        logger = loggers(link.session.sysid) if loggers is not None else None
        link.session.serial.terminal_factory = \
            lambda v=vehicle, g=logger, own=links[index]: Pxh(v, VERSION, g, own, dt_s)
