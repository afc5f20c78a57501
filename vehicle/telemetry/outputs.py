"""What goes out to the motors and what comes in from the radio: SERVO_OUTPUT_RAW,
RC_CHANNELS, (Rover) RC_CHANNELS_SCALED and (Copter) ESC_TELEMETRY_1_TO_4.

Servo outputs are the simulated drive's, as ArduPilot's output stage would write them:
- Copter (quad X, ArduPilot's motor order FR, BL, FL, BR on servos 1-4): each rotor's speed
  as a fraction of full speed (what the mixer commanded, through the motor's lag) mapped
  onto MOT_PWM_MIN..MOT_PWM_MAX (disarmed 0 -> MOT_PWM_MIN, armed idle MOT_SPIN_ARM).
- Rover (skid steering, ArduRover's ThrottleLeft on servo 1 and ThrottleRight on servo 3):
  throttle (speed / SIM_RVR_MAX_SPD) plus and minus steering (turn rate / the turn-rate
  limit), scaled into -1..1 together as AP_MotorsUGV does, mapped onto the servo's
  1100 / 1500 / 1900 us (SERVOn_MIN / TRIM / MAX defaults).
Outputs with no function are 0.

ESC_TELEMETRY_1_TO_4 (AP_ESC_Telem::send_esc_telemetry_mavlink; ArduPilot SITL's ESC
telemetry, SIM_ESC_TELEM 1, reports each motor's simulated rpm and fixed electrical values,
and nothing in its first 6 s): rpm = each rotor's speed (rev/min), in ArduPilot's motor
order; voltage (cV) the battery's pack voltage, current (cA) and totalcurrent (mAh) a
quarter of the pack's current and consumption (SITL sends a constant 16.8 V, 0.8 A, 1 mAh;
towerlink has no per-motor electrics, so the pack is shared evenly); temperature 0 degC
(SITL's 32 cdegC in whole degrees); count the ESC telemetry updates at the 50 Hz autopilot
tick since boot, wrapping at 65535. A rover sends none (SITL's rover has no ESC telemetry).

RC_CHANNELS reports the RC input (vehicle/autopilot/rc_input.py) as ArduPilot's radio_in:
the simulated receiver's 8 channels (chancount 8; channels 9-16 0) or a GCS's override
(RC_CHANNELS_OVERRIDE, MANUAL_CONTROL) where there is one; with no receiver frame ever
(SIM_RC_FAIL 1 from boot) a channel keeps its last pulse, one that never had one reads its
RCn_TRIM, and chancount is SITL's 16; RSSI unknown (255). The servo outputs follow what the
sticks fly, through the simulated drive.
"""
from __future__ import annotations

import math

from vehicle.telemetry.wire import boot_ms, wire_clamp

RSSI_UNKNOWN = 255
RC_CHANNELS_SIM = 16
SERVO_MIN, SERVO_TRIM, SERVO_MAX = 1100, 1500, 1900
U16 = (0, 65535)
ESC_SILENT_S = 6.0          # AP_ESC_Telem_SITL sends no data in the first 6 s after boot
ESC_UPDATE_HZ = 50.0
RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)


def servo_pwm(x: float) -> int:
    """A -1..1 output on a servo with the default range (trim at 0)."""
    x = max(-1.0, min(1.0, x))
    span = (SERVO_MAX - SERVO_TRIM) if x >= 0 else (SERVO_TRIM - SERVO_MIN)
    return wire_clamp(SERVO_TRIM + x * span, *U16)


def skid_mix(throttle: float, steering: float) -> tuple[float, float]:
    """(left, right) motor outputs of skid steering, both scaled down together to fit -1..1."""
    left, right = throttle + steering, throttle - steering
    over = max(1.0, abs(left), abs(right))
    return left / over, right / over


class OutputsTelemetry:
    """SERVO_OUTPUT_RAW, RC_CHANNELS and RC_CHANNELS_SCALED of one vehicle."""

    def __init__(self, ap, clock) -> None:
        self.ap = ap
        self.clock = clock

    def _skid(self) -> tuple[float, float]:
        fleet, i = self.ap.fleet, self.ap.i
        speed, rate = fleet.drive_outputs(i)[1:]
        g = fleet.gains_of(i)
        return skid_mix(speed / g.max_speed, rate / g.max_rate)

    def servo_outputs(self) -> list[int]:
        """servo1..16 in microseconds (0 = no function)."""
        ap = self.ap
        out = [0] * 16
        if ap.kind == "copter":
            lo = float(ap.params.get("MOT_PWM_MIN", 1000))
            hi = float(ap.params.get("MOT_PWM_MAX", 2000))
            for k, f in enumerate(ap.fleet.motor_outputs(ap.i)):
                out[k] = wire_clamp(lo + (hi - lo) * f, *U16)
        else:
            left, right = self._skid()
            out[0], out[2] = servo_pwm(left), servo_pwm(right)
        return out

    def servo_output_raw_fields(self) -> tuple:
        t_us = int(self.clock() * 1e6) & 0xFFFFFFFF          # ArduPilot: 32-bit micros()
        return (t_us, 0, *self.servo_outputs())

    def rc_channels_fields(self) -> tuple:
        rc = self.ap.rc
        chans = [wire_clamp(v, *U16) for v in rc.channels(RC_CHANNELS_SIM)]
        return (boot_ms(self.clock()), rc.channel_count(), *chans, 0, 0, RSSI_UNKNOWN)

    def rc_channels_scaled_fields(self) -> tuple | None:
        """Rover's SERVO_OUT: the skid-steering outputs x 10000 on channels 1 and 3."""
        if self.ap.kind != "rover":
            return None
        left, right = self._skid()
        s16 = (-32768, 32767)
        return (boot_ms(self.clock()), 0, wire_clamp(10000 * left, *s16), 0, wire_clamp(10000 * right, *s16),
                0, 0, 0, 0, 0, RSSI_UNKNOWN)

    def esc_telemetry_1_to_4_fields(self) -> tuple | None:
        """ESC_TELEMETRY_1_TO_4 of a copter's four motors (module doc); None for a rover."""
        ap = self.ap
        t = self.clock()
        if ap.kind != "copter" or t < ESC_SILENT_S:
            return None
        w_max = ap.fleet.airframe.omega_max
        rpm = [wire_clamp(f * w_max * RPM_PER_RAD_S, *U16) for f in ap.fleet.motor_outputs(ap.i)]
        b = ap.battery.reading(ap.params.values)
        volt = 0 if b.voltage is None else wire_clamp(b.voltage * 100.0, *U16)
        amps = 0 if b.current is None else wire_clamp(b.current * 25.0, *U16)         # cA, a quarter
        mah = 0 if b.consumed_mah is None else wire_clamp(b.consumed_mah / 4.0, *U16)
        count = int(t * ESC_UPDATE_HZ) & 0xFFFF
        return ([0] * 4, [volt] * 4, [amps] * 4, [mah] * 4, rpm, [count] * 4)
