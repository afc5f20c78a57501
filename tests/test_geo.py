"""common.geo: latitude/longitude <-> local NED exactly as ArduPilot's Location computes it."""
from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from common import geo

# AP_Math/definitions.h: 1e-7 degree in metres at the equator, for RADIUS_OF_EARTH = 6378100 m
LOCATION_SCALING_FACTOR = 0.011131884502145034
CMAC = (-35.3632621, 149.1652374, 584.0)     # ArduPilot SITL's default home (Canberra)


def test_scaling_is_ardupilots_not_wgs84():
    assert geo.RADIUS_OF_EARTH == 6378100.0
    assert geo.LATLON_TO_M * 1e-7 == pytest.approx(LOCATION_SCALING_FACTOR, rel=1e-15)
    n, e, d = geo.lla_to_ned((0.0, 0.0, 0.0), 1e-3, 0.0, 0.0)
    assert n == pytest.approx(1e4 * LOCATION_SCALING_FACTOR, rel=1e-12)   # 111.318 m, not 111.319 m


@given(st.integers(-2_000_000, 2_000_000), st.integers(-2_000_000, 2_000_000))
def test_ned_matches_location_get_distance_NED(dlat, dlng):
    """Location::get_distance_NED on integer 1e-7 degrees: the longitude is scaled at the mid latitude."""
    lat0, lon0 = int(CMAC[0] * 1e7), int(CMAC[1] * 1e7)
    lat, lon = lat0 + dlat, lon0 + dlng
    want_n = dlat * LOCATION_SCALING_FACTOR
    want_e = dlng * LOCATION_SCALING_FACTOR * max(math.cos(math.radians((lat0 + lat) / 2 * 1e-7)), 0.01)
    n, e, d = geo.lla_to_ned((lat0 * 1e-7, lon0 * 1e-7, 584.0), lat * 1e-7, lon * 1e-7, 590.0)
    assert n == pytest.approx(want_n, abs=1e-6)
    assert e == pytest.approx(want_e, abs=1e-6)
    assert d == pytest.approx(-6.0)


@given(st.floats(-89.0, 89.0), st.floats(-180.0, 179.999), st.floats(-5000.0, 5000.0),
       st.floats(-5000.0, 5000.0), st.floats(-500.0, 500.0))
def test_round_trip_is_exact(lat0, lon0, n, e, d):
    origin = (lat0, lon0, 100.0)
    lat, lon, alt = geo.ned_to_lla(origin, (n, e, d))
    assert -180.0 <= lon < 180.0
    assert alt == pytest.approx(100.0 - d)
    back = geo.lla_to_ned(origin, lat, lon, alt)
    assert back == pytest.approx((n, e, d), abs=1e-6)


def test_longitude_wraps_at_the_antimeridian():
    origin = (10.0, 179.9999, 0.0)
    lat, lon, _ = geo.ned_to_lla(origin, (0.0, 50.0, 0.0))
    assert -180.0 < lon < -179.999            # crossed to the west side, not 180.0003
    n, e, _ = geo.lla_to_ned(origin, lat, lon, 0.0)
    assert e == pytest.approx(50.0, abs=1e-6)
    assert geo.diff_longitude(-179.5, 179.5) == pytest.approx(1.0)
    assert geo.diff_longitude(179.5, -179.5) == pytest.approx(-1.0)


def test_longitude_scale_is_floored_at_the_pole():
    assert geo.longitude_scale(90.0) == 0.01
    assert geo.longitude_scale(60.0) == pytest.approx(0.5)
