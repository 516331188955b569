"""Geofence: inclusion/exclusion polygons and circles from the FENCE plan, plus max distances.

After PX4 ``src/modules/navigator/geofence.cpp`` (``checkAll`` / ``isInsidePolygonOrCircle``:
inside at least one inclusion area if there are any, outside every exclusion area) and the
GF_MAX_HOR_DIST / GF_MAX_VER_DIST checks against home.

Rules: pure geometry on the vehicle's local NED frame (the fence is converted once, when the plan
or the origin changes). ``check`` returns None when inside, else the reason text PX4 prints. When
the plan loads, an area that would be breached at home (or where the vehicle flies, with
GF_ACTION set) is dropped with PX4's text, as PX4 does.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from vehicles.plan_types import MavCmd, PlanItem
from vehicles.plans import POLYGON_COMMANDS, item_ned
from vehicles.types import GeoPoint

Vec2 = tuple[float, float]


@dataclass(frozen=True)
class FenceArea:
    inclusion: bool
    polygon: tuple[Vec2, ...] = ()
    center: Vec2 = (0.0, 0.0)
    radius_m: float = 0.0

    def contains(self, n: float, e: float) -> bool:
        if not self.polygon:
            return math.hypot(n - self.center[0], e - self.center[1]) <= self.radius_m
        return point_in_polygon(n, e, self.polygon)

    def allows(self, n: float, e: float) -> bool:
        """Inside an inclusion area, outside an exclusion area."""
        return self.contains(n, e) == self.inclusion


def point_in_polygon(n: float, e: float, poly: Sequence[Vec2]) -> bool:
    """Even-odd ray casting (geofence.cpp insidePolygon)."""
    inside = False
    j = len(poly) - 1
    for i in range(len(poly)):
        ni, ei = poly[i]
        nj, ej = poly[j]
        if (ei > e) != (ej > e) and n < (nj - ni) * (e - ei) / (ej - ei) + ni:
            inside = not inside
        j = i
    return inside


def build_areas(items: Sequence[PlanItem], origin: GeoPoint) -> tuple[FenceArea, ...]:
    areas: list[FenceArea] = []
    i = 0
    while i < len(items):
        it = items[i]
        if it.command in POLYGON_COMMANDS:
            n = int(it.param1)
            pts = tuple(item_ned(v, origin, origin.alt_amsl_m)[:2] for v in items[i:i + n])
            areas.append(FenceArea(it.command == MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION, pts))
            i += n
            continue
        if it.command in (MavCmd.NAV_FENCE_CIRCLE_INCLUSION, MavCmd.NAV_FENCE_CIRCLE_EXCLUSION):
            c = item_ned(it, origin, origin.alt_amsl_m)
            areas.append(FenceArea(it.command == MavCmd.NAV_FENCE_CIRCLE_INCLUSION,
                                   center=(c[0], c[1]), radius_m=float(it.param1)))
        i += 1
    return tuple(areas)


class Geofence:
    def __init__(self, params) -> None:
        self._params = params
        self._params_version = -1  # GF_MAX_HOR_DIST / GF_MAX_VER_DIST, read when first needed
        self._max_dist_set = False
        self.areas: tuple[FenceArea, ...] = ()

    def load(self, items: Sequence[PlanItem], origin: GeoPoint,
             home_ne: Vec2 | None = None, flying_at_ne: Vec2 | None = None) -> list[str]:
        """Take the FENCE plan; returns PX4's texts for the areas it drops (geofence.cpp
        _updateFence): one that does not contain home (when home is set), or, while flying with
        GF_ACTION set, the vehicle's position."""
        texts = []
        kept = []
        for area in build_areas(items, origin):
            if home_ne is not None and not area.allows(*home_ne):
                texts.append("Geofence invalid, doesn't contain Home position")
                continue
            if (flying_at_ne is not None and int(self._params["GF_ACTION"]) != 0
                    and not area.allows(*flying_at_ne)):
                texts.append("Geofence invalid, doesn't contain current vehicle position")
                continue
            kept.append(area)
        self.areas = tuple(kept)
        return texts

    @property
    def enabled(self) -> bool:
        if self.areas:
            return True
        p = self._params
        if p.version != self._params_version:  # (asked every 50 Hz tick)
            self._params_version = p.version
            self._max_dist_set = (float(p["GF_MAX_HOR_DIST"]) > 0
                                  or float(p["GF_MAX_VER_DIST"]) > 0)
        return self._max_dist_set

    def inside_areas(self, n: float, e: float) -> bool:
        inclusions = [a for a in self.areas if a.inclusion]
        if inclusions and not any(a.contains(n, e) for a in inclusions):
            return False
        return not any(a.contains(n, e) for a in self.areas if not a.inclusion)

    def check(self, position_ned_m: Sequence[float], home_ned_m: Sequence[float] | None
              ) -> str | None:
        """None when the position is allowed, else PX4's reason text."""
        n, e, d = position_ned_m[0], position_ned_m[1], position_ned_m[2]
        p = self._params
        if home_ned_m is not None:
            max_ver, max_hor = float(p["GF_MAX_VER_DIST"]), float(p["GF_MAX_HOR_DIST"])
            dz = home_ned_m[2] - d
            if max_ver > 0 and dz > max_ver:
                return f"Geofence exceeded max vertical distance by {dz - max_ver:.1f} m"
            dxy = math.hypot(n - home_ned_m[0], e - home_ned_m[1])
            if max_hor > 0 and dxy > max_hor:
                return f"Geofence exceeded max horizontal distance by {dxy - max_hor:.1f} m"
        if not self.inside_areas(n, e):
            return "Geofence violation"
        return None
