"""PX4's events protocol (mavlink_events.cpp, events.h) and the health and arming report it
carries (Commander's HealthAndArmingChecks, modeCheck.cpp, mode_requirements.cpp)."""

from __future__ import annotations

import json
import struct

import pytest
from pymavlink.dialects.v20 import common as M
from pymavlink.generator.mavcrc import x25crc

from gateway.ci.lockstep import CLIENT_SYSID
from gateway.mavlink import event_messages as EM
from gateway.mavlink.session import LinkKind
from gateway.mavlink.wip_dialect import ESC_INFO, ESC_STATUS, SET_VELOCITY_LIMITS
from gateway.onboard.metadata import events_json
from gateway.testing import Sim
from vehicles.events import DEFINITIONS, INITIAL_SEQUENCE, EventLog, Log, event_id
from vehicles.health_checks import (
    INDEX,
    REQ_MANUAL_CONTROL,
    CheckInputs,
    HealthChecks,
    evaluate,
)
from vehicles.types import NavState


def test_event_ids_are_px4s():
    """events::ID: FNV-1a 32 of the name, low 24 bits, component 1 on top; the ids PX4's
    metadata (and tools that decode PX4's events by number) know."""
    assert event_id("commander_takeoff_detected") == 0x01414569
    assert event_id("commander_landing_detected") == 0x019638AC
    assert event_id("commander_arming_check_summary") == 0x01A893E0
    assert event_id("commander_health_summary") == 0x011D3727
    assert event_id("commander_arm_denied_resolve_failures") & 0xFFFFFF == 133277
    assert event_id("check_modes_manual_control") & 0xFFFFFF == 453929
    assert event_id("check_modes_mission") & 0xFFFFFF == 377561
    assert event_id("check_modes_offboard_signal") & 0xFFFFFF == 3087815
    assert event_id("check_modes_home_position") & 0xFFFFFF == 79408


@pytest.mark.parametrize("cls", [EM.EVENT, EM.CURRENT_EVENT_SEQUENCE, EM.REQUEST_EVENT,
                                 EM.RESPONSE_EVENT_ERROR, ESC_INFO, ESC_STATUS,
                                 SET_VELOCITY_LIMITS])
def test_message_definitions_have_mavgens_crc_extra(cls):
    """CRC_EXTRA as mavgen computes it from the definition (name, then the wire-ordered fields'
    types and names, array lengths); a frame round-trips through pymavlink's own parser."""
    crc = x25crc()
    crc.accumulate_str(cls.msgname + " ")
    for i, name in enumerate(cls.ordered_fieldnames):
        crc.accumulate_str(cls.fieldtypes[cls.fieldnames.index(name)] + " ")
        crc.accumulate_str(name + " ")
        if cls.array_lengths[i]:
            crc.accumulate([cls.array_lengths[i]])
    assert cls.crc_extra == (crc.crc & 0xFF) ^ (crc.crc >> 8)
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths))
    values = [list(range(lengths[n])) if lengths[n] else k + 1
              for k, n in enumerate(cls.fieldnames)]
    frame = cls(*values).pack(M.MAVLink(None, 1, 1))
    (decoded,) = M.MAVLink(None, 0, 0).parse_buffer(frame)
    assert [getattr(decoded, n) for n in cls.fieldnames] == values


def test_sequence_starts_high_wraps_and_keeps_twenty():
    log = EventLog()
    first = log.send(0.5, DEFINITIONS[0], Log.INFO)
    assert first.sequence == INITIAL_SEQUENCE + 1 == 65526 and first.time_boot_ms == 500
    assert first.log_levels == 0x66
    for k in range(30):
        log.send(1.0 + k, DEFINITIONS[0], Log.CRITICAL, Log.INFO)
    assert log.latest == (65526 + 30) & 0xFFFF == 20 and len(log) == 20
    assert [e.sequence for e in log.after(15)] == [16, 17, 18, 19, 20]
    assert log.get(1) is not None and log.get(0) is None and log.get(65535) is None
    assert log.after(20) == [] and log.get(20).log_levels == 0x62
    assert log.oldest_after(65526) == 1  # the oldest kept, after a sequence no longer kept
    with pytest.raises(ValueError):
        log.send(2.0, DEFINITIONS[0], Log.INFO, None, "26B", *range(26))


