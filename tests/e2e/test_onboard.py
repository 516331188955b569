"""PX4's onboard services against `cornet run` with the real MAVSDK plugins: the logger and log
download (log_files, the flow of MAVSDK-Python's logfile_download.py) and failure injection
(failure, the flow of its failure_injection.py)."""

from __future__ import annotations

import asyncio

import pytest
import pyulog

from tests.e2e.persona import connected, first


@pytest.mark.asyncio
async def test_mavsdk_lists_downloads_and_erases_the_flight_log(daemon_factory, tmp_path):
    d = daemon_factory("--state-dir", str(tmp_path / "state"))
    async with connected(d.api_port()) as drone:
        await drone.action.arm()
        await drone.action.takeoff()
        await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 2.0, 30,
                    "at 2 m")
        await drone.action.land()
        await first(drone.telemetry.armed(), lambda a: not a, 60, "disarmed after landing")
        entries = await drone.log_files.get_entries()
        assert len(entries) == 1 and entries[0].size_bytes > 10_000, entries
        assert entries[0].date.startswith("20"), entries[0].date  # ISO 8601, UTC
        path = tmp_path / "flight.ulg"
        progress = []
        async for p in drone.log_files.download_log_file(entries[0], str(path)):
            progress.append(p.progress)
        assert len(progress) > 1 and progress == sorted(progress)  # chunk by chunk
        on_disk = sorted((tmp_path / "state" / "vehicle-1" / "log").rglob("*.ulg"))
        assert path.read_bytes() == on_disk[0].read_bytes()[:entries[0].size_bytes]
        log = pyulog.ULog(str(path))
        assert min(log.get_dataset("vehicle_local_position").data["z"]) < -1.5  # the takeoff
        assert any("Takeoff" in m.message for m in log.logged_messages)
        await drone.log_files.erase_all_log_files()
        from mavsdk.log_files import LogFilesError
        with pytest.raises(LogFilesError, match="NO_LOGFILES"):  # num_logs 0, as on PX4
            await drone.log_files.get_entries()


@pytest.mark.asyncio
async def test_mavsdk_gps_failure_makes_the_vehicle_descend_land_and_disarm(daemon_factory):
    from mavsdk.failure import FailureType, FailureUnit

    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        await drone.param.set_param_int("SYS_FAILURE_EN", 1)
        await drone.action.arm()
        await drone.action.takeoff()
        await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 2.0, 30,
                    "at 2 m")
        await drone.failure.inject(FailureUnit.SENSOR_GPS, FailureType.OFF, 0)
        await first(drone.telemetry.health(), lambda h: not h.is_global_position_ok, 10,
                    "global position lost (EKF2_NOAID_TOUT)")
        await first(drone.telemetry.armed(), lambda a: not a, 60, "descended, landed, disarmed")
        await drone.param.set_param_int("SYS_FAILURE_EN", 0)
        # PX4 sends the changed parameter again after the echo; MAVSDK's failure plugin, which
        # subscribes to SYS_FAILURE_EN, then refuses by itself (the vehicle would say DENIED).
        await asyncio.sleep(0.5)
        from mavsdk.failure import FailureError
        with pytest.raises(FailureError, match="DISABLED"):
            await drone.failure.inject(FailureUnit.SENSOR_GPS, FailureType.OK, 0)


@pytest.mark.asyncio
async def test_mavsdk_shell_talks_to_pxh(daemon_factory):
    """MAVSDK's shell plugin (SERIAL_CONTROL): PX4 SITL's pxh answers, commands act."""
    import asyncio

    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        received: list[str] = []

        async def collect():
            async for text in drone.shell.receive():
                received.append(text)

        async def until(text: str) -> None:
            for _ in range(50):
                if text in "".join(received):
                    return
                await asyncio.sleep(0.1)

        task = asyncio.ensure_future(collect())
        try:
            # MAVSDK's receive stream starts asynchronously: what pxh says before it is
            # subscribed is not delivered, so the first command waits for an answer first.
            await drone.shell.send("")
            await until("pxh> ")
            await drone.shell.send("ver all")
            await drone.shell.send("param show MPC_XY_CRUISE")
            await until("MPC_XY_CRUISE [")
        finally:
            task.cancel()
        out = "".join(received)
        assert "HW arch: PX4_SITL" in out and "x   MPC_XY_CRUISE [" in out and "pxh> " in out


@pytest.mark.asyncio
async def test_mavsdk_ftp_lists_downloads_uploads_and_compares(daemon_factory, tmp_path):
    """MAVSDK's ftp plugin on the vehicle's root (--state-dir): the log directory is there,
    a file goes up and comes back identical, and a path out of the root is refused."""
    from mavsdk.ftp import FtpError

    d = daemon_factory("--state-dir", str(tmp_path / "state"))
    async with connected(d.api_port()) as drone:
        listing = await drone.ftp.list_directory("/")
        assert "log" in listing.dirs, listing
        local = tmp_path / "up.txt"
        local.write_bytes(b"cornet " * 500)
        async for _ in drone.ftp.upload(str(local), "/"):
            pass
        assert await drone.ftp.are_files_identical(str(local), "/up.txt")
        (tmp_path / "down").mkdir()
        async for _ in drone.ftp.download("/up.txt", str(tmp_path / "down"), False):
            pass
        assert (tmp_path / "down" / "up.txt").read_bytes() == local.read_bytes()
        with pytest.raises(FtpError):
            await drone.ftp.list_directory("/../..")


