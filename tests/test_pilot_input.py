"""The pilot's sticks as ArduPilot reads them, in-process: RC_CHANNELS_OVERRIDE's per-channel
semantics and MANUAL_CONTROL's mapping (vehicle/autopilot/rc_input.py, against a model of
GCS_MAVLINK::handle_rc_channels_override), RC_Channel's scaling and ArduCopter's stick
scaling (copter_pilot.py) as properties, the override timeout, and the autopilot's radio
failsafe and throttle arming checks on the real World stepped in sim time."""
from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from test_autopilot_behaviour import _until, _with_texts, _world
from test_sitl_support import mav
from vehicle.autopilot import copter_pilot, modes
from vehicle.autopilot.rc_input import (INT16_MAX, NUM_CHANNELS, ROVER_RECEIVER, RcInput, Sticks, control_mid, manual_pwm,
                                        norm_input_dz, pwm_to_range)

A = mav
KEEP = 65535
pwm = st.integers(0, 65535)


def _model(before: list[int], values: list[int]) -> list[int]:
    """handle_rc_channels_override as its source reads: chan1..8 UINT16_MAX keeps, others set
    (0 too); chan9..18 0 and UINT16_MAX keep, UINT16_MAX-1 releases (0); past 16 dropped."""
    out = list(before)
    for i, v in enumerate(values):
        if i >= NUM_CHANNELS:
            continue
        if i < 8:
            if v != 65535:
                out[i] = v
        elif v not in (0, 65535):
            out[i] = 0 if v == 65534 else v
    return out


@settings(max_examples=200, deadline=None)
@given(st.lists(st.lists(st.one_of(pwm, st.sampled_from([0, 65534, 65535, 1500])), min_size=18, max_size=18),
                min_size=1, max_size=4))
def test_override_semantics_per_channel_range(messages):
    rc = RcInput({})
    want = [0] * NUM_CHANNELS
    for values in messages:
        rc.channels_override(values, 1.0)
        want = _model(want, values)
        assert rc.override == want


@settings(max_examples=300, deadline=None)
@given(st.integers(800, 2200), st.integers(800, 1400), st.integers(1600, 2200), st.integers(0, 200), st.booleans())
def test_norm_input_dz_is_bounded_monotonic_and_zero_in_the_dead_zone(p, lo, hi, dz, rev):
    trim = (lo + hi) // 2
    x = norm_input_dz(p, lo, hi, trim, dz, rev)
    assert -1.0 <= x <= 1.0
    if abs(p - trim) <= dz:
        assert x == 0.0
    y = norm_input_dz(min(p + 10, 2200), lo, hi, trim, dz, rev)
    assert (y >= x) if not rev else (y <= x)
    assert norm_input_dz(p, lo, hi, trim, dz, not rev) == -x


@settings(max_examples=300, deadline=None)
@given(st.integers(800, 2200), st.integers(800, 1400), st.integers(1600, 2200), st.integers(0, 100))
def test_throttle_range_is_0_to_1000_and_monotonic(p, lo, hi, dz):
    r = pwm_to_range(p, lo, hi, dz, False)
    assert 0 <= r <= 1000
    assert pwm_to_range(p + 1, lo, hi, dz, False) >= r
    assert pwm_to_range(hi, lo, hi, dz, False) == 1000 and pwm_to_range(lo + dz, lo, hi, dz, False) == 0


def test_manual_control_axes_map_onto_the_channel_range():
    # x forward (+1000) is the pitch channel's low end, as ArduCopter's reversed mapping
    assert manual_pwm(1000, 1000, 2000, 1100, 1900, reversed_=True) == 1100
    assert manual_pwm(-1000, 1000, 2000, 1100, 1900, reversed_=True) == 1900
    assert manual_pwm(0, 1000, 2000, 1100, 1900) == 1500
    assert manual_pwm(0, 0, 1000, 1100, 1900) == 1100 and manual_pwm(1000, 0, 1000, 1100, 1900) == 1900
    assert manual_pwm(INT16_MAX, 1000, 2000, 1100, 1900) == 0          # release


def _sticks(throttle_pwm: int, roll=0.0, pitch=0.0, yaw=0.0) -> Sticks:
    thr = pwm_to_range(throttle_pwm, 1100, 1900, 30, False)
    return Sticks(roll, pitch, yaw, thr, 0.0, control_mid(1100, 1900, 30), throttle_pwm)


