"""The MAVLink shell (SERIAL_CONTROL, device SHELL) as PX4 SITL's pxh: prompt after the first
newline, echo, PX4's command outputs, unknown commands as pxh answers them, long lines cut."""

from __future__ import annotations

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.link import LinkKind
from gateway.testing import Sim
from vehicles.types import NavState

RESPOND = M.SERIAL_CONTROL_FLAG_RESPOND | M.SERIAL_CONTROL_FLAG_EXCLUSIVE


def shell(sim: Sim, text: str, flags: int = RESPOND) -> str:
    api = sim.api(0)
    since = len(api.frames)
    data = text.encode()
    for i in range(0, max(len(data), 1), 70):
        chunk = data[i:i + 70]
        api.send(M.MAVLink_serial_control_message(M.SERIAL_CONTROL_DEV_SHELL, flags, 0, 0,
                                                  len(chunk), list(chunk.ljust(70, b"\0"))))
    sim.advance(0.1)
    replies = [m for m in api.messages("SERIAL_CONTROL", since)
               if m.flags & M.SERIAL_CONTROL_FLAG_REPLY]
    return b"".join(bytes(m.data[:m.count]) for m in replies).decode()


def test_prompt_echo_and_commands():
    with Sim() as sim:
        sim.advance(1.0)
        assert shell(sim, "\n") == "\npxh> "
        out = shell(sim, "ver all\n")
        assert out.startswith("ver all\n") and "HW arch: PX4_SITL" in out and out.endswith("pxh> ")
        # ver.cpp: a release build (type byte 0xFF) says "Release"; posix has no MCU
        assert "PX4 version: Release 1.15.2 (17761023)\n" in out and "UNKNOWN MCU\n" in out
        assert "x   MPC_XY_CRUISE [" in shell(sim, "param show MPC_XY_CRU*\n")
        assert "  MPC_XY_CRUISE: curr: 5.0000 -> new: 7.0000" in \
            shell(sim, "param set MPC_XY_CRUISE 7\n")
        assert sim.vehicles[0].params["MPC_XY_CRUISE"] == 7.0
        shell(sim, "param set MIS_TAKEOFF_ALT 4\n")
        shell(sim, "param reset MPC_XY_CRU*\n")
        assert sim.vehicles[0].params["MPC_XY_CRUISE"] == 5.0
        shell(sim, "param set MPC_XY_CRUISE 7\n")
        shell(sim, "param reset_all MPC_*\n")  # all but the MPC_ parameters
        assert sim.vehicles[0].params["MIS_TAKEOFF_ALT"] == 2.5
        assert sim.vehicles[0].params["MPC_XY_CRUISE"] == 7.0
        assert "Parameter NOPE not found." in shell(sim, "param set NOPE 1\n")
        assert "Invalid command: frobnicate\ntype 'help' for a list of commands" in \
            shell(sim, "frobnicate\n")
        assert "  listener\n" in shell(sim, "help\n")
        for missing in ("top", "dmesg", "free"):  # not in PX4 SITL's build (NuttX commands)
            assert f"Invalid command: {missing}\n" in shell(sim, f"{missing}\n")
        shell(sim, "param set COM_ARMABLE 0\n")
        assert "INFO  [commander] Preflight check: FAILED\n" in shell(sim, "commander check\n")
        shell(sim, "param set COM_ARMABLE 1\n")
        # listener_main.cpp's usage and its words for an unknown topic (returning -1)
        usage = shell(sim, "listener\n")
        assert "Usage: listener <command> [arguments...]\n Commands:\n" \
            "     <topic_name> uORB topic name\n     [-i <val>]  Topic instance\n" in usage
        assert usage.endswith("Command 'listener' failed, returned 1.\npxh> ")
        assert shell(sim, "listener nope\n").endswith(
            "Topic nope did not match any known topics\nCommand 'listener' failed, returned -1.\n"
            "pxh> ")
        listened = shell(sim, "listener vehicle_attitude\n")
        assert "TOPIC: vehicle_attitude" in listened and "    q: [" in listened
        assert "    thrust_body: [" in shell(sim, "listener vehicle_rates_setpoint\n")
        # a nested message as orb_print_message_internal prints it: its name and type, then
        # its fields
        triplet = shell(sim, "listener position_setpoint_triplet\n")
        assert "  current (position_setpoint):\n    valid: " in triplet
        assert "    lat: 47.3977" in triplet
        esc = shell(sim, "listener esc_status\n")
        assert "    esc_online_flags: 15 (0b1111)\n" in esc
        assert "  esc[0] (esc_report):\n" in esc and "  esc[7] (esc_report):\n" in esc
        assert "(Roll: " in listened  # q with its Euler angles
        sim.advance(6.0)
        assert "INFO  [commander] Preflight check: OK\n" in shell(sim, "commander check\n")
        shell(sim, "commander arm\n")
        assert sim.status(0).armed
        # the shell's own vehicle_command: command_internal
        assert "Armed by internal command\t" in [t.text for t in sim.vehicles[0].status_texts()]
        shell(sim, "commander mode auto:precland\n")
        assert sim.status(0).nav_state is NavState.AUTO_PRECLAND
        shell(sim, "commander mode auto:rtl\n")
        assert sim.status(0).nav_state is NavState.AUTO_RTL or sim.status(0).armed
        # custom_command: an unknown mode is said, and the command still returns 0
        out = shell(sim, "commander mode warp\n")
        assert "ERROR [commander] argument warp unsupported.\n" in out and "failed" not in out
        long = shell(sim, "x" * 10_000 + "\n")
        assert long.endswith("pxh> ") and "Invalid command" in long


