"""The default scenario reproduces the lab's tower; the frames and static-transform tools."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from common.frames import InvalidArgumentException, Transform
from common.scenario import ScenarioError, load_scenario, parse_static_transform
from tools.frames_cmd import LAB_CHECKPOINT, checkpoint_rows, convert


def towerlink(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "tools.cli", *args],
                          capture_output=True, text=True, timeout=60)


def test_default_scenario_reproduces_all_seven_checkpoint_rows():
    rows = checkpoint_rows(load_scenario())
    assert len(rows) == 7
    for world_xy, got, expected in rows:
        assert got == expected, f"world {world_xy}: got {got}, lab says {expected}"


def test_checkpoint_rows_are_close_before_rounding():
    scenario = load_scenario()
    for world_xy, expected in LAB_CHECKPOINT:
        p = convert(scenario, "world", "tower", (*world_xy, 0.0))
        assert abs(p[0] - expected[0]) <= 0.05 and abs(p[1] - expected[1]) <= 0.05
        assert p[2] == pytest.approx(0.0, abs=1e-9)


def test_house_goal_is_world_minus4_minus2():
    scenario = load_scenario()
    house = scenario.goals[0]
    world = convert(scenario, scenario.goal_frame, "world", house)
    assert world == pytest.approx([-4.0, -2.0, -scenario.altitude], abs=2e-3)
    assert len(scenario.goals) >= 3 and scenario.altitude == 9.0


def test_convert_round_trip_between_any_frames():
    scenario = load_scenario()
    p = np.array([12.5, -7.25, -3.0])
    back = convert(scenario, "tower", "world", convert(scenario, "world", "tower", p))
    assert back == pytest.approx(p, abs=1e-9)


def test_parse_static_transform_euler_and_quaternion_forms_agree():
    yaw = -math.pi / 6
    a = parse_static_transform(f"1 2 3 {yaw} 0 0 world tower")
    b = parse_static_transform(["1", "2", "3", "0", "0", str(math.sin(yaw / 2)), str(math.cos(yaw / 2)), "world", "tower"])
    assert (a.frame_id, a.child_frame_id, a.stamp) == ("world", "tower", 0.0)
    assert a.transform.to_matrix() == pytest.approx(b.transform.to_matrix(), abs=1e-12)
    assert np.asarray(a.transform.translation) == pytest.approx([1, 2, 3])


@pytest.mark.parametrize("line, error, text", [
    ("1 2 3 0 0 world tower", ScenarioError, "8 or 9 arguments"),
    ("1 2 x 0 0 0 world tower", ScenarioError, "must be numbers"),
    ("1 2 nan 0 0 0 world tower", InvalidArgumentException, ""),
    ("0 0 0 0 0 0 2 world tower", InvalidArgumentException, "quaternion"),
    ("0 0 0 0 0 0 world world", InvalidArgumentException, "world"),
    ("0 0 0 0 0 0 /world tower", InvalidArgumentException, "/world"),
])
def test_parse_static_transform_rejects_bad_input(line, error, text):
    with pytest.raises(error) as info:
        ts = parse_static_transform(line)
        # frame-id checks belong to the buffer: adding is where tf2 refuses them
        from common.frames import Buffer
        Buffer().set_transform_static(ts, "test")
    assert text in str(info.value)


def test_scenario_errors_name_the_file_and_field(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('static_transforms = ["0 0 0 0 0 0 world tower", "0 0 0 0 0 0 tower world"]\n')
    with pytest.raises(ScenarioError, match="bad.toml: static_transforms"):
        load_scenario(bad)
    bad.write_text('[mission]\ngoal_frame = "world"\ngoals = [[1]]\n')
    with pytest.raises(ScenarioError, match=r"mission.goals\[0\]"):
        load_scenario(bad)
    bad.write_text('[mission]\ngoal_frame = "world"\n[follow]\nframe = "rover"\n')
    with pytest.raises(ScenarioError, match="follow.frame"):
        load_scenario(bad)
    with pytest.raises(ScenarioError, match="no such scenario"):
        load_scenario(tmp_path / "missing.toml")


def test_cli_checkpoint_prints_the_lab_table():
    out = towerlink("frames", "checkpoint")
    assert out.returncode == 0, out.stderr
    for world_xy, tower_xy in LAB_CHECKPOINT:
        assert (f"World [{world_xy[0]:.1f}, {world_xy[1]:.1f}] -> "
                f"Tower [{tower_xy[0]:.1f}, {tower_xy[1]:.1f}]") in out.stdout
    assert "all 7 rows match the lab" in out.stdout


def test_cli_convert_and_unknown_frame():
    out = towerlink("frames", "convert", "--from", "world", "--to", "tower", "0", "10")
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("world [0.000, 10.000, 0.000] -> tower [-133.5")
    bad = towerlink("frames", "convert", "--from", "world", "--to", "moon", "0", "10")
    assert bad.returncode == 1 and "LookupException" in bad.stderr and "moon" in bad.stderr


def test_cli_static_transform_prints_both_directions():
    yaw = -0.5235987756
    out = towerlink("static-transform", "72.72144", "-131.19296", "0", str(yaw), "0", "0", "world", "tower")
    assert out.returncode == 0, out.stderr
    text = out.stdout
    assert "$ tf_echo world tower" in text and "$ tf_echo tower world" in text
    assert "- Translation: [72.721, -131.193, 0.000]" in text
    assert "in RPY (degree) [0.000, 0.000, -30.000]" in text
    assert "in RPY (degree) [0.000, 0.000, 30.000]" in text   # the inverse turns back
    inv = Transform.from_euler(yaw=yaw, translation=(72.72144, -131.19296, 0)).inverse()
    tx, ty, _ = np.asarray(inv.translation)
    assert f"- Translation: [{tx:.3f}, {ty:.3f}, 0.000]" in text


def test_cli_static_transform_refuses_bad_quaternion():
    out = towerlink("static-transform", "0", "0", "0", "0", "0", "0", "3", "world", "tower")
    assert out.returncode == 2
    assert "InvalidArgumentException" in out.stderr and "quaternion" in out.stderr


def test_cli_help_lists_every_tool():
    out = towerlink("--help")
    assert out.returncode == 0
    for name in ("fly", "sitl", "bridge", "tower", "frames", "static-transform", "tf-echo", "view-frames"):
        assert name in out.stdout