@settings(max_examples=200, deadline=None)
@given(st.integers(1100, 1900), st.integers(50, 500), st.integers(0, 500), st.integers(0, 300))
def test_climb_rate_dead_band_and_limits(p, up, dn, dz):
    params = {"PILOT_SPEED_UP": up, "PILOT_SPEED_DN": dn, "THR_DZ": dz}
    s = _sticks(p)
    c = copter_pilot.climb_rate(s, params)
    assert -(dn or up) / 100.0 - 1e-9 <= c <= up / 100.0 + 1e-9
    if abs(s.throttle - s.throttle_mid) <= dz:
        assert c == 0.0
    assert copter_pilot.climb_rate(_sticks(1900), params) == pytest.approx(up / 100.0)
    assert copter_pilot.climb_rate(_sticks(1100), params) == pytest.approx(-(dn or up) / 100.0)


@settings(max_examples=200, deadline=None)
@given(st.floats(-1, 1), st.floats(-1, 1))
def test_lean_angles_stay_within_angle_max(r, p):
    amax = math.radians(30)
    roll, pitch = copter_pilot.lean_angles(Sticks(r, p, 0.0, 0, 0.0, 480, 1500), amax)
    assert abs(roll) <= amax + 1e-9 and abs(pitch) <= amax + 1e-9
    assert math.copysign(1, roll) == math.copysign(1, r) or roll == 0.0


def test_mid_stick_throttle_is_the_hover_throttle():
    assert copter_pilot.throttle(_sticks(1500), 0.45) == pytest.approx(0.45, abs=0.01)
    assert copter_pilot.throttle(_sticks(1100), 0.45) == 0.0
    assert copter_pilot.throttle(_sticks(1900), 0.45) == pytest.approx(1.0)


def test_override_time_out_zero_and_never():
    params = {"RC_OVERRIDE_TIME": 3.0}
    rc = RcInput(params)
    rc.channels_override([1600] + [KEEP] * 17, 10.0)
    assert rc.has_override(0, 12.9) and not rc.has_override(0, 13.0)
    params["RC_OVERRIDE_TIME"] = -1
    assert rc.has_override(0, 1000.0)
    params["RC_OVERRIDE_TIME"] = 0
    assert not rc.has_override(0, 10.0)


def test_a_released_channel_goes_back_to_the_receiver():
    rc = RcInput({})
    assert rc.read(0.0) and rc.channels(9) == [1500, 1500, 1000, 1500, 1800, 1000, 1000, 1800, 0]
    assert rc.channel_count() == 8 and rc.sticks.throttle == 0
    assert not rc.read(0.01)                                           # the next frame: 20 ms on
    rc.channels_override([1600, 1700] + [KEEP] * 16, 1.0)
    assert rc.read(1.0) and rc.channels(3) == [1600, 1700, 1000]
    rc.channels_override([0] + [KEEP] * 17, 1.01)                     # chan1 released
    assert rc.read(1.01) and rc.channels(2) == [1500, 1700]           # the receiver's last pulse at once
    assert rc.read(1.02) and rc.channels(2) == [1500, 1700]           # and its next frame
    assert rc.read(5.0) and rc.channels(2) == [1500, 1500]            # chan2's override timed out


def test_rover_receiver_centres_the_throttle():
    rc = RcInput({}, ROVER_RECEIVER)
    assert rc.read(0.0) and rc.channels(8) == [1500, 1500, 1500, 1500, 1800, 1000, 1000, 1800]
    assert rc.sticks.throttle_norm == 0.0


def test_receiver_frames_at_50_hz_and_rc_options_ignore_it():
    params = {}
    rc = RcInput(params)
    frames = sum(rc.read(k * 0.0025) for k in range(400))              # 1 s of 400 Hz ticks
    assert frames == 50 and rc.last_frame == pytest.approx(0.98)
    params["RC_OPTIONS"] = 32 | 1                                      # ignore the receiver
    assert not rc.read(2.0) and rc.last_frame == pytest.approx(0.98)


