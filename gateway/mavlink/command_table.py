"""Which part of PX4 v1.15 answers a command, and which leave it unanswered.

Source: PX4 v1.15.2 mavlink_receiver.cpp handle_message_command_both (what the MAVLink module
answers itself, and what it passes on), Commander::handle_command (the commands it lets through
for "other parts of the system"), navigator_main.cpp (the ones the navigator ACKs), the default
SITL start-up (init.d-posix rcS: gimbal, camera trigger, payload deliverer, VTOL attitude
control and the RC input driver are not running on a multicopter with default parameters).
Rules:
- A command for another target is answered FAILED by the MAVLink module, unless that component
  was heard on another MAVLink instance (SITL's GCS and onboard links forward, ``-f``): then it
  is forwarded there and not answered.
- A command the MAVLink module passes on (not in ``MAVLINK_ANSWERS``) that comes from the
  autopilot's own system and component is dropped unanswered.
- ``UNANSWERED`` are the commands Commander leaves to a module that, in default multicopter
  SITL, is not running or does not ACK: no COMMAND_ACK at all (a client times out).
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as M

# handle_message_command_both answers these itself, whoever sent them
MAVLINK_ANSWERS = frozenset({
    M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, M.MAV_CMD_REQUEST_PROTOCOL_VERSION,
    M.MAV_CMD_GET_HOME_POSITION, M.MAV_CMD_REQUEST_FLIGHT_INFORMATION,
    M.MAV_CMD_REQUEST_STORAGE_INFORMATION, M.MAV_CMD_SET_MESSAGE_INTERVAL,
    M.MAV_CMD_GET_MESSAGE_INTERVAL, M.MAV_CMD_REQUEST_MESSAGE, M.MAV_CMD_INJECT_FAILURE,
    M.MAV_CMD_DO_AUTOTUNE_ENABLE,
})

# Commander::handle_command "ignore commands that are handled by other parts of the system",
# less the ones a running module answers (navigator: DO_CHANGE_SPEED, DO_LAND_START,
# DO_GO_AROUND, the ROI commands; the logger: LOGGING_START/STOP; the simulator: INJECT_FAILURE;
# MAVLink: REQUEST_MESSAGE). EKF2 takes EXTERNAL_POSITION_ESTIMATE without an ACK.
UNANSWERED = frozenset({
    0, 1, 2,  # VEHICLE_CMD_CUSTOM_0..2
    M.MAV_CMD_START_RX_PAIR,
    M.MAV_CMD_DO_MOUNT_CONTROL, M.MAV_CMD_DO_MOUNT_CONFIGURE, M.MAV_CMD_DO_MOUNT_CONTROL_QUAT,
    M.MAV_CMD_PREFLIGHT_SET_SENSOR_OFFSETS, M.MAV_CMD_PREFLIGHT_UAVCAN,
    M.MAV_CMD_PAYLOAD_PREPARE_DEPLOY, M.MAV_CMD_PAYLOAD_CONTROL_DEPLOY,
    M.MAV_CMD_DO_VTOL_TRANSITION, M.MAV_CMD_DO_TRIGGER_CONTROL, M.MAV_CMD_DO_DIGICAM_CONTROL,
    M.MAV_CMD_DO_SET_CAM_TRIGG_DIST, M.MAV_CMD_OBLIQUE_SURVEY, M.MAV_CMD_DO_SET_CAM_TRIGG_INTERVAL,
    M.MAV_CMD_SET_CAMERA_MODE, M.MAV_CMD_SET_CAMERA_ZOOM, M.MAV_CMD_SET_CAMERA_FOCUS,
    M.MAV_CMD_NAV_DELAY, M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
    M.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE,
    311,  # VEHICLE_CMD_CONFIGURE_ACTUATOR (PX4's number; dshot only)
    M.MAV_CMD_DO_WINCH, M.MAV_CMD_DO_GRIPPER,
    43003,  # MAV_CMD_EXTERNAL_POSITION_ESTIMATE (EKF2, no ACK)
    M.MAV_CMD_REQUEST_CAMERA_INFORMATION,
    # Commander answers nothing unless a high-latency link was heard (then FAILED)
    M.MAV_CMD_CONTROL_HIGH_LATENCY,
})

# Commander's DO_FIGUREEIGHT on a multicopter: a critical text, and no ACK (it sets UNSUPPORTED,
# which handle_command only sends itself in its default case).
FIGURE_EIGHT = M.MAV_CMD_DO_FIGURE_EIGHT

# The navigator ACKs these at once (navigator_main.cpp).
DO_GO_AROUND = M.MAV_CMD_DO_GO_AROUND
ROI_COMMANDS = frozenset({
    M.MAV_CMD_DO_SET_ROI, M.MAV_CMD_DO_SET_ROI_LOCATION, M.MAV_CMD_DO_SET_ROI_NONE,
    M.MAV_CMD_NAV_ROI, M.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET,
})

# DO_SET_STANDARD_MODE: mode_util::getNavStateFromStandardMode (lib/modes/standard_modes.hpp)
STANDARD_MODE_RETURN_HOME = 5
STANDARD_MODE_MISSION = 7
STANDARD_MODE_LAND = 8
STANDARD_MODE_TAKEOFF = 9


class SeenComponents:
    """The (system, component) pairs each link of a vehicle has heard from: PX4's
    Mavlink::component_was_seen over its other instances. One per vehicle, shared by the
    sessions of its links; each link is a key (its session)."""

    def __init__(self) -> None:
        self._by_link: dict[object, set[tuple[int, int]]] = {}

    def heard(self, link: object, system: int, component: int) -> None:
        """Every valid frame's sender (at most 256 x 256 pairs per link, whatever a flood sends)."""
        seen = self._by_link.get(link)
        if seen is None:
            seen = self._by_link[link] = set()
        seen.add((system, component))

    def seen_elsewhere(self, link: object, system: int, component: int) -> bool:
        """MavlinkReceiver::component_was_seen on every link but ``link``: system 0 matches any
        component heard, component 0 any component of that system."""
        for other, seen in self._by_link.items():
            if other is link or not seen:
                continue
            if system == 0:
                return True
            if any(s == system and (component == 0 or c == component) for s, c in seen):
                return True
        return False
