"""Positions, the link capability: where the vehicle is told to go (SET_POSITION_TARGET_*),
where its local frame starts (SET_GPS_GLOBAL_ORIGIN in, GPS_GLOBAL_ORIGIN out) and where
other vehicles are (GLOBAL_POSITION_INT: FOLLOW's lead).

GPS_GLOBAL_ORIGIN goes to every endpoint when the EKF origin is first set and whenever it
moves (a reboot says it again), as ArduPilot sends it.
"""
from __future__ import annotations

from vehicle.link.link_core import LinkCore
from vehicle.link.telemetry import Telemetry


class PositionLink:
    def __init__(self, core: LinkCore, ap, telemetry: Telemetry) -> None:
        """ap: the vehicle's autopilot (its targets, its EKF origin, its FOLLOW)."""
        self.core = core
        self.ap = ap
        self.telemetry = telemetry
        self._origin_sent: tuple | None = None
        core.register("SET_POSITION_TARGET_LOCAL_NED", self.on_set_position_target_local_ned)
        core.register("SET_POSITION_TARGET_GLOBAL_INT", self.on_set_position_target_global_int)
        core.register("SET_ATTITUDE_TARGET", self.on_set_attitude_target)
        core.register("GLOBAL_POSITION_INT", self.on_global_position_int)
        core.register("SET_GPS_GLOBAL_ORIGIN", self.on_set_gps_global_origin)
        core.on_tick(self.update)
        core.on_reboot(self.forget)

    def forget(self) -> None:
        """A new boot says its EKF origin again."""
        self._origin_sent = None

    def update(self) -> None:
        """Every tick: GPS_GLOBAL_ORIGIN when the EKF origin was set or moved."""
        origin = self.ap.ekf_origin()
        if origin != self._origin_sent:          # set (first good estimate) or moved
            self._origin_sent = origin
            msg = self.telemetry.gps_global_origin()
            if msg is not None:
                self.core.send(msg)

    def on_set_position_target_local_ned(self, m, ch) -> None:
        self.ap.position_target_local(m.coordinate_frame, m.type_mask, (m.x, m.y, m.z), (m.vx, m.vy, m.vz),
                                      (m.afx, m.afy, m.afz), m.yaw, m.yaw_rate)

    def on_set_position_target_global_int(self, m, ch) -> None:
        self.ap.position_target_global(m.coordinate_frame, m.type_mask, m.lat_int, m.lon_int, m.alt,
                                       (m.vx, m.vy, m.vz), (m.afx, m.afy, m.afz), m.yaw, m.yaw_rate)

    def on_set_attitude_target(self, m, ch) -> None:
        self.ap.attitude_target(m.type_mask, m.q, (m.body_roll_rate, m.body_pitch_rate, m.body_yaw_rate), m.thrust)

    def on_global_position_int(self, m, ch) -> None:
        """Another vehicle's position: FOLLOW's lead, when FOLL_ENABLE is set (AP_Follow)."""
        self.ap.follow.on_global_position(m.get_srcSystem(), m, self.ap.t, self.ap.home_lla()[2])

    def on_set_gps_global_origin(self, m, ch) -> None:
        """As ArduPilot's handle_set_gps_global_origin: a bad latitude/longitude is dropped
        silently; the origin is set only if it is not set yet (then GPS_GLOBAL_ORIGIN goes out
        from update()); a second one is ignored, also silently. Altitude is mm AMSL."""
        lat, lon, alt = m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3
        if abs(lat) > 90 or abs(lon) > 180:
            return
        self.ap.local_origin.set(lat, lon, alt)
