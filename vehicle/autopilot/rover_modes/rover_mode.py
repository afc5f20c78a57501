"""What every rover mode shares (Rover/mode.h `Mode`): the hooks ArduRover's modes answer,
the stop when disarmed, and the two ways a mode drives (stop; drive to a point).

The pilot's sticks (vehicle/autopilot/rc_input.py: the simulated receiver, centred, or
RC_CHANNELS_OVERRIDE / MANUAL_CONTROL from the GCS) drive MANUAL, ACRO and STEERING through
drive_sticks(); before any RC frame they read neutral and those modes stop. Setpoints are world NED; the RoverFleet ignores z.
"""
from __future__ import annotations

from typing import ClassVar

import math

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.mode import Mode

ZERO = np.zeros(3)


class RoverMode(Mode):
    """A rover mode. Subclasses drive in `drive(dt)`; disarmed, run() stops."""

    names = modes.ROVER_MODES

    # ----- Rover's Mode hooks (values declared as in Mode; defaults as Rover/mode.h) -----
    velocity_required: ClassVar[bool] = True     # requires_velocity()
    manual_input: ClassVar[bool] = False         # has_manual_input()
    radio_failsafe_acts: ClassVar[bool] = True   # a radio failsafe triggers (not in RTL, HOLD)

    def requires_velocity(self) -> bool:
        """Refused without a velocity estimate (towerlink's estimate has both or neither)."""
        return self.velocity_required

    def has_manual_input(self) -> bool:
        """The pilot's sticks drive (MANUAL, ACRO, STEERING): base_mode MANUAL_INPUT_ENABLED."""
        return self.manual_input

    def base_mode_flags(self) -> int:
        flags = mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED if self.has_manual_input() else 0
        return flags | (mav.MAV_MODE_FLAG_GUIDED_ENABLED if self.is_autopilot() else 0)

    # ----- the tick ---------------------------------------------------------------------
    def run(self, dt: float) -> None:
        if not self.ap.armed:
            self.stop()
            return
        self.drive(dt)

    def drive(self, dt: float) -> None:
        """Setpoints while armed."""
        raise NotImplementedError

    def stop(self) -> None:
        """Speed 0, no turn."""
        ap = self.ap
        ap.setpoint(vel=ZERO.copy(), yaw_rate=0.0)
        ap.echo = GuidedTarget("vel", None, ZERO.copy(), None, None, 0.0)

    def drive_sticks(self, pilot) -> None:
        """Drive as the sticks ask: `pilot(sticks, params, top_speed)` -> (speed m/s, turn
        rate rad/s) (rover_pilot.py). The fleet steers to a velocity's heading at
        ATC_STR_ANG_P, so the heading asked for leads the rover's by rate / ATC_STR_ANG_P;
        it drives forwards only (a backwards speed stops it)."""
        ap = self.ap
        s = ap.rc.sticks
        if s is None:
            self.stop()
            return
        g = ap.fleet.gains_of(ap.i)
        speed, rate = pilot(s, ap.params, g.max_speed)
        speed = max(0.0, speed)
        if speed < 0.05:
            ap.echo = GuidedTarget("vel", None, ZERO.copy(), None, None, rate)
            ap.setpoint(vel=ZERO.copy(), yaw_rate=rate)
            return
        lead = max(-0.9 * g.pivot, min(0.9 * g.pivot, rate / max(g.k_hdg, 1e-6)))
        h = ap.yaw + lead
        vel = np.array([speed * math.cos(h), speed * math.sin(h), 0.0])
        ap.echo = GuidedTarget("vel", None, vel, None, None, rate)
        ap.setpoint(vel=vel)

    def drive_to(self, dest) -> None:
        """Drive to dest's x, y (and stop there: the fleet's waypoint controller)."""
        ap = self.ap
        tgt = np.array([dest[0], dest[1], ap.pos[2]])
        ap.echo = GuidedTarget("pos", tgt, None, None, None, None)
        ap.setpoint(pos=tgt)