def test_transmit_is_an_rc_packet():
    """read_all_socket_input: 0 leaves a channel, the packet's length is the channel count;
    SIM_RC_FAIL 2 sends its own pulses and the transmitter's come back with SIM_RC_FAIL 0."""
    params = {}
    rc = RcInput(params)
    rc.transmit([0, 0, 1500, 0, 0, 0, 0, 0])
    assert rc.read(0.0) and rc.channels(8) == [1500, 1500, 1500, 1500, 1800, 1000, 1000, 1800]
    assert rc.sticks.throttle == rc.sticks.throttle_mid
    rc.transmit([1600] + [0] * 14 + [1200])
    assert rc.read(0.02) and rc.channel_count() == 16 and rc.channels(16)[::15] == [1600, 1200]
    params["SIM_RC_FAIL"] = 2
    assert rc.read(0.04) and rc.channels(16) == [1500, 1500, 950] + [1500] * 13
    params["SIM_RC_FAIL"] = 1
    assert not rc.read(0.06) and rc.channels(3) == [1500, 1500, 950]
    params["SIM_RC_FAIL"] = 0
    assert rc.read(0.08) and rc.channels(3) == [1600, 1500, 1500]
    with pytest.raises(ValueError):
        rc.transmit([1500] * 4)


def test_after_the_pulses_stop_a_released_channel_reads_the_receivers_last():
    params = {}
    rc = RcInput(params)
    assert rc.read(0.0)
    params["SIM_RC_FAIL"] = 1
    rc.channels_override([1600, KEEP, 1700] + [KEEP] * 15, 0.5)
    assert rc.read(0.5) and rc.channels(3) == [1600, 1500, 1700]
    rc.channels_override([0] + [KEEP] * 17, 0.6)                     # chan1 released
    assert rc.read(0.6) and rc.channels(3) == [1500, 1500, 1700]      # the receiver's last pulse


def test_without_pulses_a_released_channel_keeps_its_last_pulse():
    params = {"SIM_RC_FAIL": 1}
    rc = RcInput(params)
    assert not rc.read(0.0) and rc.channel_count() == 16 and rc.channels(3) == [1500, 1500, 1500]
    rc.channels_override([1600, 1700] + [KEEP] * 16, 1.0)
    assert rc.read(1.0) and rc.channels(3) == [1600, 1700, 1500]
    rc.channels_override([0] + [KEEP] * 17, 1.1)                     # chan1 released
    assert rc.read(1.1) and rc.channels(2) == [1600, 1700]            # radio_in stays (no pulses)
    assert not rc.read(1.2)                                            # nothing new: no frame


# ---------------------------------------------------------------- the autopilot, in sim time

def _hold(w, ap, chans, secs):
    """Send `chans` (RC_CHANNELS_OVERRIDE's) every 0.1 sim s for secs."""
    t0 = w.t
    while w.t - t0 < secs:
        ap.rc.channels_override(list(chans) + [KEEP] * (18 - len(chans)), ap.t)
        w.run_for(0.1)


@pytest.fixture
def copter():
    return _with_texts(_world())


def test_arming_refused_with_the_throttle_up(copter):
    w, ap, texts = copter
    _hold(w, ap, [1500, 1500, 1500, 1500], 0.3)                # STABILIZE: above zero is too high
    assert ap.arm() == A.MAV_RESULT_FAILED and texts[-1] == "Arm: Throttle too high"
    assert ap.set_mode(modes.ALT_HOLD)
    _hold(w, ap, [1500, 1500, 1800, 1500], 0.3)                # ALT_HOLD: a climb asked is too high
    assert ap.arm() == A.MAV_RESULT_FAILED and texts[-1] == "Arm: Throttle too high"
    _hold(w, ap, [1500, 1500, 1500, 1500], 0.3)                # mid stick: in the dead band
    assert ap.arm() == A.MAV_RESULT_ACCEPTED


def test_throttle_below_failsafe_is_a_prearm_failure(copter):
    w, ap, texts = copter
    ap.params.set("FS_THR_ENABLE", 0)                          # no failsafe, so the pre-arm check alone
    _hold(w, ap, [1500, 1500, 950, 1500], 0.3)
    ap.params.set("FS_THR_ENABLE", 1)
    assert ap.arm() == A.MAV_RESULT_FAILED and "PreArm: Throttle below failsafe" in texts


def _pilot_takeoff(w, ap):
    """ALT_HOLD, armed at mid stick, climbed on the throttle stick to over 4 m."""
    assert ap.set_mode(modes.ALT_HOLD)
    _hold(w, ap, [1500, 1500, 1500, 1500], 0.3)
    assert ap.arm() == A.MAV_RESULT_ACCEPTED
    _hold(w, ap, [1500, 1500, 1900, 1500], 5)
    assert ap.pos[2] < -4.0 and not ap.radio.active


