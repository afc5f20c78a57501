"""RTL (ArduCopter/mode_rtl.cpp ModeRTL): climb, return home or to a rally point, land.

Climbs to RTL_ALT above home (or stays higher), flies home or to the nearest rally point
(rally.py: RALLY_LIMIT_KM, RALLY_INCL_HOME, inside an enabled fence), waits RTL_LOIT_TIME above
it, then lands and disarms; with RTL_ALT_FINAL > 0 it descends to that height and hovers.
AUTO's NAV_RETURN_TO_LAUNCH flies this same object (start(), fly(); its landing does not
disarm: the mission decides), as ArduCopter's ModeAuto uses mode_rtl.
"""
from __future__ import annotations

import numpy as np

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.mission_store import RALLY
from vehicle.autopilot.rally import best_return, rally_points

ARRIVED_M = 0.5          # m horizontally from the destination, and
STILL_M_S = 0.3          # below this speed: arrived
CLIMBED_M = 0.5          # m from RTL's altitude: the climb is done


class ModeRTL(CopterMode):
    number = modes.RTL
    position_required, arming_allowed, autopilot_mode = True, False, True
    disarm_on_land = True
    reports_guided_enabled = True

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.stage = ""                  # climb, return, loiter, final, land
        self.dest = np.zeros(3)          # home or the rally point (world NED)
        self.z = 0.0                     # world z of the return
        self.loiter_t0 = 0.0

    def is_landing(self) -> bool:
        return self.stage == "land"

    def enter(self) -> None:
        self.start()

    # ----- what AUTO's NAV_RETURN_TO_LAUNCH uses too ---------------------------------------
    def destination(self) -> np.ndarray:
        """Home, or the nearest usable rally point (AP_Rally)."""
        ap = self.ap
        home = ap.home if ap.home is not None else ap.start_ned
        pts = rally_points(ap.missions.items(RALLY), ap.origin, float(home[2]))
        fence = ap.fence if ap.fence.active() else None
        dest, _ = best_return(ap.pos, home, pts, float(ap.params.get("RALLY_LIMIT_KM", 0.3)),
                              int(ap.params.get("RALLY_INCL_HOME", 1)) == 1,
                              (lambda p: fence.destination_ok(p)) if fence else None)
        return dest

    def start(self) -> None:
        """Climb to RTL_ALT (or stay higher), then return to home / the rally point."""
        ap = self.ap
        ap.refresh()
        ap.hold_here()
        self.stage = "climb"
        self.dest = self.destination()
        rtl_alt = float(ap.params.get("RTL_ALT", 1500)) / 100.0
        home_z = ap.home[2] if ap.home is not None else 0.0
        self.z = min(ap.pos[2], home_z - rtl_alt)

    def complete(self) -> bool:
        """Landed at the end of the return."""
        return self.stage == "land" and self.ap.on_ground

    def fly(self, dt: float) -> None:
        ap = self.ap
        home = self.dest
        if self.stage == "climb":
            tgt = np.array([ap.hold_pos[0], ap.hold_pos[1], self.z])
            if abs(ap.pos[2] - self.z) < CLIMBED_M:
                self.stage = "return"
        if self.stage == "return":
            tgt = np.array([home[0], home[1], self.z])
            if np.linalg.norm(ap.pos[:2] - home[:2]) < ARRIVED_M and np.linalg.norm(ap.vel) < STILL_M_S:
                self.stage = "loiter"          # RTL_LOIT_TIME above home, then down
                self.loiter_t0 = ap.t
                ap.hold_pos = np.array([home[0], home[1], ap.pos[2]])
        if self.stage == "loiter":
            tgt = ap.hold_pos.copy()
            if ap.t - self.loiter_t0 >= float(ap.params.get("RTL_LOIT_TIME", 5000)) / 1000.0:
                final = float(ap.params.get("RTL_ALT_FINAL", 0)) / 100.0
                self.stage = "final" if final > 0 else "land"
        if self.stage == "final":              # RTL_ALT_FINAL > 0: hover there, stay in RTL
            home_z = ap.home[2] if ap.home is not None else home[2]
            tgt = np.array([home[0], home[1], home_z - float(ap.params.get("RTL_ALT_FINAL", 0)) / 100.0])
        if self.stage == "land":
            self.land_run(dt)
            return
        self.pilot.yaw(dt)                     # the yaw stick turns the returning copter
        ap.echo = GuidedTarget("pos", tgt, None, None, ap.hold_yaw, None)
        ap.setpoint(pos=tgt, yaw=ap.hold_yaw)
