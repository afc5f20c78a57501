"""Where the autopilot is going: NAV_CONTROLLER_OUTPUT and POSITION_TARGET_GLOBAL_INT.

Copter (GCS_MAVLINK_Copter::send_nav_controller_output): nav_roll / nav_pitch / nav_bearing
are the attitude controller's target (deg; roll and pitch the lean the position controller
asked for, yaw its heading reference); target_bearing and wp_dist point from the estimate to
the mode's destination (the fleet setpoint's horizontal position; 0 in modes without one);
alt_error is the position controller's vertical error (its altitude target minus the
estimate, m, positive below the target); xtrack_error is AC_PosControl::crosstrack_error
(the horizontal distance from the position target across its desired velocity; the whole
distance while the target stands still). aspd_error 0.

Rover (GCS_MAVLINK_Rover::send_nav_controller_output, only in autopilot modes): nav_roll and
nav_pitch 0 (no balance bot), nav_bearing the heading the guidance steers to, target_bearing
and wp_dist to the destination, aspd_error the commanded minus the actual speed (m/s);
towerlink's rover drives straight at its goal (no track), so xtrack_error is 0.

POSITION_TARGET_GLOBAL_INT (send_position_target_global_int): the destination of a mode that
navigates to one (autopilot modes with a full position setpoint), MAV_FRAME_GLOBAL (alt AMSL),
only the position valid; nothing otherwise.
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.telemetry.wire import boot_ms, e7

_T = mav
POSITION_ONLY = (_T.POSITION_TARGET_TYPEMASK_VX_IGNORE | _T.POSITION_TARGET_TYPEMASK_VY_IGNORE
                 | _T.POSITION_TARGET_TYPEMASK_VZ_IGNORE | _T.POSITION_TARGET_TYPEMASK_AX_IGNORE
                 | _T.POSITION_TARGET_TYPEMASK_AY_IGNORE | _T.POSITION_TARGET_TYPEMASK_AZ_IGNORE
                 | _T.POSITION_TARGET_TYPEMASK_YAW_IGNORE | _T.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
                 | 0xF000)                    # ArduPilot also sets the unused top bits


def _finite(*v: float) -> bool:
    return all(math.isfinite(x) for x in v)


def bearing_deg(dn: float, de: float) -> float:
    """Bearing (deg, 0..360 clockwise from north) of a north/east offset."""
    return math.degrees(math.atan2(de, dn)) % 360.0


def crosstrack(pn: float, pe: float, tn: float, te: float, vn: float, ve: float) -> float:
    """AC_PosControl::crosstrack_error: distance from the target (tn, te) to the position
    (pn, pe) across the desired velocity (vn, ve); the whole distance when it is zero."""
    en, ee = tn - pn, te - pe
    v2 = vn * vn + ve * ve
    if v2 == 0.0:
        return math.hypot(en, ee)
    along = (en * vn + ee * ve) / math.sqrt(v2)
    return math.sqrt(max(en * en + ee * ee - along * along, 0.0))


class NavigationTelemetry:
    """NAV_CONTROLLER_OUTPUT and POSITION_TARGET_GLOBAL_INT of one vehicle."""

    def __init__(self, ap, clock) -> None:
        self.ap = ap
        self.clock = clock

    def _destination(self):
        """The setpoint's position (world NED) when it has a horizontal one, else None."""
        sp = self.ap.fleet.setpoint(self.ap.i)
        if sp.pos is None:
            return None
        p = [float(v) for v in sp.pos]
        return p if _finite(p[0], p[1]) else None

    def _to_destination(self, dest) -> tuple[float, float]:
        """(bearing deg, horizontal distance m) from the estimate to dest (0, 0 without one)."""
        if dest is None:
            return 0.0, 0.0
        pn, pe = float(self.ap.pos[0]), float(self.ap.pos[1])
        dn, de = dest[0] - pn, dest[1] - pe
        return bearing_deg(dn, de), math.hypot(dn, de)

    def nav_controller_output_fields(self) -> tuple | None:
        ap = self.ap
        dest = self._destination()
        bearing, dist = self._to_destination(dest)
        wp_dist = int(min(dist, 65535.0))              # ArduPilot's float -> uint16 truncates
        if ap.kind == "rover":
            if not ap.flightmode.is_autopilot():
                return None
            v_cmd, speed, _ = ap.fleet.drive_outputs(ap.i)
            nav_bearing = bearing if dest is not None else math.degrees(ap.yaw) % 360.0
            return (0.0, 0.0, int(nav_bearing), int(bearing), wp_dist, 0.0, v_cmd - speed, 0.0)
        c = ap.fleet.controller_of(ap.i)
        pn, pe, pd = (float(v) for v in ap.pos)
        xtrack = crosstrack(pn, pe, c.px, c.py, c.vx, c.vy) if dest is not None else 0.0
        yaw = math.degrees(math.atan2(math.sin(c.yaw), math.cos(c.yaw)))
        return (math.degrees(math.atan(c.tan_roll_t)), math.degrees(math.atan(c.tan_pitch_t)),
                int(yaw), int(bearing), wp_dist, pd - c.pz, 0.0, xtrack)

    def position_target_global_int_fields(self) -> tuple | None:
        ap = self.ap
        if not ap.flightmode.is_autopilot():
            return None
        sp = ap.fleet.setpoint(ap.i)
        if sp.pos is None:
            return None
        n, e, d = (float(v) for v in sp.pos)
        if not _finite(n, e):
            return None
        if not math.isfinite(d):                # a rover's setpoint: its own height
            if ap.kind != "rover":
                return None
            d = float(ap.pos[2])
        lat, lon, alt = ap.lla((n, e, d))
        return (boot_ms(self.clock()), mav.MAV_FRAME_GLOBAL, POSITION_ONLY, e7(lat), e7(lon), alt,
                0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
