"""Mission protocol server (mission / fence / rally) for one link, as PX4's MavlinkMissionManager.

Source: PX4 src/modules/mavlink/mavlink_mission.cpp; shape after MAVSDK's
mavlink_mission_transfer_server (one state machine, named timeouts, result codes).
Rules and invariants:
- Accepted only with target_system == own (0 is not enough) and target_component ∈ {0, 1, 190}.
- Upload: MISSION_COUNT → MISSION_REQUEST_INT seq 0.. (legacy MISSION_REQUEST after the client
  answers MISSION_ACK UNSUPPORTED, or once it sends float MISSION_ITEMs) → items are buffered
  here; only the complete list goes to ``vehicle.set_plan`` and its PlanResult is the MISSION_ACK.
  So a lost, aborted or timed-out upload never leaves a half-written plan. Each item is checked
  when it arrives (plans.validate_item, PX4's parse_mavlink_mission_item and the plan type's
  check): a refused item ends the transfer with its MAV_MISSION_RESULT, after the text
  "IGN MISSION_ITEM: Invalid item" when the parser refused it. A float MISSION_ITEM in a *_INT
  frame is UNSUPPORTED_FRAME, as PX4 takes those frames only in int mode.
- The expected item is re-requested every RETRY_S; TIMEOUT_S without anything from the partner
  aborts the transfer with "Operation timeout". Out-of-sequence items are ignored (the retry
  re-requests). Outside a transfer an item whose seq is just before where the last transfer's
  sequence stopped is taken for a repeat whose ACK was lost and ACCEPTED (PX4 checks nothing
  else), any other gets "IGN MISSION_ITEM: No transfer" and ERROR.
- One upload per vehicle at a time across all links (PX4's static _transfer_in_progress): a
  MISSION_COUNT while another link uploads → MISSION_ACK ERROR.
- Download: MISSION_REQUEST_LIST → MISSION_COUNT → the client requests each seq (INT or legacy)
  → MISSION_ITEM_INT / MISSION_ITEM → client MISSION_ACK. The list is snapshotted at
  REQUEST_LIST, so a concurrent upload elsewhere cannot mix two plans into one download.
  An empty plan answers COUNT 0 and is a transfer like any other: busy (a MISSION_COUNT gets
  "WPM: IGN MISSION_COUNT: Busy") until the client's MISSION_ACK, a new REQUEST_LIST, or
  "Operation timeout". The client drives retries (PX4 never resends).
- A mission_type other than mission, fence, rally (and all for CLEAR_ALL) is no plan PX4 has:
  its item count and capacity are 0 (current_max_item_count / current_item_count), so
  MISSION_COUNT gets NO_SPACE (ACCEPTED for count 0, nothing cleared), MISSION_REQUEST_LIST a
  COUNT 0, MISSION_CLEAR_ALL ACCEPTED, each with that mission_type.
- MISSION_CURRENT goes out when ``vehicle.mission_status.current_seq`` differs from the
  vehicle's last sent one (checked at the wake-ups after the vehicle's
  ``changes.mission_progress`` moved, or at each one without it). That one is shared by the
  vehicle's links (PX4's static ``_current_seq``): the first link to see a change sends it, and
  MISSION_SET_CURRENT sets it without sending, so its MISSION_CURRENT comes with the 1 Hz stream
  (telemetry.py). MISSION_ITEM_REACHED goes out when a reach (``reached_count`` moved) is of
  another seq than the link sent last (PX4 sends it when mission_result.seq_reached changes: a
  DO_JUMP loop reaching the same item again is no news), then REACHED_REPEATS more times at
  1 Hz (PX4: "send the reached message another 10 times"), until the navigator puts
  seq_reached back to -1 (``reached_resets`` moved: a new mission does, once stored). PX4 1.15's
  handle_mission_count does not reset the last reached item (newer PX4 does): a MISSION_COUNT
  alone leaves the repeats running. After a DO_JUMP is taken the link sends that item, unasked,
  to its last transfer partner when idle (PX4: "Send a mission item again if the remaining
  DO_JUMPs has changed").
- Every MISSION_ACK goes to the link's transfer partner with the link's mission type (PX4's
  send_mission_ack(_transfer_partner_sysid, _transfer_partner_compid, ...) with _mission_type),
  not to the sender: a busy refusal to the partner of the transfer under way, a CLEAR_ALL's ACK
  and a COUNT 0 or NO_SPACE answer to the last partner (0/0 before any transfer), as only an
  upload or download that starts takes its sender as the partner. A MISSION_COUNT or
  CLEAR_ALL sets the mission type before its answer; a busy or locked-out one does not.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from typing import Any, cast

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.link import LinkContext, Say
from gateway.mavlink.mission_items import (
    item_from_float,
    item_from_int,
    mission_status_of,
    pack_item,
    pack_item_reached,
    pack_mission_current,
    plan_type_of,
)
from gateway.mavlink.vehicle_port import VehicleFeatures
from vehicles.plan_types import MissionStatus, PlanItem, PlanResult, PlanType
from vehicles.plans import CAPACITY, validate_item  # one source: what the vehicle stores
from vehicles.types import Changes, Severity

RETRY_S = 0.25  # MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT: re-request the expected item
TIMEOUT_S = 5.0  # MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT: give the transfer up
REACHED_REPEATS = 10  # MISSION_ITEM_REACHED repeats after the first one
REPEAT_INTERVAL_S = 1.0
MISSION_TYPE_ALL = 255
MISSION_COMPONENTS = frozenset({0, 1, 190})  # autopilot, broadcast, MAV_COMP_ID_MISSIONPLANNER
INT_FRAMES = frozenset({5, 6})  # MAV_FRAME_GLOBAL_INT, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT

# MAV_MISSION_RESULT codes this module produces itself (the vehicle's come as PlanResult).
ACCEPTED = PlanResult.ACCEPTED
ERROR = PlanResult.ERROR
UNSUPPORTED_FRAME = PlanResult.UNSUPPORTED_FRAME
UNSUPPORTED = PlanResult.UNSUPPORTED
NO_SPACE = PlanResult.NO_SPACE
OPERATION_CANCELLED = 15


class UploadLock:
    """Which link is uploading a plan to one vehicle (PX4: MavlinkMissionManager's static
    ``_transfer_in_progress``). One per vehicle, shared by the MissionService of each of its
    links: an upload on one link refuses another until it ends or times out. It also holds the
    static ``_current_seq``: the current item last sent or set (None: not yet read)."""

    def __init__(self) -> None:
        self.owner: MissionService | None = None
        self.current_seq: int | None = None


class Phase(enum.Enum):
    IDLE = "idle"
    UPLOAD = "upload"  # PX4 MAVLINK_WPM_STATE_GETLIST
    DOWNLOAD = "download"  # PX4 MAVLINK_WPM_STATE_SENDLIST


class MissionService:
    """Uses the vehicle, the encoder, send, sysid, other_target and ``say`` (STATUSTEXT on this
    link) for PX4's mission texts."""

    def __init__(self, ctx: LinkContext, say: Say, uploads: UploadLock) -> None:
        """``uploads``: the vehicle's lock, shared with its other links' services."""
        self.uploads = uploads
        self.vehicle = ctx.vehicle
        self.encoder = ctx.encoder
        self.send = ctx.send
        self.sysid = ctx.sysid
        self.other_target = ctx.other_target
        self.say = say
        self.phase = Phase.IDLE
        self.partner = (0, 0)
        self.mission_type = int(PlanType.MISSION)
        self.count = 0
        self.seq = 0  # upload: next expected item; download: next item to be requested
        self.int_mode = True
        self._items: list[PlanItem] = []
        self._download: tuple[PlanItem, ...] = ()
        self._retry_at = math.inf
        self._timeout_at = math.inf
        self.due_s = math.inf  # the earliest of the retry, timeout and repeat times (_rearm)
        st = mission_status_of(self.vehicle)
        if uploads.current_seq is None:
            uploads.current_seq = st.current_seq
        self._last_reached_count = st.reached_count
        self._last_reached_resets = st.reached_resets
        self._last_jump_count = st.jump_count
        self._last_progress: object = None  # vehicle.mission_progress at the last full poll
        # The vehicle's generations (None: it has none, progress is read at every wake-up) and
        # the one of mission_progress when it was last read (-1: never): the session calls
        # handle_timer only once that moved or ``due_s`` has come.
        self._changes: Changes | None = getattr(self.vehicle, "changes", None)
        self.seen_progress = -1
        self._reached_seq = -1
        self._repeats_left = 0
        self._repeat_at = math.inf

    # --- helpers ------------------------------------------------------------------------------
    def _for_us(self, msg: Any) -> bool:
        if msg.target_system == self.sysid and msg.target_component in MISSION_COMPONENTS:
            return True
        self.other_target()
        return False

    def _text(self, now_s: float, text: str, severity: Severity = Severity.CRITICAL) -> None:
        """send_statustext_critical / _info: every MavlinkMissionManager text ends in "\t"
        (each is also an event in PX4)."""
        self.say(now_s, severity, text + "\t")

    def ack(self, result: int) -> None:
        """send_mission_ack: to the transfer partner, with the link's mission type."""
        self.send(self.encoder.pack(M.MAVLink_mission_ack_message, self.partner[0],
                                    self.partner[1], int(result), self.mission_type & 0xFF))

    def _heard(self, now_s: float) -> None:
        self._timeout_at = now_s + TIMEOUT_S
        self._rearm()

    def _rearm(self) -> None:
        """``due_s`` after a change of the retry, timeout or repeat time."""
        self.due_s = min(self._retry_at, self._timeout_at, self._repeat_at)

    def _idle(self) -> None:
        if self.phase is Phase.UPLOAD and self.uploads.owner is self:
            self.uploads.owner = None
        self.phase = Phase.IDLE
        self._items = []
        self._download = ()
        self._retry_at = self._timeout_at = math.inf
        self._rearm()

    def _other_upload_active(self, now_s: float) -> bool:
        owner = self.uploads.owner
        return (owner is not None and owner is not self and owner.phase is Phase.UPLOAD
                and now_s < owner._timeout_at)

    def _request(self, now_s: float) -> None:
        cls = M.MAVLink_mission_request_int_message if self.int_mode else \
            M.MAVLink_mission_request_message
        self.send(self.encoder.pack(cls, self.partner[0], self.partner[1], self.seq,
                                    self.mission_type))
        self._retry_at = now_s + RETRY_S
        self._rearm()

    # --- upload -------------------------------------------------------------------------------
    def on_count(self, msg: M.MAVLink_mission_count_message, now_s: float) -> None:
        if not self._for_us(msg):
            return
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if self.phase is Phase.UPLOAD:
            self._heard(now_s)
            if self.seq == 0:  # our first request was lost: a COUNT (from anyone) re-requests
                self._request(now_s)
            else:
                self._text(now_s, "WPM: REJ. CMD: Busy")
                self.ack(ERROR)
            return
        if self.phase is Phase.DOWNLOAD:
            self._text(now_s, "WPM: IGN MISSION_COUNT: Busy")
            self.ack(ERROR)
            return
        if not hasattr(self.vehicle, "set_plan"):
            self.ack(UNSUPPORTED)
            return
        if self._other_upload_active(now_s):
            self.ack(ERROR)
            return
        self.mission_type = msg.mission_type  # the partner stays until an upload starts
        ptype = plan_type_of(msg.mission_type)
        if msg.count > (CAPACITY[ptype] if ptype is not None else 0):
            self.ack(NO_SPACE)
            return
        plans = cast(VehicleFeatures, self.vehicle)  # it stores plans (set_plan checked above)
        if msg.count == 0:  # an unknown type: "mission type %u not handled", and ACCEPTED
            self.ack(plans.clear_plan(now_s, ptype) if ptype is not None else ACCEPTED)
            return
        assert ptype is not None  # its capacity is 0
        self.phase = Phase.UPLOAD
        self.uploads.owner = self
        self.partner, self.mission_type, self.count, self.seq = src, int(ptype), msg.count, 0
        self._items = []
        self._heard(now_s)
        self._request(now_s)

    def on_item_int(self, msg: M.MAVLink_mission_item_int_message, now_s: float) -> None:
        self._on_item(msg, item_from_int(msg), True, now_s)

    def on_item(self, msg: M.MAVLink_mission_item_message, now_s: float) -> None:
        self._on_item(msg, item_from_float(msg), False, now_s)

    def _on_item(self, msg: Any, item: PlanItem, is_int: bool, now_s: float) -> None:
        if not self._for_us(msg):
            return
        self.int_mode = is_int  # PX4 follows the client's item flavour from here on
        if msg.mission_type != self.mission_type:
            self.ack(ERROR)
            return
        if self.phase is Phase.IDLE:
            # "Assume this is a duplicate" of the last item of a finished upload whose ACK was
            # lost: PX4 tests only that the transfer's sequence stopped right after this seq, so
            # this is ACCEPTED also after a download, or before the item an upload failed at.
            if self.seq == msg.seq + 1:
                self.ack(ACCEPTED)
            else:
                self._text(now_s, "IGN MISSION_ITEM: No transfer")
                self.ack(ERROR)
            return
        if self.phase is Phase.DOWNLOAD:
            self._text(now_s, "IGN MISSION_ITEM: Busy")
            self.ack(ERROR)
            return
        self._heard(now_s)  # (handle_mission_item_both takes the item from any sender)
        if msg.seq != self.seq:
            return  # a duplicate or a jump ahead: ignored, the retry timer re-requests
        ptype = PlanType(self.mission_type)
        # parse_mavlink_mission_item takes the *_INT frames only in int mode
        verdict = UNSUPPORTED_FRAME if not is_int and msg.frame in INT_FRAMES else \
            validate_item(ptype, item)
        if verdict is not ACCEPTED:
            # The transfer ends at this item. A parser refusal comes with PX4's text; the plan
            # type's own check (MAV_MISSION_ERROR) with none.
            if verdict is not ERROR:
                self._text(now_s, "IGN MISSION_ITEM: Invalid item")
            self.ack(verdict)
            self._idle()
            return
        self._items.append(item)
        self.seq += 1
        if self.seq < self.count:
            self._request(now_s)
            return
        items = tuple(self._items)
        self._idle()
        plans = cast(VehicleFeatures, self.vehicle)  # an upload starts only if it has set_plan
        self.ack(int(plans.set_plan(now_s, ptype, items)))

    # --- download -----------------------------------------------------------------------------
    def on_request_list(self, msg: M.MAVLink_mission_request_list_message, now_s: float) -> None:
        if not self._for_us(msg):
            return
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if self.phase is Phase.DOWNLOAD and self.seq >= self.count:
            self._idle()
        busy = self.phase is Phase.UPLOAD or (
            self.phase is Phase.DOWNLOAD and msg.mission_type != self.mission_type)
        if busy:
            self._text(now_s, "Mission download request ignored, already active", Severity.INFO)
            return
        ptype = plan_type_of(msg.mission_type)
        self._idle()
        plan = getattr(self.vehicle, "plan", None)
        items = tuple(plan(ptype)) if plan is not None and ptype is not None else ()
        mission_type = msg.mission_type & 0xFF
        self.partner, self.mission_type, self.count, self.seq = src, mission_type, len(items), 0
        self.phase = Phase.DOWNLOAD  # SENDLIST until the ACK, even for an empty plan
        self._download = items
        self._heard(now_s)
        self.send(self.encoder.pack(M.MAVLink_mission_count_message, src[0], src[1],
                                    len(items), mission_type))

    def on_request_int(self, msg: M.MAVLink_mission_request_int_message, now_s: float) -> None:
        self._on_request(msg, True, now_s)

    def on_request(self, msg: M.MAVLink_mission_request_message, now_s: float) -> None:
        self._on_request(msg, False, now_s)

    def _on_request(self, msg: Any, is_int: bool, now_s: float) -> None:
        if not self._for_us(msg):
            return
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        self.int_mode = is_int
        if self.phase is Phase.IDLE:
            return  # PX4 ignores stray requests silently (buggy OSDs send them)
        if src != self.partner:
            self._text(now_s, "WPM: REJ. CMD: partner id mismatch")
            return
        if self.phase is Phase.UPLOAD:
            self._text(now_s, "WPM: REJ. CMD: Busy")
            return
        if msg.mission_type != self.mission_type:
            return
        self._heard(now_s)
        if msg.seq == self.seq and self.seq < self.count:
            self.seq += 1
        elif msg.seq != self.seq - 1:  # neither the next item nor a repeat of the last one
            self._idle()
            self.ack(ERROR)
            self._text(now_s, "WPM: REJ. CMD: Req. WP was unexpected")
            return
        # send_mission_item marks the mission's current seq as current, in a fence or rally
        # download too
        current = int(msg.seq == mission_status_of(self.vehicle).current_seq)
        item = dataclasses.replace(self._download[msg.seq], current=current)
        self.send(pack_item(self.encoder, item, msg.seq, self.mission_type, src, self.int_mode))

    def on_ack(self, msg: M.MAVLink_mission_ack_message, now_s: float) -> None:
        if not self._for_us(msg) or self.phase is Phase.IDLE:
            return
        if (msg.get_srcSystem(), msg.get_srcComponent()) != self.partner:
            self._text(now_s, "REJ. WP CMD: partner id mismatch")
            return
        if self.phase is Phase.DOWNLOAD:
            if msg.mission_type == self.mission_type:
                self._idle()  # whatever the result: the client is done
            return
        if msg.type == UNSUPPORTED:  # the client cannot do MISSION_ITEM_INT (or the reverse)
            self.int_mode = not self.int_mode
            self._heard(now_s)
            self._request(now_s)
        elif msg.type == OPERATION_CANCELLED:
            self._idle()

    # --- clear / set current ------------------------------------------------------------------
    def on_clear_all(self, msg: M.MAVLink_mission_clear_all_message, now_s: float) -> None:
        if not self._for_us(msg):
            return
        if self.phase is not Phase.IDLE:
            self._text(now_s, "WPM: IGN CLEAR CMD: Busy")
            return
        self.mission_type = msg.mission_type  # "needed for the returned ack"; to the partner
        if msg.mission_type == MISSION_TYPE_ALL:
            types = list(PlanType)
        else:  # an unknown type clears nothing: "mission type %u not handled", and ACCEPTED
            ptype = plan_type_of(msg.mission_type)
            types = [] if ptype is None else [ptype]
        if not hasattr(self.vehicle, "clear_plan"):
            self.ack(UNSUPPORTED)
            return
        results = [int(self.vehicle.clear_plan(now_s, t)) for t in types]
        failed = [r for r in results if r != ACCEPTED]
        self.ack(failed[0] if failed else ACCEPTED)

    def on_set_current(self, msg: M.MAVLink_mission_set_current_message, now_s: float) -> None:
        if not self._for_us(msg):
            return
        if self.phase is not Phase.IDLE:
            self._text(now_s, "WPM: IGN WP CURR CMD: Busy")
            return
        setter = getattr(self.vehicle, "set_current_mission_item", None)
        if setter is None or not setter(now_s, msg.seq):
            self._text(now_s, "WPM: WP CURR CMD: Not in list")
            return
        # update_active_mission sets the static _current_seq and sends nothing: the new item's
        # MISSION_CURRENT comes with the stream (MAVSDK retries the set until it sees it)
        self.uploads.current_seq = mission_status_of(self.vehicle).current_seq

    def _send_jump_item(self, st: MissionStatus) -> None:
        """The DO_JUMP just taken, as a download would give it, to the last transfer partner
        (0/0 before any transfer on this link), unless a transfer is under way."""
        plan = getattr(self.vehicle, "plan", None)
        items = tuple(plan(PlanType.MISSION)) if plan is not None else ()
        if self.phase is not Phase.IDLE or not 0 <= st.jump_seq < min(st.count, len(items)):
            return
        item = dataclasses.replace(items[st.jump_seq],
                                   current=int(st.jump_seq == self.uploads.current_seq))
        self.mission_type = int(PlanType.MISSION)  # as send() sets _mission_type for it
        self.send(pack_item(self.encoder, item, st.jump_seq, int(PlanType.MISSION), self.partner,
                            self.int_mode))

    # --- timers -------------------------------------------------------------------------------
    def handle_timer(self, now_s: float) -> None:
        phase = self.phase
        if phase is not Phase.IDLE:
            if now_s >= self._timeout_at:
                self._text(now_s, "Operation timeout")
                self._idle()
            elif phase is Phase.UPLOAD and now_s >= self._retry_at:
                self._request(now_s)
        changes = self._changes
        if changes is not None:
            if changes.mission_progress == self.seen_progress and now_s < self._repeat_at:
                return  # the usual wake-up: progress as last read, no repeat due
            self.seen_progress = changes.mission_progress
        progress = getattr(self.vehicle, "mission_progress", None)
        if progress is not None and progress == self._last_progress and now_s < self._repeat_at:
            return  # no progress and no repeat due, nothing to report
        self._poll_status(now_s, progress)

    def _poll_status(self, now_s: float, progress: object) -> None:
        if progress is not None:
            self._last_progress = progress
        st = mission_status_of(self.vehicle)
        enc = self.encoder
        if st.current_seq != self.uploads.current_seq:
            self.uploads.current_seq = st.current_seq
            if 0 <= st.current_seq < st.count:
                self.send(pack_mission_current(enc, st))
        if st.reached_resets != self._last_reached_resets:  # seq_reached went back to -1
            self._last_reached_resets = st.reached_resets
            self._reached_seq, self._repeats_left, self._repeat_at = -1, 0, math.inf
            self._rearm()
        if st.reached_count != self._last_reached_count:
            self._last_reached_count = st.reached_count
            if st.reached_seq != self._reached_seq and st.reached_seq >= 0 and st.count > 0:
                self._reached_seq = st.reached_seq
                self.send(pack_item_reached(enc, st.reached_seq))
                self._repeats_left = REACHED_REPEATS
                self._repeat_at = now_s + REPEAT_INTERVAL_S
                self._rearm()
        if st.jump_count != self._last_jump_count:
            self._last_jump_count = st.jump_count
            self._send_jump_item(st)
        if self._repeats_left > 0 and now_s >= self._repeat_at:
            self.send(pack_item_reached(enc, self._reached_seq))
            self._repeats_left -= 1
            self._repeat_at = now_s + REPEAT_INTERVAL_S if self._repeats_left else math.inf
            self._rearm()
