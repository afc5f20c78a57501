"""AUTO (Rover/mode_auto.cpp ModeAuto): drives the stored mission.

The mission half is vehicle/autopilot/auto.py's AutoMission; this drives its sub-modes: to
each waypoint at WP_SPEED / CRUISE_SPEED (a stop for NAV_DELAY and hold times), rtl (the RTL
mode object's drive), stop at the end ("Mission Complete"). The mission runs disarmed too.
"""
from __future__ import annotations

from vehicle.autopilot import modes
from vehicle.autopilot.auto import AutoMission
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeAuto(RoverMode):
    number = modes.ROVER_AUTO

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.mission = AutoMission(ap, ap.flightmodes[modes.ROVER_RTL])

    def is_autopilot(self) -> bool:
        return True

    def init(self, ignore_checks: bool) -> bool:
        return self.mission.init()

    def exit(self) -> None:
        self.mission.exit()

    def pause(self) -> bool:
        return self.mission.pause()

    def resume(self) -> bool:
        return self.mission.resume()

    def run(self, dt: float) -> None:
        self.mission.step()
        super().run(dt)

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
