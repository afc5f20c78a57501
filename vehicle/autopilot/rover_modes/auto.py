"""AUTO (Rover/mode_auto.cpp ModeAuto): drives the stored mission.

The mission half is vehicle/autopilot/auto.py's AutoMission (started, stepped, paused and left
through MissionMode); this drives its sub-modes: to each waypoint at WP_SPEED / CRUISE_SPEED
(a stop for NAV_DELAY and hold times), rtl (the RTL mode object's drive), stop at the end
("Mission Complete"). The mission runs disarmed too.
"""
from __future__ import annotations

from vehicle.autopilot import modes
from vehicle.autopilot.auto import MissionMode
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeAuto(MissionMode, RoverMode):
    number = modes.ROVER_AUTO
    autopilot_mode = True

    def drive(self, dt: float) -> None:
        m = self.mission
        if m.sub == "stop" or m.paused:
            self.stop()
        elif m.sub == "rtl":
            m.rtl.drive(dt)
        elif m.dest is None:
            self.stop()
        else:
            self.drive_to(m.dest)
