"""A jerk-limited stop, then a hold where the copter stopped: BRAKE, POSHOLD with the sticks
centred (both StoppingModes), and GUIDED's pause each own one.

The stop decelerates along the horizontal velocity the copter had when it started, with a
deceleration (m/s/s) reached at a jerk limit (m/s/s/s) and eased out so the speed reaches 0
with zero acceleration (AC_PosControl's stopping with those limits; ANGLE_MAX still caps it).
While it stops, the fleet's shaped reference is allowed that deceleration (WPNAV_ACCEL,
PSC_JERK_XY pushed up); the parameters' values are given back once stopped or when the mode
is left. Setpoints are world NED.
"""
from __future__ import annotations

import math

import numpy as np

from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.guided import GuidedTarget

STOPPED_SPEED = 0.1              # m/s: below it the copter counts as stopped


class StopThenHold:
    """The stop one mode runs. `stop_time` is the time (s) from start() to stopped."""

    def __init__(self, ap) -> None:
        self.ap = ap
        self.active = False                # still decelerating
        self.stop_time: float | None = None
        self.t0 = 0.0
        self.speed = self.acc = self.decel = self.jerk = 0.0
        self.dir = np.zeros(3)
        self.pos = np.zeros(3)

    def start(self, decel: float, jerk: float) -> None:
        """Begin stopping with `decel` (m/s/s) at `jerk` (m/s/s/s) from the current velocity."""
        ap = self.ap
        self.t0 = ap.t
        self.stop_time = None
        self.active = True
        v = np.array([ap.vel[0], ap.vel[1], 0.0])
        self.speed = float(np.linalg.norm(v))
        self.dir = v / self.speed if self.speed > 1e-6 else np.zeros(3)
        self.acc = 0.0
        self.pos = np.array([ap.pos[0], ap.pos[1], ap.hold_pos[2]])
        self.decel, self.jerk = decel, jerk
        # the shaped reference must be allowed this deceleration while it follows the stop
        # (the stop's own jerk limit is in the profile below; the reference keeps PSC_JERK_XY
        # when that is higher, so it does not lag the profile)
        p = ap.params
        ap.push_params({"WPNAV_ACCEL": max(decel * 100.0, float(p.get("WPNAV_ACCEL", 250))),
                        "PSC_JERK_XY": max(jerk, float(p.get("PSC_JERK_XY", 5.0)))})

    def release(self) -> None:
        """Leave off stopping (the mode is left, or GUIDED resumes): limits given back."""
        if self.active:
            self._restore_limits()
        self.active = False

    def _restore_limits(self) -> None:
        p = self.ap.params
        self.ap.push_params({"WPNAV_ACCEL": float(p.get("WPNAV_ACCEL", 250)),
                             "PSC_JERK_XY": float(p.get("PSC_JERK_XY", 5.0))})

    def run(self, dt: float) -> None:
        """One tick: the stopping trajectory, then the hold at ap.hold_pos."""
        ap = self.ap
        if self.active:
            s, j = self.speed, self.jerk
            # deceleration ramps up at the jerk limit, and down again so the speed reaches 0
            # with zero acceleration (a <= sqrt(2 j s))
            a = min(self.decel, self.acc + j * dt, math.sqrt(2.0 * j * max(s, 0.0)))
            self.acc = a
            s_new = max(0.0, s - a * dt)
            self.pos = self.pos + self.dir * 0.5 * (s + s_new) * dt
            self.speed = s = s_new
            if s <= 0.0 and float(np.linalg.norm(ap.vel[:2])) < STOPPED_SPEED:
                self.active = False
                self.stop_time = ap.t - self.t0
                self._restore_limits()
                # hold where it stopped (within a few cm of the profile's stopping point)
                ap.hold_pos = np.array([ap.pos[0], ap.pos[1], ap.hold_pos[2]])
            else:
                # the stopping trajectory as position + velocity + acceleration, so the
                # position loop corrects the lag as ArduPilot's brake (a stopping point) does
                vel, acc = self.dir * s, -self.dir * (a if s > 0 else 0.0)
                ap.echo = GuidedTarget("posvel", self.pos.copy(), vel, acc, ap.hold_yaw, None)
                ap.setpoint(pos=self.pos.copy(), vel=vel, acc=acc, yaw=ap.hold_yaw)
                return
        ap.echo = GuidedTarget("pos", ap.hold_pos.copy(), None, None, ap.hold_yaw, None)
        ap.setpoint(pos=ap.hold_pos, yaw=ap.hold_yaw)


class StoppingMode(CopterMode):
    """A mode that, entered in the air, stops with its stop_limits() and then holds (BRAKE,
    POSHOLD); entered disarmed or on the ground there is nothing to stop: it holds."""

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.stop = StopThenHold(ap)

    def stop_limits(self) -> tuple[float, float]:
        """(deceleration m/s/s, jerk m/s/s/s) of this mode's stop."""
        raise NotImplementedError

    def enter(self) -> None:
        super().enter()
        if self.ap.armed and not self.ap.on_ground:
            self.stop.start(*self.stop_limits())

    def exit(self) -> None:
        super().exit()
        self.stop.release()

    def fly(self, dt: float) -> None:
        self.stop.run(dt)