def test_failure_command_needs_sys_failure_en_and_closing_the_shell():
    with Sim(params={"SYS_FAILURE_EN": 0}) as sim:
        sim.advance(1.0)
        assert "this requires param SYS_FAILURE_EN=1" in shell(sim, "failure gps off\n")
        shell(sim, "param set SYS_FAILURE_EN 1\n")
        shell(sim, "failure gps off\n")
        sim.advance(7.0)
        assert not sim.status(0).position_valid
        shell(sim, "", flags=0)  # no RESPOND: the shell closes; the next one starts afresh
        assert shell(sim, "\n") == "\npxh> "


def test_logger_on_off_and_status(tmp_path):
    """pxh's ``logger``: ``status`` as Logger::print_status, ``on`` logs whatever the arming
    state (SDLOG_MODE 0 would wait for arming), ``off`` ends it; without storage the logger
    runs (PX4's without its SD card) but only a MAVLink stream makes it log."""
    import pyulog

    with Sim() as sim:
        sim.advance(1.0)
        shell(sim, "logger on\n")
        sim.advance(0.5)
        assert "INFO  [logger] Not logging\n" in shell(sim, "logger status\n")
        assert sim.api(0).start_log_stream() == 0
        status = shell(sim, "logger status\n")
        assert "INFO  [logger] Mavlink Logging Running (Full log)\n" in status
        assert "Not logging" not in status
    with Sim(log_dir=tmp_path, params={"SDLOG_MODE": 0}) as sim:
        sim.advance(1.0)
        assert "INFO  [logger] Not logging\n" in shell(sim, "logger status\n")
        shell(sim, "logger on\n")
        sim.advance(3.0)
        status = shell(sim, "logger status\n")
        assert "INFO  [logger] Full File Logging Running:" in status
        assert "INFO  [logger] Log file: ./log/" in status and "KiB/s)" in status
        shell(sim, "logger off\n")
        assert "Not logging" in shell(sim, "logger status\n")
        assert "Command 'logger' failed" in shell(sim, "logger frobnicate\n")
    files = sorted((tmp_path / "vehicle-1" / "log").rglob("*.ulg"))
    assert len(files) == 1
    log = pyulog.ULog(str(files[0]))
    assert set(log.get_dataset("vehicle_status").data["arming_state"]) == {1}  # never armed
    assert log.last_timestamp - log.start_timestamp > 2_500_000


