"""Geodesy: the one place that turns latitude/longitude into local metres and back.

PX4's ``lib/geo`` (MapProjection) maps the globe onto the local NED plane of the EKF origin with
an azimuthal equidistant projection on a sphere of CONSTANTS_RADIUS_OF_EARTH; distances between
two global points use the haversine (``get_distance_to_next_waypoint``), bearings and points a
heading and distance away follow the great circle (``get_bearing_to_next_waypoint``,
``waypoint_from_heading_and_distance``, ``create_waypoint_from_line_and_dist``). The simulator, the
MAVLink services, the CI kit and the examples all use these functions, so a waypoint uploaded in
degrees lands where PX4 would put it.

Rules: pure functions of their arguments; degrees and metres in, degrees and metres out; north
is x, east is y (NED).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

EARTH_RADIUS_M = 6371000.0  # PX4 CONSTANTS_RADIUS_OF_EARTH
_FLT_EPSILON = 1.1920929e-07  # float32 machine epsilon (C FLT_EPSILON)
_asin, _atan2, _cos, _sin, _hypot = math.asin, math.atan2, math.cos, math.sin, math.hypot
_degrees, _radians = math.degrees, math.radians


def project(ref_lat_deg: float, ref_lon_deg: float, lat_deg: float, lon_deg: float
            ) -> tuple[float, float]:
    """(north, east) in metres of a point from the reference (PX4 MapProjection::project)."""
    ref_lat = math.radians(ref_lat_deg)
    lat = math.radians(lat_deg)
    d_lon = math.radians(lon_deg - ref_lon_deg)
    sin_ref, cos_ref = math.sin(ref_lat), math.cos(ref_lat)
    sin_lat, cos_lat = math.sin(lat), math.cos(lat)
    cos_d_lon = math.cos(d_lon)
    c = math.acos(min(max(sin_ref * sin_lat + cos_ref * cos_lat * cos_d_lon, -1.0), 1.0))
    k = c / math.sin(c) if c != 0.0 else 1.0
    return (k * (cos_ref * sin_lat - sin_ref * cos_lat * cos_d_lon) * EARTH_RADIUS_M,
            k * cos_lat * math.sin(d_lon) * EARTH_RADIUS_M)


def reproject(ref_lat_deg: float, ref_lon_deg: float, north_m: float, east_m: float
              ) -> tuple[float, float]:
    """(lat, lon) in degrees of a local point (PX4 MapProjection::reproject)."""
    # The math functions as module globals, the clamp as comparisons (the same values as
    # min(max(v, -1), 1), NaN included): the telemetry reprojects every vehicle's position.
    x = north_m / EARTH_RADIUS_M
    y = east_m / EARTH_RADIUS_M
    c = _hypot(x, y)
    if c == 0.0:
        return (ref_lat_deg, ref_lon_deg)
    ref_lat = _radians(ref_lat_deg)
    sin_ref, cos_ref = _sin(ref_lat), _cos(ref_lat)
    sin_c, cos_c = _sin(c), _cos(c)
    s = cos_c * sin_ref + x * sin_c * cos_ref / c
    if s < -1.0:
        s = -1.0
    elif s > 1.0:
        s = 1.0
    lon = _radians(ref_lon_deg) + _atan2(y * sin_c, c * cos_ref * cos_c - x * sin_ref * sin_c)
    return (_degrees(_asin(s)), _degrees(lon))


def distance_m(lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float) -> float:
    """Great-circle distance (PX4 get_distance_to_next_waypoint, haversine)."""
    lat1, lat2 = math.radians(lat1_deg), math.radians(lat2_deg)
    d_lat = lat2 - lat1
    d_lon = math.radians(lon2_deg) - math.radians(lon1_deg)
    a = math.sin(d_lat / 2) ** 2 + math.sin(d_lon / 2) ** 2 * math.cos(lat1) * math.cos(lat2)
    return EARTH_RADIUS_M * 2.0 * math.atan2(math.sqrt(a), math.sqrt(1.0 - a))


def bearing_rad(lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float) -> float:
    """Initial great-circle bearing (rad, in [-pi, pi], 0 north, pi/2 east) from the first point to
    the second (PX4 get_bearing_to_next_waypoint; PX4 takes atan2 in float32, this in double)."""
    lat1, lat2 = math.radians(lat1_deg), math.radians(lat2_deg)
    d_lon = math.radians(lon2_deg - lon1_deg)
    cos_lat2 = math.cos(lat2)
    return math.atan2(math.sin(d_lon) * cos_lat2,
                      math.cos(lat1) * math.sin(lat2) - math.sin(lat1) * cos_lat2 * math.cos(d_lon))


def waypoint_from_heading_and_distance(lat_deg: float, lon_deg: float, bearing: float, dist_m: float
                                       ) -> tuple[float, float]:
    """(lat, lon) in degrees reached by flying ``dist_m`` along the great circle leaving the start at
    ``bearing`` (rad); a negative distance goes the other way (PX4
    waypoint_from_heading_and_distance)."""
    bearing %= 2.0 * math.pi
    ratio = dist_m / EARTH_RADIUS_M
    lat0 = math.radians(lat_deg)
    sin_lat0, cos_lat0 = math.sin(lat0), math.cos(lat0)
    lat = math.asin(sin_lat0 * math.cos(ratio) + cos_lat0 * math.sin(ratio) * math.cos(bearing))
    lon = math.radians(lon_deg) + math.atan2(math.sin(bearing) * math.sin(ratio) * cos_lat0,
                                             math.cos(ratio) - sin_lat0 * math.sin(lat))
    return (math.degrees(lat), math.degrees(lon))


def waypoint_from_line_and_dist(lat_a_deg: float, lon_a_deg: float, lat_b_deg: float,
                                lon_b_deg: float, dist_m: float) -> tuple[float, float]:
    """(lat, lon) in degrees ``dist_m`` from A along the line towards B (behind A when negative); A
    itself when the distance is below float32 epsilon (PX4 create_waypoint_from_line_and_dist)."""
    if abs(dist_m) < _FLT_EPSILON:
        return (lat_a_deg, lon_a_deg)
    return waypoint_from_heading_and_distance(
        lat_a_deg, lon_a_deg, bearing_rad(lat_a_deg, lon_a_deg, lat_b_deg, lon_b_deg), dist_m)


# The largest altitude (m) the MAVLink position messages carry: int32 millimetres
# (GLOBAL_POSITION_INT.alt, HOME_POSITION.altitude).
MAX_ALT_M = (2**31 - 1) / 1000.0


def position_fault(lat_deg: float, lon_deg: float, alt_m: float) -> str | None:
    """Which coordinate makes this no place a vehicle can be: "lat" (not finite or beyond ±90°),
    "lon" (beyond ±180°), "alt" (not finite or more than MAX_ALT_M from sea level, which no
    position message could report); None when it is one."""
    if not (math.isfinite(lat_deg) and -90.0 <= lat_deg <= 90.0):
        return "lat"
    if not (math.isfinite(lon_deg) and -180.0 <= lon_deg <= 180.0):
        return "lon"
    if not (math.isfinite(alt_m) and abs(alt_m) <= MAX_ALT_M):
        return "alt"
    return None


_new_object = object.__new__


@dataclass(frozen=True)
class GeoPoint:
    """A point on the globe: WGS-84 latitude/longitude in degrees, altitude above mean sea level."""

    lat_deg: float
    lon_deg: float
    alt_amsl_m: float

    def offset_ned(self, north_m: float, east_m: float, down_m: float) -> GeoPoint:
        """The point ``(north, east, down)`` metres from this one (the local frame's origin)."""
        lat, lon = reproject(self.lat_deg, self.lon_deg, north_m, east_m)
        # What GeoPoint(lat, lon, alt) makes, without the frozen dataclass's three
        # object.__setattr__ calls (the telemetry asks for a vehicle's position at every send).
        point = _new_object(GeoPoint)
        point.__dict__.update(lat_deg=lat, lon_deg=lon, alt_amsl_m=self.alt_amsl_m - down_m)
        return point

    def ned_of(self, other: GeoPoint) -> tuple[float, float, float]:
        """NED offset (m) of ``other`` relative to this point (inverse of ``offset_ned``)."""
        north, east = project(self.lat_deg, self.lon_deg, other.lat_deg, other.lon_deg)
        return (north, east, self.alt_amsl_m - other.alt_amsl_m)