@pytest.mark.asyncio
async def test_mavsdk_component_metadata_gets_px4s_parameter_metadata(daemon_factory):
    """MAVSDK's component_metadata plugin (QGC's flow): COMPONENT_METADATA, then
    etc/extras/component_general.json.xz and parameters.json.xz over MAVLink FTP, decompressed,
    with every parameter's description, units and range — also without a state dir; and the
    actuators metadata."""
    import json

    from mavsdk.component_metadata import MetadataType

    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        updates = drone.component_metadata.metadata_available()
        await drone.component_metadata.request_autopilot_component()
        got = {}
        async with asyncio.timeout(60):
            async for update in updates:
                got[update.type] = update
                if update.type == MetadataType.ALL_COMPLETED:
                    break
        assert MetadataType.PARAMETER in got, got
        params = json.loads(got[MetadataType.PARAMETER].json_metadata)
        by_name = {p["name"]: p for p in params["parameters"]}
        assert by_name["MPC_XY_CRUISE"]["units"] == "m/s" and by_name["MPC_XY_CRUISE"]["shortDesc"]
        assert by_name["SYS_FAILURE_EN"]["type"] == "Int32"
        data = await drone.component_metadata.get_metadata(1, MetadataType.PARAMETER)
        assert json.loads(data.json_metadata) == params
        assert MetadataType.ACTUATORS in got, got  # actuators.json.xz, QGC's Actuators page
        actuators = json.loads(got[MetadataType.ACTUATORS].json_metadata)
        assert [c["type"] for c in actuators["mixer_v1"]["config"]] == ["multirotor"]


@pytest.mark.asyncio
async def test_mavsdk_battery_failure_empties_the_battery_and_the_vehicle_lands(daemon_factory):
    """MAVSDK's failure plugin, battery off (PX4's battery simulator forced empty): the
    battery reads empty, the emergency level lands the vehicle (COM_LOW_BAT_ACT 2, SITL rcS); a barometer
    stuck is accepted and shows in MAVSDK's health."""
    from mavsdk.failure import FailureError, FailureType, FailureUnit

    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        await drone.action.arm()
        await drone.action.takeoff()
        await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 2.0, 30,
                    "at 2 m")
        await drone.failure.inject(FailureUnit.SENSOR_BARO, FailureType.STUCK, 0)
        with pytest.raises(FailureError, match="UNSUPPORTED"):
            await drone.failure.inject(FailureUnit.SENSOR_GPS, FailureType.GARBAGE, 0)
        await drone.failure.inject(FailureUnit.SYSTEM_BATTERY, FailureType.OFF, 0)
        await first(drone.telemetry.battery(), lambda b: b.remaining_percent < 1.0, 10,
                    "the battery empty")
        await first(drone.telemetry.armed(), lambda a: not a, 60, "landed and disarmed")


@pytest.mark.asyncio
async def test_mavsdk_log_streaming_gets_the_ulog_of_a_flight(daemon_factory, tmp_path):
    """MAVSDK's log_streaming plugin (MAV_CMD_LOGGING_START, LOGGING_DATA(_ACKED), LOGGING_ACK):
    the parts it hands out, base64-decoded and joined, are a ULog that pyulog reads, with the
    takeoff in it. No storage: PX4's logger streams without its SD card too."""
    import base64

    d = daemon_factory()
    async with connected(d.api_port()) as drone:
        parts: list[bytes] = []

        async def collect():
            async for part in drone.log_streaming.log_streaming_raw():
                parts.append(base64.b64decode(part.data_base64))

        task = asyncio.ensure_future(collect())
        await asyncio.sleep(0.5)  # subscribed before the first packet comes
        await drone.log_streaming.start_log_streaming()
        await drone.action.arm()
        await drone.action.takeoff()
        await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 2.0, 30,
                    "at 2 m")
        await drone.log_streaming.stop_log_streaming()
        await asyncio.sleep(0.5)
        task.cancel()
        data = b"".join(parts)
        assert data[:7] == b"ULog\x01\x12\x35", data[:16]
        path = tmp_path / "streamed.ulg"
        path.write_bytes(data)
        log = pyulog.ULog(str(path))
        assert log.msg_info_dict["ver_hw"] == "PX4_SITL"
        assert len(log.initial_parameters) > 600
        assert min(log.get_dataset("vehicle_local_position").data["z"]) < -1.5  # the takeoff
        assert any("Takeoff" in m.message for m in log.logged_messages)
        await drone.action.land()


def test_stream_log_example_saves_the_ulog_of_its_flight(daemon_factory, tmp_path):
    """gcs_examples/stream_log.py as a user runs it: a takeoff, hover and landing streamed into
    a .ulg file that pyulog reads."""
    import subprocess
    import sys
    from pathlib import Path

    from gateway.ci.launcher import free_tcp_port

    d = daemon_factory()
    out = tmp_path / "streamed.ulg"
    script = Path(__file__).resolve().parents[2] / "gcs_examples" / "stream_log.py"
    run = subprocess.run([sys.executable, str(script), "--port", str(d.api_port(0)),
                          "--grpc-port", str(free_tcp_port()), "--out", str(out), "--hover", "8"],
                         capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert run.returncode == 0 and "-- saved" in run.stdout, f"{run.stdout}\n{run.stderr}"
    log = pyulog.ULog(str(out))
    assert len(log.initial_parameters) > 600 and log.msg_info_dict["ver_hw"] == "PX4_SITL"
    assert min(log.get_dataset("vehicle_local_position").data["z"]) < -1.0  # it flew