def test_mavlink_status_streams_and_stream_rates():
    """``mavlink status``: one instance per link (GCS link Normal, API link Onboard) with its
    rates, loss and transport; ``status streams``: the link's streams at their rates;
    ``mavlink stream -u PORT -s NAME -r HZ`` sets one on the link bound to PORT."""
    from pymavlink.dialects.v20 import common as M

    from gateway.onboard.shell import attach_shells

    with Sim(links=(LinkKind.GCS, LinkKind.API)) as sim:
        ports = {"GCS": (18570, 14550, True), "API": (14580, 14540, False)}
        attach_shells(sim.simulation, None, lambda i, tag: ports[tag.name])
        sim.advance(2.0)
        api = sim.api(0)
        shell(sim, "\n")
        api.mav.seq = (api.mav.seq + 3) % 256  # three frames lost on the way
        out = shell(sim, "mavlink status\n")
        assert "\ninstance #0:\n" in out and "\ninstance #1:\n" in out
        first, second = out.split("\ninstance #1:\n")
        assert "\tmode: Normal\n" in first and "\tmode: Onboard\n" in second
        assert "\ttransport protocol: UDP (18570, remote port: 14550)\n" in first
        assert "\tBroadcast enabled: YES\n" in first and "\tBroadcast enabled: NO\n" in second
        assert "\t  rx loss: 0.0%\n" in first and "\t  rx loss: 0.0%\n" not in second
        # rx_message_lost_rate is lost / received (MavlinkReceiver's counts), which
        # display_status prints as it is before a % sign
        st = sim.simulation.links[(0, LinkKind.API)].session.stats
        assert f"\t  rx loss: {3 / st.rx_counted:.1f}%\n" in second and st.rx_lost == 3
        assert "partner IP" not in out  # no sockets: the lockstep's clients have no address
        tx = float(second.split("\t  tx: ")[1].split(" B/s")[0])
        assert tx > 10_000  # the API link's ~400 messages a second
        streams = shell(sim, "mavlink status streams\n").split("\ninstance #1:\n")[1]
        assert "\tATTITUDE                      100.00 (100.000)  40\n" in streams
        # get_size() 0: no size (no range finder advertised; the mode list never changed)
        assert "\tDISTANCE_SENSOR                10.00 (10.000) \n" in streams
        assert "\tAVAILABLE_MODES                 0.30 (0.300)  \n" in streams
        # onboard's unlimited_rate: every GPS sample (Mavlink::display_status_streams)
        assert "\tGPS_RAW_INT                   unlimited         64\n" in streams
        assert "\tCOMMAND_LONG                  unlimited       \n" in streams
        assert shell(sim, "mavlink stream -u 14580 -s ATTITUDE -r 5\n").endswith("pxh> ")
        assert sim.simulation.links[(0, LinkKind.API)].session.scheduler.interval_us(
            M.MAVLINK_MSG_ID_ATTITUDE) == 200_000
        assert "not running" in shell(sim, "mavlink stream -u 1 -s ATTITUDE -r 5\n")
        assert "ULog rate" not in out
        assert api.start_log_stream() == 0
        sim.advance(1.0)
        first, second = shell(sim, "mavlink status\n").split("\ninstance #1:\n")
        assert "ULog rate" not in first  # the link that streams says how much it sends
        rate = float(second.split("\tULog rate: ")[1].split("%")[0])
        assert 0.0 < rate < 70.0 and "% of max 70.0%\n" in second
        assert "Usage: mavlink" in shell(sim, "mavlink frobnicate\n")


