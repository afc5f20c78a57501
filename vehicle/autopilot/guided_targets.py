"""GUIDED's current target and how SET_POSITION_TARGET_* (and DO_REPOSITION) become one; the
copter's and the rover's GUIDED mode each own one.

Decoding is guided.py's (ArduPilot's rules); this keeps the result: the target (world NED),
when it arrived (velocity and acceleration targets expire after GUID_TIMEOUT s), and what
POSITION_TARGET_LOCAL_NED echoes. A target that cannot be decoded is refused with its
reason as a STATUSTEXT and the vehicle holds where it is.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from common import geo
from vehicle.autopilot.guided import GuidedTarget, TargetError, decode_global, decode_local

EXPIRING = ("vel", "acc", "posvel")


class GuidedTargets:
    """`destination_ok(ned) -> bool` may refuse position targets (the copter's fence check:
    ArduPilot keeps flying its previous target); `accepted()` is called for every target
    taken (its mode's other controls, such as attitude targets, stop)."""

    def __init__(self, ap, destination_ok: Callable[[np.ndarray], bool] | None = None,
                 accepted: Callable[[], None] | None = None) -> None:
        self.ap = ap
        self.destination_ok = destination_ok
        self.accepted = accepted
        self.target: GuidedTarget | None = None
        self.time = 0.0                       # sim s the target arrived

    def clear(self) -> None:
        self.target = None

    def position_target_local(self, frame, type_mask, p, v, a, yaw, yaw_rate) -> bool:
        """SET_POSITION_TARGET_LOCAL_NED: the wire's local frame is centred on this vehicle's
        EKF origin, the fleet's on the world."""
        ap = self.ap
        ap.refresh()
        try:
            tgt = decode_local(frame, type_mask, p, v, a, yaw, yaw_rate, ap.local_origin.to_local(ap.pos), ap.yaw)
        except TargetError as e:
            return self.refuse(str(e))
        if tgt.pos is not None:
            tgt = dataclasses.replace(tgt, pos=ap.local_origin.to_world(tgt.pos))
        return self.accept(tgt)

    def position_target_global(self, frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate) -> bool:
        """SET_POSITION_TARGET_GLOBAL_INT (relative altitudes above home)."""
        ap = self.ap
        ap.refresh()
        try:
            tgt = decode_global(frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate,
                                lambda la, lo, al: geo.lla_to_ned(ap.origin, la, lo, al),
                                ap.home_lla()[2], ap.yaw)
        except TargetError as e:
            return self.refuse(str(e))
        return self.accept(tgt)

    def refuse(self, why: str) -> bool:
        """Say why, drop the target and hold here; False."""
        self.ap.text(mav.MAV_SEVERITY_WARNING, why)
        self.target = None
        self.ap.hold_here()
        return False

    def accept(self, tgt: GuidedTarget) -> bool:
        """Fly `tgt` from now (False, nothing changed, if its destination is refused)."""
        if tgt.pos is not None and self.destination_ok is not None and not self.destination_ok(tgt.pos):
            return False
        self.target = tgt
        self.time = self.ap.t
        self.ap.echo = tgt
        if self.accepted is not None:
            self.accepted()
        return True

    def timed_out(self) -> bool:
        """A velocity or acceleration target older than GUID_TIMEOUT s."""
        tgt = self.target
        return (tgt is not None and tgt.kind in EXPIRING
                and self.ap.t - self.time > float(self.ap.params.get("GUID_TIMEOUT", 3.0)))
