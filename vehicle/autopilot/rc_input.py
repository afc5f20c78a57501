"""The vehicle's RC input as ArduPilot's RC_Channels / RC_Channel read it (pure: no sockets,
no clocks; times are sim seconds passed in).

Where the pulses come from:
- The simulated receiver, always there as in ArduPilot SITL (AP_RCProtocol_UDP): a frame of 8
  channels every 20 ms (its 50 Hz) at the transmitter's resting positions
  (set_default_pwm_input_values): ch1, 2, 4 1500; ch3 1000 (Rover: 1500, its throttle centred
  for reverse); ch5 1800; ch6, 7 1000; ch8 1800; channels 9-16 read 0. SIM_RC_FAIL 1: no
  pulses (the radio failsafe's RC_FS_TIMEOUT then runs out); 2: every channel 1500 but ch3
  (the throttle, "assumed to be on channel 3") at 950. SITL's receiver keeps those pulses until
  its next RC packet; towerlink's transmitter keeps sending its sticks (as autotest's RC
  thread streams them to SITL's RC port), so they are back as soon as SIM_RC_FAIL is 0 again.
  `transmit` moves the sticks: an RC packet as autotest's set_rc sends it (8 or 16 pulses, 0
  leaves a channel, its length the receiver's channel count).
- RC_CHANNELS_OVERRIDE (GCS_MAVLINK::handle_rc_channels_override), accepted by the link only
  from SYSID_MYGCS: chan1..8 = 65535 leaves that channel as it is, any other value (0
  included) is set as its override; chan9..18 = 0 or 65535 leave it, 65534 releases it
  (override 0), others are set. Channels past NUM_CHANNELS (17, 18) are dropped.
- MANUAL_CONTROL (the vehicle's handle_manual_control_axes, mapped here by the caller with
  `manual_override`): pwm = RCn_MIN + (RCn_MAX - RCn_MIN) * (value + offset) / scaler, the
  value negated first when reversed; INT16_MAX releases the channel (override 0).

An override counts while it is non-zero and younger than RC_OVERRIDE_TIME (s; 0 disables
overrides, negative never times out) (RC_Channel::has_override). Each tick `read(t)` is
RC_Channels::read_input: a new frame when a receiver pulse or a new override arrived since
the last read; then every channel with an override takes it as radio_in, the others the
receiver's last pulse (so a released or timed-out override goes back to the receiver's value,
also once its pulses have stopped); before the receiver's first frame they keep their last
value. `last_frame` is the sim time of the last
frame (the radio failsafe's RC_FS_TIMEOUT counts from it).

Sticks (RC_Channel's conversions, RCn_MIN/MAX/TRIM/DZ/REVERSED, channels by RCMAP_*):
roll, pitch and yaw as norm_input_dz (-1..1: right, nose-up, right), the throttle as
pwm_to_range (0..1000, dead zone at the bottom) and as norm_input_dz (-1..1, Rover's).
With the receiver's throttle at 1000 (below RC3_MIN) a copter's pilot modes (ALT_HOLD,
LOITER, POSHOLD) descend at PILOT_SPEED_DN, as ArduCopter SITL's do: autotest raises RC3 to
1500 before flying them.

The flight mode switch (FLTMODE_CH / MODE_CH) is not read. ArduCopter reads it from its first
debounced position (reset_mode_switch starts it at "none"), so ~200 ms after the receiver's
first frame it sets FLTMODE6 (ch5 at 1800), STABILIZE by default, the mode it booted in: no
change; after that the switch never moves. towerlink boots as that leaves it. Not modelled:
a non-default FLTMODE6 (ArduCopter would boot into it) and Rover's MODE6 (MANUAL, where
towerlink's rover boots in HOLD).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

NUM_CHANNELS = 16              # ArduPilot's NUM_RC_CHANNELS
UINT16_MAX = 65535
RELEASE = UINT16_MAX - 1       # chan9..18: back to the radio
INT16_MAX = 32767              # MANUAL_CONTROL: axis not used -> release
SITL_FAIL_THROTTLE = 950       # SIM_RC_FAIL 2: the throttle's pulse (us)
SITL_NEUTRAL = 1500
IGNORE_RECEIVER, IGNORE_OVERRIDES = 1, 2    # RC_OPTIONS bits
NO_PULSES, THROTTLE_950 = 1, 2              # SIM_RC_FAIL values
RECEIVER_PERIOD = 0.02         # s between the simulated receiver's frames (50 Hz)
TICK_SLACK = 1e-6              # s: a tick that float rounding puts just short of a frame still gets it
RECEIVER_CHANNELS = 8          # what SITL's receiver reports (RC_CHANNELS chancount)
SITL_CHANCOUNT = 16            # SIM_RC_CHANCOUNT: the count before any receiver frame
# the transmitter's resting positions, ch1..8 (us)
COPTER_RECEIVER = (1500, 1500, 1000, 1500, 1800, 1000, 1000, 1800)
ROVER_RECEIVER = (1500, 1500, 1500, 1500, 1800, 1000, 1000, 1800)


@dataclass(frozen=True)
class Sticks:
    """The pilot's sticks after RC_Channel's scaling. roll, pitch, yaw: -1..1 after the dead
    zone (positive: roll right, pitch back / nose up, yaw right). throttle: 0..1000
    (pwm_to_range: Copter's control_in); throttle_norm: -1..1 about trim (Rover's throttle);
    throttle_mid: the mid stick as a control_in value (get_control_mid); throttle_pwm: us."""
    roll: float
    pitch: float
    yaw: float
    throttle: int
    throttle_norm: float
    throttle_mid: int
    throttle_pwm: int


def _p(params: Mapping[str, float], n: int, what: str, default: float) -> int:
    return int(params.get(f"RC{n}_{what}", default))


def channel_numbers(params: Mapping[str, float]) -> tuple[int, int, int, int]:
    """(roll, pitch, throttle, yaw) channel numbers, 1-based (RCMAP_*; defaults 1, 2, 3, 4)."""
    return (int(params.get("RCMAP_ROLL", 1)), int(params.get("RCMAP_PITCH", 2)),
            int(params.get("RCMAP_THROTTLE", 3)), int(params.get("RCMAP_YAW", 4)))


def norm_input_dz(pwm: int, lo: int, hi: int, trim: int, dz: int, reversed_: bool) -> float:
    """RC_Channel::norm_input_dz: -1..1 about trim, 0 within dz of it."""
    dz_min, dz_max = trim - dz, trim + dz
    sign = -1.0 if reversed_ else 1.0
    if pwm < dz_min and dz_min > lo:
        out = sign * (pwm - dz_min) / (dz_min - lo)
    elif pwm > dz_max and hi > dz_max:
        out = sign * (pwm - dz_max) / (hi - dz_max)
    else:
        out = 0.0
    return max(-1.0, min(1.0, out))


def pwm_to_range(pwm: int, lo: int, hi: int, dz: int, reversed_: bool, high: int = 1000) -> int:
    """RC_Channel::pwm_to_range_dz: 0..high above lo + dz (integer arithmetic as ArduPilot's)."""
    r = max(lo, min(hi, pwm))
    if reversed_:
        r = hi - (r - lo)
    low = lo + dz
    if r > low and hi != low:
        return int(high * (r - low) / (hi - low))
    return 0


def control_mid(lo: int, hi: int, dz: int, high: int = 1000) -> int:
    """RC_Channel::get_control_mid of a range channel: mid stick as a control_in value."""
    if hi == lo + dz:
        return 0
    return int(high * ((lo + hi) // 2 - (lo + dz)) / (hi - (lo + dz)))


def manual_pwm(value: int, offset: int, scaler: float, lo: int, hi: int, reversed_: bool = False) -> int:
    """GCS_MAVLINK::manual_override's PWM for one MANUAL_CONTROL axis (0: release)."""
    if value == INT16_MAX:
        return 0
    if reversed_:
        value = -value
    return int(lo + (hi - lo) * (value + offset) / scaler)


class RcInput:
    """One vehicle's RC input: overrides, the simulated receiver, radio_in per channel."""

    def __init__(self, params: Mapping[str, float], receiver: Sequence[int] = COPTER_RECEIVER) -> None:
        """receiver: the transmitter's resting pulses of channels 1.. (us)."""
        self.params = params
        self.sent = [int(v) for v in receiver] + [0] * (NUM_CHANNELS - len(receiver))   # the transmitter's
        self.sent_count = len(receiver)
        self.frame = self._frame_of(self.sent)     # what the receiver sends of them
        self.override = [0] * NUM_CHANNELS          # us; 0 = none
        self.override_t = [0.0] * NUM_CHANNELS      # sim s it was set
        self.radio_in = [0] * NUM_CHANNELS          # us; 0 = never had a value
        self.new_overrides = False
        self.next_pulse = 0.0                       # sim s the receiver's next frame is due
        self.last_frame: float | None = None        # sim s of the last RC frame
        self.receiver_seen = False                  # ArduPilot's has_had_rc_receiver
        self.last_pulses: list[int] | None = None   # the receiver's last frame
        self.override_seen = False                  # has_had_rc_override
        self.sticks: Sticks | None = None           # None until the first frame
        self._scaled: tuple | None = None           # (radio_in, params.changes) `sticks` came from

    # ----- what comes in --------------------------------------------------------------
    def set_override(self, ch: int, value: int, t: float) -> None:
        """RC_Channel::set_override of channel index ch (0-based)."""
        if 0 <= ch < NUM_CHANNELS:
            self.override[ch] = int(value)
            self.override_t[ch] = t
            self.new_overrides = True
            self.override_seen = True

    def channels_override(self, values: Sequence[int], t: float) -> None:
        """RC_CHANNELS_OVERRIDE's chan1_raw..chan18_raw (the sender already checked)."""
        for i, v in enumerate(values):
            v = int(v)
            if i < 8:
                if v != UINT16_MAX:
                    self.set_override(i, v, t)
            elif v not in (0, UINT16_MAX):
                self.set_override(i, 0 if v == RELEASE else v, t)

    def manual_override(self, channel: int, value: int, offset: int, scaler: float, t: float,
                        reversed_: bool = False) -> None:
        """One MANUAL_CONTROL axis onto channel number `channel` (1-based)."""
        p = self.params
        lo, hi = _p(p, channel, "MIN", 1100), _p(p, channel, "MAX", 1900)
        self.set_override(channel - 1, manual_pwm(value, offset, scaler, lo, hi, reversed_), t)

    def transmit(self, pulses: Sequence[int]) -> None:
        """The transmitter's sticks moved: SITL's RC input packet (read_all_socket_input), 8 or
        16 pulses (us) of channels 1..; 0 leaves a channel as it was. The receiver sends them
        from its next frame, and the packet's length is its channel count (chancount)."""
        if len(pulses) not in (RECEIVER_CHANNELS, NUM_CHANNELS):
            raise ValueError(f"an RC packet has 8 or 16 channels, not {len(pulses)}")
        for i, v in enumerate(pulses):
            if int(v):
                self.sent[i] = int(v)
        self.sent_count = len(pulses)
        self.frame = self._frame_of(self.sent)

    def clear_overrides(self) -> None:
        """RC_Channels::clear_overrides (the GCS failsafe drops them)."""
        self.override = [0] * NUM_CHANNELS
        self.override_t = [0.0] * NUM_CHANNELS

    # ----- reading ----------------------------------------------------------------------
    def has_override(self, ch: int, t: float) -> bool:
        """RC_Channel::has_override: non-zero and not timed out (RC_OVERRIDE_TIME)."""
        if self.override[ch] == 0:
            return False
        timeout = float(self.params.get("RC_OVERRIDE_TIME", 3.0))
        if timeout < 0:
            return True
        if timeout == 0:
            return False
        return t - self.override_t[ch] < timeout

    def receiver_frame(self) -> list[int] | None:
        """The simulated receiver's pulses of channels 1..16 (SIM_RC_FAIL as the module doc
        says; channels past its count read 0), None for no pulses."""
        fail = self.params.get("SIM_RC_FAIL", 0)
        if not fail:
            return self.frame
        if fail == NO_PULSES:
            return None
        return self._frame_of([SITL_NEUTRAL, SITL_NEUTRAL, SITL_FAIL_THROTTLE] + [SITL_NEUTRAL] * (NUM_CHANNELS - 3))

    def _frame_of(self, pulses: list[int]) -> list[int]:
        """Channels 1..16 of the receiver's frame: `pulses` up to its channel count, 0 past it."""
        n = self.sent_count
        return pulses[:n] + [0] * (NUM_CHANNELS - n)

    def read(self, t: float) -> bool:
        """RC_Channels::read_input at sim time t: True when a new frame was read (the
        channels then hold it and `sticks` is updated). The receiver sends a frame every
        RECEIVER_PERIOD. RC_OPTIONS bit 0 ignores the receiver, bit 1 the overrides
        (ignore_receiver, ignore_overrides)."""
        if not self.new_overrides and t < self.next_pulse:
            return False               # the common tick: no receiver frame due, no new override
        rx = None
        if t >= self.next_pulse:
            self.next_pulse = t + RECEIVER_PERIOD - TICK_SLACK
            rx = self.receiver_frame()
        options = int(self.params.get("RC_OPTIONS", 32))
        if options & IGNORE_RECEIVER:
            rx = None
        if options & IGNORE_OVERRIDES:
            self.new_overrides = False
        if rx is not None:
            self.receiver_seen = True
            self.last_pulses = rx
        elif not self.new_overrides:
            return False
        self.new_overrides = False
        # a channel without an override reads the receiver's last pulse once it has sent one
        # (hal.rcin->read keeps it when the pulses stop), else keeps its radio_in
        src = self.last_pulses if self.receiver_seen and not options & IGNORE_RECEIVER else None
        got = False
        if rx is not None and (options & IGNORE_OVERRIDES or not any(self.override)):
            self.radio_in[:] = rx      # the receiver alone (the common frame)
            got = True
        else:
            for ch in range(NUM_CHANNELS):
                if self.override[ch] and not options & IGNORE_OVERRIDES and self.has_override(ch, t):
                    self.radio_in[ch] = self.override[ch]
                elif src is not None:
                    self.radio_in[ch] = src[ch]
                else:
                    continue
                got = True
        if got:
            self.last_frame = t
            self._rescale()
        return got

    def _rescale(self) -> None:
        """`sticks` from radio_in, unless neither it nor the parameters (a ParamStore counts
        its changes; a plain mapping is read again every time) changed since."""
        changes = getattr(self.params, "changes", None)
        if changes is not None and self._scaled is not None and self._scaled[1] == changes \
                and self._scaled[0] == self.radio_in:
            return
        self.sticks = self.scale()
        self._scaled = (self.radio_in.copy(), changes)

    def pwm(self, channel: int) -> int:
        """radio_in of channel number `channel` (1-based; 0 = none yet)."""
        return self.radio_in[channel - 1] if 1 <= channel <= NUM_CHANNELS else 0

    def scale(self) -> Sticks:
        """The sticks from radio_in (channels without a value yet read as their trim)."""
        p = self.params
        roll_ch, pitch_ch, thr_ch, yaw_ch = channel_numbers(p)

        def norm(n: int) -> float:
            lo, hi, trim = _p(p, n, "MIN", 1100), _p(p, n, "MAX", 1900), _p(p, n, "TRIM", 1500)
            pwm = self.pwm(n) or trim
            return norm_input_dz(pwm, lo, hi, trim, _p(p, n, "DZ", 0), bool(_p(p, n, "REVERSED", 0)))

        lo, hi = _p(p, thr_ch, "MIN", 1100), _p(p, thr_ch, "MAX", 1900)
        dz, rev = _p(p, thr_ch, "DZ", 0), bool(_p(p, thr_ch, "REVERSED", 0))
        thr_pwm = self.pwm(thr_ch) or _p(p, thr_ch, "TRIM", 1500)
        return Sticks(roll=norm(roll_ch), pitch=norm(pitch_ch), yaw=norm(yaw_ch),
                      throttle=pwm_to_range(thr_pwm, lo, hi, dz, rev), throttle_norm=norm(thr_ch),
                      throttle_mid=control_mid(lo, hi, dz), throttle_pwm=thr_pwm)

    def channel_count(self) -> int:
        """RC_CHANNELS chancount (get_valid_channel_count): the receiver's channels (8 unless
        a 16-channel packet came) once it has sent a frame, SITL's SIM_RC_CHANCOUNT (16) before."""
        return self.sent_count if self.receiver_seen else SITL_CHANCOUNT

    def channels(self, n: int = NUM_CHANNELS) -> list[int]:
        """radio_in of channels 1..n for RC_CHANNELS. Once the receiver has sent a frame that
        is ArduPilot's radio_in (0 for the channels it has no pulse for); before, a channel
        without a value reads as its RCn_TRIM (1500 past the channels with parameters)."""
        if self.receiver_seen:
            return self.radio_in[:n]
        p = self.params
        return [self.radio_in[i] or _p(p, i + 1, "TRIM", 1500) for i in range(n)]
