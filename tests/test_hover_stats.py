"""The run summary's hover figures (issue 10): hovers found in truth, the hover error, and the
wobble of the full-attitude frame's ground point while hovering (it leans in wind)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from tools.hover_stats import HOVER_MIN_S, format_hover, hover_figures, hover_segments
from tools.run_data import FOLLOW_FIELDS, RunData, Track, load_messages
from tools.run_summary import format_summary, summarize


def _run(tilt_deg=7.0, wobble=0.05, seed=0) -> RunData:
    """20 s: 5 s climbing at 1.5 m/s, 10 s hovering at 9 m leaning tilt_deg west with 5 cm of
    jitter, 5 s flying east at 4 m/s. Follow ticks: ground-point error 9 tan(tilt) (+ wobble
    noise) through the full frame, zero through the yaw-only one."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 20.0, 0.1)
    n = len(t)
    xyz = np.zeros((n, 3))
    vel = np.zeros((n, 3))
    climb, hover = t < 5.0, (t >= 5.0) & (t < 15.0)
    xyz[climb, 2] = -1.5 * t[climb] - 1.5
    vel[climb, 2] = -1.5
    xyz[hover, 2] = -9.0
    xyz[hover, :2] = 0.05 * rng.standard_normal((hover.sum(), 2))
    fly = t >= 15.0
    xyz[fly, 2] = -9.0
    xyz[fly, 1] = 4.0 * (t[fly] - 15.0)
    vel[fly, 1] = 4.0
    roll = np.where(hover, -math.radians(tilt_deg), 0.0) + math.radians(wobble) * rng.standard_normal(n)
    extra = {"roll": roll, "pitch": np.zeros(n), "yaw": np.zeros(n),
             "vn": vel[:, 0], "ve": vel[:, 1], "vd": vel[:, 2]}
    d = RunData()
    d.truth[1] = Track(t, xyz, extra)
    gp = 9.0 * np.tan(np.abs(roll))
    follow = {k: np.zeros(n) for k in FOLLOW_FIELDS}
    follow["t"], follow["err_full"], follow["height"] = t, gp, -xyz[:, 2]
    d.follow = follow
    return d


def test_segments_need_low_speed_height_and_duration():
    d = _run()
    tr = d.truth[1]
    vel = np.column_stack([tr.extra["vn"], tr.extra["ve"], tr.extra["vd"]])
    segs = hover_segments(tr.t, tr.xyz, vel)
    assert len(segs) == 1 and segs[0][0] == pytest.approx(5.0) and segs[0][1] == pytest.approx(14.9)
    # shorter than HOVER_MIN_S, or on the ground: no hover
    short = tr.t < 5.0 + HOVER_MIN_S - 0.5
    assert hover_segments(tr.t[short], tr.xyz[short], vel[short]) == []
    ground = tr.xyz.copy()
    ground[:, 2] = 0.0
    assert hover_segments(tr.t, ground, vel) == []


def test_hover_error_and_wobble_in_hover():
    h = hover_figures(_run(tilt_deg=7.0))
    assert h["seconds"] == pytest.approx(9.9)
    assert h["error"]["rms"] == pytest.approx(0.07, abs=0.02)         # 5 cm per axis around the mean
    assert h["tilt_mean_deg"] == pytest.approx(7.0, abs=0.2)
    assert h["wobble"]["drone"]["rms"] == pytest.approx(9 * math.tan(math.radians(7)), rel=0.05)
    assert h["wobble"]["drone_yaw"]["max"] == 0.0
    calm = hover_figures(_run(tilt_deg=0.0))
    assert calm["wobble"]["drone"]["rms"] < 0.02 < h["wobble"]["drone"]["rms"] / 50
    lines = format_hover(h, (8.0, 270.0, 1.0))
    assert lines[0].startswith("hover (wind 8 m/s from 270°, turbulence 1 m/s; 10 s in 1 hover(s), mean tilt 7.0°)")
    assert "wobble in hover: full attitude (drone) RMS 1.10" in lines[1]


def test_no_hover():
    d = _run()
    d.truth[1] = d.truth[1].window(15.0, None)
    assert hover_figures(d) == {}
    assert "did not hover" in format_hover({}, None)[0]


def test_only_hovers_before_the_missions_end_count(tmp_path):
    """What is recorded after the tower's end (the drone hovering while fly stops the
    processes, as long as the machine takes) is not the mission's: with lockstep a seed must
    give the same figures whatever the wall time of the shutdown."""
    d = _run()                                      # hovers 5 .. 14.9 s
    assert hover_figures(d, until=4.0) == {}
    h = hover_figures(d, until=10.0)
    assert h["segments"] == [[5.0, 10.0]] and h["wobble"]["drone"]["n"] == 41    # 6.0 .. 10.0 s, after SETTLE_S
    assert summarize(tmp_path, data=d, tower={"ok": True, "goals": [], "end_sim": 4.0})["hover"] == {"wind": None}
    assert summarize(tmp_path, data=d, tower={"ok": True, "goals": []})["hover"]["seconds"] == pytest.approx(9.9)


def test_summary_carries_the_hover_and_the_scenario_wind(tmp_path):
    sc = tmp_path / "wind.toml"
    sc.write_text('wind = {speed = 8, direction = 270, turbulence = 1}\n'
                  'static_transforms = ["72.72144 -131.19296 0 -0.5235987756 0 0 world tower"]\n')
    tower = {"ok": True, "goals": []}
    s = summarize(tmp_path, data=_run(), tower=tower, scenario_path=str(sc))
    assert s["hover"]["wind"] == [8.0, 270.0, 1.0] and s["hover"]["seconds"] == pytest.approx(9.9)
    text = format_summary(s)
    assert "hover (wind 8 m/s from 270°" in text and "wobble in hover" in text
    s = summarize(tmp_path, data=load_messages([]), tower=tower)
    assert "hover (no wind): the drone did not hover" in format_summary(s)
