"""Geofence areas from a stored FENCE plan, as PX4 v1.15 geofence.cpp reads them
(_updateFence, checkPointAgainstPolygonCircle, isInsidePolygonOrCircle, insidePolygon,
insideCircle)."""

import math

import pytest

from tests.unit.test_vehicles_mission import item
from vehicles.geofence import Geofence
from vehicles.params import ParamStore
from vehicles.plan_types import MavCmd, MavFrame, PlanType
from vehicles.status_log import StatusLog
from vehicles.types import GeoPoint

ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)
HOME = (0.0, 0.0)
NO_HOME = "Geofence invalid, doesn't contain Home position\t"
NO_POS = "Geofence invalid, doesn't contain current vehicle position\t"
C_IN, C_OUT = MavCmd.NAV_FENCE_CIRCLE_INCLUSION, MavCmd.NAV_FENCE_CIRCLE_EXCLUSION
P_IN, P_OUT = MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION
SQUARE = [(-20.0, -20.0), (20.0, -20.0), (20.0, 20.0), (-20.0, 20.0)]


def fence(*specs):
    """(command, n, e, p1[, frame]) each, in order."""
    return [item(i, s[0], s[1], s[2], 0.0, ORIGIN, frame=s[4] if len(s) > 4 else MavFrame.GLOBAL,
                 p1=s[3], mission_type=PlanType.FENCE)
            for i, s in enumerate(specs)]


def polygon(cmd, points, count=None):
    return [(cmd, n, e, float(count or len(points))) for n, e in points]


def load(specs, home=HOME, flying_at=None, gf_action=2):
    gf = Geofence(ParamStore({"GF_ACTION": gf_action}))
    log = StatusLog()
    gf.load(fence(*specs), ORIGIN, home, flying_at, log, 0.0)
    return gf, [t.text for t in log.after(0)]


def allowed(gf, n, e):
    return gf.check((n, e, -5.0), (0.0, 0.0, 0.0)) is None


def test_every_area_must_allow_the_point():
    """isInsidePolygonOrCircle ANDs the areas: two inclusion circles allow only where both
    overlap (not their union)."""
    gf, texts = load([(C_IN, 0.0, 0.0, 30.0), (C_IN, 0.0, 20.0, 30.0)])
    assert texts == [] and len(gf.areas) == 2
    assert allowed(gf, 0.0, 10.0)
    assert not allowed(gf, 0.0, -20.0)  # in the first circle only
    assert not allowed(gf, 0.0, 40.0)  # in the second only


@pytest.mark.parametrize("radius, kept, inside_at_25", [
    (30.0, True, False),
    (-30.0, True, False),  # dx² + dy² < r²: a negative radius acts as its magnitude
    (math.nan, True, True),  # contains nothing: an exclusion that excludes nothing
])
def test_exclusion_circle_radius(radius, kept, inside_at_25):
    gf, texts = load([(C_OUT, 0.0, 25.0, radius)], home=(0.0, -40.0))
    assert texts == [] and len(gf.areas) == int(kept)
    assert allowed(gf, 0.0, 25.0) is inside_at_25


def test_inclusion_circle_with_nan_radius_is_dropped_at_load():
    gf, texts = load([(C_IN, 0.0, 0.0, math.nan)])
    assert texts == [NO_HOME] and gf.areas == () and not gf.enabled


def test_an_area_failing_home_and_position_gets_both_texts():
    """_updateFence runs checkHomeRequirementsForGeofence and
    checkCurrentPositionRequirementsForGeofence for every area, each with its text."""
    gf, texts = load([(C_IN, 100.0, 0.0, 10.0)], flying_at=(0.0, 30.0))
    assert texts == [NO_HOME, NO_POS] and gf.areas == ()
    gf, texts = load([(C_IN, 100.0, 0.0, 10.0)], flying_at=(0.0, 30.0), gf_action=0)
    assert texts == [NO_HOME]


