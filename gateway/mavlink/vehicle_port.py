"""The vehicle as the MAVLink protocol sees it: the ports the services and telemetry call.

Rules and invariants:
- ``VehiclePort`` is what every vehicle given to a ``Session`` has (vehicles/README.md, "The
  contract the gateway relies on"): read-only views the telemetry samples at each wake-up, and
  the commands every PX4 persona answers. The protocol calls these directly.
- ``VehicleFeatures`` is the rest of the contract (missions, offboard, actions, manual control,
  failsafe inputs). A vehicle may have any subset of it (a test's fake, a vehicle type without
  that mode): the protocol looks each one up by name when it needs it (``getattr(v, name,
  None)``) and answers as PX4 does without the feature (UNSUPPORTED, no ACK, nothing sent).
- Both are Protocols, so tests pass fakes; the real ``vehicles.vehicle.Vehicle`` is checked
  against both by the type checker (``_conforms`` below), never imported at run time.
- Every method takes simulated time (``now_s``) first; nothing here reads a clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:  # annotations only: importing this module loads nothing of vehicles/
    from collections.abc import Iterable

    from vehicles.geodesy import GeoPoint
    from vehicles.manual_control import Sticks
    from vehicles.orbit import OrbitStatus
    from vehicles.params import ParamStore
    from vehicles.plan_types import MissionStatus, OffboardSetpoint, PlanItem, PlanResult, PlanType
    from vehicles.types import (
        Changes,
        CommandResult,
        HomePosition,
        Kinematics,
        NavState,
        StatusText,
        Vec3,
        VehicleState,
        VehicleStatus,
    )
    from vehicles.vehicle import Vehicle


class VehiclePort(Protocol):
    """What the protocol calls on every vehicle."""

    @property
    def params(self) -> ParamStore: ...  # MAV_SYS_ID, MAV_TYPE, the parameter protocol

    @property
    def origin(self) -> GeoPoint: ...  # EKF origin: LOCAL_POSITION_NED and offboard are from it

    @property
    def status(self) -> VehicleStatus: ...

    @property
    def home(self) -> HomePosition | None: ...  # status.home, without building the status

    @property
    def kinematics(self) -> Kinematics: ...  # a new object at each physics step (SampleCache)

    @property
    def state(self) -> VehicleState: ...

    @property
    def global_position(self) -> GeoPoint: ...

    @property
    def acceleration_ned_mps2(self) -> Vec3: ...

    def arm(self, now_s: float, forced: bool = False, internal: bool = False) -> CommandResult: ...

    def disarm(self, now_s: float, forced: bool = False, internal: bool = False
               ) -> CommandResult: ...

    def takeoff(self, now_s: float, alt_amsl_m: float = ...) -> CommandResult: ...

    def land(self, now_s: float) -> CommandResult: ...

    def return_to_launch(self, now_s: float) -> CommandResult: ...

    def set_nav_state(self, now_s: float, nav_state: NavState) -> CommandResult: ...


class VehicleFeatures(Protocol):
    """What the protocol calls only when the vehicle has it (looked up by name)."""

    def status_texts(self, after_seq: int = ...) -> list[StatusText]: ...

    @property
    def changes(self) -> Changes: ...  # generations of mission_progress and status_texts

    def on_gcs_heartbeat(self, now_s: float) -> None: ...  # data-link-loss failsafe input

    def record_command(self, now_s: float, command: int,
                       params: tuple[float, float, float, float, float, float, float],
                       source: tuple[int, int], result: int | None) -> None: ...  # for the log

    # plans (MISSION / FENCE / RALLY)
    def plan(self, plan_type: PlanType) -> tuple[PlanItem, ...]: ...

    def set_plan(self, now_s: float, plan_type: PlanType, items: Iterable[PlanItem]
                 ) -> PlanResult: ...

    def clear_plan(self, now_s: float, plan_type: PlanType) -> PlanResult: ...

    def set_current_mission_item(self, now_s: float, seq: int) -> bool: ...

    @property
    def mission_status(self) -> MissionStatus: ...

    @property
    def mission_progress(self) -> object: ...  # changes whenever mission_status may have

    def start_mission(self, now_s: float, first_seq: float = -1) -> CommandResult: ...

    # offboard, sticks, Follow Me
    def set_offboard_setpoint(self, now_s: float, setpoint: OffboardSetpoint) -> None: ...

    def manual_control(self, now_s: float, sticks: Sticks, source: object = None) -> None: ...

    def set_follow_target(self, now_s: float, lat_deg: float, lon_deg: float,
                          alt_amsl_m: float, velocity_ned_mps: Vec3 = ...) -> None: ...

    def set_velocity_limits(self, horizontal_mps: float, vertical_mps: float,
                            yaw_rate_rps: float) -> None: ...

    def landing_target(self, now_s: float, position_valid: bool, frame: int,
                       position_ned_m: Vec3, stamp_us: int | None = ...) -> None: ...

    # actions
    def goto(self, now_s: float, lat_deg: float, lon_deg: float, alt_amsl_m: float,
             yaw_rad: float = ..., speed_mps: float = ..., what: str = ...) -> CommandResult: ...

    def orbit(self, now_s: float, radius_m: float = ..., speed_mps: float = ...,
              yaw_behaviour: float = ..., lat_deg: float = ..., lon_deg: float = ...,
              alt_amsl_m: float = ...) -> CommandResult: ...

    @property
    def orbit_status(self) -> OrbitStatus | None: ...  # None unless orbiting

    def change_speed(self, now_s: float, speed_mps: float) -> CommandResult: ...

    def set_roi(self, now_s: float, command: int,
                params: tuple[float, float, float, float, float, float, float]
                ) -> CommandResult: ...  # DO_SET_ROI*, NAV_ROI: the navigator's ROI

    def set_home(self, now_s: float, geo: GeoPoint | None = None,
                 yaw_rad: float = ...) -> CommandResult: ...

    def terminate(self, now_s: float) -> CommandResult: ...


if TYPE_CHECKING:
    def _conforms(v: Vehicle) -> tuple[VehiclePort, VehicleFeatures]:
        """The simulated vehicle has the whole contract (checked by mypy only)."""
        return v, v