def inputs(**kw) -> CheckInputs:
    base = dict(armed=False, nav_state=NavState.AUTO_LOITER, position_valid=True,
                manual_control=True, mission_valid=True, offboard_available=True,
                home_valid=True, rc_in_mode=1, mission_required=False, sensor_failures=0)
    base.update(kw)
    return CheckInputs(**base)


def names(results) -> list[str]:
    return [event.message for event, *_ in results.checks]


def test_mode_checks_as_modecheck_cpp():
    ok = evaluate(inputs())
    assert ok.checks == () and ok.can_arm == ok.can_run == 0xFFFFFFFF
    no_pos = evaluate(inputs(position_valid=False))
    assert names(no_pos) == ["No valid local position estimate",
                             "No valid global position estimate"]
    assert not no_pos.can_arm_in(NavState.AUTO_LOITER) and not no_pos.can_arm_in(NavState.POSCTL)
    assert no_pos.can_arm_in(NavState.STAB)  # no position needed
    assert no_pos.error == 1 << INDEX["system"]
    # Sticks missing: a warning shown for every mode, and no manual mode can arm or run.
    sticks = evaluate(inputs(manual_control=False))
    (event, level, modes, component, _), = sticks.checks
    assert (event.message, level, modes) == ("No manual control input", Log.WARNING, 0xFFFFFFFF)
    assert component == INDEX["remote_control"] and sticks.warning == 1 << component
    assert sticks.can_arm & REQ_MANUAL_CONTROL == 0 and sticks.can_arm_in(NavState.AUTO_LOITER)
    disabled = evaluate(inputs(manual_control=False, rc_in_mode=4))
    assert disabled.checks[0][1:3] == (Log.ERROR, REQ_MANUAL_CONTROL)
    # No mission: Mission cannot arm (Info: neither error nor warning); COM_ARM_MIS_REQ: none.
    no_mission = evaluate(inputs(mission_valid=False))
    assert not no_mission.can_arm_in(NavState.AUTO_MISSION) and no_mission.error == 0
    assert evaluate(inputs(mission_valid=False, mission_required=True)).can_arm == 0
    rtl = evaluate(inputs(nav_state=NavState.AUTO_RTL))
    assert names(rtl) == ["Mode not suitable for arming"]
    assert not rtl.can_arm_in(NavState.AUTO_RTL) and rtl.can_run & (1 << NavState.AUTO_RTL)
    assert evaluate(inputs(nav_state=NavState.AUTO_RTL, armed=True)).checks == ()


def test_gps_failure_is_a_health_error_of_the_gps():
    from vehicles.estimation import F_GPS_OFF, F_GYRO_STUCK

    r = evaluate(inputs(sensor_failures=F_GPS_OFF | F_GYRO_STUCK))  # a stuck gyro still publishes
    assert r.health_error == 1 << INDEX["gps"] and r.checks == ()
    assert r.present & (1 << INDEX["gps"])


