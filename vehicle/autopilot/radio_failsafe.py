"""The radio (throttle) failsafe: when it triggers (ArduCopter/radio.cpp read_radio and
set_throttle_and_failsafe; Rover/radio.cpp radio_failsafe_check and failsafe.cpp
failsafe_trigger) and what each vehicle does then (ArduCopter/events.cpp
failsafe_radio_on_event; Rover's FS_ACTION). Sim time throughout.

Copter (FS_THR_ENABLE != 0):
- a frame's throttle below FS_THR_VALUE three reads running triggers it; good throttle
  frames count back down and at zero clear it ("Radio Failsafe Cleared", WARNING);
- no RC frame for RC_FS_TIMEOUT s (at least 0.1) triggers it once RC input (the simulated
  receiver or an override) has been seen (has_ever_seen_rc_input): the receiver sends from
  the first tick, so SIM_RC_FAIL 1 (no pulses) triggers it RC_FS_TIMEOUT s later; with
  SIM_RC_FAIL 1 from boot there is never a frame and nothing times out.
- then, in events.cpp's order: should disarm (STABILIZE with the throttle at zero, AUTO not
  auto-armed and landed, any mode landed): "Radio Failsafe - Disarming"; landing under a
  battery failsafe: "Radio + Battery Failsafe - Continuing Landing"; landing with FS_OPTIONS
  bit 3: "Radio Failsafe - Continuing Landing"; AUTO with bit 0: "... - Continuing Auto
  Mode"; GUIDED with bit 2 and FS_GCS_ENABLE: "... - Continuing Guided Mode"; else "Radio
  Failsafe" and FS_THR_ENABLE's action: 1, 2, 6 RTL or LAND; 3 LAND; 4 SmartRTL, RTL or LAND;
  5 SmartRTL or LAND; 7 BRAKE or LAND.
Rover (FS_THR_ENABLE != 0): throttle below FS_THR_VALUE or no RC frame for RC_FS_TIMEOUT s
(after the first RC input, as above) for FS_TIMEOUT s, outside RTL and HOLD: "Radio Failsafe" (WARNING),
overrides cleared, FS_ACTION (rover_failsafe.py's chains); "Radio Failsafe Cleared" (INFO).
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes

FS_COUNTER = 3                     # low-throttle frames in a row that trigger (Copter)
MIN_TIMEOUT = 0.1                  # s: RC_Channels::get_fs_timeout_ms's floor
THROTTLE_ZERO_DEBOUNCE = 0.4       # s of zero throttle before throttle_zero (Copter)
SEV_WARNING, SEV_INFO = mav.MAV_SEVERITY_WARNING, mav.MAV_SEVERITY_INFO
# FS_OPTIONS bits (Copter's FailsafeOption)
RC_CONTINUE_IF_AUTO, RC_CONTINUE_IF_GUIDED, CONTINUE_IF_LANDING = 1, 4, 8
COPTER_ACTIONS = {1: (modes.RTL, modes.LAND), 2: (modes.RTL, modes.LAND), 3: (modes.LAND,),
                  4: (modes.SMART_RTL, modes.RTL, modes.LAND), 5: (modes.SMART_RTL, modes.LAND),
                  6: (modes.RTL, modes.LAND), 7: (modes.BRAKE, modes.LAND)}


class RadioFailsafe:
    """Radio failsafe state of one autopilot; `update(t, new_frame)` every tick after the RC
    input was read."""

    def __init__(self, ap) -> None:
        self.ap = ap
        self.active = False

    def enabled(self) -> bool:
        return int(self.ap.params.get("FS_THR_ENABLE", 1)) != 0

    def timed_out(self, t: float) -> bool:
        """No RC frame for RC_FS_TIMEOUT s (after the first one)."""
        rc = self.ap.rc
        if rc.last_frame is None:
            return False
        return t - rc.last_frame >= max(MIN_TIMEOUT, float(self.ap.params.get("RC_FS_TIMEOUT", 1.0)))

    def throttle_low(self) -> bool:
        rc = self.ap.rc
        return rc.sticks is not None and rc.sticks.throttle_pwm < int(self.ap.params.get("FS_THR_VALUE", 975))

    def update(self, t: float, new_frame: bool) -> None:
        """One tick at sim time t (new_frame: an RC frame was read this tick); a vehicle
        without a radio failsafe does nothing."""


class CopterRadioFailsafe(RadioFailsafe):
    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.counter = 0
        self.throttle_zero = True          # ArduCopter's ap.throttle_zero
        self._nonzero_t = 0.0

    def update(self, t: float, new_frame: bool) -> None:
        ap = self.ap
        if ap.rc.last_frame is None:
            return                     # never any RC frame (SIM_RC_FAIL 1 from boot): nothing to lose
        if new_frame:
            self._throttle_zero(t)
            if not self.enabled():
                return
            if self.throttle_low():
                if self.active:
                    return
                self.counter = min(FS_COUNTER, self.counter + 1)
                if self.counter >= FS_COUNTER:
                    self.set(True)
            else:
                self.counter = max(0, self.counter - 1)
                if self.counter == 0 and self.active:
                    self.set(False)
            return
        if self.active or not self.enabled():
            return
        if self.timed_out(t):
            self.set(True)

    def _throttle_zero(self, t: float) -> None:
        """set_throttle_zero_flag: non-zero at once, zero after 0.4 s of zero throttle."""
        if self.ap.rc.sticks.throttle > 0:
            self._nonzero_t = t
            self.throttle_zero = False
        elif t - self._nonzero_t > THROTTLE_ZERO_DEBOUNCE:
            self.throttle_zero = True

    def set(self, on: bool) -> None:
        self.active = on
        if on:
            self.on_event()
        else:
            self.ap.text(SEV_WARNING, "Radio Failsafe Cleared")

    def on_event(self) -> None:
        """failsafe_radio_on_event."""
        ap = self.ap
        p = ap.params
        options = int(p.get("FS_OPTIONS", 0))
        mode = ap.flightmode
        chain = COPTER_ACTIONS.get(int(p.get("FS_THR_ENABLE", 1)), (modes.LAND,))
        battery = ap.failsafe.battery_priority
        if mode.disarms_on_failsafe(self.throttle_zero):
            ap.text(SEV_WARNING, "Radio Failsafe - Disarming")
            ap.disarm(force=True, reason="radio failsafe")
            return
        if mode.is_landing() and battery is not None and battery <= ap.failsafe.priorities.index(1):
            ap.text(SEV_WARNING, "Radio + Battery Failsafe - Continuing Landing")
            chain = (modes.LAND,)
        elif mode.is_landing() and options & CONTINUE_IF_LANDING:
            ap.text(SEV_WARNING, "Radio Failsafe - Continuing Landing")
            chain = (modes.LAND,)
        elif mode is ap.auto and options & RC_CONTINUE_IF_AUTO:
            ap.text(SEV_WARNING, "Radio Failsafe - Continuing Auto Mode")
            return
        elif (mode.in_guided_mode() and options & RC_CONTINUE_IF_GUIDED
              and int(p.get("FS_GCS_ENABLE", 0)) != 0):
            ap.text(SEV_WARNING, "Radio Failsafe - Continuing Guided Mode")
            return
        else:
            ap.text(SEV_WARNING, "Radio Failsafe")
        self._act(chain)

    def _act(self, chain) -> None:
        ap = self.ap
        why = "radio failsafe"
        if chain[0] == modes.SMART_RTL and not ap.set_mode(modes.SMART_RTL, why):
            ap.text(SEV_WARNING, "SmartRTL Unavailable, Trying RTL Mode" if modes.RTL in chain
                    else "SmartRTL Unavailable, Using Land Mode")
            chain = chain[1:]
        ap.failsafe.failsafe_modes(chain, why)      # LAND with its pause (copter_failsafe.py)


class RoverRadioFailsafe(RadioFailsafe):
    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.failing_since: float | None = None   # sim s the condition started
        self.triggered = False

    def update(self, t: float, new_frame: bool) -> None:
        ap = self.ap
        if ap.rc.last_frame is None and not self.triggered:
            return                     # never any RC frame (SIM_RC_FAIL 1 from boot): nothing to lose
        if not self.enabled() or ap.rc.last_frame is None:
            failed = False
        else:
            failed = self.throttle_low() or self.timed_out(t)
        self.active = failed
        if not failed:
            self.failing_since = None
            if self.triggered:
                self.triggered = False
                ap.text(SEV_INFO, "Radio Failsafe Cleared")
            return
        if self.failing_since is None:
            self.failing_since = t
        if (not self.triggered and t - self.failing_since > float(ap.params.get("FS_TIMEOUT", 1.5))
                and ap.flightmode.radio_failsafe_acts):
            self.triggered = True
            ap.text(SEV_WARNING, "Radio Failsafe")
            ap.rc.clear_overrides()
            if ap.armed:
                ap.failsafe.radio_action(int(ap.params.get("FS_ACTION", 2)))
