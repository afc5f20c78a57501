"""Pilot input, the link capability: RC_CHANNELS_OVERRIDE and MANUAL_CONTROL from the ground
station into the autopilot's RC input (vehicle/autopilot/rc_input.py), at sim time.

Both are taken only from the system SYSID_MYGCS names (ArduPilot's "only accept control from
our gcs"), others are dropped silently; a MANUAL_CONTROL from it also counts as the GCS's
heartbeat for the GCS failsafe, as ArduPilot's sysid_myggcs_seen. MANUAL_CONTROL's axes go
onto the RCMAP_* channels as the vehicle's handle_manual_control_axes puts them:
- Copter (z < 0 ignored: no negative thrust): roll <- y, pitch <- x reversed (x forward ->
  low PWM), yaw <- r, each -1000..1000 over RCn_MIN..MAX; throttle <- z 0..1000.
- Rover: steering (RCMAP_ROLL) <- y, throttle <- z, each -1000..1000.
An axis at INT16_MAX releases its channel.
"""
from __future__ import annotations

from vehicle.autopilot.rc_input import channel_numbers
from vehicle.link.link_core import LinkCore

# (message field, channel index in channel_numbers(), offset, scaler, reversed)
COPTER_AXES = (("y", 0, 1000, 2000, False), ("x", 1, 1000, 2000, True),
               ("z", 2, 0, 1000, False), ("r", 3, 1000, 2000, False))
ROVER_AXES = (("y", 0, 1000, 2000, False), ("z", 2, 1000, 2000, False))


class RcLink:
    def __init__(self, core: LinkCore, ap) -> None:
        """ap: the vehicle's autopilot (its RC input, its parameters, its sim time)."""
        self.core = core
        self.ap = ap
        core.register("RC_CHANNELS_OVERRIDE", self.on_rc_channels_override)
        core.register("MANUAL_CONTROL", self.on_manual_control)

    def _from_gcs(self, m) -> bool:
        return m.get_srcSystem() == int(self.ap.params.get("SYSID_MYGCS", 255))

    def on_rc_channels_override(self, m, ch) -> None:
        if not self._from_gcs(m):
            return
        values = [getattr(m, f"chan{n}_raw", 0) for n in range(1, 19)]
        self.ap.rc.channels_override(values, self.ap.t)

    def on_manual_control(self, m, ch) -> None:
        ap = self.ap
        if not self._from_gcs(m):
            return
        copter = ap.kind == "copter"
        if not (copter and m.z < 0):     # Copter doesn't do negative thrust
            chans = channel_numbers(ap.params)
            for field, k, offset, scaler, rev in (COPTER_AXES if copter else ROVER_AXES):
                ap.rc.manual_override(chans[k], getattr(m, field), offset, scaler, ap.t, rev)
        ap.gcs_heartbeat()
