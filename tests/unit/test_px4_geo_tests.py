"""PX4's own unit tests of its geo library, run against ours (vehicles/geodesy.py).

Source: ``src/lib/geo/test_geo.cpp`` (GeoTest), checked against ``geo.cpp``/``geo.h`` beside it.
v1.15's file holds the two projection round trips and the seven waypoint_from_* tests; later
PX4 added mapProjectionAbsoluteValues, distanceAndBearingToNextWaypoint and the tests of
functions CORNET does not have (below). Every applicable test carries PX4's inputs, expected
numbers and tolerances:

- ``EXPECT_FLOAT_EQ``: the two as float32, at most 4 units in the last place apart;
- ``EXPECT_DOUBLE_EQ``: the same for float64;
- ``EXPECT_NEAR``: the absolute tolerance PX4 gives.

PX4's inputs that are C floats (distances, ``one_degree_m``) are built in float32 as PX4 builds
them. PX4's MapProjection holds its reference (the fixture's initReference at 47.3566094°,
8.5190237°); ours takes the reference as the first two arguments of ``project``/``reproject``.
PX4 returns the projected metres as float32, ours as float64 (closer still to the round trip).

Not reproduced (CORNET has no such function; its global/local conversions all go through the
projection, and nothing it flies or checks needs these):
- ``vectorToNextWaypoint`` (get_vector_to_next_waypoint),
  ``fastVectorToNextWaypointWrapsAntimeridian`` (get_vector_to_next_waypoint_fast) and
  ``addVectorToGlobalPositionWrapsAntimeridian`` (add_vector_to_global_position): the
  flat-earth offset helpers PX4's navigator and fixed-wing code use;
- ``distanceToLine`` (get_distance_to_line, crosstrack_error_s): cross-track error of the old
  fixed-wing line following; CORNET flies multicopters along PositionSmoothing tracks;
- ``distanceToPointGlobalWgs84`` (get_distance_to_point_global_wgs84) and
  ``mavlinkWpmDistanceToPointLocal`` (mavlink_wpm_distance_to_point_local): 3-D distance
  helpers; CORNET's horizontal distance is ``distance_m`` (checked in
  distanceAndBearingToNextWaypoint) and its local distances are plain vector norms.
"""

from __future__ import annotations

import math

import numpy as np

from vehicles.geodesy import (
    EARTH_RADIUS_M,
    bearing_rad,
    distance_m,
    project,
    reproject,
    waypoint_from_heading_and_distance,
    waypoint_from_line_and_dist,
)

f32 = np.float32
REF_LAT = 473566094 / 1e7  # GeoTest::SetUp: proj.initReference(473566094 / 1e7, 85190237 / 1e7, 0)
REF_LON = 85190237 / 1e7
R_F = f32(EARTH_RADIUS_M)  # CONSTANTS_RADIUS_OF_EARTH_F
PI_F = f32(math.pi)  # M_PI_F
ONE_DEGREE_M = float(R_F * PI_F / f32(180.0))  # one_degree_m


def _biased(bits: int, sign: int, width: int) -> int:
    """gtest's biased integer of a float's bits: ordered so that neighbours differ by one."""
    return (~bits + 1) & ((1 << width) - 1) if bits & sign else bits | sign


def float_eq(a: float, b: float) -> bool:
    """EXPECT_FLOAT_EQ: the two as float32, at most 4 ULPs apart."""
    ua = _biased(int(np.array(a, dtype=np.float32).view(np.uint32)), 1 << 31, 32)
    ub = _biased(int(np.array(b, dtype=np.float32).view(np.uint32)), 1 << 31, 32)
    return abs(ua - ub) <= 4


def double_eq(a: float, b: float) -> bool:
    """EXPECT_DOUBLE_EQ: the two float64 at most 4 ULPs apart."""
    ua = _biased(int(np.array(a, dtype=np.float64).view(np.uint64)), 1 << 63, 64)
    ub = _biased(int(np.array(b, dtype=np.float64).view(np.uint64)), 1 << 63, 64)
    return abs(ua - ub) <= 4


def test_reprojectProject():
    """test_geo.cpp TEST_F(GeoTest, reprojectProject): local → global → local → global."""
    x, y = 0.5, 1.0
    lat, lon = reproject(REF_LAT, REF_LON, x, y)
    x_new, y_new = project(REF_LAT, REF_LON, lat, lon)
    lat_new, lon_new = reproject(REF_LAT, REF_LON, x_new, y_new)
    assert float_eq(x, x_new)
    assert float_eq(y, y_new)
    assert float_eq(lat, lat_new)
    assert float_eq(lon, lon_new)


