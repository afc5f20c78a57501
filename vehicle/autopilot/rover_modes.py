"""ArduRover's ACRO, STEERING, LOITER and SMART_RTL, as a mixin of RoverAutopilot.

No RC is simulated: the throttle and steering sticks are centred, so
  ACRO, STEERING  target speed 0 and no turn: the rover stops and stays stopped.
  LOITER          holds the point where it was entered: within LOIT_RADIUS it stops; further
                  away it drives back to the point (ArduRover's ModeLoiter).
  SMART_RTL       retraces the SmartRTL breadcrumbs (smartrtl.py: SRTL_ACCURACY, SRTL_POINTS)
                  recorded while armed in other modes, says "Reached destination" at the
                  first point (where it armed) and stops there. Without a usable path the mode
                  refuses to start, as ArduRover's ModeSmartRTL::_enter.
Setpoints are world NED (z ignored by the RoverFleet).
"""
from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.smartrtl import RecordsSmartRTLPath


class RoverModes(RecordsSmartRTLPath):
    """Mixin: needs Autopilot's state and RoverAutopilot's _stop()."""

    SMART_RTL_MODE = modes.ROVER_SMART_RTL

    def __init__(self, *a, **kw) -> None:
        self.srtl_dest: np.ndarray | None = None
        self.srtl_done = False
        super().__init__(*a, **kw)

    def exit_mode(self, number: int) -> None:
        if number == modes.ROVER_SMART_RTL and not self.srtl_done and self.srtl_dest is not None:
            self.srtl.push(self.srtl_dest)
        self.srtl_dest = None
        super().exit_mode(number)

    def enter_extra_mode(self, number: int) -> None:
        if number == modes.ROVER_SMART_RTL:
            self.srtl.cleanup()
            self.srtl_done = False
            self.srtl_dest = None            # the first point is taken when it drives

    def _smart_rtl(self) -> None:
        radius = float(self.params.get("WP_RADIUS", 2))
        if self.srtl_dest is None and not self.srtl_done:
            self.srtl_dest = self.srtl.pop()
        while (not self.srtl_done and self.srtl_dest is not None
               and np.linalg.norm(self.pos[:2] - self.srtl_dest[:2]) < radius):
            nxt = self.srtl.pop()
            if nxt is None:
                self.srtl_done = True
                self.text(mav.MAV_SEVERITY_INFO, "Reached destination")
                self.hold_here()
            else:
                self.srtl_dest = nxt
        if self.srtl_done or self.srtl_dest is None:
            self._stop()
            return
        tgt = np.array([self.srtl_dest[0], self.srtl_dest[1], self.pos[2]])
        self.echo = GuidedTarget("pos", tgt, None, None, None, None)
        self.setpoint(pos=tgt)

    def _loiter(self) -> None:
        hp = self.hold_pos
        if np.linalg.norm(self.pos[:2] - hp[:2]) <= float(self.params.get("LOIT_RADIUS", 2)):
            self._stop()
            return
        tgt = np.array([hp[0], hp[1], self.pos[2]])
        self.echo = GuidedTarget("pos", tgt, None, None, None, None)
        self.setpoint(pos=tgt)

    def run_extra_mode(self, m: int) -> bool:
        """Setpoints for this module's modes (armed); False for other modes."""
        if m in (modes.ROVER_ACRO, modes.ROVER_STEERING):
            self._stop()
        elif m == modes.ROVER_LOITER:
            self._loiter()
        elif m == modes.ROVER_SMART_RTL:
            self._smart_rtl()
        else:
            return False
        return True
