"""What a vehicle's onboard log records of its state, at ArduPilot-like rates.

ArduCopter writes ATT, CTUN, RCIN, RCOU and the EKF position (POS) in its 10 Hz logging
loop (ArduCopter/Copter.cpp ten_hz_logging_loop, default LOG_BITMASK: ATTITUDE_MED), BAT
when the battery monitor is read (10 Hz), GPS per receiver update; towerlink writes all of
them at 10 Hz (its GPS model runs at 10 Hz), and XKF1 (the EKF3 output) at the same rate.
A Rover log has THR in place of CTUN. Each vehicle's samples fall on its own tick of the
five 50 Hz ticks in a 10 Hz period (its index), so a big world spreads the work.

Which state is which (as ArduPilot's): ATT, POS, CTUN.Alt and XKF1 are the estimate
(vehicle/estimation.py: what the autopilot believes), GPS is the noisy receiver sample
the estimator fuses, ATT's DesRoll / DesPitch / DesYaw the controller's attitude target
(what NAV_CONTROLLER_OUTPUT says), CTUN's DAlt / DCRt its position target and ThO its
collective, BAT the battery monitor. RCOU and RCIN are what SERVO_OUTPUT_RAW and
RC_CHANNELS say (vehicle/telemetry/outputs.py: the motors' PWM; the simulated receiver's
channels and the GCS's overrides). Angles are degrees, yaw 0..360.

Not simulated, logged as ArduPilot logs an absent input: CTUN.ThI / ABst 0, no rangefinder
(DSAlt / SAlt / TAlt 0), ATT.ErrRP / ErrYaw 0, XKF1's gyro bias 0; a rover's ATT.Des* are
its attitude (ArduRover has no attitude target to log).
"""
from __future__ import annotations

import math
from collections.abc import Callable

from common import geo
from vehicle.logs.dataflash import Schema
from vehicle.telemetry.outputs import OutputsTelemetry

