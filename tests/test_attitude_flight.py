"""SET_ATTITUDE_TARGET flown by the real fleet and autopilot in-process (sim time, no sockets),
as ArduCopter's GUIDED and GUIDED_NOGPS fly it (mode_guided.cpp angle_control_run) and
ArduRover's GUIDED drives it: the target sent at 10 Hz as a companion computer or MAVSDK's
offboard sends it, through Autopilot.attitude_target (what the link calls)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from auto_world import Flight, hover_stick
from test_attitude_target import q_wxyz
from vehicle.autopilot import modes
from vehicle.autopilot.attitude_target import ATTITUDE_IGNORE, RATES_IGNORE, THROTTLE_IGNORE

C = mav
LEVEL = q_wxyz(0.0, 0.0, 0.0)
RATE_S = 0.1                  # s between targets


def send(f: Flight, seconds: float, mask=RATES_IGNORE, q=LEVEL, rates=(0.0, 0.0, 0.0), thrust=0.5, each=None):
    """The same target every RATE_S for `seconds` of sim time; each() after every step."""
    end = f.world.t + seconds
    while f.world.t < end - 1e-9:
        f.ap.attitude_target(mask, q, rates, thrust)
        f.step(RATE_S)
        if each is not None:
            each()


def roll_deg(f: Flight) -> float:
    return math.degrees(f.ap.euler[0])


def alt(f: Flight) -> float:
    return float(f.ap.home[2] - f.ap.pos[2])


def airborne(alt_m: float = 10.0, params: dict | None = None) -> Flight:
    f = Flight("copter", params=params)
    f.settle()
    assert f.ap.set_mode(modes.GUIDED) and f.ap.arm() == C.MAV_RESULT_ACCEPTED
    assert f.ap.command(C.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, alt_m]) == C.MAV_RESULT_ACCEPTED
    f.until(lambda: alt(f) > alt_m - 0.2, 40, "takeoff")
    f.step(2.0)
    return f


def armed_on_the_ground(mode: int = modes.GUIDED, params: dict | None = None) -> Flight:
    f = Flight("copter", params=params)
    f.settle()
    assert f.ap.set_mode(mode) and f.ap.arm() == C.MAV_RESULT_ACCEPTED
    return f


# ------------------------------------------------------------------ GUIDED: climb rate, takeoff

def test_thrust_0_7_takes_off_and_climbs_at_a_metre_a_second():
    """MAVSDK's offboard attitude example: level, thrust 0.7. ArduCopter reads thrust as a
    climb rate ((0.7 - 0.5) * 2 * WPNAV_SPEED_UP = 1 m/s) and a positive one takes off."""
    f = armed_on_the_ground()
    send(f, 2.0, thrust=0.5)                        # hold: stays on the ground
    send(f, 2.0, thrust=0.0)                        # descend: stays on the ground
    assert f.ap.on_ground and alt(f) < 0.05 and not f.ap.auto_armed
    speeds = []
    send(f, 8.0, thrust=0.7, each=lambda: speeds.append(-f.ap.vel[2]))
    assert f.ap.auto_armed and not f.ap.on_ground and f.ap.armed
    assert np.mean(speeds[-30:]) == pytest.approx(1.0, abs=0.1)
    assert 5.0 < alt(f) < 8.0
    assert f.ap.landed_state() == C.MAV_LANDED_STATE_IN_AIR
    assert f.ap.echo is None                        # no POSITION_TARGET_LOCAL_NED in angle control


def test_climb_and_descent_bounded_by_wpnav_speeds():
    f = airborne(10.0, params={"WPNAV_SPEED_UP": 200, "WPNAV_SPEED_DN": 100})
    up, down = [], []
    send(f, 5.0, thrust=1.0, each=lambda: up.append(-f.ap.vel[2]))
    send(f, 5.0, thrust=0.0, each=lambda: down.append(f.ap.vel[2]))
    assert np.mean(up[-20:]) == pytest.approx(2.0, abs=0.15)
    assert np.mean(down[-20:]) == pytest.approx(1.0, abs=0.15)


# ------------------------------------------------------------------ GUIDED: attitude, timeout

def test_a_20_degree_roll_target_is_flown_then_the_timeout_levels_and_holds():
    """Airborne at 10 m a 20 deg roll target (thrust 0.5: hold altitude) gives 20 deg of roll;
    GUID_TIMEOUT (3 s) after the last target the copter levels at its heading and holds its
    altitude (it drifts on: no position control), still in GUIDED, saying nothing."""
    f = airborne(10.0)
    z0 = alt(f)
    rolls = []
    send(f, 4.0, q=q_wxyz(math.radians(20), 0.0, f.ap.yaw), each=lambda: rolls.append(roll_deg(f)))
    assert np.mean(rolls[-10:]) == pytest.approx(20.0, abs=1.0)
    assert max(rolls) < 23.0 and abs(alt(f) - z0) < 0.5
    assert f.ap.vel[1] > 3.0                        # leaning right: accelerating east
    n = len(f.texts)
    f.step(2.5)                                     # within GUID_TIMEOUT: still the last target
    assert roll_deg(f) == pytest.approx(20.0, abs=1.5)
    f.step(2.5)                                     # past it: level
    assert abs(roll_deg(f)) < 1.5 and abs(math.degrees(f.ap.euler[1])) < 1.5
    assert abs(alt(f) - z0) < 0.6 and abs(f.ap.vel[2]) < 0.2
    assert f.ap.mode == modes.GUIDED and f.said()[n:] == []


def test_pitch_and_yaw_from_the_quaternion():
    f = airborne(10.0)
    yaw0 = f.ap.yaw
    send(f, 5.0, q=q_wxyz(0.0, math.radians(-10), yaw0 + math.radians(90)))
    assert math.degrees(f.ap.euler[1]) == pytest.approx(-10.0, abs=1.0)
    dyaw = math.degrees((f.ap.yaw - yaw0 + math.pi) % (2 * math.pi) - math.pi)
    assert dyaw == pytest.approx(90.0, abs=3.0)
    # nose down towards the new heading: moving that way
    heading = math.atan2(f.ap.vel[1], f.ap.vel[0])
    assert abs((heading - f.ap.yaw + math.pi) % (2 * math.pi) - math.pi) < math.radians(15)


def test_body_rates_alone_turn_the_attitude_and_zero_rates_hold_it():
    """ATTITUDE_IGNORE (MAVSDK's set_attitude_rate): the attitude turns at the body rates and
    stays where zero rates leave it (ArduCopter integrates the target attitude)."""
    f = airborne(10.0)
    send(f, 2.0, mask=ATTITUDE_IGNORE, q=(0, 0, 0, 0), rates=(math.radians(10), 0.0, 0.0))
    assert roll_deg(f) == pytest.approx(20.0, abs=2.0)
    send(f, 2.0, mask=ATTITUDE_IGNORE, q=(0, 0, 0, 0))
    assert roll_deg(f) == pytest.approx(20.0, abs=2.0)
    yaw0 = f.ap.yaw
    send(f, 3.0, mask=ATTITUDE_IGNORE | RATES_IGNORE, q=(0, 0, 0, 0))     # all rates ignored: zero
    assert roll_deg(f) == pytest.approx(20.0, abs=2.0) and abs(f.ap.yaw - yaw0) < 0.05


def test_yaw_rate_feed_forward_turns_the_heading():
    """A quaternion with body rates: the rates are feed-forward, and the target moves at them
    between messages (here only one target, then nothing new for 2 s)."""
    f = airborne(10.0)
    yaw0 = f.ap.yaw
    f.ap.attitude_target(0, q_wxyz(0.0, 0.0, yaw0), (0.0, 0.0, math.radians(30)), 0.5)
    f.step(2.0)
    turned = math.degrees((f.ap.yaw - yaw0 + math.pi) % (2 * math.pi) - math.pi)
    assert turned == pytest.approx(60.0, abs=10.0)


# ------------------------------------------------------------------ GUIDED: thrust as thrust

def test_guid_options_8_thrust_is_the_throttle():
    """GUID_OPTIONS bit 3: thrust drives the motors directly (angle boosted), no climb-rate
    bound: from the ground thrust 0.7 takes off and climbs twice WPNAV_SPEED_UP; a thrust
    below hover slows it; the timeout goes back to climb-rate control and holds an altitude."""
    f = armed_on_the_ground(params={"GUID_OPTIONS": 8})
    send(f, 2.0, thrust=0.7)                        # MOT_THST_HOVER 0.45: 1.55 g up
    climb = -f.ap.vel[2]
    assert not f.ap.on_ground and climb > 2.0 * f.ap.params["WPNAV_SPEED_UP"] / 100.0
    send(f, 2.0, thrust=0.35)                       # below hover: slowing down
    assert -f.ap.vel[2] < climb - 3.0
    f.step(12.0)                                    # timeout: climb rate 0 from where it is
    assert abs(f.ap.vel[2]) < 0.3 and alt(f) > 10.0 and not f.ap.on_ground


# ------------------------------------------------------------------ GUIDED: stops, switches

def test_throttle_ignored_stops_the_copter_and_holds_without_a_word():
    """ModeGuided::init(true): a zero velocity target, the copter brakes to a stop."""
    f = airborne(10.0)
    send(f, 3.0, q=q_wxyz(0.0, math.radians(-15), f.ap.yaw))
    assert np.linalg.norm(f.ap.vel[:2]) > 3.0
    n = len(f.texts)
    assert f.ap.attitude_target(THROTTLE_IGNORE, LEVEL, (0, 0, 0), 0.5) is False
    f.step(6.0)
    assert np.linalg.norm(f.ap.vel) < 0.3 and f.said()[n:] == []
    assert not f.ap.flightmode.angle.active and f.ap.echo is not None


@pytest.mark.parametrize("mask, q, why", [
    (RATES_IGNORE, (0.9, 0.0, 0.0, 0.0), "Guided: attitude quaternion not unit length"),
    (1, LEVEL, "Guided: partial body rate mask 0x1")])
def test_a_target_arducopter_cannot_fly_stops_and_says_why(mask, q, why):
    f = airborne(6.0)
    send(f, 2.0, q=q_wxyz(math.radians(15), 0.0, f.ap.yaw))
    assert f.ap.attitude_target(mask, q, (0, 0, 0), 0.5) is False
    assert f.said()[-1] == why
    f.step(5.0)
    assert np.linalg.norm(f.ap.vel) < 0.3


def test_a_position_target_takes_over_from_attitude_control():
    f = airborne(6.0)
    send(f, 2.0, q=q_wxyz(math.radians(10), 0.0, f.ap.yaw))
    goal = f.ap.local_origin.to_local(f.ap.pos + [5.0, 0.0, 0.0])
    mask = 0b110111111000                                     # position only
    assert f.ap.position_target_local(C.MAV_FRAME_LOCAL_NED, mask, tuple(goal), (0, 0, 0), (0, 0, 0), 0, 0)
    assert not f.ap.flightmode.angle.active
    f.until(lambda: np.linalg.norm(f.ap.local_origin.to_local(f.ap.pos) - goal) < 0.5, 30, "the point")


def test_ignored_outside_the_guided_modes():
    f = airborne(6.0)
    hover_stick(f.ap)
    assert f.ap.set_mode(modes.LOITER)
    x0 = f.ap.pos.copy()
    assert f.ap.attitude_target(RATES_IGNORE, q_wxyz(math.radians(20), 0, 0), (0, 0, 0), 1.0) is False
    f.step(2.0)
    assert abs(roll_deg(f)) < 1.0 and np.linalg.norm(f.ap.pos - x0) < 0.3


# ------------------------------------------------------------------ GUIDED_NOGPS

def test_guided_nogps_flies_attitude_targets_only():
    """GUIDED_NOGPS (20): armable from the GCS, takes off on a positive climb rate, flies the
    roll asked; ignores position targets; NAV_TAKEOFF refused; levels and holds on timeout."""
    f = armed_on_the_ground(modes.GUIDED_NOGPS)
    assert f.ap.mode_name == "GUIDED_NOGPS"
    assert f.ap.command(C.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 5]) == C.MAV_RESULT_FAILED
    send(f, 5.0, thrust=1.0)
    assert alt(f) > 8.0
    send(f, 4.0)                                    # climb rate 0: stops climbing, holds
    z = alt(f)
    rolls = []
    send(f, 3.0, q=q_wxyz(math.radians(-20), 0.0, f.ap.yaw), each=lambda: rolls.append(roll_deg(f)))
    assert np.mean(rolls[-10:]) == pytest.approx(-20.0, abs=1.0) and abs(alt(f) - z) < 0.5
    here = tuple(f.ap.local_origin.to_local(f.ap.pos))
    assert f.ap.position_target_local(C.MAV_FRAME_LOCAL_NED, 0b110111111000, here, (0, 0, 0), (0, 0, 0), 0, 0) is False
    f.step(5.0)
    assert abs(roll_deg(f)) < 1.5 and abs(alt(f) - z) < 0.6 and f.ap.mode == modes.GUIDED_NOGPS
    assert f.ap.command(C.MAV_CMD_DO_PAUSE_CONTINUE, [0] * 7) == C.MAV_RESULT_FAILED


def test_guided_nogps_entered_in_flight_levels_and_holds_altitude():
    f = airborne(8.0)
    send(f, 2.0, q=q_wxyz(0.0, math.radians(-10), f.ap.yaw))
    z = alt(f)
    assert f.ap.set_mode(modes.GUIDED_NOGPS)
    f.step(2.0)
    assert abs(math.degrees(f.ap.euler[1])) < 1.5 and abs(alt(f) - z) < 0.6
    send(f, 1.0, mask=THROTTLE_IGNORE)               # ArduCopter stops GUIDED, not this mode
    assert f.ap.mode == modes.GUIDED_NOGPS and f.ap.flightmode.angle.active


# ------------------------------------------------------------------ rover

def rover_in_guided(params: dict | None = None) -> Flight:
    f = Flight("rover", params=params)
    f.settle()
    assert f.ap.set_mode(modes.ROVER_GUIDED) and f.ap.arm() == C.MAV_RESULT_ACCEPTED
    return f


def test_rover_drives_the_heading_at_thrust_times_the_default_speed():
    f = rover_in_guided({"WP_SPEED": 4.0})
    send(f, 6.0, q=q_wxyz(0.3, 0.2, math.radians(90)), thrust=0.5)        # roll, pitch ignored
    v = f.ap.vel[:2]
    assert np.linalg.norm(v) == pytest.approx(2.0, abs=0.15)
    assert math.degrees(math.atan2(v[1], v[0])) == pytest.approx(90.0, abs=3.0)


def test_rover_turns_at_the_body_yaw_rate_and_stops_after_3_s():
    f = rover_in_guided()                        # WP_SPEED 0: CRUISE_SPEED (8 m/s) is the default
    yaws = []
    mask = 0b011                                 # the yaw rate is used
    send(f, 6.0, mask=mask, q=(0, 0, 0, 0), rates=(0, 0, math.radians(20)), thrust=0.25,
         each=lambda: yaws.append(f.ap.yaw))
    rate = np.degrees(np.diff(np.unwrap(yaws[-20:]))).mean() / RATE_S
    assert rate == pytest.approx(20.0, abs=4.0)
    assert np.linalg.norm(f.ap.vel[:2]) == pytest.approx(2.0, abs=0.3)
    assert f.ap.attitude_target(THROTTLE_IGNORE | mask, (0, 0, 0, 0), (0, 0, 1.0), 1.0) is False   # ignored
    f.step(2.5)
    assert np.linalg.norm(f.ap.vel[:2]) > 1.5                                                  # still driving
    f.step(2.0)
    assert "target not received last 3secs, stopping" in f.said()
    f.step(3.0)
    assert np.linalg.norm(f.ap.vel[:2]) < 0.1 and f.ap.mode == modes.ROVER_GUIDED
