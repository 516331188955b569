"""Status topics PX4's logger writes (logged_topics.py has the rules): takeoff_status,
vehicle_acceleration, failure_detector_status, mission_result, vehicle_roi, telemetry_status and
timesync_status.

Source: PX4 1.15 msg/TakeoffStatus.msg, VehicleAcceleration.msg, FailureDetectorStatus.msg,
MissionResult.msg, VehicleRoi.msg, TelemetryStatus.msg, TimesyncStatus.msg; logged_topics.cpp
(takeoff_status at 1 s, vehicle_acceleration at 50 ms, failure_detector_status at 100 ms,
mission_result at every publication, vehicle_roi at 1 s, telemetry_status at 1 s for each of up
to 4 instances, timesync_status at 1 s for each of up to 3); the publishers:
MulticopterPositionControl::Run (takeoff_status when the takeoff state or the tilt limit
changes), VehicleAcceleration::Run (every accelerometer sample), Commander::run (failure_detector
_status with vehicle_status: every 500 ms), Navigator::publish_mission_result (when the result
changed; vehicle_roi at each ROI command), Mavlink::task_main (telemetry_status every second),
each MAVLink instance's Timesync::update (timesync_status at every TIMESYNC reply: its uORB
instances in the order the links first published, gateway/mavlink/timesync.py).
Rules:
- Unlike the topics CORNET logs a subset of, these carry every field of their message, in the
  order and with the padding of PX4's generated ULog format (px_generate_uorb_topic_helper:
  fields sorted by type size, largest first, then ``uint8_t[n] _padding0`` up to 8 bytes);
  the records leave the trailing padding out (ulog.py).
- Where CORNET has no model of a quantity the value is what PX4 SITL publishes, said where set.
"""

from __future__ import annotations

import math
from typing import Any

from gateway.mavlink.link import DATARATE_B_S, LinkKind
from gateway.mavlink.streams import STREAMS
from gateway.onboard.topic import COMMANDER_REPUBLISH_S, U64, B, D, F, Topic
from vehicles.cnum import f32
from vehicles.estimation import R_ACC_LP
from vehicles.mission_jumps import jump_repeats

U8, U16, U32 = "uint8_t", "uint16_t", "uint32_t"
# takeoff_status_s::TAKEOFF_STATE_DISARMED is 1 (0: uninitialized), CORNET's TakeoffState 0
TAKEOFF_STATE_DISARMED = 1
TELEMETRY_INSTANCES = 4  # add_optional_topic_multi("telemetry_status", 1000, 4)
LINK_TYPE_GENERIC = 0  # telemetry_status_s (UDP)
MAVLINK_MODE_NORMAL, MAVLINK_MODE_ONBOARD = 0, 2  # Mavlink::MAVLINK_MODE
HEARTBEAT_TIMEOUT_S = 2.5  # telemetry_status_s::HEARTBEAT_TIMEOUT_US


def _takeoff_status(v: Any, now_us: int) -> tuple:
    """mc_pos_control's takeoff state (TakeoffHandling) and its slewed tilt limit."""
    stage = v.autopilot.stage
    return (stage.tilt_limit_rad, TAKEOFF_STATE_DISARMED + int(stage.takeoff.state))


def _acceleration(v: Any, now_us: int) -> tuple | None:
    """The last physics step's filtered sample (a vehicle without the steps ring: none)."""
    recent = getattr(v, "recent_steps", None)
    rows = recent(None) if recent is not None else None
    if not rows:
        return None
    t_s, row = rows[-1]
    return (round(t_s * 1e6), *row[R_ACC_LP:R_ACC_LP + 3])


def _acceleration_step(r: Any, t_us: int) -> tuple:
    return (t_us, *r[R_ACC_LP:R_ACC_LP + 3])


def _failure_detector(v: Any, now_us: int) -> tuple:
    """The attitude checks CORNET runs (failure_detector.py). The others as PX4 SITL has them:
    no external ATS (FD_EXT_ATS_EN 0), every ESC armed while the vehicle is (updateEscsStatus
    passes), gz's ESC reports carry no current so updateMotorStatus finds no motor failure,
    and no battery or altitude check for a multicopter. imbalanced_prop_metric: CORNET does not
    model vehicle_imu_status's accelerometer variances; gz's IMU noise, the same on every axis,
    keeps PX4 SITL's metric at about 0."""
    fd = v.autopilot.failure_detector
    return (0.0, 0, fd.roll, fd.pitch, False, False, False, False, False, False)


