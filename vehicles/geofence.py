"""Geofence: inclusion/exclusion polygons and circles from the FENCE plan, plus max distances.

After PX4 v1.15 ``src/modules/navigator/geofence.cpp``: ``_updateFence`` (which stored items make
areas), ``checkPointAgainstPolygonCircle`` / ``isInsidePolygonOrCircle`` (every area must allow
the point: inside each inclusion area, outside each exclusion area), ``insidePolygon`` /
``insideCircle``, and the GF_MAX_HOR_DIST / GF_MAX_VER_DIST checks against home.

Rules:
- The upload stores whatever parses (plans.py); here the fence is read as PX4 reads it. A polygon
  vertex starts an area of its ``vertex_count`` items, whatever those items are, and the next
  area starts after them; a circle is one item; a return point and any other command are
  skipped. PX4's ``is_circle_area`` is never reset: after the first circle every polygon vertex
  starts an area of its own (of ``vertex_count`` items from it), which PX4 reads the same way.
- ``insidePolygon`` runs PNPOLY on latitude/longitude over the area's items and stops (with the
  answer so far) at an item past the end of the plan or one not in a global frame; an area
  running past the end therefore contains nothing. ``insideCircle``: squared distance below
  radius², so a NaN radius contains nothing and a negative one acts as its magnitude.
- When the plan loads, an area that would be breached at home (home set), and, with GF_ACTION
  set while flying, one breached where the vehicle is, is dropped with PX4's text (both texts
  when both fail).
- Circles are measured in the vehicle's local NED frame (the fence is converted once, when the
  plan changes); polygons in degrees, as PX4 does.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from vehicles.events import GF_INVALID_HOME, GF_INVALID_POSITION, EventDef, Log
from vehicles.geodesy import reproject
from vehicles.plan_types import MavCmd, PlanItem
from vehicles.plans import GLOBAL_FRAMES, POLYGON_COMMANDS, item_ned, vertex_count
from vehicles.status_log import StatusLog
from vehicles.types import GeoPoint

Vec2 = tuple[float, float]
CIRCLE_COMMANDS = frozenset({MavCmd.NAV_FENCE_CIRCLE_INCLUSION, MavCmd.NAV_FENCE_CIRCLE_EXCLUSION})
INCLUSION_COMMANDS = frozenset({MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                                MavCmd.NAV_FENCE_CIRCLE_INCLUSION})


FLT_EPSILON = 1.1920929e-07


@dataclass(frozen=True)
class FenceArea:
    inclusion: bool
    # A polygon: (lat, lon, in a global frame) of the items from its first vertex on, at most
    # vertex_count of them (fewer where the plan ends). A MAV_FRAME_MISSION item is stored by PX4
    # at latitude/longitude 0.
    polygon: tuple[tuple[float, float, bool], ...] = ()
    vertex_count: int = 0
    center: Vec2 = (0.0, 0.0)  # a circle: local NED
    radius_m: float = 0.0

    def contains(self, n: float, e: float, lat: float, lon: float) -> bool:
        if not self.polygon:
            dn, de = n - self.center[0], e - self.center[1]
            return dn * dn + de * de < self.radius_m * self.radius_m
        return inside_polygon(lat, lon, self.polygon, self.vertex_count)

    def allows(self, n: float, e: float, lat: float, lon: float) -> bool:
        """Inside an inclusion area, outside an exclusion area."""
        return self.contains(n, e, lat, lon) == self.inclusion


def inside_polygon(lat: float, lon: float, vertices: Sequence[tuple[float, float, bool]],
                   count: int) -> bool:
    """geofence.cpp insidePolygon (PNPOLY, W. R. Franklin) over ``count`` vertices; it stops at
    a vertex it cannot read (past the plan's end) or whose frame is not global."""
    inside = False
    j = count - 1
    for i in range(count):
        if i >= len(vertices) or j >= len(vertices):
            break
        lat_i, lon_i, global_i = vertices[i]
        if not global_i:
            break
        lat_j, lon_j, _ = vertices[j]
        if (lon_i >= lon) != (lon_j >= lon) and \
                lat <= (lat_j - lat_i) * (lon - lon_i) / (lon_j - lon_i) + lat_i:
            inside = not inside
        j = i
    return inside


def _vertex(item: PlanItem) -> tuple[float, float, bool]:
    if item.frame in GLOBAL_FRAMES:
        return (item.lat_deg, item.lon_deg, True)
    return (0.0, 0.0, False)


def build_areas(items: Sequence[PlanItem], origin: GeoPoint) -> list[tuple[int, FenceArea]]:
    """geofence.cpp _updateFence: each area with the index of the item it starts at."""
    areas: list[tuple[int, FenceArea]] = []
    circle_seen = False  # PX4's is_circle_area: set by the first circle, never cleared
    i = 0
    while i < len(items):
        it = items[i]
        cmd = it.command
        if cmd in CIRCLE_COMMANDS:
            circle_seen = True
        if cmd not in CIRCLE_COMMANDS and cmd not in POLYGON_COMMANDS:
            i += 1  # the return point ("TODO: do we need to store this?"), unhandled commands
            continue
        inclusion = cmd in INCLUSION_COMMANDS
        if cmd in CIRCLE_COMMANDS:
            c = item_ned(it, origin, origin.alt_amsl_m)
            areas.append((i, FenceArea(inclusion, center=(c[0], c[1]), radius_m=it.param1)))
            i += 1
            continue
        count = vertex_count(it.param1)
        if not circle_seen and count == 0:
            i += 1  # "Polygon with 0 vertices. Skipping" (the upload refuses fewer than 3)
            continue
        vertices = tuple(_vertex(v) for v in items[i:i + count])
        areas.append((i, FenceArea(inclusion, vertices, count)))
        i += 1 if circle_seen else count
    return areas


def _invalid(log: StatusLog | None, now_s: float, event: EventDef) -> str:
    """mavlink_log_critical + events::send {Critical, internal Warning}."""
    text = event.message + "\t"
    if log is not None:
        log.critical(now_s, text)
        log.event(now_s, event, Log.CRITICAL, Log.WARNING)
    return text


class Geofence:
    def __init__(self, params) -> None:
        self._params = params
        self._params_version = -1  # GF_MAX_HOR_DIST / GF_MAX_VER_DIST, read when first needed
        self._max_dist_set = False
        self._origin: GeoPoint | None = None
        self._has_polygon = False
        self.areas: tuple[FenceArea, ...] = ()

    def _latlon(self, n: float, e: float) -> Vec2:
        if not self._has_polygon or self._origin is None:
            return (math.nan, math.nan)  # (only polygons need them)
        return reproject(self._origin.lat_deg, self._origin.lon_deg, n, e)

    def load(self, items: Sequence[PlanItem], origin: GeoPoint, home_ne: Vec2 | None = None,
             flying_at_ne: Vec2 | None = None, log: StatusLog | None = None, now_s: float = 0.0
             ) -> list[str]:
        """Take the FENCE plan; returns (and, given ``log``, sends with their events) PX4's
        texts for the areas it drops (geofence.cpp _updateFence: checkHomeRequirementsForGeofence
        when home is set, then checkCurrentPositionRequirementsForGeofence while flying with
        GF_ACTION set; both run for every area)."""
        self._origin = origin
        built = [area for _, area in build_areas(items, origin)]
        self._has_polygon = any(a.polygon for a in built)
        texts = []
        kept = []
        gf_action = int(self._params["GF_ACTION"])
        for area in built:
            home_ok = home_ne is None or area.allows(*home_ne, *self._latlon(*home_ne))
            if not home_ok:
                texts.append(_invalid(log, now_s, GF_INVALID_HOME))
            here_ok = (flying_at_ne is None or gf_action == 0
                       or area.allows(*flying_at_ne, *self._latlon(*flying_at_ne)))
            if not here_ok:
                texts.append(_invalid(log, now_s, GF_INVALID_POSITION))
            if home_ok and here_ok:
                kept.append(area)
        self.areas = tuple(kept)
        self._has_polygon = any(a.polygon for a in kept)
        return texts

    @property
    def enabled(self) -> bool:
        if self.areas:
            return True
        p = self._params
        if p.version != self._params_version:  # (asked every 50 Hz tick)
            self._params_version = p.version
            self._max_dist_set = (float(p["GF_MAX_HOR_DIST"]) > FLT_EPSILON
                                  or float(p["GF_MAX_VER_DIST"]) > FLT_EPSILON)
        return self._max_dist_set

    def inside_areas(self, n: float, e: float) -> bool:
        """isInsidePolygonOrCircle: every area allows the point (PX4 1.15 ANDs them all, so two
        inclusion areas allow only their intersection)."""
        lat, lon = self._latlon(n, e)
        return all(a.allows(n, e, lat, lon) for a in self.areas)

    def check(self, position_ned_m: Sequence[float], home_ned_m: Sequence[float] | None
              ) -> str | None:
        """None when the position is allowed, else the text geofenceCheck.cpp says for the
        first limit broken, in its order (distance to home, altitude, the fence's areas)."""
        n, e, d = position_ned_m[0], position_ned_m[1], position_ned_m[2]
        p = self._params
        if home_ned_m is not None:
            max_ver, max_hor = float(p["GF_MAX_VER_DIST"]), float(p["GF_MAX_HOR_DIST"])
            # isBelowMaxAltitude / isCloserThanMaxDistToHome: on from FLT_EPSILON, inside only
            # strictly below the limit
            dxy = math.hypot(n - home_ned_m[0], e - home_ned_m[1])
            if max_hor > FLT_EPSILON and not dxy < max_hor:
                return "Geofence violation: exceeding maximum distance to Home"
            dz = home_ned_m[2] - d
            if max_ver > FLT_EPSILON and not dz < max_ver:
                return "Geofence violation: exceeding maximum altitude above Home"
        if not self.inside_areas(n, e):
            return "Geofence violation: approaching or outside geofence"
        return None
