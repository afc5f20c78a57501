"""Each vehicle's origin frame: the static edge world -> <vehicle>_origin, from GPS_GLOBAL_ORIGIN.

A real ArduPilot vehicle's local NED (LOCAL_POSITION_NED, POSITION_TARGET_LOCAL_NED, local
targets) is centred on its own EKF origin, set where it booted and announced in
GPS_GLOBAL_ORIGIN. The bridge keeps one `world` for every vehicle (REP-105's map, the
vehicle origins its odom frames)::

    world --static--> drone_origin --dynamic--> drone, drone_yaw
          --static--> rover_origin --dynamic--> rover, rover_yaw

The static edge is a pure translation (both frames are NED): the origin's latitude,
longitude and altitude as NED metres from the world's reference point, by common.geo
(ArduPilot's Location math). The world's reference point is --world-origin when given,
else the first vehicle's (the drone's) own origin, so by default world == drone_origin.
Until a vehicle's origin is known its frames are stored but not connected to world: a
lookup fails (goals wait, tower telemetry is dropped and counted) rather than guess.

Pure: no sockets, no clocks. The loop asks GPS_GLOBAL_ORIGIN (REQUEST_MESSAGE 49) from a
vehicle whose origin it lacks (:meth:`OriginDesk.wanted`) and gives it every
GPS_GLOBAL_ORIGIN it sees (:meth:`OriginDesk.on_origin`).
"""
from __future__ import annotations

import math

from common import geo
from common.frames import Transform, TransformStamped

MSG_GPS_GLOBAL_ORIGIN = 49
REQUEST_PERIOD = 1.0            # wall s between asking a vehicle for its origin

Lla = tuple[float, float, float]


def origin_frame(name: str) -> str:
    """The frame a vehicle's local NED is in: ``drone`` -> ``drone_origin``."""
    return name + "_origin"


def origin_from_message(msg) -> Lla | None:
    """GPS_GLOBAL_ORIGIN as (lat deg, lon deg, alt m AMSL), None if not a place."""
    try:
        lat, lon, alt = msg.latitude * 1e-7, msg.longitude * 1e-7, msg.altitude * 1e-3
    except (AttributeError, TypeError):
        return None
    if not all(math.isfinite(v) for v in (lat, lon, alt)) or abs(lat) > 90 or abs(lon) > 180:
        return None
    return (lat, lon, alt)


class OriginDesk:
    def __init__(self, world_frame: str = "world", world_origin: Lla | None = None,
                 reference: str | None = None) -> None:
        self.world_frame = world_frame
        self.world_origin = world_origin      # None: the reference vehicle's origin, when known
        self.reference = reference            # vehicle whose origin is world's by default
        self.origins: dict[str, Lla] = {}     # vehicle name -> its GPS_GLOBAL_ORIGIN
        self._asked: dict[str, float] = {}

    def known(self, name: str) -> bool:
        return name in self.origins and self.world_origin is not None

    def wanted(self, name: str, now: float) -> bool:
        """True when the loop should ask `name` for GPS_GLOBAL_ORIGIN now (at most 1/s)."""
        if name in self.origins or now - self._asked.get(name, -1e9) < REQUEST_PERIOD:
            return False
        self._asked[name] = now
        return True

    def on_origin(self, name: str, lla: Lla) -> list[TransformStamped]:
        """A vehicle's GPS_GLOBAL_ORIGIN: the static edges that are new or changed."""
        if self.origins.get(name) == lla:
            return []
        self.origins[name] = lla
        if self.world_origin is None:
            if self.reference is not None and name != self.reference:
                return []                     # world waits for the reference vehicle
            self.world_origin = lla
            return [self.edge(n) for n in self.origins]
        return [self.edge(name)]

    def edge(self, name: str) -> TransformStamped:
        """world -> <name>_origin: the origin's NED from the world's reference point."""
        ned = geo.lla_to_ned(self.world_origin, *self.origins[name])
        return TransformStamped(self.world_frame, origin_frame(name), 0.0, Transform(translation=ned))