def test_a_sensor_off_for_a_second_fails_its_check_and_no_mode_arms():
    """gyroCheck.cpp and the others: data older than 1 s is "No valid data from Gyro 0", a
    health failure (Error) of the gyro affecting every mode; SYS_HAS_MAG 0 skips the compass."""
    from vehicles.estimation import F_GYRO_OFF, F_MAG_OFF

    log = EventLog()
    seen = []
    checks = HealthChecks(log, seen.append)

    def update(t, failures, required=0xFFFF):
        return checks.update(t, False, NavState.AUTO_LOITER, lambda: inputs(
            sensor_failures=failures, required_sensors=required), force=True)

    update(0.0, F_GYRO_OFF | F_MAG_OFF)
    assert seen[-1].checks == () and seen[-1].can_arm == 0xFFFFFFFF
    update(0.9, F_GYRO_OFF | F_MAG_OFF)
    assert seen[-1].checks == ()
    update(1.0, F_GYRO_OFF | F_MAG_OFF)
    r = seen[-1]
    assert names(r) == ["No valid data from Gyro {3}", "No valid data from Compass {3}"]
    assert r.can_arm == 0 and r.error == 0  # a health failure, not an arming check's
    assert r.health_error == (1 << INDEX["gyro"]) | (1 << INDEX["magnetometer"])
    assert r.preflight_texts == ("Preflight Fail: No valid data from Gyro 0",
                                 "Preflight Fail: No valid data from Compass 0")
    gyro = [e for e in log.after(INITIAL_SEQUENCE) if e.id == event_id("check_gyro_no_data")][-1]
    assert gyro.arguments == struct.pack("<IBB", 0xFFFFFFFF, INDEX["gyro"], 0)
    update(1.1, F_GYRO_OFF | F_MAG_OFF, required=0xFFFF & ~F_MAG_OFF)  # SYS_HAS_MAG 0
    assert names(seen[-1]) == ["No valid data from Gyro {3}"]
    update(1.2, 0)  # back: the check passes at once
    assert seen[-1].checks == () and seen[-1].health_error == 0


def test_reports_on_change_at_most_every_two_seconds_or_when_forced():
    log = EventLog()
    checks = HealthChecks(log)
    state = {"pos": False}

    def now_inputs():
        return inputs(position_valid=state["pos"])

    def update(t, force=False):
        return checks.update(t, False, NavState.AUTO_LOITER, now_inputs, force)

    assert update(0.0)  # the first evaluation differs from nothing
    burst = log.after(INITIAL_SEQUENCE)
    assert [e.id for e in (burst[0], burst[-1])] == [event_id("commander_arming_check_summary"),
                                                     event_id("commander_health_summary")]
    assert len(burst) == 4  # summary, two position checks, summary
    summary = struct.unpack("<BIIII", burst[0].arguments)
    assert summary[0] == 0 and summary[1] == 1 << INDEX["system"]
    assert burst[0].log_levels == 0x88 and burst[1].log_levels == 0x33
    modes, component = struct.unpack("<IB", burst[1].arguments)
    assert component == INDEX["system"] and modes & (1 << NavState.AUTO_LOITER)
    assert not update(0.05)  # not due yet (10 Hz)
    state["pos"] = True
    assert not update(1.0)  # changed, but within 2 s of the last report
    assert not update(1.5)
    assert update(2.0)  # the change is sent once 2 s passed
    assert not update(4.5)  # nothing changed
    seq = log.latest
    assert update(4.6, force=True) and log.latest == (seq + 2) & 0xFFFF  # RUN_PREARM_CHECKS


def test_the_metadata_names_every_event_and_the_mode_groups():
    doc = json.loads(events_json())
    px4 = doc["components"]["1"]
    assert px4["namespace"] == "px4" and "health_and_arming_check" in px4["supported_protocols"]
    defined = {int(k) | (1 << 24): v["name"] for g in px4["event_groups"].values()
               for k, v in g["events"].items()}
    assert {d.id: d.name for d in DEFINITIONS} == defined
    for name, enum in px4["enums"].items():
        for value, e in enum["entries"].items():  # PX4's own: no words for "none" or "generic"
            assert e["name"] and (e["description"] or (name, value) in (
                ("failsafe_action_t", "0"), ("failsafe_cause_t", "0")))
    groups = px4["navigation_mode_groups"]["groups"]
    assert groups[str(int(NavState.AUTO_LOITER))] == [0x03040000]  # Hold's custom_mode
    assert groups[str(int(NavState.AUTO_TAKEOFF))] == [0x02040000]


def _events(client, since=0):
    return client.messages("EVENT", since)


