"""MAV_CMD_PREFLIGHT_CALIBRATION as PX4 SITL runs it (Commander.cpp, calibration_routines.cpp,
accelerometer_calibration.cpp, mag_calibration.cpp): PX4's "[cal]" texts, which QGC's sensor
page and MAVSDK's calibration plugin parse, on the simulated IMU; nobody turns a simulated
vehicle, so the accelerometer and magnetometer calibrations end as on a PX4 SITL vehicle left
on the ground."""

from __future__ import annotations

from pymavlink.dialects.v20 import common as M

from gateway.ci.lockstep import CLIENT_SYSID
from gateway.testing import Sim
from vehicles.events import ARM_DENIED_CALIBRATING

CAL = M.MAV_CMD_PREFLIGHT_CALIBRATION
ACCEL = (0, 0, 0, 0, 1, 0, 0)
MAG = (0, 1, 0, 0, 0, 0, 0)
CANCEL = (0, 0, 0, 0, 0, 0, 0)


def texts(api, since: int = 0) -> list[tuple[float, str]]:
    """(time, text) of the STATUSTEXTs received, a text sent in chunks (chunk_seq 1.. follow
    chunk 0) joined."""
    out: list[tuple[float, str]] = []
    for t, m in api.timed_messages("STATUSTEXT", since):
        if m.chunk_seq:
            out[-1] = (out[-1][0], out[-1][1] + m.text)
        else:
            out.append((t, m.text))
    return out


def test_gyro_and_level_calibration_as_px4_sitl():
    """Gyro and level horizon: PX4's progress texts; one at a time and disarmed only
    (TEMPORARILY_REJECTED otherwise, as Commander answers)."""
    with Sim() as sim:
        sim.advance(1.0)
        api = sim.api(0)
        assert api.command_long(CAL, 1, 0, 0, 0, 0, 0, 0) == 0
        assert api.command_long(CAL, 0, 0, 0, 0, 2, 0, 0) == 1
        sim.advance(3.0)
        assert api.command_long(CAL, 0, 0, 0, 0, 2, 0, 0) == 0
        sim.advance(3.0)
        said = [text for _, text in texts(api)]
        assert said[:2] == ["[cal] calibration started: 2 gyro", "[cal] progress <0>"]
        assert "[cal] progress <100>" in said and "[cal] calibration done: gyro" in said
        assert "[cal] calibration done: level" in said
        assert api.arm() == 0
        assert api.command_long(CAL, 1, 0, 0, 0, 0, 0, 0) == 1


def test_accelerometer_calibration_measures_the_side_it_rests_on_then_times_out():
    """PX4's routine on the resting IMU: the "down" side is detected and measured (g on -z);
    the vehicle then rests on it five more times and the calibration fails "timeout: no
    motion", as PX4 SITL's does when nobody turns the vehicle. Arming is denied meanwhile."""
    with Sim() as sim:
        sim.advance(1.0)
        api = sim.api(0)
        assert api.command_long(CAL, *ACCEL) == 0
        events = sim.vehicles[0].events
        before = events.latest
        assert api.arm() == 1
        # Commander::arm's event comes with the text (whose tab tells an events GCS to hide it)
        assert ARM_DENIED_CALIBRATING.id in [e.id for e in events.after(before)]
        sim.advance(35.0)
        said = texts(api)
        lines = [text for _, text in said]
        assert lines[:3] == ["[cal] calibration started: 2 accel", "Arming denied: calibrating\t",
                             "[cal] pending: back front left right up down"]
        assert lines.count("[cal] down orientation detected") == 2
        result = next(text for text in lines if text.startswith("[cal] down side result: "))
        x, y, z = (float(v) for v in result.split("[")[-1].rstrip("]").split())
        assert abs(x) < 0.05 and abs(y) < 0.05 and abs(z + 9.81) < 0.05
        assert "[cal] progress <17>" in lines
        assert lines.count("[cal] down side done, rotate to a different side") == 2
        assert "[cal] pending: back front left right up" in lines
        assert lines.count("[cal] down side already completed") == 5
        assert lines[-2:] == ["[cal] calibration failed: timeout: no motion",
                              "[cal] calibration failed: accel"]
        # Rest detection (~1.3 s still after the EMA settles), ~4 s of samples, five more rests.
        started, ended = said[0][0], said[-1][0]
        assert 20.0 < ended - started < 35.0, ended - started
        sim.advance(1.0)
        assert api.arm() == 0


def test_magnetometer_calibration_fails_without_rotation():
    with Sim() as sim:
        sim.advance(1.0)
        api = sim.api(0)
        assert api.command_long(CAL, *MAG) == 0
        sim.advance(45.0)
        said = texts(api)
        lines = [text for _, text in said]
        assert lines[0] == "[cal] calibration started: 2 mag"
        assert "[cal] down orientation detected" in lines
        assert "[cal] Rotate vehicle" in lines
        # PX4 before v1.11 said more ("… around the detected orientation", "Continue rotation …")
        assert not any("Continue rotation" in line or "around the" in line for line in lines)
        assert lines[-2:] == ["Failed: This calibration requires rotation.",
                              "[cal] calibration failed: mag"]
        asked = next(t for t, text in said if text == "[cal] Rotate vehicle")
        assert abs(said[-1][0] - asked - 35.0) < 0.2  # five times the 7 s a side may take


def test_cancel_ends_a_running_calibration_where_px4_checks_for_it():
    with Sim() as sim:
        sim.advance(1.0)
        api = sim.api(0)
        assert api.command_long(CAL, *ACCEL) == 0
        sim.advance(9.0)  # measuring the down side, or just done
        since = len(api.frames)
        # Answered twice: the routine ACCEPTs it where it checks, Commander (its worker busy)
        # rejects it; here the routine is averaging a side, so the rejection comes first.
        assert api.command_long(CAL, *CANCEL, retries=0) == 1
        sim.advance(6.0)
        lines = [text for _, text in texts(api, since)]
        assert lines[-2:] == ["[cal] calibration cancelled", "[cal] calibration failed: accel"]
        acks = [(m.command, m.result, m.target_system) for m in api.messages("COMMAND_ACK", since)]
        assert sorted(acks) == [(CAL, 0, CLIENT_SYSID), (CAL, 1, CLIENT_SYSID)]
        sim.advance(1.0)
        assert api.command_long(CAL, 1, 0, 0, 0, 0, 0, 0) == 0  # free again


def test_quick_accelerometer_calibration_on_the_resting_vehicle():
    """do_accel_calibration_quick (param5 4): no "started" text; more than 300 resting IMU samples
    (1.2 s at 250 Hz) and the closest orientation, then "[cal] calibration done: accel";
    arming is denied meanwhile. The shell's `commander calibrate accel quick` sends the same."""
    from tests.unit.test_onboard_shell import shell

    with Sim() as sim:
        sim.advance(1.0)
        api = sim.api(0)
        assert api.command_long(CAL, 0, 0, 0, 0, 4, 0, 0) == 0
        assert api.arm() == 1
        sim.advance(1.0)
        assert not any("accel" in text for _, text in texts(api))  # still averaging
        sim.advance(1.0)
        said = texts(api)
        done = [t for t, text in said if text == "[cal] calibration done: accel"]
        assert len(done) == 1 and 1.2 <= done[0] - 1.0 < 1.5, said
        assert not any("started" in text for _, text in said)
        assert api.arm() == 0
        assert api.disarm() == 0
        since = len(texts(api))
        assert shell(sim, "commander calibrate accel quick\n").endswith("pxh> ")
        sim.advance(2.0)
        assert [text for _, text in texts(api)][since:].count("[cal] calibration done: accel") == 1


def test_quick_accelerometer_calibration_fails_on_a_moving_vehicle():
    """A vehicle that never rests for 300 samples within 3 s: "[cal] calibration failed:
    accel", as do_accel_calibration_quick ends."""
    from vehicles.calibration import Calibration
    from vehicles.status_log import StatusLog

    log = StatusLog()
    cal = Calibration(log)
    assert cal.start(0.0, "accel_quick", armed=False) == 0
    t = 0.0
    while cal.busy and t < 5.0:
        t += 0.02
        cal.sample((0.0, 0.0, -9.8 + (0.8 if int(t * 50) % 2 else 0.0)), (0.0, 0.0, 0.0))
        cal.update(t)
    assert not cal.busy and 3.0 <= t < 3.1
    assert [m.text for m in log.after(0)] == ["[cal] calibration failed: accel"]


def test_radio_esc_and_unserved_calibrations():
    with Sim() as sim:
        sim.advance(1.0)
        api = sim.api(0)
        assert api.command_long(CAL, 0, 0, 0, 0, 0, 0, 1) == 2  # ESCs: battery connected
        sim.advance(0.1)
        assert texts(api)[-1][1] == "[cal] calibration failed: Disconnect battery and try again"
        assert api.command_long(CAL, 0, 0, 0, 1, 0, 0, 0) == 0  # radio: RC input off
        sim.advance(0.1)
        assert texts(api)[-1][1] == "Calibration: Disabling RC input"
        assert api.arm() == 1
        assert api.command_long(CAL, *CANCEL) == 0  # param4 0: radio calibration over
        sim.advance(0.1)
        assert texts(api)[-1][1] == "Calibration: Restoring RC input"
        assert api.command_long(CAL, 0, 0, 0, 5, 0, 0, 0) == 3  # no such calibration
        assert api.arm() == 0


def test_shell_commander_calibrate_starts_one():
    """pxh's `commander calibrate gyro` (QGC's MAVLink Console) starts the same routine."""
    from tests.unit.test_onboard_shell import shell

    with Sim() as sim:
        sim.advance(1.0)
        assert shell(sim, "commander calibrate gyro\n").endswith("pxh> ")
        sim.advance(3.0)
        lines = [text for _, text in texts(sim.api(0))]
        assert "[cal] calibration started: 2 gyro" in lines
        assert "[cal] calibration done: gyro" in lines
        assert "unsupported" in shell(sim, "commander calibrate radio\n")


def test_a_routine_that_checks_at_once_accepts_the_cancel_before_commander_rejects_it():
    """Gyro calibration checks for a cancel in every loop (at the sensors' rate): its ACCEPTED
    is the first answer, which is what MAVSDK's cancel() and QGC act on; Commander's
    TEMPORARILY_REJECTED follows."""
    with Sim() as sim:
        sim.advance(1.0)
        api = sim.api(0)
        assert api.command_long(CAL, 1, 0, 0, 0, 0, 0, 0) == 0
        sim.advance(0.5)
        since = len(api.frames)
        assert api.command_long(CAL, *CANCEL, retries=0) == 0
        sim.advance(0.5)
        acks = [(m.command, m.result) for m in api.messages("COMMAND_ACK", since)]
        assert acks == [(CAL, 0), (CAL, 1)]
        assert [text for _, text in texts(api, since)][-1] == "[cal] calibration cancelled"