def test_module_status_commands():
    """``commander status`` as Commander::print_status, ``navigator status`` with
    Geofence::printStatus's counts, ``ekf2 status`` as EKF2::print_status's line, and ``gps
    status`` as SITL answers it (the driver is never started there)."""
    from tests.unit.test_geofence import C_OUT, P_IN, SQUARE, fence, polygon
    from vehicles.plan_types import PlanType

    with Sim() as sim:
        sim.advance(1.0)
        out = shell(sim, "commander status\n")
        assert ("INFO  [commander] Disarmed\nINFO  [commander] navigation mode: Hold\n"
                "INFO  [commander] user intended navigation mode: Hold\n"
                "INFO  [commander] in failsafe: no\n") in out
        sim.run_until(lambda: sim.status(0).position_valid, timeout_s=30)
        assert "\nekf2:0 EKF dt: 0.0040s, attitude: 1, local position: 1, global position: 1\n" \
            in shell(sim, "ekf2 status\n")
        assert "INFO  [navigator] Running\nINFO  [navigator] Geofence: 0 inclusion, 0 exclusion " \
            "polygons, 0 inclusion circles, 0 exclusion circles, 0 total vertices\n" in \
            shell(sim, "navigator status\n")
        v = sim.vehicles[0]
        v.set_plan(sim.now, PlanType.FENCE, fence(*polygon(P_IN, SQUARE), (C_OUT, 5.0, 5.0, 2.0)))
        assert "Geofence: 1 inclusion, 0 exclusion polygons, 0 inclusion circles, 1 exclusion " \
            "circles, 4 total vertices\n" in shell(sim, "navigator status\n")
        out = shell(sim, "gps status\n")
        assert "INFO  [gps] not running\nCommand 'gps' failed, returned -1.\n" in out
        assert shell(sim, "commander takeoff\n") == "commander takeoff\npxh> "  # and arms
        sim.advance(1.0)
        out = shell(sim, "commander status\n")
        assert "INFO  [commander] Armed\nINFO  [commander] navigation mode: Takeoff\n" in out
        shell(sim, "commander lockdown off\n")  # DO_FLIGHTTERMINATION 0: denied
        assert not sim.status(0).terminated
        shell(sim, "commander lockdown on\n")
        assert sim.status(0).terminated
        assert "navigation mode: Termination\n" in shell(sim, "commander status\n")


def test_param_show_variants_and_compare():
    """param.cpp: ``show`` matches case-insensitively with a trailing ``*`` and marks a value
    off its default ``+`` (SITL saves at once); ``show -c`` the changed ones, ``show -q`` the
    bare value (scripts read it); ``compare``/``greater`` answer by their return code only."""
    with Sim() as sim:
        sim.advance(1.0)
        shell(sim, "\n")
        shell(sim, "param set MPC_XY_CRUISE 7\n")
        out = shell(sim, "param show mpc_xy_cru*\n")
        assert "x + MPC_XY_CRUISE [" in out and "] : 7.0000\n" in out
        assert "x   MPC_XY_VEL_MAX [" not in out
        assert "x   MPC_XY_VEL_MAX [" in shell(sim, "param show MPC_XY_VEL_MAX\n")
        assert "* symbol only allowed at end of search string" in shell(sim, "param show MPC*CRUISE\n")
        changed = shell(sim, "param show -c\n")
        assert "x + MPC_XY_CRUISE [" in changed and "MPC_XY_VEL_MAX" not in changed
        assert shell(sim, "param show -q MPC_XY_CRUISE\n") == "param show -q MPC_XY_CRUISE\n7.0000\npxh> "
        assert shell(sim, "param show -q COM_ARMABLE\n").endswith("\n1\npxh> ")
        assert shell(sim, "param compare MPC_XY_CRUISE 7\n") == "param compare MPC_XY_CRUISE 7\npxh> "
        assert "Command 'param' failed, returned 1." in shell(sim, "param compare MPC_XY_CRUISE 5\n")
        assert "Command 'param' failed" not in shell(sim, "param greater MPC_XY_CRUISE 5 9\n")
        assert "Command 'param' failed" not in shell(sim, "param compare COM_ARMABLE 0 1\n")
        assert "ERROR [param] Parameter NOPE not found\n" in shell(sim, "param compare NOPE 1\n")
        assert "not found" not in shell(sim, "param compare -s NOPE 1\n")


