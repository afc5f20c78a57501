"""Flat-earth conversion between the world's local NED and latitude/longitude/altitude.

Same scaling as ArduPilot's Location (LOCATION_SCALING_FACTOR, 6378137 m earth radius);
good to centimetres over the few kilometres a SITL world spans.
"""
from __future__ import annotations

import math

import numpy as np

EARTH_RADIUS = 6378137.0
M_PER_DEG = EARTH_RADIUS * math.pi / 180.0


def ned_to_lla(origin: tuple[float, float, float], ned) -> tuple[float, float, float]:
    lat0, lon0, alt0 = origin
    lat = lat0 + float(ned[0]) / M_PER_DEG
    lon = lon0 + float(ned[1]) / (M_PER_DEG * math.cos(math.radians(lat0)))
    return lat, lon, alt0 - float(ned[2])


def lla_to_ned(origin: tuple[float, float, float], lat: float, lon: float, alt: float) -> np.ndarray:
    lat0, lon0, alt0 = origin
    return np.array([(lat - lat0) * M_PER_DEG,
                     (lon - lon0) * M_PER_DEG * math.cos(math.radians(lat0)),
                     alt0 - alt])


def wrap_pi(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def yaw_of(q) -> float:
    """Yaw (rad) of an (x, y, z, w) quaternion, ZYX convention."""
    x, y, z, w = (float(v) for v in q)
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def euler_of(q) -> tuple[float, float, float]:
    """(roll, pitch, yaw) rad of an (x, y, z, w) quaternion."""
    x, y, z, w = (float(v) for v in q)
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    s = max(-1.0, min(1.0, 2.0 * (w * y - z * x)))
    pitch = math.asin(s)
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw
