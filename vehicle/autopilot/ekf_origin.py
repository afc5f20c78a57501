"""A vehicle's EKF origin: where its local NED frame (LOCAL_POSITION_NED, local targets) is centred.

ArduPilot sets the EKF origin once, at the first good GPS fix (AP_AHRS), or earlier from
SET_GPS_GLOBAL_ORIGIN when there is no GPS; once set it does not move (GCS_MAVLINK::
set_ekf_origin refuses a second one silently) until the next boot. GPS_GLOBAL_ORIGIN says
where it is. So two vehicles that booted 3 m apart each report (0, 0) where they started.

The autopilot and the fleet work in the SITL world's NED (centred on the world's home,
`world_origin`); this class converts at the MAVLink edge. The origin is a pure translation
of the world frame (no rotation: both are north-east-down), computed once with common.geo
(ArduPilot's Location math), so local = world - offset exactly, and the bridge's static
world -> <vehicle>_origin edge (the same translation, from GPS_GLOBAL_ORIGIN) undoes it.
Units: degrees, metres AMSL (up), NED metres (down positive). Pure: no clocks, no sockets.
"""
from __future__ import annotations

import math

import numpy as np

from common import geo


class EkfOrigin:
    def __init__(self, world_origin: tuple[float, float, float]) -> None:
        self.world_origin = world_origin
        self.lla: tuple[float, float, float] | None = None
        self.offset = np.zeros(3)          # world NED of the origin (m)

    @property
    def is_set(self) -> bool:
        return self.lla is not None

    def set(self, lat: float, lon: float, alt: float) -> bool:
        """Set the origin (deg, deg, m AMSL); False if it is already set or not a place."""
        if self.lla is not None:
            return False
        if not all(math.isfinite(v) for v in (lat, lon, alt)) or abs(lat) > 90 or abs(lon) > 180:
            return False
        # held as ArduPilot's Location holds it (1e-7 deg, cm), so GPS_GLOBAL_ORIGIN is exact
        self.lla = (round(lat * 1e7) / 1e7, round(lon * 1e7) / 1e7, round(alt * 100) / 100)
        lat, lon, alt = self.lla
        self.offset = np.asarray(geo.lla_to_ned(self.world_origin, lat, lon, alt), float)
        return True

    def to_local(self, world_ned) -> np.ndarray:
        """World NED (m) -> NED from this origin (m)."""
        return np.asarray(world_ned, float) - self.offset

    def to_world(self, local_ned) -> np.ndarray:
        """NED from this origin (m) -> world NED (m)."""
        return np.asarray(local_ned, float) + self.offset