def _listened(sim: Sim, line: str, seconds: float) -> tuple[str, list[float]]:
    """The shell's output over ``seconds`` after ``line``, and the instants (s) of the replies
    that carry a "TOPIC:" header."""
    api = sim.api(0)
    since = len(api.frames)
    first = shell(sim, line)
    sim.advance(seconds)
    replies = [(t, m) for t, m in api.timed_messages("SERIAL_CONTROL", since)
               if m.flags & M.SERIAL_CONTROL_FLAG_REPLY]
    text = b"".join(bytes(m.data[:m.count]) for _, m in replies).decode()
    assert text.startswith(first)
    return text, [t for t, m in replies if b"TOPIC:" in bytes(m.data[:m.count])]


def test_listener_n_r_i_listen_over_time_as_listener_main():
    """listener_main.cpp: -n N messages of instance -i (default 0) each as it is published,
    headed "TOPIC: <name> instance <i> #<k>", the first at once, the prompt after the last;
    -r R at most R a second (and 30 s worth of messages without -n); an on-change topic only
    when it changes; 2 s without one: "Waited for 2.0 seconds without a message. Giving up.";
    any key ends it; an unknown option: the usage and -1; an instance never published."""
    with Sim() as sim:
        shell(sim, "\n")
        text, at = _listened(sim, "listener vehicle_attitude -n 3\n", 1.0)
        heads = [ln for ln in text.splitlines() if ln.startswith("TOPIC:")]
        assert heads == [f"TOPIC: vehicle_attitude instance 0 #{k}" for k in (1, 2, 3)]
        assert text.endswith("pxh> ") and text.count("pxh> ") == 1
        assert text.count("    q: [") == 3

        text, at = _listened(sim, "listener vehicle_local_position -r 5 -n 4\n", 2.0)
        assert [ln for ln in text.splitlines() if ln.startswith("TOPIC:")][-1] == \
            "TOPIC: vehicle_local_position instance 0 #4"
        gaps = [b - a for a, b in zip(at, at[1:])]
        assert len(gaps) == 3 and all(0.19 < g < 0.25 for g in gaps), gaps  # 1000 / 5 ms

        # vehicle_status: on change, and commander's republication every 500 ms
        text, at = _listened(sim, "listener vehicle_status -n 3\n", 1.5)
        gaps = [b - a for a, b in zip(at, at[1:])]
        assert len(gaps) == 2 and all(0.45 < g < 0.55 for g in gaps), gaps

        # a topic that never changes on the ground (home_position): one, then it gives up
        text, _ = _listened(sim, "listener home_position -n 2\n", 2.5)
        assert text.count("TOPIC: home_position instance 0 #") == 1
        assert text.endswith("Waited for 2.0 seconds without a message. Giving up.\npxh> ")

        # any key ends it (listener reads one byte and returns), then the prompt
        api = sim.api(0)
        shell(sim, "listener vehicle_attitude -r 10\n")  # 300 messages at 10 Hz
        out = shell(sim, "x")
        assert out == "pxh> "
        sim.advance(0.5)
        assert shell(sim, "") == ""  # nothing more comes
        assert api is sim.api(0)

        usage = shell(sim, "listener vehicle_attitude -x 3\n")
        assert "Usage: listener" in usage and "failed, returned -1." in usage
        assert shell(sim, "listener vehicle_attitude -i 3\n").endswith(
            "never published\npxh> ")
        one = shell(sim, "listener vehicle_attitude -i 0\n")  # -i alone: the timed form, #1
        assert "TOPIC: vehicle_attitude instance 0 #1\n vehicle_attitude\n" in one
        assert one.endswith("pxh> ")
