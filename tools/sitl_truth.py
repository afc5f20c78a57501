"""A vehicle's true state for a test's assertions: where it really is, not what it estimates.

:class:`VehicleTruth` is one snapshot. In a world run in the test's process it is read from
the fleet's physics (``fleet.truth_row``, the numbers SIM_STATE carries); in a world run as
a process it is what the vehicle's SIM_STATE (10 Hz sim), HEARTBEAT and EXTENDED_SYS_STATE
said last (:class:`TruthListener`). Mode, armed and landed are the autopilot's own (the land
detector decides "landed", as ArduPilot's land_complete).

Frames and units: ``ned`` is world NED in m from the world origin (the marker's ``home``; the
drones start at (0, 2 j, 0), the rovers 3 m south of them), z down; ``lat``/``lon`` degrees,
``alt`` m AMSL; ``vel_ned`` m/s; ``attitude`` (roll, pitch, yaw) rad, body FRD to NED, yaw
clockwise from north; ``t`` the sim time of the sample, s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from common import geo
from common.frames import euler_from_quaternion


@dataclass(frozen=True)
class VehicleTruth:
    """One vehicle's true state at sim time ``t`` (see the module docstring for frames)."""
    index: int
    sysid: int
    t: float
    ned: tuple[float, float, float]
    lat: float
    lon: float
    alt: float
    vel_ned: tuple[float, float, float]
    attitude: tuple[float, float, float]
    mode: str
    armed: bool
    landed: bool

    @property
    def north(self) -> float:
        return self.ned[0]

    @property
    def east(self) -> float:
        return self.ned[1]

    @property
    def height(self) -> float:
        """m above the world origin's altitude (-down)."""
        return -self.ned[2]

    @property
    def speed(self) -> float:
        """Ground speed, m/s (horizontal)."""
        return math.hypot(self.vel_ned[0], self.vel_ned[1])

    @property
    def yaw(self) -> float:
        return self.attitude[2]

    def distance_to(self, north: float, east: float, down: float | None = None) -> float:
        """m from this vehicle to a world NED point (horizontal when `down` is None)."""
        d = (self.ned[0] - north) ** 2 + (self.ned[1] - east) ** 2
        if down is not None:
            d += (self.ned[2] - down) ** 2
        return math.sqrt(d)


def truth_of_world(world, index: int) -> VehicleTruth:
    """Vehicle `index` of an in-process vehicle.world.World, read now. Read from the test's
    thread while the world's thread steps, one sample may mix two successive physics steps
    (2.5 ms sim apart at 400 Hz): millimetres, never a stale second."""
    v = world.vehicles[index]
    ap = v.ap
    t = world.t
    px, py, pz, vx, vy, vz, qx, qy, qz, qw = ap.fleet.truth_row(ap.i)[:10]
    lat, lon, alt = geo.ned_to_lla(ap.origin, (px, py, pz))
    return VehicleTruth(index, v.sysid, t, (px, py, pz), lat, lon, alt, (vx, vy, vz),
                        tuple(euler_from_quaternion((qx, qy, qz, qw))), ap.mode_name, bool(ap.armed),
                        bool(ap.fleet.landed(ap.i)))


class TruthListener:
    """Truth of a world in another process, from what its vehicles stream (pure: it is fed
    decoded pymavlink messages; :class:`tools.sitl_recorder.Recorder` feeds it)."""

    TYPES = frozenset({"SIM_STATE", "HEARTBEAT", "EXTENDED_SYS_STATE", "ATTITUDE", "SYSTEM_TIME"})

    def __init__(self, origin: tuple[float, float, float], sysids: list[int]) -> None:
        self.origin = origin
        self.index = {s: i for i, s in enumerate(sysids)}
        self._sim: dict[int, object] = {}
        self._hb: dict[int, object] = {}
        self._landed: dict[int, bool] = {}
        self.t = 0.0                          # newest sim time heard from any vehicle, s

    def on_message(self, msg) -> None:
        sysid = msg.get_srcSystem()
        if sysid not in self.index:
            return
        kind = msg.get_type()
        if kind == "SIM_STATE":
            self._sim[sysid] = msg
        elif kind == "HEARTBEAT":
            self._hb[sysid] = msg
        elif kind == "EXTENDED_SYS_STATE":
            self._landed[sysid] = msg.landed_state == 1          # MAV_LANDED_STATE_ON_GROUND
        if kind in ("ATTITUDE", "SYSTEM_TIME"):
            self.t = max(self.t, msg.time_boot_ms / 1000.0)

    def ready(self, index: int) -> bool:
        sysid = self._sysid(index)
        return sysid in self._sim and sysid in self._hb

    def _sysid(self, index: int) -> int:
        for s, i in self.index.items():
            if i == index:
                return s
        raise IndexError(f"no vehicle {index} in this world")

    def truth(self, index: int) -> VehicleTruth:
        """The newest truth of vehicle `index`; LookupError before its first SIM_STATE."""
        from pymavlink import mavutil
        sysid = self._sysid(index)
        s, hb = self._sim.get(sysid), self._hb.get(sysid)
        if s is None or hb is None:
            raise LookupError(f"vehicle {index} (sysid {sysid}) has not streamed SIM_STATE and HEARTBEAT yet")
        lat, lon = s.lat_int / 1e7, s.lon_int / 1e7
        ned = geo.lla_to_ned(self.origin, lat, lon, s.alt)
        armed = bool(hb.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        return VehicleTruth(index, sysid, self.t, ned, lat, lon, s.alt, (s.vn, s.ve, s.vd),
                            (s.roll, s.pitch, s.yaw), mavutil.mode_string_v10(hb), armed,
                            self._landed.get(sysid, not armed))