def _mission_result(v: Any, now_us: int) -> tuple | None:
    """The navigator's mission_result: none before its first feasibility check (PX4 runs it
    once home is set). item_do_jump_changed is set in the first result after a DO_JUMP was
    counted (Navigator::publish_mission_result clears it after each publication); failure
    is set when a forced heading timed out (MIS_YAW_TMT); execution_mode 0 (normal: CORNET
    flies no reverse missions)."""
    mission = v.autopilot.navigator.mission
    check = mission.check
    ids = check.checked_ids
    if ids is None:
        return None
    items = mission.items
    count = len(items)
    valid = mission.valid()
    last, reports = mission.last_jump
    changed = reports != v.memo.setdefault("mission_jumps", reports) and 0 <= last < count
    v.memo["mission_jumps"] = reports
    index = remaining = 0
    if changed:  # report_do_jump_mission_changed: the DO_JUMP and the jumps it has left
        index = last
        remaining = max(0, jump_repeats(items[last]) - mission.jumps_taken(last))
    # checkMissionFeasible's warning: the checks ran (home known, items stored) and failed
    warning = count > 0 and v.home is not None and not valid
    return (ids[0] & 0xFFFFFFFF, ids[1] & 0xFFFFFFFF, check.home_counter, mission.progress.seq_reached,
            max(0, mission.current), count, index, remaining, valid, warning,
            mission.finished, mission.progress.failure, changed, 0)


def _vehicle_roi(v: Any, now_us: int) -> tuple | None:
    """The navigator's last vehicle_roi publication (one per ROI command or mission item; none
    before the first), with its own timestamp, so that a repeat of the same ROI is a record of
    its own. Navigator::reset_vroi publishes nothing, so a mission's reset leaves the last one
    logged."""
    nav_roi = v.autopilot.navigator.roi
    roi = nav_roi.published
    if roi is None:
        return None
    return (round(nav_roi.published_at_s * 1e6), roi.lat_deg, roi.lon_deg, f32(roi.alt_amsl_m),
            f32(roi.roll_offset_rad), f32(roi.pitch_offset_rad), f32(roi.yaw_offset_rad),
            roi.mode)


def _telemetry_status(instance: int):
    def read(v: Any, now_us: int) -> tuple | None:
        """One mavlink instance's telemetry_status (link_status.py has the rates; mavlink
        status prints the same fields). SITL's instances forward (-f), speak MAVLink 2, serve
        FTP, run no flow control and see no buffer overruns; the error rate is 0 on UDP. The
        heartbeats CORNET follows are the GCS's and an onboard controller's; it has no
        avoidance, Remote ID or parachute component, whose flags stay false. rx_parse_errors:
        the datagrams with anything unparsable (LINK_NODE_STATUS's count); CORNET does not
        tell the parser's dropped packets apart, so rx_packet_drop_count stays 0."""
        links = v.mavlink_links
        if instance >= len(links):
            return None
        s = links[instance]
        st, rates = s.stats, s.tstatus
        now_s = now_us * 1e-6
        # MavlinkReceiver sets the loss at each read: 0 before the first, then lost / received
        # (0/0: NaN while nothing was counted)
        if not st.rx_datagrams:
            lost_rate = 0.0
        elif not st.rx_counted:
            lost_rate = math.nan
        else:
            lost_rate = f32(st.rx_lost / st.rx_counted)
        streams = sum(1 for spec in STREAMS if s.scheduler.interval_us(spec.msg_id) != 0)
        gcs = now_s - s.last_gcs_heartbeat_s <= HEARTBEAT_TIMEOUT_S
        onboard = now_s - s.last_onboard_heartbeat_s <= HEARTBEAT_TIMEOUT_S
        mode = MAVLINK_MODE_ONBOARD if s.kind is LinkKind.API else MAVLINK_MODE_NORMAL
        return (float(DATARATE_B_S), 1.0, rates.tx_rate_avg, 0.0,
                getattr(st, "tx_datagrams", 0) & 0xFFFFFFFF, 0, rates.rx_rate_avg,
                st.rx_counted & 0xFFFFFFFF, st.rx_lost & 0xFFFFFFFF, 0,
                st.rx_bad_datagrams & 0xFFFFFFFF, 0, lost_rate, LINK_TYPE_GENERIC, mode, False,
                True, True, True, min(streams, 255), False, gcs, onboard,
                *(False,) * 13, False, False, False)
    return read


TAKEOFF_STATUS = Topic("takeoff_status", ((F, "tilt_limit"), (U8, "takeoff_state"),
                                          ("uint8_t[3]", "_padding0")), 1.0, _takeoff_status,
                       on_change=True)
VEHICLE_ACCELERATION = Topic("vehicle_acceleration", ((U64, "timestamp_sample"),
                                                      ("float[3]", "xyz"),
                                                      ("uint8_t[4]", "_padding0")), 0.05,
                             _acceleration, step=_acceleration_step)
