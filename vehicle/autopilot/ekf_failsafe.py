"""The EKF failsafe and the GPS glitch check of one autopilot (ArduCopter/ekf_check.cpp and
events.cpp gpsglitch_check; Rover/ekf_check.cpp), run at 10 Hz from the estimator's own
health as EKF_STATUS_REPORT shows it (vehicle/telemetry/ekf_status.py: the test ratios it
calls variances, and the filter flags).

Copter (CopterEkfCheck):
- skipped until the EKF origin is set; FS_EKF_THRESH <= 0 disables it (and clears a failsafe);
- the threshold is FS_EKF_THRESH x a slew ratio: 0.5 on the ground, growing to 1 over 10 s
  or 10 m of climb after take-off;
- over threshold (ekf_over_threshold): compass variance >= thresh counts 1; velocity >= 2 x
  thresh counts 2, else >= thresh counts 1; over if position >= thresh with a count of 1, or
  a count of 2; the check also fails without a relative or absolute position (flags);
- it starts counting once it has passed; each failing 10 Hz tick counts up, each passing one
  down; at 10 (1 s): CRITICAL "EKF variance" (at most every 30 s) and the event: nothing
  when disarmed or in a mode that needs no position (unless FS_EKF_ACTION 3); FS_EKF_ACTION
  2 ALT_HOLD (LAND if that fails), else LAND (with the failsafe pause), then CRITICAL "EKF Failsafe: changed to <MODE>
  Mode"; back at 0: CRITICAL "EKF Failsafe Cleared" if an action was taken.
- GPS glitch: the filter's GPS position innovation fails its gate (EKF_STATUS_REPORT's
  EKF_GPS_GLITCHING): CRITICAL "GPS Glitch", then "GPS Glitch cleared" once it has passed for
  GLITCH_CLEAR_S.
Rover (RoverEkfCheck): armed only; over threshold as the copter's (ArduRover counts the
velocity variance in both of its tests, and so does this) or without a good position (armed:
relative or absolute, not constant-position mode); FS_EKF_ACTION 0 nothing, 1 HOLD, 2 report:
CRITICAL "EKF failsafe", and "EKF failsafe cleared".
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.telemetry.ekf_status import CONST_POS, GPS_GLITCHING, POS_ABS, POS_REL, EkfTelemetry

PERIOD = 0.1                 # s: ArduPilot runs ekf_check and gpsglitch_check at 10 Hz
ITERATIONS_MAX = 10          # EKF_CHECK_ITERATIONS_MAX: 1 s of failing checks
WARNING_TIME = 30.0          # s between "EKF variance" texts
SLEW_TIME, SLEW_ALT, SLEW_MIN = 10.0, 10.0, 0.5   # the copter's threshold slew after take-off
CRITICAL = mav.MAV_SEVERITY_CRITICAL
GLITCH_CLEAR_S = 1.0         # s of passing GPS fixes before "GPS Glitch cleared" (see _glitch)


def copter_over_threshold(vel: float, pos: float, mag: float, thresh: float) -> bool:
    """ArduCopter's ekf_over_threshold on the variances (test ratios)."""
    count = 1 if mag >= thresh else 0
    if vel >= 2.0 * thresh:
        count += 2
    elif vel >= thresh:
        count += 1
    return (pos >= thresh and count >= 1) or count >= 2


def rover_over_threshold(vel: float, pos: float, mag: float, thresh: float) -> bool:
    """ArduRover's ekf_over_threshold on the variances (position aside)."""
    count = (mag >= thresh) + (vel >= thresh) + (pos >= thresh)
    if vel >= 2.0 * thresh:
        count += 2
    elif vel >= thresh:
        count += 1
    return count >= 2


class EkfCheck:
    """The 10 Hz counter both vehicles share; subclasses say what fails and what to do (this
    class alone checks nothing)."""

    def __init__(self, ap) -> None:
        self.ap = ap
        self.health = EkfTelemetry(ap)
        self.fail_count = 0
        self.bad_variance = False
        self.has_ever_passed = False
        self.failsafe = False            # ArduPilot's failsafe.ekf
        self.last_warn = -math.inf
        self._due = 0.0

    def update(self, t: float, dt: float) -> None:
        """Every autopilot tick; checks at 10 Hz."""
        self._due += dt
        if self._due < PERIOD - 1e-9 and dt > 0:
            return
        self._due = 0.0
        self.check(t)

    def check(self, t: float) -> None:
        """One 10 Hz check at sim time t."""

    def count(self, t: float, failing: bool) -> None:
        """One tick of the counter: up while failing (the failsafe at ITERATIONS_MAX), down
        while passing (cleared at 0)."""
        if failing:
            if not self.bad_variance:
                self.fail_count += 1
                if self.fail_count >= ITERATIONS_MAX:
                    self.fail_count = ITERATIONS_MAX
                    self.bad_variance = True
                    if t - self.last_warn > WARNING_TIME:
                        self.ap.text(CRITICAL, "EKF variance")
                        self.last_warn = t
                    self.event()
        elif self.fail_count > 0:
            self.fail_count -= 1
            if self.bad_variance and self.fail_count == 0:
                self.bad_variance = False
                self.off_event()

    def reset(self) -> None:
        self.fail_count = 0
        self.bad_variance = False
        self.off_event()

    def thresh(self) -> float:
        return float(self.ap.params.get("FS_EKF_THRESH", 0.8))

    def event(self) -> None:
        """The failsafe triggers."""

    def off_event(self) -> None:
        """The failsafe clears."""


