"""POSHOLD (ArduCopter/mode_poshold.cpp ModePosHold): the pilot's angles, braking to a hold.

Sticks: roll and pitch lean the copter (ANGLE_MAX) as in ALT_HOLD, the throttle a climb
rate as ALT_HOLD's (a climb on the ground takes off), the yaw stick turns it. Roll and pitch
centred (or no RC input): it brakes with PHLD_BRAKE_ANGLE (cdeg) of lean as its deceleration,
reached at PHLD_BRAKE_RATE (deg/s) (stopping.py), then holds the point where it stopped.
"""
from __future__ import annotations

import math

import numpy as np

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.stopping import StoppingMode

GRAVITY = 9.80665


class ModePosHold(StoppingMode):
    number = modes.POSHOLD
    position_required, arming_allowed, user_takeoff, pilot_takeoff = True, True, True, True

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.leaning = False            # the pilot's angles fly (else brake / hold)

    def enter(self) -> None:
        super().enter()
        self.leaning = False

    def stop_limits(self) -> tuple[float, float]:
        p = self.ap.params
        angle = math.radians(float(p.get("PHLD_BRAKE_ANGLE", 3000)) / 100.0)
        rate = math.radians(float(p.get("PHLD_BRAKE_RATE", 8)))
        return GRAVITY * math.tan(angle), GRAVITY * rate

    def fly(self, dt: float) -> None:
        ap = self.ap
        z, vz = self.pilot.vertical(dt)
        roll, pitch = self.pilot.lean()
        rate = self.pilot.yaw(dt)
        if roll or pitch:
            self.leaning = True
            self.stop.release()
            self.fly_pilot_angles(z, vz, roll, pitch, rate)
            return
        if self.leaning:                 # sticks released: brake, then hold
            self.leaning = False
            self.stop.start(*self.stop_limits())
        if vz and not self.stop.active:  # holding: the throttle climbs
            ap.echo = None
            ap.setpoint(pos=np.array([ap.hold_pos[0], ap.hold_pos[1], z]), vel=np.array([0.0, 0.0, vz]),
                        yaw=ap.hold_yaw, yaw_rate=rate or None)
            return
        self.stop.run(dt)
