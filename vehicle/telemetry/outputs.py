"""What goes out to the motors and what comes in from the radio: SERVO_OUTPUT_RAW,
RC_CHANNELS and (Rover) RC_CHANNELS_SCALED.

Servo outputs are the simulated drive's, as ArduPilot's output stage would write them:
- Copter (quad X, ArduPilot's motor order FR, BL, FL, BR on servos 1-4): each rotor's speed
  as a fraction of full speed (what the mixer commanded, through the motor's lag) mapped
  onto MOT_PWM_MIN..MOT_PWM_MAX (disarmed 0 -> MOT_PWM_MIN, armed idle MOT_SPIN_ARM).
- Rover (skid steering, ArduRover's ThrottleLeft on servo 1 and ThrottleRight on servo 3):
  throttle (speed / SIM_RVR_MAX_SPD) plus and minus steering (turn rate / the turn-rate
  limit), scaled into -1..1 together as AP_MotorsUGV does, mapped onto the servo's
  1100 / 1500 / 1900 us (SERVOn_MIN / TRIM / MAX defaults).
Outputs with no function are 0.

RC_CHANNELS reports the RC input (vehicle/autopilot/rc_input.py) as ArduPilot's radio_in:
a channel the GCS has overridden (RC_CHANNELS_OVERRIDE, MANUAL_CONTROL; the simulated
receiver of SIM_RC_FAIL 2) at its pulse, which it keeps once the override stops; a channel
that never had one at its RCn_TRIM (1500 for channels 9-16, which have no parameters here);
16 channels as SITL's RC input has, RSSI unknown (255). The servo outputs follow what the
sticks fly, through the simulated drive.
"""
from __future__ import annotations

from vehicle.telemetry.wire import boot_ms, wire_clamp

RSSI_UNKNOWN = 255
RC_CHANNELS_SIM = 16
SERVO_MIN, SERVO_TRIM, SERVO_MAX = 1100, 1500, 1900
U16 = (0, 65535)


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
        chans = [wire_clamp(v, *U16) for v in self.ap.rc.channels(RC_CHANNELS_SIM)]
        return (boot_ms(self.clock()), RC_CHANNELS_SIM, *chans, 0, 0, RSSI_UNKNOWN)

    def rc_channels_scaled_fields(self) -> tuple | None:
        """Rover's SERVO_OUT: the skid-steering outputs x 10000 on channels 1 and 3."""
        if self.ap.kind != "rover":
            return None
        left, right = self._skid()
        s16 = (-32768, 32767)
        return (boot_ms(self.clock()), 0, wire_clamp(10000 * left, *s16), 0, wire_clamp(10000 * right, *s16),
                0, 0, 0, 0, 0, RSSI_UNKNOWN)
