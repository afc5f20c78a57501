"""What a vehicle's onboard log records of its state, at ArduPilot-like rates.

ArduCopter writes ATT, CTUN, RCIN, RCOU and the EKF position (POS) in its 10 Hz logging
loop (ArduCopter/Copter.cpp ten_hz_logging_loop, default LOG_BITMASK: ATTITUDE_MED), BAT
when the battery monitor is read (10 Hz), GPS per receiver update; towerlink writes all of
them at 10 Hz (its GPS model runs at 10 Hz), and XKF1 (the EKF3 output) at the same rate.
A Rover log has THR in place of CTUN. Each vehicle's samples fall on its own tick of the
five 50 Hz ticks in a 10 Hz period (its index), so a big world spreads the work.

Which state is which (as ArduPilot's): ATT, POS, CTUN.Alt and XKF1 are the estimate
(vehicle/estimation.py: what the autopilot believes), GPS is the noisy receiver sample
the estimator fuses, ATT's Des* and CTUN's DAlt / DCRt / ThO the controller's reference
and output, BAT the battery monitor. Angles are degrees, yaw 0..360.

Not simulated, logged as ArduPilot logs an absent input: RCIN all 0 (no RC receiver),
CTUN.ThI / ABst 0, no rangefinder (DSAlt / SAlt / TAlt 0), ATT.ErrRP / ErrYaw 0, XKF1's
gyro bias 0. RCOU: a copter's motors 1..4 as PWM between MOT_PWM_MIN and MOT_PWM_MAX from
their rotor speed; a rover's steering (1) and throttle (3) around 1500.
"""
from __future__ import annotations

import math

from common import geo
from vehicle.logs.dataflash import Schema

LOG_RATE = 10.0             # Hz: ATT, POS, CTUN / THR, XKF1, GPS, BAT, RCIN, RCOU
R2D = 180.0 / math.pi
G = 9.80665
AEKF_EKF3 = 3               # ATT.AEKF: the active estimator is EKF3
GPS_FIX_3D = 3              # AP_GPS::GPS_OK_FIX_3D
GPS_EPOCH_UNIX = 315964800  # 1980-01-06 00:00:00 UTC
GPS_LEAP_S = 18             # GPS time runs ahead of UTC by this many seconds
WEEK_MS = 7 * 86400 * 1000