def test_links_send_events_sequence_and_answer_requests():
    """Every link: CURRENT_EVENT_SEQUENCE (RESET) before its first EVENT and every 3 s; the
    events in order; REQUEST_EVENT sends a buffered event again, byte for byte, and answers a
    sequence no longer kept with RESPONSE_EVENT_ERROR naming the oldest one kept."""
    with Sim(links=(LinkKind.API, LinkKind.GCS)) as sim:
        api = sim.api(0)
        sim.advance(7.0)
        seqs = api.timed_messages("CURRENT_EVENT_SEQUENCE")
        assert seqs[0][1].flags == 1 and all(m.flags == 0 for _, m in seqs[1:])
        times = [t for t, _ in seqs[1:]]
        assert all(abs(b - a - 3.0) < 0.05 for a, b in zip(times, times[1:]))
        events = _events(api)
        assert [e.sequence for e in events] == [(65526 + k) & 0xFFFF for k in range(len(events))]
        assert events[0].id == event_id("commander_arming_check_summary")
        assert gcs_and_api_agree(sim)
        n = len(api.frames)
        api.send(EM.REQUEST_EVENT(1, 1, events[1].sequence, events[1].sequence))
        sim.advance(0.1)
        (again,) = _events(api, n)
        assert again.get_payload() == events[1].get_payload()
        n = len(api.frames)
        api.send(EM.REQUEST_EVENT(1, 1, 1000, 1000))
        sim.advance(0.1)
        (error,) = api.messages("RESPONSE_EVENT_ERROR", n)
        assert (error.sequence, error.reason, error.target_system) == (1000, 0, CLIENT_SYSID)
        assert error.sequence_oldest_available == events[0].sequence


def gcs_and_api_agree(sim) -> bool:
    return [e.get_payload() for e in _events(sim.gcs(0))] == \
        [e.get_payload() for e in _events(sim.api(0))]


def test_run_prearm_checks_reports_at_once_and_takeoff_is_an_event():
    with Sim() as sim:
        api = sim.api(0)
        sim.advance(6.0)
        n = len(api.frames)
        assert api.command_long(M.MAV_CMD_RUN_PREARM_CHECKS, 0, 0, 0, 0, 0, 0, 0) == 0
        sim.advance(0.05)
        burst = _events(api, n)
        assert burst[0].id == event_id("commander_arming_check_summary")
        assert burst[-1].id == event_id("commander_health_summary")
        assert api.arm() == 0 and api.takeoff() == 0
        sim.advance(6.0)
        ids = [e.id for e in _events(api)]
        assert event_id("commander_takeoff_detected") in ids


def test_arming_denied_sends_its_event():
    with Sim() as sim:
        api = sim.api(0)
        sim.advance(0.2)  # no position estimate yet
        assert api.arm() != 0
        sim.advance(0.1)
        denied = [e for e in _events(api)
                  if e.id == event_id("commander_arm_denied_resolve_failures")]
        assert len(denied) == 1 and denied[0].log_levels == 0x62


def test_hostile_requests_are_bounded():
    """A REQUEST_EVENT for every sequence there is gets one error for the range's start and the
    newest twenty sequences served, not 65536 answers; links keep sending telemetry."""
    with Sim() as sim:
        api = sim.api(0)
        sim.advance(3.0)
        n = len(api.frames)
        api.send(EM.REQUEST_EVENT(1, 1, 0, 65535))
        api.send(EM.REQUEST_EVENT(1, 1, 65535, 0))
        sim.advance(0.5)
        answers = len(_events(api, n)) + len(api.messages("RESPONSE_EVENT_ERROR", n))
        assert answers <= 2 * 21
        assert api.messages("ATTITUDE", n)


