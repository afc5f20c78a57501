"""Students' mistakes, planted in copies of the reference solution, flown: each fails its checkpoint with its hint.

Four students, each with one mistake that checkpoint 1 catches and one that checkpoint 2 or 3
catches (checkpoint 1 flies the student's nodes; checkpoints 2 and 3 fly the reference
tower_to_map with the lab's transform, so one mistake never hides the other):

  raw_goal      tower_to_map sends the tower's goal untransformed | world_to_drone stamps with time.time()
  inverse       tower_to_map looks up tower <- world              | the rover's goal is (0, 0, 0): the drone's height
  crash         tower_to_map raises in its loop                   | world_to_drone never broadcasts
  yaw_sign      fly.launch's yaw has the wrong sign               | drone_yaw keeps roll and pitch

The first three are graded as a class in one command (in parallel processes); the fourth on its
own, with checkpoints 0, 1 and 3. The mistakes that need no flight (degrees, the frames swapped,
the world's position given for the tower's, ...) are in tests/test_lab_check.py.
"""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parent.parent
LAB = ROOT / "examples" / "lab"

PLANTS = {
    "raw_goal": [("tower_to_map.py", "self.goal_pub.publish(new_point)", "self.goal_pub.publish(point)"),
                 ("world_to_drone.py", "stamp = m.time_boot_ms / 1000.0", "stamp = time.time()"),
                 ("world_to_drone.py", '"""\nfrom common', '"""\nimport time\n\nfrom common')],
    "inverse": [("tower_to_map.py", 'lookup_transform("world", "tower", LATEST)',
                 'lookup_transform("tower", "world", LATEST)'),
                ("ground_robot_controller.py", "PointStamped(self.frame, transform.stamp, (0.0, 0.0, h))",
                 "PointStamped(self.frame, transform.stamp, (0.0, 0.0, 0.0))")],
    "crash": [("tower_to_map.py", 'transform = self.buffer.lookup_transform(', 'transform = self.bufer.lookup_transform('),
              ("world_to_drone.py", "        self.br.sendTransform([drone, drone_yaw])\n", "")],
    "yaw_sign": [("fly.launch", " -0.5235987756 0 0 world tower", " 0.5235987756 0 0 world tower"),
                 ("world_to_drone.py", "quaternion_from_euler(0.0, 0.0, yaw)", "quaternion_from_euler(roll, pitch, yaw)")],
}


def plant(root: Path, name: str) -> Path:
    d = root / name
    shutil.copytree(LAB, d)
    for file, old, new in PLANTS[name]:
        p = d / file
        assert old in p.read_text(), (name, file, old)
        p.write_text(p.read_text().replace(old, new, 1))
    return d


def line_of(path: Path, fragment: str) -> int:
    return next(i for i, ln in enumerate(path.read_text().splitlines(), 1) if fragment in ln)


def lab_check(*args: str) -> tuple[int, str]:
    r = subprocess.run([sys.executable, "-m", "tools.cli", "lab", "check", *args], capture_output=True, text=True,
                       cwd=ROOT, timeout=600)
    return r.returncode, r.stdout + r.stderr


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    root = tmp_path_factory.mktemp("class")
    dirs = {n: plant(root / "submissions", n) for n in PLANTS}
    out = root / "grades"
    rc, text = lab_check(*(str(dirs[n]) for n in ("raw_goal", "inverse", "crash")), "-c", "1", "-c", "2",
                         "--no-ray", "--jobs", "2", "--no-plot", "--out", str(out))
    reps = {r["name"]: r for r in json.loads((out / "class.json").read_text())}
    rc1, card = lab_check(str(dirs["yaw_sign"]), "-c", "0", "-c", "1", "-c", "3", "--no-plot",
                          "--out", str(root / "yaw_sign_report"))
    reps["yaw_sign"] = json.loads((root / "yaw_sign_report" / "report.json").read_text())
    return dirs, reps, (rc, text), (rc1, card)


def hint(rep: dict, n: int) -> dict:
    c = next(c for c in rep["checkpoints"] if c["number"] == n)
    assert not c["passed"], c
    assert c["hints"], c
    return c["hints"][0]


def test_the_class_ran_in_one_command_and_every_planted_mistake_failed(graded):
    _dirs, reps, (rc, text), (rc1, card) = graded
    assert rc == 1 and rc1 == 1, text + card
    assert all(not c["passed"] for r in reps.values() for c in r["checkpoints"]), text
    assert len({reps[n]["worker_pid"] for n in ("raw_goal", "inverse", "crash")}) == 2, text
    assert "CP0  static transform       FAIL" in card and "hint: fly.launch line" in card


# (student, checkpoint): the file the hint names, a phrase of it, the line it names (a fragment of it)
EXPECTED = [
    ("raw_goal", 1, "tower_to_map.py", "tower's own coordinates", "self.goal_pub.publish(point)"),
    ("raw_goal", 2, "world_to_drone.py", "stamped with time.time()", "stamp = time.time()"),
    ("inverse", 1, "tower_to_map.py", "ask for ('world', 'tower')", 'lookup_transform("tower", "world"'),
    ("inverse", 2, "ground_robot_controller.py", "at the drone's height", "PointStamped(self.frame"),
    ("crash", 1, "tower_to_map.py", "stopped with an exception: AttributeError", "self.bufer.lookup_transform"),
    ("crash", 2, "world_to_drone.py", "never broadcast world -> drone", "# Broadcast the transforms"),
]


@pytest.mark.parametrize("student, n, file, phrase, fragment", EXPECTED,
                         ids=[f"{e[0]}-cp{e[1]}" for e in EXPECTED])
def test_each_planted_mistake_fails_its_checkpoint_with_its_hint_and_line(graded, student, n, file, phrase, fragment):
    dirs, reps, _, _ = graded
    h = hint(reps[student], n)
    assert h["file"] == file and phrase in h["text"], h
    assert h["line"] == line_of(dirs[student] / file, fragment), h


def test_a_crashing_node_ends_its_flight(graded):
    _dirs, reps, _, _ = graded
    assert reps["crash"]["flights"]["cp1"]["sim_s"] < 15
    assert "node-tower_to_map exited" in reps["crash"]["flights"]["cp1"]["failure"]


def test_a_yaw_of_the_wrong_sign_and_a_level_frame_that_still_tilts(graded):
    dirs, reps, _, _ = graded
    rep = reps["yaw_sign"]
    line = line_of(dirs["yaw_sign"] / "fly.launch", 'type="static_transform_publisher"')
    h = hint(rep, 0)
    assert (h["file"], h["line"]) == ("fly.launch", line) and "the yaw's sign" in h["text"]
    h = hint(rep, 1)                      # the drone flew where the wrong transform put the house
    assert (h["file"], h["line"]) == ("fly.launch", line) and "your static transform" in h["text"]
    h = hint(rep, 3)
    assert h["file"] == "world_to_drone.py" and "still tilts" in h["text"]
    assert h["line"] == line_of(dirs["yaw_sign"] / "world_to_drone.py", "quaternion_from_euler(roll, pitch, yaw)")
    assert set(rep["flights"]) == {"cp1", "cp3"}          # checkpoint 3 flown beside checkpoint 1