def gps_time(unix_us: int) -> tuple[int, int]:
    """(GPS week, ms of week) of a unix time in microseconds (GPS.GWk / GPS.GMS)."""
    ms = (unix_us // 1000) - GPS_EPOCH_UNIX * 1000 + GPS_LEAP_S * 1000
    return int(ms // WEEK_MS), int(ms % WEEK_MS)


def _deg360(rad: float) -> float:
    return (rad * R2D) % 360.0


class Sampler:
    """Builds one vehicle's periodic records (`sample`) from its autopilot (`ap`: the
    estimate, home, EKF origin, battery, parameters, and its fleet's `control_row` /
    `gps_fix` for vehicle `ap.i`)."""

    def __init__(self, kind: str, schema: Schema, phase: int = 0, ap_rate: float = 50.0) -> None:
        self.kind = kind
        self.every = max(1, round(ap_rate / LOG_RATE))
        self.phase = phase % self.every
        self.ap_rate = ap_rate
        s = schema
        self.att, self.pos, self.xkf1, self.gps = s["ATT"].pack, s["POS"].pack, s["XKF1"].pack, s["GPS"].pack
        self.bat, self.rcin, self.rcou = s["BAT"].pack, s["RCIN"].pack, s["RCOU"].pack
        self.tune = s["CTUN"].pack if kind == "copter" else s["THR"].pack

    def due(self, t: float) -> bool:
        """True when the autopilot tick at sim time t is one this vehicle logs on (the
        world's tick count, so samples fall on the same instants whenever a log opened)."""
        return round(t * self.ap_rate) % self.every == self.phase

    def sample(self, ap, time_us: int, unix_us: int) -> bytes:
        """The records of one 10 Hz sample of vehicle `ap` at `time_us` (since boot)."""
        roll, pitch, yaw = ap.euler
        lat, lon, alt = ap.lla()
        vn, ve, vd = ap.vel.tolist()
        home_alt = ap.home_lla()[2]
        origin = ap.ekf_origin()
        if origin is not None:
            pn, pe, pd = ap.local_origin.to_local(ap.pos).tolist()
            oalt = origin[2]
        else:
            pn = pe = pd = 0.0
            oalt = alt
        p = ap.params.values
        row = ap.fleet.control_row(ap.i)
        out = []
        if self.kind == "copter":
            dr, dp, dy = self._desired(row, yaw)
            out.append(self.att(time_us, dr, roll * R2D, dp, pitch * R2D, dy, _deg360(yaw), 0, 0, AEKF_EKF3))
            # altitudes above the EKF origin (m), climb rates up (cm/s)
            out.append(self.tune(time_us, 0.0, 0.0, row[6], p.get("MOT_THST_HOVER", 0.45),
                                 ap.origin[2] - row[0] - oalt, alt - oalt, alt - oalt, 0.0, 0.0, 0.0,
                                 -row[1] * 100.0, -vd * 100.0))
            lo, hi = p.get("MOT_PWM_MIN", 1000), p.get("MOT_PWM_MAX", 2000)
            span = hi - lo
            if ap.armed:
                out.append(self.rcou(time_us, lo + span * row[7], lo + span * row[8], lo + span * row[9],
                                     lo + span * row[10], 0, 0, 0, 0, 0, 0, 0, 0, 0, 0))
            else:
                out.append(self.rcou(time_us, lo, lo, lo, lo, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0))
        else:
            v_cmd, speed, rate = row
            out.append(self.att(time_us, roll * R2D, roll * R2D, pitch * R2D, pitch * R2D,
                                _deg360(yaw), _deg360(yaw), 0, 0, AEKF_EKF3))
            vmax = p.get("SIM_RVR_MAX_SPD", 0) or p.get("CRUISE_SPEED", 8) or 1.0
            rmax = (p.get("ATC_STR_RAT_MAX", 120) or 120) / R2D
            thr = max(-1.0, min(1.0, v_cmd / vmax))
            out.append(self.tune(time_us, 0, thr * 100.0, v_cmd, speed, speed * rate))
            out.append(self.rcou(time_us, 1500 + 500 * max(-1.0, min(1.0, rate / rmax)), 0,
                                 1500 + 500 * thr, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0))
        out.append(self.rcin(time_us, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0))
        out.append(self.pos(time_us, lat, lon, alt, alt - home_alt, alt - oalt))
        out.append(self.xkf1(time_us, 0, roll * R2D, pitch * R2D, _deg360(yaw), vn, ve, vd, vd,
                             pn, pe, pd, 0.0, 0.0, 0.0, oalt))
        fix = ap.fleet.gps_fix(ap.i)
        if fix is not None:
            glat, glon, galt = geo.ned_to_lla(ap.origin, fix[0:3])
            gvn, gve, gvd = fix[3:6]
            week, week_ms = gps_time(unix_us)
            spd = math.hypot(gvn, gve)
            out.append(self.gps(time_us, 0, GPS_FIX_3D, week_ms, week, 10, 1.21, glat, glon, galt, spd,
                                _deg360(math.atan2(gve, gvn)) if spd > 0.2 else 0.0, gvd, 0.0, 1))
        b = ap.battery
        if p.get("BATT_MONITOR", 4):
            out.append(self.bat(time_us, 0, b.voltage, b.resting_voltage, b.current, b.consumed_mah,
                                b.consumed_wh, 0.0, 0.0))
        return b"".join(out)

    @staticmethod
    def _desired(row, yaw: float) -> tuple[float, float, float]:
        """(roll, pitch, yaw) in degrees the controller's reference acceleration asks for:
        lean into the horizontal acceleration in the heading frame, yaw its reference."""
        an, ae = row[2], row[3]
        c, s = math.cos(yaw), math.sin(yaw)
        fwd, right = c * an + s * ae, -s * an + c * ae
        return math.atan2(right, G) * R2D, -math.atan2(fwd, G) * R2D, _deg360(row[5])
