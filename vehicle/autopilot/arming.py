"""Arming, disarming and the pre-arm checks of one autopilot (ArduPilot's AP_Arming, its
vehicle subclasses' arm()/disarm()).

Pre-arm (ARMING_CHECK 0 skips them): "GPS 1: Bad fix" (no 3D fix: vehicle/sim_faults.py),
"Need Position Estimate", "Waiting for home" (never
long: home follows the first good estimate), "Mode not armable" (the mode's allows_arming),
"Mode requires mission" (AUTO with no mission: a disarmed copter may select it) and the
fence's (fence.py). Each failure is said as "PreArm: <why>" (CRITICAL) and the
request FAILS. Arming takes home here if there is none yet and the hold point where the
vehicle stands. Disarming drops GUIDED's target and AUTO's auto-armed state; ArduCopter resets
the mission on every disarm, ArduRover outside AUTO (auto.py). The copter's differences are
CopterArming's (copter_arming.py).
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.mode import ArmingMethod

ACCEPTED, FAILED = mav.MAV_RESULT_ACCEPTED, mav.MAV_RESULT_FAILED


class Arming:
    """Arming of autopilot `ap` (a rover's as it is: it may disarm while moving)."""

    disarm_refused = "Disarm: moving"

    def __init__(self, ap) -> None:
        self.ap = ap

    def prearm_failures(self) -> list[str]:
        """Why the vehicle may not arm now ([] when it may)."""
        ap = self.ap
        if ap.params.get("ARMING_CHECK", 1) == 0:
            return []
        out = []
        if not ap.fleet.faults_of(ap.i).gps_fix:
            out.append("GPS 1: Bad fix")            # AP_Arming::gps_checks (SIM_GPS1_ENABLE 0)
        if not ap.est_ok:
            out.append("Need Position Estimate")
        elif ap.home is None:
            out.append("Waiting for home")
        if not ap.flightmode.allows_arming(ArmingMethod.MAVLINK):
            out.append("Mode not armable")
        if ap.flightmode.requires_mission() and not ap.auto.mission.runner.present():
            out.append("Mode requires mission")
        why = ap.fence.prearm_failure()
        if why:
            out.append(why)
        return out

    def arm(self, force: bool = False) -> int:
        """MAV_RESULT of an arming request (force: skip the pre-arm checks)."""
        ap = self.ap
        if ap.armed:
            return ACCEPTED
        ap.refresh()
        if not force:
            fails = self.prearm_failures()
            if fails:
                for f in fails:
                    ap.text(mav.MAV_SEVERITY_CRITICAL, f"PreArm: {f}")
                return FAILED
            why = self.arm_check_failure()
            if why:
                ap.text(mav.MAV_SEVERITY_CRITICAL, f"Arm: {why}")
                return FAILED
        if ap.home is None:
            ap.home = ap.pos.copy()
        ap.armed = True
        ap.arm_time = ap.t
        ap.fleet.set_armed(ap.i, True)
        ap.hold_here()
        self.on_armed()
        ap.outbox.arming(True, force, "")
        ap.text(mav.MAV_SEVERITY_INFO, "Arming motors")
        return ACCEPTED

    def disarm(self, force: bool = False, reason: str = "") -> int:
        """MAV_RESULT of a disarm request (force: even in flight)."""
        ap = self.ap
        if not ap.armed:
            return ACCEPTED
        ap.refresh()
        if not force and not self.may_disarm():
            ap.text(mav.MAV_SEVERITY_CRITICAL, self.disarm_refused)
            return FAILED
        ap.armed = False
        ap.fleet.set_armed(ap.i, False)
        ap.guided.targets.clear()
        ap.auto.mission.on_disarmed(ap.flightmode is ap.auto)
        ap.auto_armed = False
        self.on_disarmed()
        ap.outbox.arming(False, force, reason)
        ap.text(mav.MAV_SEVERITY_INFO, f"Disarming motors{': ' + reason if reason else ''}")
        return ACCEPTED

    # ----- what a vehicle adds ------------------------------------------------------------
    def arm_check_failure(self) -> str:
        """The first of the vehicle's arm checks (AP_Arming::arm_checks, after the pre-arm
        ones; said as "Arm: <why>") that fails now, '' when none does."""
        return ""

    def may_disarm(self) -> bool:
        """May it disarm unforced now?"""
        return True

    def on_armed(self) -> None:
        """Just armed."""

    def on_disarmed(self) -> None:
        """Just disarmed."""
