"""The estimator's health as ArduPilot's EKF3 reports it: EKF_STATUS_REPORT, AHRS and AHRS2.

Variances (EKF_STATUS_REPORT) are ArduPilot's test ratios, sqrt(innovation^2 / (gate^2 x
innovation variance)), from the estimator's last fusions (vehicle/innovations.py) with the
gates EK3_VEL_I_GATE, EK3_POS_I_GATE, EK3_HGT_I_GATE (percent of a standard deviation,
default 500 = 5 sigma): below 1 the measurement passed the gate, and GCSs colour them from
0.5. The compass variance is the AHRS model's yaw error over EK3_MAG_I_GATE (300) times its
standard deviation (no magnetometer is fused: the attitude estimate is truth turned by a
modelled AHRS error, vehicle/estimation.py). No rangefinder and no airspeed sensor: 0.

Flags follow EKF3's filter status from how long GPS has not been fused (AP_NavEKF3 constants):
- before the estimator is aligned on GPS (vehicle's position estimate not OK yet) the filter
  does not aid: attitude, vertical velocity and position, CONST_POS_MODE;
- aligned, GPS fused within 7 s (posRetryTimeNoVel_ms): attitude, horizontal and vertical
  velocity, relative and absolute horizontal position, vertical position, and the predicted
  positions (831 = 0x33F);
- 7 s without GPS: position and velocity timed out, only attitude and the vertical estimate;
- 15 s (tiltDriftTimeMax_ms): aiding stops (the estimator's vehicle.no_aiding, EKF3's
  AID_NONE): CONST_POS_MODE with attitude and the vertical estimate; the velocity ratio is
  reset to 0 and stays there (no velocity is fused), the position ratio is the synthetic
  last-known-position fusion's, as EKF3 reports them;
- the filter is unhealthy (attitude and every estimate flag clear) when all three ratios
  exceed 1;
- GPS_GLITCHING while the horizontal position ratio exceeds 1 (the GPS position fails the
  gate; towerlink's filter fuses it all the same, EKF3 would reject it).
Before the first filter epoch the flags are EKF_UNINITIALIZED only.
A vehicle flying on truth (no estimator) reports the healthy GPS flags and zero ratios.

AHRS: no gyro drift is estimated (omegaI 0); error_rp / error_yaw are the AHRS model's
current roll-pitch and yaw errors (rad). AHRS2 (ArduPilot: the DCM backup) carries the one
estimate towerlink has: its attitude and position.
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.innovations import POS_TIMEOUT_S
from vehicle.telemetry.wire import e7

GPS_PRESENT_S = 1.0           # GPS still arriving (EKF3's gpsNotAvailable clear)

ATTITUDE, VEL_HORIZ, VEL_VERT = mav.EKF_ATTITUDE, mav.EKF_VELOCITY_HORIZ, mav.EKF_VELOCITY_VERT
POS_REL, POS_ABS, POS_VERT = mav.EKF_POS_HORIZ_REL, mav.EKF_POS_HORIZ_ABS, mav.EKF_POS_VERT_ABS
CONST_POS, PRED_REL, PRED_ABS = mav.EKF_CONST_POS_MODE, mav.EKF_PRED_POS_HORIZ_REL, mav.EKF_PRED_POS_HORIZ_ABS
UNINITIALIZED = mav.EKF_UNINITIALIZED
GPS_GLITCHING = mav.EKF_GPS_GLITCHING
HEALTHY_GPS = ATTITUDE | VEL_HORIZ | VEL_VERT | POS_REL | POS_ABS | POS_VERT | PRED_REL | PRED_ABS


def ekf_flags(aligned: bool, gps_age: float, healthy: bool, no_aiding: bool = False) -> int:
    """EKF_STATUS_REPORT.flags of an initialised filter: `aligned` its position estimate was
    good at the last GPS fusion, `gps_age` s since then (inf: never), `healthy` not all test
    ratios over 1, `no_aiding` the filter has stopped aiding (vehicle.no_aiding)."""
    if not healthy:
        return 0
    aiding = aligned and not no_aiding
    flags = ATTITUDE | VEL_VERT | POS_VERT
    if aiding and gps_age <= POS_TIMEOUT_S:
        flags |= VEL_HORIZ | POS_REL | POS_ABS | PRED_REL | PRED_ABS
    elif aligned and gps_age <= GPS_PRESENT_S:
        flags |= PRED_REL | PRED_ABS       # GPS good and arriving: position expected
    if not aiding:
        flags |= CONST_POS
    return flags


def test_ratio(nis: float, gate_pct: float) -> float:
    """sqrt of ArduPilot's test ratio: normalised innovation square over the gate squared."""
    gate = max(0.01 * gate_pct, 1.0)
    return math.sqrt(max(nis, 0.0)) / gate


class EkfTelemetry:
    """EKF_STATUS_REPORT, AHRS and AHRS2 of one vehicle (`ap`: its autopilot)."""

    def __init__(self, ap) -> None:
        self.ap = ap

    def _estimator(self):
        fleet = self.ap.fleet
        return fleet.estimator if fleet.use_estimator else None

    def status(self) -> tuple[int, float, float, float, float]:
        """(flags, velocity, horizontal position, height, compass variance)."""
        ap, est = self.ap, self._estimator()
        if est is None:
            return HEALTHY_GPS, 0.0, 0.0, 0.0, 0.0
        if est.kfs is None:                                  # no filter epoch yet
            return UNINITIALIZED, 0.0, 0.0, 0.0, 0.0
        i, log, p = ap.i, est.innovations, ap.params
        step = int(log.gps_step[i])
        gps_age = math.inf if step < 0 else (est.k - 1 - step) * est.dt
        vel = test_ratio(float(log.vel[i]), p.get("EK3_VEL_I_GATE", 500))
        pos = test_ratio(float(log.pos[i]), p.get("EK3_POS_I_GATE", 500))
        hgt = test_ratio(float(log.hgt[i]), p.get("EK3_HGT_I_GATE", 500))
        yaw_err = abs(est.part("ahrs_err", i)[2])
        mag = yaw_err / (max(0.01 * p.get("EK3_MAG_I_GATE", 300), 1.0) * est.spec.ahrs_sigma)
        aligned = bool(est.ok[i])
        flags = ekf_flags(aligned, gps_age, not (vel > 1 and pos > 1 and hgt > 1), est.no_aiding.active[i])
        if flags & POS_ABS and pos > 1.0:
            flags |= GPS_GLITCHING              # the GPS position fails its innovation gate
        return flags, vel, pos, hgt, mag

    def ekf_status_report_fields(self) -> tuple:
        flags, vel, pos, hgt, mag = self.status()
        return (flags, vel, pos, hgt, mag, 0.0, 0.0)

    def ahrs_fields(self) -> tuple:
        est = self._estimator()
        if est is None or est.kfs is None:
            return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        ex, ey, ez = est.part("ahrs_err", self.ap.i)
        return (0.0, 0.0, 0.0, 0.0, 0.0, math.hypot(ex, ey), abs(ez))

    def ahrs2_fields(self) -> tuple:
        ap = self.ap
        roll, pitch, yaw = ap.euler
        lat, lon, alt = ap.lla()
        return (roll, pitch, yaw, alt, e7(lat), e7(lon))