class CopterEkfCheck(EkfCheck):
    """ArduCopter's ekf_check, failsafe_ekf_event / _off_event and gpsglitch_check."""

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.action_taken = False        # AP_Notify::flags.failsafe_ekf
        self.slew = 1.0
        self.takeoff_t = 0.0
        self.takeoff_alt = 0.0
        self.glitching = False
        self._clear_ticks = 0

    def check(self, t: float) -> None:
        ap = self.ap
        if not ap.local_origin.is_set:
            return
        flags, vel, pos, _hgt, mag = self.health.status()
        self._glitch(bool(flags & GPS_GLITCHING))
        thresh = self.thresh()
        if thresh <= 0:
            self.reset()
            return
        alt = -float(ap.pos[2])
        if ap.on_ground:
            self.slew, self.takeoff_t, self.takeoff_alt = SLEW_MIN, t, alt
        elif self.slew < 1.0:
            self.slew = min(1.0, max(SLEW_MIN, self.slew, (t - self.takeoff_t) / SLEW_TIME,
                                     (alt - self.takeoff_alt) / SLEW_ALT))
        over = copter_over_threshold(vel, pos, mag, thresh * self.slew)
        passed = not over and bool(flags & (POS_REL | POS_ABS))
        self.has_ever_passed |= passed
        if self.has_ever_passed:
            self.count(t, not passed)

    def _glitch(self, glitching: bool) -> None:
        """The glitch starts with the first failing fix and clears after GLITCH_CLEAR_S of
        passing ones (EKF3 rejects the GPS for seconds, so its flag does not chatter; the
        ratios of towerlink's filter, which fuses every fix, hover about 1 as it follows a
        step)."""
        if glitching:
            self._clear_ticks = 0
            if not self.glitching:
                self.glitching = True
                self.ap.text(CRITICAL, "GPS Glitch")
        elif self.glitching:
            self._clear_ticks += 1
            if self._clear_ticks * PERIOD >= GLITCH_CLEAR_S - 1e-9:
                self.glitching = False
                self.ap.text(CRITICAL, "GPS Glitch cleared")

    def event(self) -> None:
        ap = self.ap
        if self.failsafe:
            return
        self.failsafe = True
        if not ap.armed:
            return
        if ap.flightmode is ap.flightmodes.get(modes.LAND):    # landing goes on without GPS
            return
        action = int(ap.params.get("FS_EKF_ACTION", 1))
        if not ap.flightmode.requires_position() and action != 3:
            return
        why = "EKF failsafe"
        if action == 2:
            # (ArduCopter lands instead while its radio failsafe is on)
            if ap.radio.active or not ap.set_mode(modes.ALT_HOLD, why):
                ap.failsafe.land_with_pause(why)
        else:
            ap.failsafe.land_with_pause(why)
        self.action_taken = True
        ap.text(CRITICAL, f"EKF Failsafe: changed to {ap.mode_name} Mode")

    def off_event(self) -> None:
        if not self.failsafe:
            return
        self.failsafe = False
        if self.action_taken:
            self.action_taken = False
            self.ap.text(CRITICAL, "EKF Failsafe Cleared")


class RoverEkfCheck(EkfCheck):
    """ArduRover's ekf_check and failsafe_ekf_event / _off_event."""

    def check(self, t: float) -> None:
        ap = self.ap
        if not ap.local_origin.is_set:
            return
        thresh = self.thresh()
        if not ap.armed or thresh <= 0:
            self.reset()
            return
        flags, vel, pos, _hgt, mag = self.health.status()
        position_ok = bool(flags & (POS_REL | POS_ABS)) and not flags & CONST_POS
        over = rover_over_threshold(vel, pos, mag, thresh) or not position_ok
        self.has_ever_passed |= not over
        if self.has_ever_passed:
            self.count(t, over)

    def event(self) -> None:
        ap = self.ap
        if self.failsafe:
            return
        self.failsafe = True
        if not ap.flightmode.requires_position():
            return
        action = int(ap.params.get("FS_EKF_ACTION", 1))
        if action == 0:
            return
        if action == 1:
            ap.set_mode(modes.ROVER_HOLD, "EKF failsafe")
        ap.text(CRITICAL, "EKF failsafe")

    def off_event(self) -> None:
        if not self.failsafe:
            return
        self.failsafe = False
        self.ap.text(CRITICAL, "EKF failsafe cleared")
