"""What a copter mode flies from the pilot's sticks (copter_pilot.py's scaling), one per mode:
the lean angles, the climb rate slewed at PILOT_ACCEL_Z, the heading turned at the yaw
stick's rate, LOITER's velocity slewed at LOIT_ACC_MAX (LOIT_BRK_ACCEL when slowing).

Vertically the copter flies the climb rate while there is one (the hold altitude, ap.hold_pos
z, following it) and then holds the altitude where the copter's vertical speed, at the
moment the slewed climb rate came back to zero, stops it at PILOT_ACCEL_Z. As
ArduCopter's pilot modes set the position controller's vertical limits to PILOT_SPEED_UP /
PILOT_SPEED_DN and PILOT_ACCEL_Z, the fleet's WPNAV_SPEED_UP / _DN / WPNAV_ACCEL_Z are those
while the sticks fly the climb (from the first RC input in the mode until it is left). Before
any RC frame (ap.rc.sticks None: SIM_RC_FAIL 1 from boot) or in the radio failsafe every
stick reads centred: climb 0, no lean, no turn. The simulated receiver's throttle rests at
1000 (rc_input.py), so with no override a pilot mode descends at PILOT_SPEED_DN. World NED (m, z down); rates rad/s, speeds m/s.
"""
from __future__ import annotations

import math

import numpy as np

from vehicle.autopilot import copter_pilot
from vehicle.autopilot.rc_input import Sticks

NAN = float("nan")


class PilotControl:
    def __init__(self, ap) -> None:
        self.ap = ap
        self.climb = 0.0                    # slewed climb rate, m/s up
        self.vel = np.zeros(2)              # slewed LOITER velocity (north, east), m/s
        self.engaged = False                # the fleet flies the pilot's vertical limits

    def reset(self) -> None:
        """A mode starts: nothing carried over from the last time it flew."""
        self.climb = 0.0
        self.vel = np.zeros(2)

    def release(self) -> None:
        """The mode is left: the fleet's vertical limits back to the parameters'."""
        if self.engaged:
            self.engaged = False
            p = self.ap.params
            self.ap.push_params({k: float(p.get(k, d)) for k, d in
                                 (("WPNAV_SPEED_UP", 250), ("WPNAV_SPEED_DN", 150), ("WPNAV_ACCEL_Z", 100))})

    def _engage(self) -> None:
        p = self.ap.params
        up = abs(float(p.get("PILOT_SPEED_UP", 250)))
        self.engaged = True
        self.ap.push_params({"WPNAV_SPEED_UP": up, "WPNAV_SPEED_DN": abs(float(p.get("PILOT_SPEED_DN", 0))) or up,
                             "WPNAV_ACCEL_Z": float(p.get("PILOT_ACCEL_Z", 250))})

    @property
    def sticks(self) -> Sticks | None:
        """The sticks, None without RC input."""
        return self.ap.rc.sticks

    def active(self) -> bool:
        """Is any stick asking for something (roll, pitch, yaw off centre, or a climb)?"""
        s = self.sticks
        return s is not None and (not copter_pilot.sticks_centred(s) or self.wanted_climb() != 0.0)

    def lean(self) -> tuple[float, float]:
        """(roll, pitch) rad the sticks ask for, within ANGLE_MAX."""
        s = self.sticks
        if s is None:
            return 0.0, 0.0
        return copter_pilot.lean_angles(s, math.radians(float(self.ap.params.get("ANGLE_MAX", 3000)) / 100.0))

    def wanted_climb(self) -> float:
        """get_pilot_desired_climb_rate: 0 in the radio failsafe or without RC."""
        s = self.sticks
        if s is None or self.ap.radio.active:
            return 0.0
        return copter_pilot.climb_rate(s, self.ap.params)

    def climb_rate(self, dt: float) -> float:
        """The climb rate (m/s up) slewed towards the stick's at PILOT_ACCEL_Z."""
        acc = float(self.ap.params.get("PILOT_ACCEL_Z", 250)) / 100.0 * dt
        want = self.wanted_climb()
        self.climb += max(-acc, min(acc, want - self.climb))
        return self.climb

    def yaw(self, dt: float) -> float:
        """The yaw stick's rate (rad/s); the held heading ap.hold_yaw turns with it."""
        s = self.sticks
        ap = self.ap
        if s is None or s.yaw == 0.0 or ap.radio.active:
            return 0.0
        rate = copter_pilot.yaw_rate(s, ap.params)
        ap.hold_yaw = math.remainder(ap.hold_yaw + rate * dt, math.tau)
        return rate

    def vertical(self, dt: float) -> tuple[float, float]:
        """(z target, vz) of the climb stick (m, m/s down): while climbing, no altitude
        (NaN) and the slewed climb rate; else the hold altitude and 0."""
        ap = self.ap
        if not self.engaged and self.sticks is not None:
            self._engage()
        was = self.climb
        climb = self.climb_rate(dt)
        if climb:
            ap.hold_pos[2] = ap.pos[2]
            return NAN, -climb
        if was:
            # the climb just ended: hold where the copter's own vertical speed stops it
            vz = float(ap.vel[2])
            ap.hold_pos[2] = ap.pos[2] + vz * abs(vz) / (2.0 * float(ap.params.get("PILOT_ACCEL_Z", 250)) / 100.0)
        return ap.hold_pos[2], 0.0

    def velocity(self, dt: float) -> np.ndarray:
        """LOITER's pilot velocity (north, east) m/s, slewed at LOIT_ACC_MAX, or at
        LOIT_BRK_ACCEL while slowing down."""
        ap = self.ap
        s = self.sticks
        want = np.zeros(2) if s is None else np.array(copter_pilot.velocity(s, ap.params, ap.yaw))
        p = ap.params
        slowing = float(np.linalg.norm(want)) < float(np.linalg.norm(self.vel))
        acc = float(p.get("LOIT_BRK_ACCEL" if slowing else "LOIT_ACC_MAX", 250 if slowing else 500)) / 100.0
        d = want - self.vel
        n = float(np.linalg.norm(d))
        step = acc * dt
        self.vel = want if n <= step else self.vel + d * (step / n)
        return self.vel
