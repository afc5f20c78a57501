"""Rally points: where RTL goes, as ArduPilot's AP_Rally chooses (pure).

AP_Rally (learned from its source): RTL flies to the rally point nearest the vehicle,
considering only points within RALLY_LIMIT_KM of home (0 = no limit; copter default
0.3 km) and, for the copter, inside the fence. With RALLY_INCL_HOME = 1 (copter default)
home competes too: the rally point is used only if it is nearer than home. With no
usable rally point RTL goes home. Rally items are NAV_RALLY_POINT (5100) with a
position and an altitude (frame GLOBAL_RELATIVE_ALT usually).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.mission_geo import ItemFrameError, item_ned
from vehicle.autopilot.mission_store import MissionItem


def rally_points(items: Sequence[MissionItem], origin, home_z: float) -> list[np.ndarray]:
    """World NED of the usable rally items (others skipped)."""
    out = []
    for it in items:
        if it.command != mav.MAV_CMD_NAV_RALLY_POINT or (it.x == 0 and it.y == 0):
            continue
        try:
            out.append(item_ned(it, origin, home_z, np.array([0.0, 0.0, home_z])))
        except ItemFrameError:
            continue
    return out


def best_return(here: np.ndarray, home: np.ndarray, points: Sequence[np.ndarray], limit_km: float,
                include_home: bool, valid: Callable[[np.ndarray], bool] | None = None) -> tuple[np.ndarray, bool]:
    """(where RTL goes, True if it is a rally point). Horizontal distances, world NED metres."""
    best, best_d = None, np.inf
    for p in points:
        if limit_km > 0 and np.linalg.norm(p[:2] - home[:2]) > limit_km * 1000.0:
            continue
        if valid is not None and not valid(p):
            continue
        d = float(np.linalg.norm(p[:2] - here[:2]))
        if d < best_d:
            best, best_d = p, d
    if best is None:
        return np.asarray(home, float), False
    if include_home and not best_d < float(np.linalg.norm(home[:2] - here[:2])):
        return np.asarray(home, float), False
    return np.asarray(best, float), True
