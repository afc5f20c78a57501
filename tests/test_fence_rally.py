"""Fence geometry (point in polygon / circle, zones from FENCE items), the fence's wording,
and the rally point RTL picks (AP_Rally's rules). Pure."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mav

from common import geo
from vehicle.autopilot.fence import fence_names
from vehicle.autopilot.fence_geometry import (CIRCLE_IN, CIRCLE_OUT, POLY_IN, POLY_OUT, FenceLoadError,
                                              FenceZones, load_zones, point_in_circle, point_in_polygon)
from vehicle.autopilot.mission_store import MissionItem
from vehicle.autopilot.rally import best_return, rally_points

coord = st.floats(-1000, 1000, allow_nan=False, allow_infinity=False)
ORIGIN = (47.0, 8.0, 400.0)


def rect(x0, y0, x1, y1, start=0, reverse=False):
    pts = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    pts = pts[start:] + pts[:start]
    return np.array(pts[::-1] if reverse else pts, float)


@settings(max_examples=300, deadline=None)
@given(coord, coord, st.floats(0.1, 500), st.floats(0.1, 500), coord, coord,
       st.integers(0, 3), st.booleans())
def test_point_in_rectangle_matches_the_box_test(x0, y0, w, h, px, py, start, reverse):
    poly = rect(x0, y0, x0 + w, y0 + h, start, reverse)
    # keep away from the edges, where float rounding may go either way
    assume(min(abs(px - x0), abs(px - x0 - w), abs(py - y0), abs(py - y0 - h)) > 1e-6)
    inside = x0 < px < x0 + w and y0 < py < y0 + h
    assert point_in_polygon((px, py), poly) == inside


@settings(max_examples=200, deadline=None)
@given(st.integers(3, 12), st.floats(1, 300), coord, coord, st.floats(0, 2 * math.pi),
       st.floats(0, 1.5), st.floats(0, 2 * math.pi))
def test_regular_polygon_holds_points_inside_its_incircle_not_outside_its_circumcircle(
        n, r, cx, cy, phase, rel, ang):
    k = np.arange(n)
    poly = np.stack([cx + r * np.cos(phase + 2 * np.pi * k / n), cy + r * np.sin(phase + 2 * np.pi * k / n)], 1)
    p = (cx + rel * r * math.cos(ang), cy + rel * r * math.sin(ang))
    inradius = r * math.cos(math.pi / n)
    if rel * r < inradius * 0.999:
        assert point_in_polygon(p, poly)
    elif rel * r > r * 1.001:
        assert not point_in_polygon(p, poly)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(coord, coord), min_size=3, max_size=9), coord, coord, coord, coord)
def test_point_in_polygon_is_unchanged_by_translation_and_vertex_order(verts, px, py, dx, dy):
    poly = np.array(verts, float)
    base = point_in_polygon((px, py), poly)
    # translation by whole metres keeps the arithmetic exact enough for these magnitudes
    dx, dy = round(dx), round(dy)
    assert point_in_polygon((px + dx, py + dy), poly + [dx, dy]) == base
    assert point_in_polygon((px, py), poly[::-1]) == base


def test_points_on_edges_and_vertices_count_as_inside():
    poly = rect(0, 0, 10, 10)
    for p in [(0, 0), (10, 10), (5, 0), (0, 7.5), (10, 3)]:
        assert point_in_polygon(p, poly)


def test_concave_polygon_notch_is_outside():
    # a U shape: the notch (5, 8) is outside, the arms are inside
    u = np.array([(0, 0), (10, 0), (10, 10), (7, 10), (7, 3), (3, 3), (3, 10), (0, 10)], float)
    assert not point_in_polygon((5, 8), u)
    assert point_in_polygon((1.5, 8), u) and point_in_polygon((8.5, 8), u) and point_in_polygon((5, 1), u)


@given(coord, coord, st.floats(0.1, 500), coord, coord)
def test_point_in_circle_is_distance_within_radius(cx, cy, r, px, py):
    assert point_in_circle((px, py), (cx, cy), r) == (math.hypot(px - cx, py - cy) <= r)


@settings(max_examples=200, deadline=None)
@given(coord, coord)
def test_zones_allow_the_intersection_of_inclusions_minus_exclusions(px, py):
    z = FenceZones(inclusion_polygons=[rect(-100, -100, 100, 100)],
                   inclusion_circles=[(np.array([0.0, 0.0]), 120.0)],
                   exclusion_circles=[(np.array([50.0, 50.0]), 10.0)],
                   exclusion_polygons=[rect(-80, -80, -60, -60)])
    inside_box = -100 <= px <= 100 and -100 <= py <= 100
    inside_c = math.hypot(px, py) <= 120
    in_hole = math.hypot(px - 50, py - 50) <= 10 or (-80 <= px <= -60 and -80 <= py <= -60)
    assert z.breached((px, py)) == (not (inside_box and inside_c) or in_hole)


def _fence_item(cmd, n, e, p1):
    lat, lon, _ = geo.ned_to_lla(ORIGIN, [n, e, 0])
    return MissionItem(0, mav.MAV_FRAME_GLOBAL_INT, cmd, param1=p1, x=int(round(lat * 1e7)),
                       y=int(round(lon * 1e7)), mission_type=1)


def test_zones_load_from_fence_items():
    items = [_fence_item(POLY_IN, n, e, 4) for n, e in [(-50, -50), (50, -50), (50, 50), (-50, 50)]]
    items += [_fence_item(POLY_OUT, n, e, 3) for n, e in [(0, 0), (10, 0), (0, 10)]]
    items += [_fence_item(CIRCLE_IN, 0, 0, 60.0), _fence_item(CIRCLE_OUT, -30, -30, 5.0)]
    items = [it.with_seq(i) for i, it in enumerate(items)]
    z = load_zones(items, ORIGIN)
    assert len(z.inclusion_polygons) == 1 and len(z.exclusion_polygons) == 1
    assert np.allclose(z.inclusion_polygons[0], [(-50, -50), (50, -50), (50, 50), (-50, 50)], atol=0.02)
    assert z.inclusion_circles[0][1] == 60.0
    assert z.breached((2, 2))            # inside the exclusion triangle
    assert not z.breached((20, 20))
    assert z.breached((-30, -31))        # inside the exclusion circle
    assert z.breached((40, -40)) is False          # in the box and the circle (56.6 m < 60 m)
    assert z.breached((49, -49))                    # in the box, outside the inclusion circle
    assert z.breached((55, 0))                      # in the circle, outside the box


@pytest.mark.parametrize("items, why", [
    ([(POLY_IN, 4)] * 3, "polygon of 4"),
    ([(POLY_IN, 2)] * 2, "polygon of 2"),
    ([(POLY_IN, 3), (POLY_OUT, 3), (POLY_IN, 3)], "do not agree"),
    ([(CIRCLE_IN, -5.0)], "radius"),
    ([(CIRCLE_IN, float("nan"))], "radius"),
    ([(mav.MAV_CMD_NAV_WAYPOINT, 0)], "not a fence item"),
])
def test_bad_fence_lists_are_a_typed_error(items, why):
    lst = [_fence_item(c, k, k, p).with_seq(k) for k, (c, p) in enumerate(items)]
    with pytest.raises(FenceLoadError, match=why):
        load_zones(lst, ORIGIN)


def test_fence_names_as_ac_fence_words_them():
    assert fence_names(2) == "Circle fence"
    assert fence_names(1 | 2) == "Max Alt and Circle fences"
    assert fence_names(1 | 2 | 4) == "Max Alt, Circle and Polygon fences"
    assert fence_names(8) == "Min Alt fence"


# ----- rally ------------------------------------------------------------------------
HOME = np.array([0.0, 0.0, 0.0])


def test_rtl_picks_the_nearest_rally_point():
    pts = [np.array([100.0, 0, -10]), np.array([0.0, 150, -10])]
    dest, rally = best_return(np.array([90.0, 140, -20]), HOME, pts, 0.3, True)
    assert rally and np.allclose(dest, pts[1])


def test_home_wins_when_nearer_and_included():
    pts = [np.array([200.0, 0, -10])]
    here = np.array([20.0, 0, -10])
    dest, rally = best_return(here, HOME, pts, 0.3, include_home=True)
    assert not rally and np.allclose(dest, HOME)
    dest, rally = best_return(here, HOME, pts, 0.3, include_home=False)
    assert rally and np.allclose(dest, pts[0])


def test_rally_points_beyond_rally_limit_km_are_ignored():
    far = [np.array([400.0, 0, -10])]
    here = np.array([390.0, 0, -10])
    assert best_return(here, HOME, far, 0.3, False)[1] is False       # 400 m > 0.3 km
    assert best_return(here, HOME, far, 0.0, False)[1] is True        # 0 = no limit
    assert best_return(here, HOME, far, 0.5, False)[1] is True


def test_rally_points_outside_the_fence_are_skipped():
    pts = [np.array([50.0, 0, -10]), np.array([0.0, 80, -10])]
    dest, rally = best_return(np.array([50.0, 10, -10]), HOME, pts, 0.3, False,
                              valid=lambda p: p[0] < 40)
    assert rally and np.allclose(dest, pts[1])


def test_rally_items_become_ned_points():
    lat, lon, _ = geo.ned_to_lla(ORIGIN, [30.0, -20.0, 0])
    items = [MissionItem(0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_NAV_RALLY_POINT,
                         x=int(round(lat * 1e7)), y=int(round(lon * 1e7)), z=15.0, mission_type=2),
             MissionItem(1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_NAV_RALLY_POINT, x=0, y=0, z=15.0),
             MissionItem(2, mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, mav.MAV_CMD_NAV_RALLY_POINT,
                         x=int(round(lat * 1e7)), y=int(round(lon * 1e7)), z=15.0)]
    pts = rally_points(items, ORIGIN, home_z=-2.0)
    assert len(pts) == 1
    assert np.allclose(pts[0], [30.0, -20.0, -17.0], atol=0.02)
