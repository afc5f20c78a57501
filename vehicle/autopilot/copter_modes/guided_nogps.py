"""GUIDED_NOGPS (ArduCopter/mode_guided_nogps.cpp ModeGuidedNoGPS): GUIDED's attitude control
and nothing else, so it needs no position estimate.

Entered, it levels at the current heading with a climb rate of zero (angle_control_start);
each SET_ATTITUDE_TARGET is flown as in GUIDED (guided_angle.py), including the takeoff on
a positive climb rate or thrust and the GUID_TIMEOUT level-and-hold. Position targets are
ignored (ArduCopter hands them to GUIDED's controllers, which this mode never runs).

Where towerlink answers otherwise (ArduCopter inherits these from ModeGuided and then never
runs what they start): MAV_CMD_NAV_TAKEOFF is refused (ArduCopter accepts it and stays on
the ground), DO_PAUSE_CONTINUE fails ("Failed to pause"; ArduCopter accepts it and flies on),
and a target ArduCopter answers with GUIDED's stop is only refused here: the last target
flies on until it times out, which is what ArduCopter's GUIDED_NOGPS then does.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.attitude_target import AttitudeStop
from vehicle.autopilot.copter_modes.guided import ModeGuided


class ModeGuidedNoGPS(ModeGuided):
    number = modes.GUIDED_NOGPS
    position_required, user_takeoff = False, False
    reports_guided_enabled = False       # no position controller runs

    def enter(self) -> None:
        super().enter()
        self.angle.start()

    def position_target_local(self, frame, type_mask, p, v, a, yaw, yaw_rate) -> bool:
        return False

    def position_target_global(self, frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate) -> bool:
        return False

    def attitude_target(self, type_mask: int, q, body_rates, thrust: float) -> bool:
        try:
            tgt = self.decode_attitude(type_mask, q, body_rates, thrust)
        except AttitudeStop as e:
            if str(e):
                self.ap.text(mav.MAV_SEVERITY_WARNING, str(e))
            return False
        self.angle.set(tgt)
        return True

    def pause(self) -> bool:
        return False

    def resume(self) -> bool:
        return False

    def fly(self, dt: float) -> None:
        self.angle.fly()
