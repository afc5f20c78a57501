"""Scoring math: minimum time, ground-point error, tlog folding and the summary text."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from common.geo import ned_to_lla
from tools.run_data import Track, load_messages
from tools.run_figures import ground_point_errors, horizontal_error, minimum_time, rms
from tools.run_summary import format_summary


def test_minimum_time_long_leg_is_the_design_formula():
    # d/v + v/a + a/j with ArduPilot's defaults (5 m/s, 2.5 m/s², 5 m/s³)
    assert minimum_time(30.0, 5.0, 2.5, 5.0) == pytest.approx(30 / 5 + 5 / 2.5 + 2.5 / 5)
    assert minimum_time(0.0, 5, 2.5, 5) == 0.0


def _profile_distance(vp: float, a: float, j: float, dt: float = 1e-4) -> tuple[float, float]:
    """Integrate the symmetric S-curve that peaks at vp (no cruise): (distance, time)."""
    ta = a / j
    if vp >= a * a / j:
        phases = [(j, ta), (0.0, vp / a - ta), (-j, ta)]
    else:
        tj = math.sqrt(vp / j)
        phases = [(j, tj), (-j, tj)]
    phases = phases + [(-jj, tt) for jj, tt in phases]
    x = v = acc = 0.0
    T = 0.0
    for jj, tt in phases:
        n = max(1, int(round(tt / dt)))
        h = tt / n
        for _ in range(n):
            x += v * h + acc * h * h / 2 + jj * h ** 3 / 6
            v += acc * h + jj * h * h / 2
            acc += jj * h
        T += tt
    return x, T


@pytest.mark.parametrize("d", [0.05, 0.5, 2.0, 4.47, 8.0])
def test_minimum_time_short_legs_match_integrated_profile(d):
    v, a, j = 5.0, 2.5, 5.0
    T = minimum_time(d, v, a, j)
    # find the peak speed whose profile covers d by bisection, integrate it
    lo, hi = 0.0, v
    for _ in range(60):
        mid = (lo + hi) / 2
        if _profile_distance(mid, a, j, dt=2e-3)[0] < d:
            lo = mid
        else:
            hi = mid
    x, t_int = _profile_distance(lo, a, j, dt=1e-4)
    assert x == pytest.approx(d, rel=1e-3)
    assert T == pytest.approx(t_int, rel=1e-3)
    assert T > d / v + 1e-9   # never faster than cruising the whole way


@settings(max_examples=200, deadline=None)
@given(d=st.floats(0.001, 500), v=st.floats(0.5, 20), a=st.floats(0.2, 10), j=st.floats(0.5, 50))
def test_minimum_time_monotone_and_bounded(d, v, a, j):
    T = minimum_time(d, v, a, j)
    assert T >= d / v - 1e-9
    assert minimum_time(d * 1.01, v, a, j) >= T - 1e-9
    # never faster than the two relaxed problems, each solved by hand: without the jerk
    # limit (the trapezoid: accelerate at a, cruise at v if there is room, brake at a) ...
    trapezoid = 2 * math.sqrt(d / a) if d <= v * v / a else d / v + v / a
    assert T >= trapezoid * (1 - 1e-12)
    # ... and with the jerk limit alone (+j, -j, -j, +j for T/4 each covers 2 j (T/4)^3)
    assert T >= 4 * (d / (2 * j)) ** (1 / 3) * (1 - 1e-12)


def test_minimum_time_continuous_at_boundaries():
    v, a, j = 5.0, 2.5, 5.0
    d_cruise = v * (v / a + a / j)           # shortest leg that reaches v
    d_acc = 2 * (a * a / j) ** 1.5 / math.sqrt(j)  # shortest leg that reaches a (vp = a²/j)
    for b in (d_cruise, d_acc):
        assert minimum_time(b * (1 - 1e-9), v, a, j) == pytest.approx(minimum_time(b * (1 + 1e-9), v, a, j), rel=1e-6)
    with pytest.raises(ValueError):
        minimum_time(1.0, 0.0, 1.0, 1.0)


def test_ground_point_error_full_vs_yaw_only():
    from common.frames import Transform
    h = 9.0
    tilt = math.radians(14.0)
    full = Transform.from_euler(yaw=0.7, pitch=tilt, translation=(3.0, 4.0, -h))
    yaw = full.yaw_only()
    ts, e = ground_point_errors([(1.0, full.to_tuple()), (1.1, yaw.to_tuple())])
    assert list(ts) == [1.0, 1.1]
    assert e[0] == pytest.approx(h * math.sin(tilt), rel=1e-9)  # |R e_z| horizontal part: h·sin(tilt)
    # cross-check against applying the transform to the ground point
    gp = full.apply_point([0, 0, h])
    assert e[0] == pytest.approx(math.hypot(gp[0] - 3.0, gp[1] - 4.0))
    assert e[1] < 1e-12


def test_track_interpolation_and_errors():
    tr = Track(np.array([0.0, 1.0, 2.0]), np.array([[0, 0, -9], [1, 0, -9], [2, 2, -9]], float))
    assert tr.at(0.5) == pytest.approx([0.5, 0, -9])
    assert tr.window(0.5, 2.0).t.tolist() == [1.0, 2.0]
    assert horizontal_error(np.array([3.0, 4.0, 0]), np.zeros(3)) == pytest.approx(5.0)
    assert rms(np.array([3.0, 4.0])) == pytest.approx(math.sqrt(12.5))


def _msgs():
    """A few synthetic messages as the vehicles and the bridge send them."""
    from common.mavlink.dialect import towerlink as tl
    lat0, lon0, alt0 = -35.3632621, 149.1652374, 584.0
    out = []

    def mk(msg, sysid):
        mav = tl.MAVLink(None, srcSystem=sysid, srcComponent=1)
        buf = msg.pack(mav)
        return mav.decode(bytearray(buf))

    out.append(mk(tl.MAVLink_gps_global_origin_message(int(lat0 * 1e7), int(lon0 * 1e7), int(alt0 * 1000)), 1))
    out.append(mk(tl.MAVLink_gps_global_origin_message(int(lat0 * 1e7), int(lon0 * 1e7), int(alt0 * 1000)), 2))
    out.append(mk(tl.MAVLink_param_value_message(b"WPNAV_SPEED", 400.0, 9, 100, 3), 1))
    for k in range(11):
        t = k * 0.1
        for sysid, (n, e, d) in ((1, (5.0 * t, 0.0, -9.0)), (2, (5.0 * t - 0.5, 0.0, 0.0))):
            out.append(mk(tl.MAVLink_attitude_message(int(t * 1000), 0, 0, 0, 0, 0, 0), sysid))
            lat, lon, _ = ned_to_lla((lat0, lon0, alt0), (n, e, d))
            out.append(mk(tl.MAVLink_sim_state_message(1, 0, 0, 0, 0, 0.1, 0, 0, 0, 0, 0, 0, 0,
                                                       lat, lon, alt0 - d, 0, 0, 5.0, 0, 0,
                                                       int(round(lat * 1e7)), int(round(lon * 1e7))), sysid))
        out.append(mk(tl.MAVLink_towerlink_follow_status_message(
            int(t * 1e6), 5 * t, 0, 5 * t + 0.9, 0, 5 * t, 0, 5 * t, 0, 0, 0, 5 * t - 0.5, 0, 9.0, 0.1,
            0.9, 0.0, 1, 1), 250))
    return out


def test_load_messages_truth_params_and_follow():
    d = load_messages(_msgs())
    assert d.params[1]["WPNAV_SPEED"] == 400.0
    dr, rv = d.truth[1], d.truth[2]
    assert len(dr) == 11 and dr.at(1.0) == pytest.approx([5.0, 0.0, -9.0], abs=0.02)
    assert rv.at(0.5) == pytest.approx([2.0, 0.0, 0.0], abs=0.02)
    assert horizontal_error(rv.at(dr.t), dr.xyz) == pytest.approx(np.full(11, 0.5), abs=0.02)
    assert d.follow["err_full"] == pytest.approx(np.full(11, 0.9))
    assert d.follow_frame == 1


def test_summarize_and_format(tmp_path):
    from tools.run_summary import summarize
    tower = {"ok": True, "takeoff_position": None, "goals": [
        {"index": 1, "goal": [-131.039, 73.524, -9.0], "frame": "tower", "reached": True,
         "sent_sim": 0.0, "reached_sim": 1.0, "time_to_reach": 1.0, "sends": 2},
    ]}
    s = summarize(tmp_path, data=load_messages(_msgs()), tower=tower,
                  meta={"seed": 3, "speedup": 5.0, "follow_frame": "drone_yaw"})
    assert s["ok"] and s["goals_reached"] == 1
    assert s["goals"][0]["world"][:2] == pytest.approx([-4.0, -2.0], abs=0.05)
    assert s["follow_error"]["rms"] == pytest.approx(0.5, abs=0.03)
    assert s["goals"][0]["rover_error_at_arrival"] == pytest.approx(0.5, abs=0.03)
    assert s["wobble"]["drone"]["rms"] == pytest.approx(0.9)
    assert s["wobble"]["ratio_rms"] > 1e5
    assert s["limits"]["WPNAV_SPEED"] == 4.0
    # the two limits the tlog did not hold are Copter's defaults, and the summary says so
    assert s["limits"]["WPNAV_ACCEL"] == 2.5 and s["limits_assumed"] == ["PSC_JERK_XY", "WPNAV_ACCEL"]
    text = format_summary(s)
    assert "WARNING: PSC_JERK_XY, WPNAV_ACCEL not read from the drone" in text
    assert "MISSION OK: 1/1 goals reached" in text
    assert "[ -4.00,  -2.00]" in text
    assert "yaw-only" in text and "RMS 0.50 m" in text


def test_the_follower_is_named_by_who_sent_the_rover_its_goals():
    from tools.run_summary import follower
    assert follower({}, None) == "bridge tf follow (sysid 2)"
    assert follower({"nodes": ["drone_frames", "follow_rover"]}, None) == \
        "the nodes' follow (drone_frames, follow_rover) (sysid 2)"
    assert follower({"nodes": ["follow_rover"]}, 2) == "ArduPilot FOLLOW (sysid 2)"