LOG_RATE = 10.0             # Hz: ATT, POS, CTUN / THR, XKF1, GPS, BAT, RCIN, RCOU
R2D = 180.0 / math.pi
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
    estimate, home, EKF origin, battery, parameters, and its fleet's `controller_of` /
    `drive_outputs` / `gps_fix` for vehicle `ap.i`).

    A sample's records are packed by one generated function (dataflash.run_packer) from the
    floats the autopilot already holds: no per-record call, no numpy arithmetic. Integer
    fields take the raw values (RC pulses, servo outputs): packing rounds and clamps them
    exactly as the telemetry's wire_clamp does, so the bytes are the same."""

    def __init__(self, kind: str, schema: Schema, clock: Callable[[], float], phase: int = 0,
                 ap_rate: float = 50.0) -> None:
        self.kind = kind
        self.clock = clock
        self.every = max(1, round(ap_rate / LOG_RATE))
        self.phase = phase % self.every
        self.ap_rate = ap_rate
        rows = ("ATT", "CTUN" if kind == "copter" else "THR", "RCOU", "RCIN", "POS", "XKF1")
        # (GPS fix, battery monitor) -> the records of a sample with or without them
        self._packers = {(g, b): schema.packer(*rows, *(("GPS",) if g else ()), *(("BAT",) if b else ()))
                         for g in (False, True) for b in (False, True)}
        self._outputs: OutputsTelemetry | None = None
        self._origin: tuple = (None, None, (0.0, 0.0, 0.0))   # (EkfOrigin, its lla, its offset as floats)

    def due(self, t: float) -> bool:
        """True when the autopilot tick at sim time t is one this vehicle logs on (the
        world's tick count, so samples fall on the same instants whenever a log opened)."""
        return round(t * self.ap_rate) % self.every == self.phase

    def _offset(self, lo, lla) -> tuple[float, float, float]:
        """The EKF origin's world NED offset as floats (read once per origin)."""
        o = self._origin
        if o[0] is not lo or o[1] is not lla:
            o = self._origin = (lo, lla, tuple(lo.offset.tolist()))
        return o[2]

    def sample(self, ap, time_us: int, unix_us: int) -> bytes:
        """The records of one 10 Hz sample of vehicle `ap` at `time_us` (since boot)."""
        roll, pitch, yaw = ap.euler
        lat, lon, alt = ap.lla()
        vn, ve, vd = ap.vel.tolist()
        origin = ap.ekf_origin()
        if origin is not None:
            ox, oy, oz = self._offset(ap.local_origin, origin)
            px, py, pz = ap.pos.tolist()
            pn, pe, pd = px - ox, py - oy, pz - oz           # local_origin.to_local, in floats
            oalt = origin[2]
        else:
            pn = pe = pd = 0.0
            oalt = alt
        p = ap.params.values
        roll_d, pitch_d, yaw_d = roll * R2D, pitch * R2D, (yaw * R2D) % 360.0
        if self.kind == "copter":
            tune = self._copter(ap, p, time_us, alt, oalt, vd, roll_d, pitch_d, yaw_d)
        else:
            tune = self._rover(ap, time_us, roll_d, pitch_d, yaw_d)
        outputs = self._outputs
        if outputs is None or outputs.ap is not ap:
            outputs = self._outputs = OutputsTelemetry(ap, self.clock)
        rows = (*tune, time_us, *outputs.servo_outputs()[:14], time_us, *ap.rc.channels(14),
                time_us, lat, lon, alt, alt - ap.home_lla()[2], alt - oalt,
                time_us, 0, roll_d, pitch_d, yaw_d, vn, ve, vd, vd, pn, pe, pd, 0.0, 0.0, 0.0, oalt)
        fix = ap.fleet.gps_fix(ap.i)
        if fix is not None:
            glat, glon, galt = geo.ned_to_lla(ap.origin, fix[0:3])
            gvn, gve, gvd = fix[3:6]
            week, week_ms = gps_time(unix_us)
            spd = math.hypot(gvn, gve)
            rows += (time_us, 0, GPS_FIX_3D, week_ms, week, 10, 1.21, glat, glon, galt, spd,
                     _deg360(math.atan2(gve, gvn)) if spd > 0.2 else 0.0, gvd, 0.0, 1)
        bat = bool(p.get("BATT_MONITOR", 4))
        if bat:
            b = ap.battery
            rows += (time_us, 0, b.voltage, b.resting_voltage, b.current, b.consumed_mah, b.consumed_wh, 0.0, 0.0)
        return self._packers[fix is not None, bat](*rows)

    def _copter(self, ap, p, time_us, alt, oalt, vd, roll_d, pitch_d, yaw_d) -> tuple:
        """ATT's values with the attitude target, then CTUN's with the position target
        (altitudes above the EKF origin in m, climb rates up in cm/s) and the collective."""
        c = ap.fleet.controller_of(ap.i)
        des_yaw = math.atan2(math.sin(c.yaw), math.cos(c.yaw))
        return (time_us, math.atan(c.tan_roll_t) * R2D, roll_d, math.atan(c.tan_pitch_t) * R2D, pitch_d,
                _deg360(des_yaw), yaw_d, 0, 0, AEKF_EKF3,
                time_us, 0.0, 0.0, c.coll, p.get("MOT_THST_HOVER", 0.45), ap.origin[2] - c.pz - oalt,
                alt - oalt, alt - oalt, 0.0, 0.0, 0.0, -c.vz * 100.0, -vd * 100.0)

    def _rover(self, ap, time_us, roll_d, pitch_d, yaw_d) -> tuple:
        """ATT's values (no attitude target: the attitude), then THR's: the speed command
        against the speed, throttle as the command's share of the top speed (%), lateral
        acceleration."""
        v_cmd, speed, rate = ap.fleet.drive_outputs(ap.i)
        top = ap.fleet.gains_of(ap.i).max_speed or 1.0
        return (time_us, roll_d, roll_d, pitch_d, pitch_d, yaw_d, yaw_d, 0, 0, AEKF_EKF3,
                time_us, 0, max(-100.0, min(100.0, 100.0 * v_cmd / top)), v_cmd, speed, speed * rate)
