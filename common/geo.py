"""Latitude/longitude/altitude <-> local NED, the way ArduPilot's Location does it.

ArduPilot (AP_Common/Location.cpp, AP_Math/definitions.h) works on a flat earth around a
reference: north = dlat * LOCATION_SCALING_FACTOR, east = dlng * LOCATION_SCALING_FACTOR *
longitude_scale(mid latitude), where LOCATION_SCALING_FACTOR is 1e-7 deg in metres at the
equator for RADIUS_OF_EARTH = 6378100 m (not WGS-84's 6378137 m), and longitude_scale(lat) =
max(cos(lat), 0.01). Both directions scale the longitude at the mid latitude of the two points
(get_distance_NED, offset_latlng), so a round trip is exact. Longitude differences wrap at
+-180 deg (diff_longitude). Good to centimetres over the few kilometres a SITL world spans.

Units: degrees for latitude/longitude, metres for altitude (up, AMSL) and NED (down positive).
An origin is (lat0, lon0, alt0). Pure: no numpy needed, plain floats in and out.
"""
from __future__ import annotations

import math

RADIUS_OF_EARTH = 6378100.0                           # m, ArduPilot's RADIUS_OF_EARTH
LATLON_TO_M = RADIUS_OF_EARTH * math.pi / 180.0       # m per degree = LOCATION_SCALING_FACTOR * 1e7

Origin = tuple[float, float, float]


def longitude_scale(lat: float) -> float:
    """cos(lat), floored at 0.01 as ArduPilot does so the poles do not divide by zero."""
    return max(math.cos(math.radians(lat)), 0.01)


def diff_longitude(lon1: float, lon2: float) -> float:
    """lon1 - lon2 in degrees, wrapped to [-180, 180)."""
    return (lon1 - lon2 + 180.0) % 360.0 - 180.0


def lla_to_ned(origin: Origin, lat: float, lon: float, alt: float) -> tuple[float, float, float]:
    """(north, east, down) m of (lat, lon, alt AMSL) from origin (lat0, lon0, alt0)."""
    lat0, lon0, alt0 = origin
    return ((lat - lat0) * LATLON_TO_M,
            diff_longitude(lon, lon0) * LATLON_TO_M * longitude_scale(0.5 * (lat0 + lat)),
            alt0 - alt)


def ned_to_lla(origin: Origin, ned) -> tuple[float, float, float]:
    """(lat, lon, alt AMSL) of the point `ned` (north, east, down m) from origin."""
    lat0, lon0, alt0 = origin
    dlat = float(ned[0]) / LATLON_TO_M
    dlon = float(ned[1]) / LATLON_TO_M / longitude_scale(lat0 + 0.5 * dlat)
    return lat0 + dlat, diff_longitude(lon0 + dlon, 0.0), alt0 - float(ned[2])
