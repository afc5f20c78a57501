"""Fence shapes from the FENCE list, and which points they allow (pure geometry).

As ArduPilot's AC_PolyFence_loader reads the fence items (learned from its source):
  NAV_FENCE_POLYGON_VERTEX_INCLUSION (5001) / _EXCLUSION (5002): param1 = the polygon's vertex
      count; that many consecutive items of the same command make one polygon.
  NAV_FENCE_CIRCLE_INCLUSION (5003) / _EXCLUSION (5004): param1 = radius (m) around x, y.
  NAV_FENCE_RETURN_POINT (5000): where Plane returns; kept, unused by Copter and Rover.
A point breaches the polygon fence when it is inside any exclusion zone, or outside any
inclusion zone (all inclusion zones must hold it: their intersection is the allowed area).
Points are north/east metres in the world frame; a point exactly on an edge counts as inside.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from common import geo
from vehicle.autopilot.mission_store import MissionItem

RETURN_POINT = mav.MAV_CMD_NAV_FENCE_RETURN_POINT
POLY_IN = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
POLY_OUT = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION
CIRCLE_IN = mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
CIRCLE_OUT = mav.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION


class FenceLoadError(ValueError):
    """The FENCE list does not describe valid zones ("Polygon fence(s) invalid")."""


@dataclass
class FenceZones:
    """Zones in world north/east metres."""
    inclusion_polygons: list[np.ndarray] = field(default_factory=list)
    exclusion_polygons: list[np.ndarray] = field(default_factory=list)
    inclusion_circles: list[tuple[np.ndarray, float]] = field(default_factory=list)
    exclusion_circles: list[tuple[np.ndarray, float]] = field(default_factory=list)
    return_point: np.ndarray | None = None

    def count(self) -> int:
        return (len(self.inclusion_polygons) + len(self.exclusion_polygons)
                + len(self.inclusion_circles) + len(self.exclusion_circles))

    def breached(self, ne: Sequence[float]) -> bool:
        """True when the north/east point is outside the allowed area."""
        p = np.asarray(ne, float)[:2]
        for poly in self.exclusion_polygons:
            if point_in_polygon(p, poly):
                return True
        for c, r in self.exclusion_circles:
            if point_in_circle(p, c, r):
                return True
        for poly in self.inclusion_polygons:
            if not point_in_polygon(p, poly):
                return True
        for c, r in self.inclusion_circles:
            if not point_in_circle(p, c, r):
                return True
        return False


def point_in_circle(p: Sequence[float], center: Sequence[float], radius: float) -> bool:
    return math.hypot(p[0] - center[0], p[1] - center[1]) <= radius


def point_in_polygon(p: Sequence[float], poly: np.ndarray) -> bool:
    """Even-odd rule; points on an edge or vertex count as inside."""
    x, y = float(p[0]), float(p[1])
    n = len(poly)
    inside = False
    for k in range(n):
        x1, y1 = float(poly[k][0]), float(poly[k][1])
        x2, y2 = float(poly[(k + 1) % n][0]), float(poly[(k + 1) % n][1])
        if _on_segment(x, y, x1, y1, x2, y2):
            return True
        if (y1 > y) != (y2 > y):
            xc = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
            if xc > x:
                inside = not inside
    return inside


def _on_segment(x, y, x1, y1, x2, y2, eps: float = 1e-9) -> bool:
    cross = (x2 - x1) * (y - y1) - (y2 - y1) * (x - x1)
    scale = max(1.0, math.hypot(x2 - x1, y2 - y1))
    if abs(cross) > eps * scale:
        return False
    return min(x1, x2) - eps <= x <= max(x1, x2) + eps and min(y1, y2) - eps <= y <= max(y1, y2) + eps


def _ne(item: MissionItem, origin) -> np.ndarray:
    if item.frame == mav.MAV_FRAME_LOCAL_NED:
        return np.array([item.x / 1e4, item.y / 1e4])
    lat, lon = item.x * 1e-7, item.y * 1e-7
    return np.array(geo.lla_to_ned(origin, lat, lon, origin[2])[:2])


def load_zones(items: Sequence[MissionItem], origin: tuple[float, float, float]) -> FenceZones:
    """Zones from the FENCE list; FenceLoadError if a polygon's vertex count is wrong."""
    z = FenceZones()
    k = 0
    while k < len(items):
        it = items[k]
        if it.command in (POLY_IN, POLY_OUT):
            n = _count(it.param1)
            if n < 3 or k + n > len(items):
                raise FenceLoadError(f"fence item {it.seq}: polygon of {it.param1} vertices")
            verts = items[k:k + n]
            if any(v.command != it.command or _count(v.param1) != n for v in verts):
                raise FenceLoadError(f"fence item {it.seq}: polygon vertices do not agree")
            poly = np.array([_ne(v, origin) for v in verts])
            (z.inclusion_polygons if it.command == POLY_IN else z.exclusion_polygons).append(poly)
            k += n
            continue
        if it.command in (CIRCLE_IN, CIRCLE_OUT):
            r = float(it.param1)
            if not math.isfinite(r) or r <= 0:
                raise FenceLoadError(f"fence item {it.seq}: circle radius {it.param1}")
            (z.inclusion_circles if it.command == CIRCLE_IN else z.exclusion_circles).append((_ne(it, origin), r))
        elif it.command == RETURN_POINT:
            z.return_point = _ne(it, origin)
        else:
            raise FenceLoadError(f"fence item {it.seq}: command {it.command} is not a fence item")
        k += 1
    return z


def _count(v: float) -> int:
    try:
        return int(v)
    except (ValueError, OverflowError):
        return 0
