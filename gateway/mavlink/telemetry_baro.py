"""The barometer as PX4 v1.15 SITL with gz_x500 reports it (SCALED_PRESSURE, HIGHRES_IMU,
ALTITUDE, OPEN_DRONE_ID_LOCATION, the logged sensor_baro and vehicle_air_data).

Source: 4001_gz_x500 sets SENS_EN_BAROSIM 0, so no sensor_baro_sim: the gz bridge's
barometerCallback (src/modules/simulation/gz_bridge/GZBridge.cpp) publishes sensor_baro with
the pressure of Gazebo's ``air_pressure_sensor`` (gz-sensors AirPressureSensor::Update: the
standard atmosphere at the geopotential height, RotorS's constants; 50 Hz, σ 0.01 Pa in
PX4-gazebo-models x500_base) and a constant temperature, GZBridge::_temperature = 288.15 — in
kelvin, but sensor_baro's field is °C. The sensors module's VehicleAirData derives
baro_alt_meter with atmosphere::getAltitudeFromPressure at SENS_BARO_QNH and rho with
getDensityFromPressureAndTemp from that temperature. The sensor's height is
vehicles/estimation.py's barometer sample.
"""

from __future__ import annotations

from gateway.mavlink.snapshot import Snapshot
from vehicles.estimation import S_BARO_DOWN
from vehicles.types import GRAVITY_MPS2

GZ_BARO_TEMPERATURE_C = 288.15
SENS_BARO_QNH_HPA = 1013.25
_EARTH_RADIUS_M = 6356766.0  # gz-sensors AirPressureSensor's constants (from RotorS)
_AIR_EXPONENT = 9.80665 * 28.9644 / (8314.32 * 0.0065)
_PX4_AIR_GAS_CONST = 287.1  # PX4 atmosphere: CONSTANTS_AIR_GAS_CONST, kTempGradient -0.0065


def gz_pressure_pa(alt_m: float) -> float:
    """gz-sensors AirPressureSensor::Update: the standard atmosphere at the geopotential height
    of ``alt_m`` (the sensor's height; see ``baro_alt_m``)."""
    geo_m = _EARTH_RADIUS_M * alt_m / (_EARTH_RADIUS_M + alt_m)
    return 101325.0 * ((288.15 - 0.0065 * geo_m) / 288.15) ** _AIR_EXPONENT


def pressure_altitude_m(pressure_pa: float, qnh_hpa: float = SENS_BARO_QNH_HPA) -> float:
    """atmosphere::getAltitudeFromPressure (the hypsometric equation, PX4's constants)."""
    ratio = pressure_pa / (qnh_hpa * 100.0)
    return (ratio ** (0.0065 * _PX4_AIR_GAS_CONST / GRAVITY_MPS2) * 288.15 - 288.15) / -0.0065


def baro_height_m(s: Snapshot) -> float:
    """The simulated barometer's height (m AMSL; the estimate's altitude without sensors).
    Gazebo's air pressure sensor takes its height from the world's origin (reference altitude
    0), which PX4's gz worlds put at altitude 0; CORNET's home altitude stands in for it."""
    sensed = s.sample.sensors
    if sensed is None:
        return s.sample.geo.alt_amsl_m
    return s.vehicle.origin.alt_amsl_m - sensed[S_BARO_DOWN]


def baro_sample(s: Snapshot) -> tuple[float, float, float]:
    """(pressure Pa, baro_alt_meter m, temperature °C) as sensor_baro and vehicle_air_data
    have them (module docstring)."""
    pressure_pa = gz_pressure_pa(baro_height_m(s))
    return pressure_pa, pressure_altitude_m(pressure_pa), GZ_BARO_TEMPERATURE_C


def baro_alt_m(s: Snapshot) -> float:
    """vehicle_air_data.baro_alt_meter."""
    return baro_sample(s)[1]