def test_released_overrides_go_back_to_the_receiver_no_failsafe(copter):
    w, ap, texts = copter
    _pilot_takeoff(w, ap)
    z = float(ap.pos[2])
    ap.rc.channels_override([0] * 8 + [KEEP] * 10, ap.t)             # every override released
    w.run_for(5.0)
    assert ap.rc.channels(4) == [1500, 1500, 1000, 1500]             # the receiver's sticks
    assert not ap.radio.active and "Radio Failsafe" not in texts
    assert ap.flightmode is ap.flightmodes[modes.ALT_HOLD]
    assert ap.pos[2] - z > 3.0 and ap.vel[2] > 2.0                   # throttle at 1000: descends


def test_radio_failsafe_on_lost_pulses_rtl_and_cleared(copter):
    w, ap, texts = copter
    _pilot_takeoff(w, ap)
    ap.params.set("SIM_RC_FAIL", 1)                                  # the receiver goes silent
    last = ap.rc.last_frame                                          # the last override's frame
    _until(w, lambda: ap.radio.active, 5)                            # no more overrides either
    assert 1.0 <= ap.t - last <= 1.1                                 # RC_FS_TIMEOUT
    assert "Radio Failsafe" in texts and ap.flightmode is ap.flightmodes[modes.RTL]
    assert ap.system_status() == A.MAV_STATE_CRITICAL
    ap.params.set("SIM_RC_FAIL", 0)
    w.run_for(0.5)
    assert not ap.radio.active and texts[-1] == "Radio Failsafe Cleared"
    assert ap.flightmode is ap.flightmodes[modes.RTL]                # the mode is not restored


def test_radio_failsafe_landed_disarms(copter):
    w, ap, texts = copter
    w.run_for(0.3)                                                   # the receiver: throttle 1000
    assert ap.arm() == A.MAV_RESULT_ACCEPTED
    ap.params.set("SIM_RC_FAIL", 1)
    _until(w, lambda: not ap.armed, 3)
    assert "Radio Failsafe - Disarming" in texts


def test_sim_rc_fail_2_is_a_throttle_failsafe(copter):
    w, ap, texts = copter
    ap.params.set("SIM_RC_FAIL", 2)
    _until(w, lambda: ap.radio.active, 1)
    assert ap.rc.channels(9) == [1500, 1500, 950, 1500, 1500, 1500, 1500, 1500, 0]
    assert any(t.startswith("Radio Failsafe") for t in texts)
    ap.params.set("SIM_RC_FAIL", 0)                 # the transmitter's sticks again: 1000 is good
    w.run_for(1.0)
    assert not ap.radio.active and texts[-1] == "Radio Failsafe Cleared"


def test_the_sticks_follow_a_changed_scaling(copter):
    w, ap, _ = copter
    w.run_for(0.1)
    assert ap.rc.sticks.throttle == 0                       # 1000 is below RC3_MIN (1100)
    ap.params.set("RC3_MIN", 950)
    w.run_for(0.1)
    assert ap.rc.sticks.throttle > 0                         # the same pulse, scaled again


def test_receiver_alone_never_triggers_the_radio_failsafe(copter):
    w, ap, texts = copter
    w.run_for(0.5)
    assert ap.arm() == A.MAV_RESULT_ACCEPTED
    assert ap.set_mode(modes.GUIDED) and ap.command(A.MAV_CMD_NAV_TAKEOFF, [0] * 6 + [5.0]) == A.MAV_RESULT_ACCEPTED
    w.run_for(10.0)
    assert not ap.radio.active and ap.armed and ap.pos[2] < -4.0
    assert not any("Radio Failsafe" in t for t in texts)


def test_rover_manual_drives_on_the_sticks():
    w = _world(drones=0, rovers=1)
    ap = w.vehicles[0].ap
    assert ap.set_mode(modes.ROVER_MANUAL) and ap.arm() == A.MAV_RESULT_ACCEPTED
    _hold(w, ap, [1500, 1500, 1800, 1500], 3)
    fwd = ap.vel[0] * math.cos(ap.yaw) + ap.vel[1] * math.sin(ap.yaw)
    assert fwd > 6.0
    _hold(w, ap, [1800, 1500, 1500, 1500], 1)
    assert ap.rates[2] > 1.0                                   # steering right: turns right
    _hold(w, ap, [1500, 1500, 1500, 1500], 3)
    assert math.hypot(ap.vel[0], ap.vel[1]) < 0.2 and abs(ap.rates[2]) < 0.05
