"""Copter cascade, shaping and mixer; rover guidance. Simulated time only."""
from __future__ import annotations

import math

import numpy as np
import pytest
from sim_support import DT, run

from vehicle.control import copter as ccore
from vehicle.control import shaping
from vehicle.fleet import CopterFleet, RoverFleet, Setpoint
from vehicle.physics import ScalarOps


def hover_at(alt=10.0, **kw):
    f = CopterFleet(1, **kw)
    f.set_armed(0, True)
    f.set_setpoint(0, Setpoint(pos=[0.0, 0.0, -alt]))
    run(f, 10.0)
    return f


def tilt_deg(st):
    x, y = st.quat[0], st.quat[1]
    return math.degrees(math.acos(max(-1.0, min(1.0, 1 - 2 * (x * x + y * y)))))


def step_move(f, d=20.0):
    """Straight move of d m north at the configured limits -> (time ratio, overshoot, max tilt)."""
    p0 = f.truth(0).pos.copy()
    goal = np.array([p0[0] + d, p0[1], -10.0])
    f.set_setpoint(0, Setpoint(pos=goal))
    t_reach = None
    over = -1e9
    max_tilt = 0.0
    for k in range(int(16.0 / DT)):
        f.step(DT)
        st = f.truth(0)
        over = max(over, st.pos[0] - goal[0])
        max_tilt = max(max_tilt, tilt_deg(st))
        if t_reach is None and np.linalg.norm(st.pos - goal) < 0.3:
            t_reach = (k + 1) * DT
    g = f.gains
    t_min = d / g.v_xy + g.v_xy / g.a_xy + g.a_xy / g.j_xy
    return (t_reach / t_min if t_reach else math.inf), over, max_tilt


@pytest.mark.parametrize("estimator", [False, True])
def test_step_response_20m(estimator):
    f = hover_at(seed=11, estimator=estimator)
    ratio, over, _ = step_move(f)
    assert ratio <= 1.15
    assert over <= 0.3


def test_step_response_slow_limits():
    f = hover_at(seed=2, estimator=False, params={"WPNAV_SPEED": 300, "WPNAV_ACCEL": 100, "PSC_JERK_XY": 2})
    ratio, over, _ = step_move(f, d=20.0)
    assert ratio <= 1.15 and over <= 0.3


@pytest.mark.parametrize("seed", [1, 7])
def test_hover_rms_under_sensor_noise(seed):
    f = hover_at(seed=seed)
    errs = []
    run(f, 15.0, lambda f: errs.append(np.linalg.norm(f.truth(0).pos - [0, 0, -10.0])))
    assert math.sqrt(np.mean(np.square(errs))) <= 0.2


def test_velocity_only_setpoint_tracks():
    f = hover_at(seed=3)
    f.set_setpoint(0, Setpoint(vel=[2.0, 1.0, -0.5]))
    run(f, 6.0)
    v = f.truth(0).vel
    assert np.allclose(v, [2.0, 1.0, -0.5], atol=0.25)
    f.set_setpoint(0, Setpoint())        # hold: brakes and stays
    run(f, 5.0)
    p = f.truth(0).pos.copy()
    run(f, 3.0)
    assert np.linalg.norm(f.truth(0).pos - p) < 0.5 and np.linalg.norm(f.truth(0).vel) < 0.3


def test_position_with_velocity_feed_forward_follows_moving_target():
    f = hover_at(seed=4)
    t0 = f.sim_time
    errs = []
    for _ in range(int(20.0 / DT)):
        t = f.sim_time - t0
        tgt = np.array([3.0 * t, 1.0 * t, -10.0])
        f.set_setpoint(0, Setpoint(pos=tgt, vel=[3.0, 1.0, 0.0]))
        f.step(DT)
        errs.append(np.linalg.norm(f.truth(0).pos - tgt))
    assert max(errs[-int(10 / DT):]) < 0.6


def test_tilt_never_exceeds_angle_max():
    params = {"ANGLE_MAX": 1500, "WPNAV_ACCEL": 500, "PSC_JERK_XY": 20}
    f = hover_at(estimator=False, params=params)
    _, _, max_tilt = step_move(f, d=30.0)
    assert 12.0 < max_tilt <= 15.0 + 0.1      # the limit is reached and respected


