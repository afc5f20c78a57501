"""Flat-earth conversion between the world's local NED and latitude/longitude/altitude.

Same scaling as ArduPilot's Location (LOCATION_SCALING_FACTOR, 6378137 m earth radius);
good to centimetres over the few kilometres a SITL world spans.
"""
from __future__ import annotations

import math

import numpy as np

from gcs.frames import euler_from_quaternion

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
    return euler_from_quaternion(q)[2]