def test_the_navigators_texts_come_with_their_events():
    """takeoff.cpp and rtl_direct.cpp: each text (with PX4's tab) beside its event, as QGC shows
    the event; the return altitude is AMSL (PX4 SITL's home is 488 m up)."""
    from pyulog.libevents_parse.parser import Parser

    from tests.unit.test_vehicles_flight import Sim as FlightSim
    from tests.unit.test_vehicles_flight import take_off

    sim = FlightSim()
    try:
        sim.run(1.2)
        v = sim.v
        take_off(sim)
        v.return_to_launch(sim.t)
        assert sim.run(60.0, until=lambda: not v.status.armed)
        assert [t for t in sim.texts() if t.startswith(("Using", "RTL"))] == [
            "Using default takeoff altitude: 2.5 m\t",
            "RTL: start return at 491 m (3 m above destination)\t", "RTL: land at destination\t"]
        parser = Parser()
        parser.load_definitions(json.loads(events_json()))
        parser.set_profile("dev")
        shown = [parser.parse(e.id, e.arguments.ljust(25, b"\0"))
                 for e in v.events.after(v.events.latest - len(v.events))]
        assert [m.message() for m in shown if m is not None and m.group() == "default"] == [
            "Armed by external command", "Using default takeoff altitude: 2.50 m",
            "Takeoff detected", "Returning to launch",
            "RTL: start return at 491 m (3 m above destination)",
            "RTL: land at destination", "Landing detected", "Disarmed by landing"]
    finally:
        sim.close()


def test_estimator_test_ratios_over_their_limits_deny_arming_in_the_modes_needing_attitude():
    """estimatorCheck.cpp checkEstimatorStatus: disarmed, each estimator_status test ratio over
    its COM_ARM_EKF_* limit is an arming check Error of the local position estimate, in the
    modes that need an attitude (not Manual, Acro, Termination), with the ratio and the limit as
    the event's arguments; the arming request says PX4's "Preflight Fail" text. It runs after
    the accelerometer's and the barometer's checks, before the failure detector's and the
    gyro's (HealthAndArmingChecks' order)."""
    from vehicles.estimation import F_GYRO_OFF
    from vehicles.health_checks import LOCAL_POSITION_ESTIMATE, REQ_ATTITUDE

    log = EventLog()
    seen = []
    checks = HealthChecks(log, seen.append)
    failing = ((0, 1.5, 1.0), (2, 0.75, 0.5))  # height, then position (ESTIMATOR_CHECKS')
    checks.update(0.0, False, NavState.AUTO_LOITER, lambda: inputs(
        sensor_failures=F_GYRO_OFF, estimator_failing=failing), force=True)
    checks.update(1.0, False, NavState.AUTO_LOITER, lambda: inputs(
        sensor_failures=F_GYRO_OFF, estimator_failing=failing), force=True)
    r = seen[-1]
    assert names(r) == ["Height estimate error", "Position estimate error",
                        "No valid data from Gyro {3}"]
    assert r.error == 1 << LOCAL_POSITION_ESTIMATE
    assert r.preflight_texts == ("Preflight Fail: height estimate error",
                                 "Preflight Fail: position estimate error",
                                 "Preflight Fail: No valid data from Gyro 0")
    event = [e for e in log.after(INITIAL_SEQUENCE)
             if e.id == event_id("check_estimator_pos_est_err")][-1]
    assert event.arguments == struct.pack("<IBff", REQ_ATTITUDE, LOCAL_POSITION_ESTIMATE, 0.75, 0.5)
    checks.update(2.0, False, NavState.MANUAL, lambda: inputs(estimator_failing=failing))
    r = seen[-1]
    assert r.can_arm & (1 << int(NavState.MANUAL)) and r.can_arm & (1 << int(NavState.ACRO))
    assert not r.can_arm & (1 << int(NavState.AUTO_LOITER))
    assert not r.can_arm & (1 << int(NavState.STAB))


def test_a_new_ratio_alone_is_no_new_report():
    """Report sends when the results change, not the values of a failing check's arguments."""
    log = EventLog()
    seen = []
    checks = HealthChecks(log, seen.append)
    assert checks.update(0.0, False, NavState.AUTO_LOITER,
                         lambda: inputs(estimator_failing=((2, 0.75, 0.5),)))
    assert not checks.update(2.5, False, NavState.AUTO_LOITER,
                             lambda: inputs(estimator_failing=((2, 0.8, 0.5),)))
    assert seen[-1].check_args == ((0.8, 0.5),)