FAILURE_DETECTOR_STATUS = Topic(
    "failure_detector_status", ((F, "imbalanced_prop_metric"), (U16, "motor_failure_mask"),
                                *((B, f"fd_{name}") for name in (
                                    "roll", "pitch", "alt", "ext", "arm_escs", "battery",
                                    "imbalanced_prop", "motor")),
                                ("uint8_t[2]", "_padding0")), 0.1, _failure_detector,
    on_change=True, republish_s=COMMANDER_REPUBLISH_S)
MISSION_RESULT = Topic(
    "mission_result", ((U32, "mission_id"), (U32, "geofence_id"), (U32, "home_position_counter"),
                       ("int32_t", "seq_reached"), (U16, "seq_current"), (U16, "seq_total"),
                       (U16, "item_changed_index"), (U16, "item_do_jump_remaining"),
                       (B, "valid"), (B, "warning"), (B, "finished"), (B, "failure"),
                       (B, "item_do_jump_changed"), (U8, "execution_mode"),
                       ("uint8_t[2]", "_padding0")), 0.0, _mission_result, on_change=True)
# VehicleRoi.msg, logged at 1 s; navigator publishes it at each ROI command, each publication
# with its own timestamp (a repeat of the same ROI is written again).
VEHICLE_ROI = Topic("vehicle_roi", ((D, "lat"), (D, "lon"), (F, "alt"), (F, "roll_offset"),
                                    (F, "pitch_offset"), (F, "yaw_offset"), (U8, "mode"),
                                    ("uint8_t[7]", "_padding0")), 1.0, _vehicle_roi,
                    on_change=True, stamped=True)
_TELEMETRY_FIELDS = (
    (F, "data_rate"), (F, "rate_multiplier"), (F, "tx_rate_avg"), (F, "tx_error_rate_avg"),
    (U32, "tx_message_count"), (U32, "tx_buffer_overruns"), (F, "rx_rate_avg"),
    (U32, "rx_message_count"), (U32, "rx_message_lost_count"), (U32, "rx_buffer_overruns"),
    (U32, "rx_parse_errors"), (U32, "rx_packet_drop_count"), (F, "rx_message_lost_rate"),
    (U8, "type"), (U8, "mode"), (B, "flow_control"), (B, "forwarding"), (B, "mavlink_v2"),
    (B, "ftp"), (U8, "streams"),
    *((B, f"heartbeat_type_{name}") for name in (
        "antenna_tracker", "gcs", "onboard_controller", "gimbal", "adsb", "camera", "parachute",
        "open_drone_id")),
    *((B, f"heartbeat_component_{name}") for name in (
        "telemetry_radio", "log", "osd", "obstacle_avoidance", "vio", "pairing_manager",
        "udp_bridge", "uart_bridge")),
    (B, "avoidance_system_healthy"), (B, "open_drone_id_system_healthy"),
    (B, "parachute_system_healthy"), ("uint8_t[2]", "_padding0"))
TELEMETRY_STATUS = tuple(Topic("telemetry_status", _TELEMETRY_FIELDS, 1.0, _telemetry_status(k),
                               multi_id=k) for k in range(TELEMETRY_INSTANCES))
TIMESYNC_INSTANCES = 3  # add_topic_multi("timesync_status", 1000, 3)


def _timesync_status(instance: int):
    def read(v: Any, now_us: int) -> tuple | None:
        """The ``instance``-th link to publish timesync_status: its last publication, with its
        own timestamp (the reply's arrival)."""
        clocks = sorted((s.timesync for s in v.mavlink_links
                         if s.timesync.published_at_us is not None),
                        key=lambda ts: ts.published_at_us)
        if instance >= len(clocks):
            return None
        st = clocks[instance].status
        return (st.timestamp_us, st.remote_timestamp_us, st.observed_offset_us,
                st.estimated_offset_us, st.round_trip_time_us, st.source_protocol)
    return read


TIMESYNC_STATUS = tuple(Topic(
    "timesync_status", ((U64, "remote_timestamp"), ("int64_t", "observed_offset"),
                        ("int64_t", "estimated_offset"), (U32, "round_trip_time"),
                        (U8, "source_protocol"), ("uint8_t[3]", "_padding0")),
    1.0, _timesync_status(k), on_change=True, multi_id=k, stamped=True)
    for k in range(TIMESYNC_INSTANCES))
STATUS_TOPICS = (TAKEOFF_STATUS, VEHICLE_ACCELERATION, FAILURE_DETECTOR_STATUS, MISSION_RESULT,
                 VEHICLE_ROI, *TELEMETRY_STATUS, *TIMESYNC_STATUS)