def test_polygon_cut_short_contains_nothing():
    """insidePolygon stops at the first vertex it cannot read: a 4-vertex polygon stored with
    2 items (PX4 takes it) is an inclusion area that contains nothing, dropped at load; without
    home at load it stays and everything is outside."""
    short = polygon(P_IN, SQUARE[:2], count=4)
    gf, texts = load(short)
    assert texts == [NO_HOME] and gf.areas == ()
    gf, texts = load(short, home=None)
    assert texts == [] and len(gf.areas) == 1
    assert not allowed(gf, 0.0, 0.0)


def test_polygons_after_a_circle_make_an_area_at_every_vertex():
    """_updateFence's is_circle_area is never reset: after a circle each polygon vertex starts a
    polygon of vertex_count items from it. Round home, all but the first run past the plan's end
    and are dropped, each with its text; the fence then acts as sent."""
    specs = [(C_OUT, 60.0, 60.0, 5.0)] + polygon(P_IN, SQUARE)
    gf, texts = load(specs)
    assert texts == [NO_HOME] * 3 and len(gf.areas) == 2
    assert allowed(gf, 10.0, 10.0) and not allowed(gf, 30.0, 0.0)
    gf, texts = load(specs, home=None)  # no home to drop them: nothing is inside
    assert texts == [] and len(gf.areas) == 5
    assert not allowed(gf, 10.0, 10.0)
    # the other order is what PX4 means
    gf, texts = load(polygon(P_IN, SQUARE) + [(C_OUT, 60.0, 60.0, 5.0)])
    assert texts == [] and len(gf.areas) == 2 and allowed(gf, 10.0, 10.0)


def test_other_commands_are_skipped_but_can_be_vertices():
    """A return point and commands no fence knows are skipped when the fence loads; inside a
    polygon's vertex range any item is a vertex, and one not in a global frame stops
    insidePolygon."""
    wp = (MavCmd.NAV_WAYPOINT, 0.0, 0.0, 0.0)
    gf, texts = load([(MavCmd.NAV_FENCE_RETURN_POINT, 5.0, 5.0, 0.0), wp]
                     + polygon(P_IN, SQUARE))
    assert texts == [] and len(gf.areas) == 1 and allowed(gf, 10.0, 10.0)
    gf, texts = load(polygon(P_IN, SQUARE[:3], count=4)
                     + [(MavCmd.NAV_WAYPOINT, -20.0, 20.0, 0.0)])
    assert texts == [] and allowed(gf, 10.0, 10.0) and not allowed(gf, 30.0, 0.0)
    # v0, a DO_CHANGE_SPEED, v2, v3: insidePolygon tests the edge v3-v0 and stops at vertex 1,
    # so the exclusion is the strip south of that edge
    square = polygon(P_OUT, SQUARE[::-1])
    specs = [square[0], (MavCmd.DO_CHANGE_SPEED, 0.0, 0.0, 5.0, MavFrame.MISSION)] + square[2:]
    gf, texts = load(specs, home=(50.0, 50.0))
    assert texts == [] and len(gf.areas) == 1
    assert allowed(gf, 0.0, 0.0) and allowed(gf, 30.0, 0.0) and not allowed(gf, -30.0, 0.0)


@pytest.mark.parametrize("limit, distance, breached", [
    (10.0, 9.99, False),
    (10.0, 10.0, True),  # isCloserThanMaxDistToHome: inside only below the limit
    (1e-8, 50.0, False),  # on only above FLT_EPSILON
    (math.nan, 50.0, False),
])
def test_max_distances_from_home_as_px4_compares_them(limit, distance, breached):
    gf = Geofence(ParamStore({"GF_MAX_HOR_DIST": limit, "GF_MAX_VER_DIST": limit}))
    home = (0.0, 0.0, 0.0)
    assert (gf.check((distance, 0.0, -1e-9), home) is not None) is breached
    assert (gf.check((0.0, 0.0, -distance), home) is not None) is breached