def test_projectReproject():
    """test_geo.cpp TEST_F(GeoTest, projectReproject): global → local → global → local."""
    lat, lon = 47.356616973876953, 8.5190505981445313
    x, y = project(REF_LAT, REF_LON, lat, lon)
    lat_new, lon_new = reproject(REF_LAT, REF_LON, x, y)
    x_new, y_new = project(REF_LAT, REF_LON, lat_new, lon_new)
    assert float_eq(x, x_new)
    assert float_eq(y, y_new)
    assert float_eq(lat, lat_new)
    assert float_eq(lon, lon_new)


def test_mapProjectionAbsoluteValues():
    """test_geo.cpp TEST_F(GeoTest, mapProjectionAbsoluteValues): reference (0, 0), one degree
    north and east is one_degree_m both ways."""
    x, y = project(0.0, 0.0, 1.0, 0.0)
    assert abs(x - ONE_DEGREE_M) <= 0.01 and abs(y) <= 0.01
    x, y = project(0.0, 0.0, 0.0, 1.0)
    assert abs(x) <= 0.01 and abs(y - ONE_DEGREE_M) <= 0.01
    lat, lon = reproject(0.0, 0.0, ONE_DEGREE_M, 0.0)
    assert abs(lat - 1.0) <= 1e-6 and abs(lon) <= 1e-6
    lat, lon = reproject(0.0, 0.0, 0.0, ONE_DEGREE_M)
    assert abs(lat) <= 1e-6 and abs(lon - 1.0) <= 1e-6


def test_distanceAndBearingToNextWaypoint():
    """test_geo.cpp TEST_F(GeoTest, distanceAndBearingToNextWaypoint)."""
    assert abs(distance_m(0.0, 0.0, 1.0, 0.0) - ONE_DEGREE_M) <= 0.01
    assert abs(distance_m(0.0, 0.0, 0.0, 1.0) - ONE_DEGREE_M) <= 0.01
    assert abs(bearing_rad(0.0, 0.0, 1.0, 0.0) - 0.0) <= 1e-6
    assert abs(bearing_rad(0.0, 0.0, 0.0, 1.0) - float(f32(math.pi / 2))) <= 1e-6


def _heading_dist(lat_offset: float) -> float:
    """PX4's float dist = CONSTANTS_RADIUS_OF_EARTH_F * M_PI_F / 180.f * lat_offset."""
    return float(R_F * PI_F / f32(180.0) * f32(lat_offset))


def test_waypoint_from_heading_and_zero_distance():
    """test_geo.cpp TEST_F(GeoTest, waypoint_from_heading_and_zero_distance)."""
    lat, lon = waypoint_from_heading_and_distance(-33.0, 18.0, 0.0, 0.0)
    assert double_eq(-33.0, lat)
    assert double_eq(18.0, lon)


def test_waypoint_from_heading_and_negative_distance():
    """test_geo.cpp TEST_F(GeoTest, waypoint_from_heading_and_negative_distance)."""
    lat, lon = waypoint_from_heading_and_distance(-33.0, 18.0, 0.0, _heading_dist(-0.01))
    assert float_eq(float(f32(-33.0) + f32(-0.01)), lat)
    assert double_eq(18.0, lon)


def test_waypoint_from_heading_and_positive_distance():
    """test_geo.cpp TEST_F(GeoTest, waypoint_from_heading_and_positive_distance)."""
    lat, lon = waypoint_from_heading_and_distance(-33.0, 18.0, 0.0, _heading_dist(0.01))
    assert float_eq(float(f32(-33.0) + f32(0.01)), lat)
    assert double_eq(18.0, lon)


def test_waypoint_from_line_and_zero_distance():
    """test_geo.cpp TEST_F(GeoTest, waypoint_from_line_and_zero_distance)."""
    lat, lon = waypoint_from_line_and_dist(-33.0, 18.0, -32.0, 18.0, 0.0)
    assert double_eq(-33.0, lat)
    assert double_eq(18.0, lon)


def test_waypoint_from_line_and_positive_distance():
    """test_geo.cpp TEST_F(GeoTest, waypoint_from_line_and_positive_distance)."""
    lat_start, lat_offset = -33.0, 0.01
    lat, lon = waypoint_from_line_and_dist(lat_start, 18.0, lat_start + lat_offset, 18.0,
                                           _heading_dist(lat_offset))
    assert float_eq(lat_start + lat_offset, lat)
    assert double_eq(18.0, lon)


def test_waypoint_from_line_and_negative_distance():
    """test_geo.cpp TEST_F(GeoTest, waypoint_from_line_and_negative_distance)."""
    lat_start, lat_offset = -33.0, 0.01
    lat, lon = waypoint_from_line_and_dist(lat_start, 18.0, lat_start + lat_offset, 18.0,
                                           -_heading_dist(lat_offset))
    assert float_eq(lat_start - lat_offset, lat)
    assert double_eq(18.0, lon)