def test_tilt_within_angle_max_default_move():
    f = hover_at(seed=5)
    _, _, max_tilt = step_move(f, d=20.0)
    assert max_tilt <= 30.0


def test_yaw_target_reached_and_yaw_rate():
    f = hover_at(seed=6)
    f.set_setpoint(0, Setpoint(pos=[0, 0, -10.0], yaw=math.radians(120)))
    run(f, 5.0)
    assert math.degrees(f.truth(0).yaw) == pytest.approx(120.0, abs=3.0)
    assert np.linalg.norm(f.truth(0).pos - [0, 0, -10.0]) < 0.5
    f.set_setpoint(0, Setpoint(pos=[0, 0, -10.0], yaw_rate=math.radians(30)))
    y0 = f.truth(0).yaw
    run(f, 2.0)
    dy = (f.truth(0).yaw - y0 + math.pi) % (2 * math.pi) - math.pi
    assert math.degrees(dy) == pytest.approx(60.0, abs=8.0)


def test_level_mode_holds_level_and_altitude():
    f = hover_at(seed=8)
    f.set_setpoint(0, Setpoint(vel=[3.0, 0.0, 0.0]))
    run(f, 4.0)
    f.set_setpoint(0, Setpoint(level=True))
    run(f, 6.0)
    st = f.truth(0)
    roll, pitch, _ = st.euler
    assert abs(math.degrees(roll)) < 2.0 and abs(math.degrees(pitch)) < 2.0
    assert st.pos[2] == pytest.approx(-10.0, abs=0.5)
    assert st.vel[0] > 0.2       # no horizontal control: it drifts on


def test_takeoff_land_and_land_detector():
    f = CopterFleet(1, seed=9)
    run(f, 2.0)
    assert f.landed(0) and f.truth(0).pos[2] == 0.0
    f.set_armed(0, True)
    run(f, 1.0)
    assert f.landed(0) and f.truth(0).pos[2] == 0.0          # armed, idle on the ground
    f.set_setpoint(0, Setpoint(pos=[0, 0, -5.0]))
    run(f, 8.0)
    assert not f.landed(0) and f.truth(0).pos[2] == pytest.approx(-5.0, abs=0.3)
    f.set_setpoint(0, f.land_setpoint(0))
    touched = []
    landed_at = []
    t0 = f.sim_time

    def cb(f):
        if not touched and f.truth(0).pos[2] >= 0.0:
            touched.append(f.sim_time - t0)
        if not landed_at and f.landed(0):
            landed_at.append(f.sim_time - t0)
    run(f, 16.0, cb)
    assert touched and landed_at
    assert landed_at[0] > touched[0] - 0.2                     # not before touching down
    assert landed_at[0] - touched[0] < 2.5                     # ~1 s detector after touch-down
    # descent at LAND_SPEED: 5 m at 0.5 m/s ~ 10 s (+ acceleration)
    assert 9.5 < touched[0] < 12.0
    assert f.thrust_demand[0] == 0.0                           # idling
    f.set_armed(0, False)
    run(f, 1.0)
    assert f.landed(0) and f.phys.m0[0] < 1.0


def test_disarmed_motors_stop_and_sit():
    f = CopterFleet(1, seed=1)
    f.set_setpoint(0, Setpoint(pos=[0, 0, -10.0]))
    run(f, 2.0)
    assert f.truth(0).pos[2] == 0.0 and f.phys.m0[0] == 0.0 and f.landed(0)


def test_shaping_reference_near_time_optimal():
    class R:
        px = py = vx = vy = ax = ay = 0.0
    r = R()
    v, a, j, d = 5.0, 2.5, 5.0, 20.0
    t, reach, over = 0.0, None, 0.0
    while t < 20:
        shaping.shape_xy(r, d, 0.0, True, 0.0, 0.0, 0.0, 0.0, v, a, j, DT, ScalarOps)
        t += DT
        over = max(over, r.px - d)
        assert abs(r.ax) <= a + 1e-9 and math.hypot(r.vx, r.vy) <= v + 1e-9
        if reach is None and abs(r.px - d) < 0.3:
            reach = t
    assert reach / (d / v + v / a + a / j) < 1.05
    assert over < 0.1


