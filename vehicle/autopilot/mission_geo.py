"""Where a stored mission / fence / rally item points, in the world's NED (pure).

Frames (MISSION_ITEM_INT conventions; the store keeps x, y as ints):
  GLOBAL (0), GLOBAL_INT (5)                    x, y = lat, lon * 1e7; z = altitude AMSL (m)
  GLOBAL_RELATIVE_ALT (3), _INT (6)             x, y = lat, lon * 1e7; z = altitude above home (m)
  LOCAL_NED (1)                                 x, y = north, east metres * 1e4 from the EKF origin
                                                (the world origin); z = down (m), MAVLink's local sign
  MISSION (2)                                   no position (do/condition commands)
ArduPilot (Location / ModeAuto::loc_from_cmd): lat = lon = 0 means "here" (the default
position), and an altitude of 0 means "the default altitude"; the caller passes those
defaults. Terrain frames are not flown (no terrain data): ItemFrameError.
"""
from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from common import geo
from vehicle.autopilot.mission_store import MissionItem

AMSL = {mav.MAV_FRAME_GLOBAL, mav.MAV_FRAME_GLOBAL_INT}
RELATIVE = {mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT}
LOCAL = {mav.MAV_FRAME_LOCAL_NED}


class ItemFrameError(ValueError):
    """The item's frame or coordinates cannot be flown; str() says why."""


def has_position(item: MissionItem) -> bool:
    return not (item.x == 0 and item.y == 0)


def item_ned(item: MissionItem, origin: tuple[float, float, float], home_z: float,
             default: np.ndarray) -> np.ndarray:
    """World NED (m) of the item; `default` fills a 0,0 position and a 0 altitude.

    home_z: world NED z of home (relative altitudes are measured from it).
    """
    z_in = float(item.z)
    if not math.isfinite(z_in):
        raise ItemFrameError(f"item {item.seq}: altitude not finite")
    if item.frame in LOCAL:
        out = np.array([item.x / 1e4, item.y / 1e4, z_in], float)
        if not has_position(item):
            out[:2] = default[:2]
        if z_in == 0.0:
            out[2] = default[2]
        return out
    if item.frame not in AMSL | RELATIVE:
        raise ItemFrameError(f"item {item.seq}: frame {item.frame} not supported")
    out = np.array(default, float).copy()
    if has_position(item):
        lat, lon = item.x * 1e-7, item.y * 1e-7
        if abs(lat) > 90 or abs(lon) > 180:
            raise ItemFrameError(f"item {item.seq}: bad latitude/longitude")
        ned = geo.lla_to_ned(origin, lat, lon, origin[2])
        out[0], out[1] = ned[0], ned[1]
    if z_in != 0.0:
        out[2] = (origin[2] - z_in) if item.frame in AMSL else (home_z - z_in)
    return out


def item_alt_z(item: MissionItem, origin: tuple[float, float, float], home_z: float) -> float:
    """World NED z of the item's altitude alone (takeoff targets)."""
    z_in = float(item.z)
    if item.frame in LOCAL:
        return z_in
    if item.frame in AMSL:
        return origin[2] - z_in
    return home_z - z_in