def test_mixer_gives_roll_pitch_priority_over_yaw():
    f = ccore.mix(0.5, 0.0, 0.0, 0.0, 0.15, ScalarOps)
    assert all(x == pytest.approx(math.sqrt(0.5)) for x in f)
    # saturating roll + yaw demand: roll differential kept, yaw cut, motors in range
    f = [x * x for x in ccore.mix(0.5, 0.9, 0.0, 1.0, 0.15, ScalarOps)]
    assert all(0.15 ** 2 - 1e-12 <= x <= 1.0 + 1e-12 for x in f)
    roll = 0.5 * ((f[1] + f[2]) - (f[0] + f[3]))          # left minus right, normalised
    assert roll == pytest.approx(0.9, abs=1e-9)
    yaw = 0.5 * ((f[0] + f[1]) - (f[2] + f[3]))
    assert yaw < 0.2
    # collective kept when there is room
    assert sum(f) / 4 == pytest.approx(0.5, abs=1e-9)


# ---------------------------------------------------------------- rover

def rover(**kw):
    f = RoverFleet(1, **kw)
    f.set_armed(0, True)
    return f


def test_rover_reaches_goal_and_stops_without_orbiting():
    f = rover(seed=1)
    goal = np.array([-30.0, 40.0, 0.0])
    f.set_setpoint(0, Setpoint(pos=goal))
    run(f, 15.0)
    assert np.linalg.norm(f.truth(0).pos[:2] - goal[:2]) < 0.5
    p = f.truth(0).pos.copy()
    yaw = f.truth(0).yaw
    run(f, 10.0)
    assert np.linalg.norm(f.truth(0).pos - p) < 0.05          # parked, not circling
    assert abs(f.truth(0).yaw - yaw) < 0.05
    assert f.truth(0).pos[2] == 0.0


def test_rover_speed_limit_respected():
    f = rover(seed=2, params={"CRUISE_SPEED": 6.0})
    f.set_setpoint(0, Setpoint(pos=[200.0, 0.0, 0.0]))
    top = []
    run(f, 20.0, lambda f: top.append(np.linalg.norm(f.truth(0).vel)))
    assert 5.8 < max(top) <= 6.0 + 1e-6
    assert f.gains.cruise >= 6.0
    f.set_params({"WP_SPEED": 3.0})
    run(f, 5.0)
    assert np.linalg.norm(f.truth(0).vel) == pytest.approx(3.0, abs=0.05)


def test_rover_default_cruise_keeps_up_with_drone():
    f = rover(seed=2)
    assert f.gains.cruise >= 6.0


def test_rover_follows_moving_target():
    f = rover(seed=3)
    errs = []
    for _ in range(int(30.0 / DT)):
        t = f.sim_time
        tgt = np.array([10.0 + 5.0 * t, 5.0 * math.sin(0.1 * t), 0.0])
        vel = np.array([5.0, 0.5 * math.cos(0.1 * t), 0.0])
        f.set_setpoint(0, Setpoint(pos=tgt, vel=vel))
        f.step(DT)
        errs.append(np.linalg.norm(f.truth(0).pos[:2] - tgt[:2]))
    assert max(errs[-int(10 / DT):]) < 1.5


def test_rover_velocity_and_hold_and_yaw():
    f = rover(seed=4)
    f.set_setpoint(0, Setpoint(vel=[0.0, 4.0, 0.0]))
    run(f, 6.0)
    assert np.allclose(f.truth(0).vel[:2], [0.0, 4.0], atol=0.2)
    f.set_setpoint(0, Setpoint(yaw=math.radians(-90)))
    run(f, 6.0)
    assert np.linalg.norm(f.truth(0).vel) < 0.05
    assert math.degrees(f.truth(0).yaw) == pytest.approx(-90.0, abs=3.0)
    f.set_setpoint(0, Setpoint(yaw_rate=math.radians(45)))
    y0 = f.truth(0).yaw
    run(f, 2.0)
    turned = (f.truth(0).yaw - y0 + math.pi) % (2 * math.pi) - math.pi
    assert math.degrees(turned) == pytest.approx(90.0, abs=5.0)
    assert np.linalg.norm(f.truth(0).vel) < 0.05
    f.set_armed(0, False)
    f.set_setpoint(0, Setpoint(vel=[3.0, 0.0, 0.0]))
    run(f, 2.0)
    assert np.linalg.norm(f.truth(0).vel) < 0.01
