"""`towerlink lab`: the skeletons, checkpoint 0 and its mistakes, the hints' lines, a class graded at once.

No flight here (tests/test_lab_nodes.py and tests/test_lab_mistakes.py fly): checkpoint 0 is
judged on fly.launch alone, the untouched skeletons need no flight, and the hints' places come
from reading the files.
"""
from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tools.lab import cp0, hints
from tools.lab.checker import check
from tools.lab.evidence import crash_in
from tools.lab.launch_file import read_launch
from tools.lab.skeleton import FILES, write_skeleton
from tools.lab.source_scan import Source
from tools.lab.submission import NODES, Submission

ROOT = Path(__file__).resolve().parent.parent
REFERENCE = ROOT / "examples" / "lab"
TRUE_ARGS = "72.72144 -131.19296 0 -0.5235987756 0 0 world tower"


def planted(tmp_path: Path, file: str, old: str, new: str, name: str = "student") -> Path:
    """A copy of the reference solution with one mistake planted (old -> new in `file`)."""
    d = tmp_path / name
    shutil.copytree(REFERENCE, d)
    p = d / file
    text = p.read_text()
    assert old in text, f"{old!r} not in {file}"
    p.write_text(text.replace(old, new, 1))
    return d


def line_of(path: Path, fragment: str) -> int:
    return next(i for i, ln in enumerate(path.read_text().splitlines(), 1) if fragment in ln)


# ----------------------------------------------------------------------------- lab init


def test_init_writes_the_starting_point_and_never_overwrites_a_students_file(tmp_path):
    files = write_skeleton(tmp_path / "me")
    assert sorted(p.name for p in files) == sorted(FILES)
    for n in NODES:
        p = tmp_path / "me" / f"{n}.py"
        assert os.access(p, os.X_OK) and "TODO" in p.read_text() and "common.tf2_ros" in p.read_text()
    launch = (tmp_path / "me" / "fly.launch").read_text()
    assert 'type="static_transform_publisher"' in launch and 'args="TODO"' in launch
    readme = (tmp_path / "me" / "README.md").read_text()
    for step in ("towerlink view-frames", "towerlink tf-echo", "towerlink static-transform", "[-351.8, 63.9]",
                 "towerlink lab check . --checkpoint 0", "--checkpoint 3"):
        assert step in readme
    with pytest.raises(FileExistsError):
        write_skeleton(tmp_path / "me")
    r = subprocess.run([sys.executable, "-m", "tools.cli", "lab", "init", str(tmp_path / "me")],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 2 and "--force" in r.stderr


def test_the_untouched_skeletons_fail_every_checkpoint_not_done_yet_without_flying(tmp_path):
    write_skeleton(tmp_path / "me")
    rep = check(tmp_path / "me", out=tmp_path / "report")
    assert [c["number"] for c in rep["checkpoints"]] == [0, 1, 2, 3]
    for c in rep["checkpoints"]:
        assert not c["passed"] and c["verdict"] == "FAIL" and c["measured"].startswith("not done yet"), c
    assert "fly.launch line" in rep["checkpoints"][0]["measured"]
    assert not rep["passed"] and rep["flights"] == {} and not (tmp_path / "report" / "runs").exists()
    assert json.loads((tmp_path / "report" / "report.json").read_text())["name"] == "me"
    assert "not done yet" in (tmp_path / "report" / "report.md").read_text()


class QuietNode:
    """What the skeletons use of a Node: they must run (and do nothing) as they are."""

    def __init__(self):
        self.sent, self.turns = [], 2

    def subscribe(self, *a, **k):
        pass

    def send(self, m):
        self.sent.append(m)

    def log(self, text):
        pass

    def ok(self):
        self.turns -= 1
        return self.turns >= 0

    def now(self):
        return 0.0

    def rate(self, hz):
        return type("R", (), {"sleep": lambda self: None})()


@pytest.mark.parametrize("node, cls", [("tower_to_map", "TowerToMap"), ("world_to_drone", "WorldToDrone"),
                                       ("ground_robot_controller", "GroundRobotController")])
def test_a_skeleton_runs_as_it_is_and_sends_nothing(tmp_path, node, cls):
    write_skeleton(tmp_path)
    spec = importlib.util.spec_from_file_location(f"skel_{node}", tmp_path / f"{node}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    n = QuietNode()
    obj = getattr(mod, cls)(n)
    obj.goal = object() if node == "tower_to_map" else None
    if hasattr(obj, "mainloop"):
        obj.mainloop()
    assert n.sent == []


# ----------------------------------------------------------------------------- checkpoint 0


def test_the_reference_passes_checkpoint_0_and_prints_both_directions():
    c = cp0.judge(read_launch(REFERENCE / "fly.launch"))
    assert c.passed and c.hints == [] and c.figures["rows_ok"] == 7 and c.figures["worst_error"] < 0.1
    assert "tf_echo world tower: [72.72, -131.19, 0.00] yaw -30.0 deg" in c.measured
    assert "tf_echo tower world: [-128.58, 77.26, 0.00] yaw 30.0 deg" in c.measured
    assert "$ tf_echo tower world" in c.details and "| [-200.0, 100.0] | [-351.8, 63.9] |" in c.details


CP0_MISTAKES = [
    # the mistake, its args, a phrase of its hint
    ("yaw sign (NED yaw is clockwise)", "72.72144 -131.19296 0 0.5235987756 0 0 world tower", "the yaw's sign"),
    ("degrees given as radians", "72.72144 -131.19296 0 -30 0 0 world tower", "looks like degrees"),
    ("parent and child swapped", "72.72144 -131.19296 0 -0.5235987756 0 0 tower world", "parent and child are swapped"),
    ("the world's position in the tower frame", "-128.5751 77.2557 0 -0.5235987756 0 0 world tower",
     "where the world's origin is in the tower frame"),
    ("the inverse transform's numbers", "-128.5751 77.2557 0 0.5235987756 0 0 world tower",
     "numbers of the inverse transform"),
    ("z, pitch, roll not zero", "72.72144 -131.19296 3 -0.5235987756 0.2 0 world tower", "must be 0"),
    ("frames not the lab's", "72.72144 -131.19296 0 -0.5235987756 0 0 map tower", "the lab's are frame_id world"),
]


@pytest.mark.parametrize("what, args, phrase", CP0_MISTAKES, ids=[m[0] for m in CP0_MISTAKES])
def test_a_checkpoint_0_mistake_fails_with_its_hint_at_the_launch_line(tmp_path, what, args, phrase):
    d = planted(tmp_path, "fly.launch", TRUE_ARGS, args)
    c = cp0.judge(read_launch(d / "fly.launch"))
    assert not c.passed
    assert any(phrase in h.text for h in c.hints), [str(h) for h in c.hints]
    line = line_of(d / "fly.launch", 'type="static_transform_publisher"')
    assert all(h.file == "fly.launch" and h.line == line for h in c.hints)
    assert len(c.hints) == 1, [str(h) for h in c.hints]          # one mistake, one hint


def test_checkpoint_0_says_what_it_cannot_read(tmp_path):
    d = planted(tmp_path, "fly.launch", TRUE_ARGS, "1 2 3")
    c = cp0.judge(read_launch(d / "fly.launch"))
    assert not c.passed and "8 or 9 arguments" in c.hints[0].text
    (d / "fly.launch").write_text("<launch><node type=")
    assert "not valid XML" in cp0.judge(read_launch(d / "fly.launch")).hints[0].text
    (d / "fly.launch").unlink()
    c = cp0.judge(read_launch(d / "fly.launch"))
    assert c.not_done and "no fly.launch" in c.measured
    # right, but written the other way round: the lab asks for world -> tower
    (d / "fly.launch").write_text((REFERENCE / "fly.launch").read_text().replace(
        TRUE_ARGS, "-128.5751 77.2557 0 0.5235987756 0 0 tower world"))
    c = cp0.judge(read_launch(d / "fly.launch"))
    assert not c.passed and c.figures["rows_ok"] == 7 and "written tower -> world" in c.hints[0].text


# ----------------------------------------------------------------------------- where the hints point


def test_the_hints_name_the_line_of_the_call_they_are_about(tmp_path):
    d = planted(tmp_path, "tower_to_map.py", 'lookup_transform("world", "tower", LATEST)',
                'lookup_transform("tower", "world", LATEST)')
    src = Source(d / "tower_to_map.py")
    h = hints.lookup_direction(src, "world", "tower", "the tower's goal")
    assert h.line == line_of(d / "tower_to_map.py", 'lookup_transform("tower", "world"') and "('world', 'tower')" in h.text
    assert hints.not_transformed(src).line == line_of(d / "tower_to_map.py", "self.goal_pub.publish(new_point)")
    d = planted(tmp_path, "world_to_drone.py", "stamp = m.time_boot_ms / 1000.0", "stamp = time.time()", "w")
    h = hints.wall_clock_stamp(Source(d / "world_to_drone.py"), 1.7e9)
    assert h.line == line_of(d / "world_to_drone.py", "time.time()") and "time.time()" in h.text
    d = planted(tmp_path, "world_to_drone.py", "quaternion_from_euler(0.0, 0.0, yaw)",
                "quaternion_from_euler(roll, pitch, yaw)", "w2")
    assert hints.roll_pitch_kept(Source(d / "world_to_drone.py"), 18.0).line == \
        line_of(d / "world_to_drone.py", "quaternion_from_euler(roll, pitch, yaw)")
    g = Source(REFERENCE / "ground_robot_controller.py")
    assert hints.goal_at_drone_height(g, -9.0).line == line_of(REFERENCE / "ground_robot_controller.py",
                                                                "point = PointStamped(")
    bad = tmp_path / "tower_to_map.py"
    bad.write_text("def f(:\n")
    src = Source(bad)
    assert src.error and hints.syntax(src).line == 1


def test_a_crash_is_read_from_the_nodes_log_with_the_students_line():
    log = ('$ python /x/student/tower_to_map.py --connect udpout:127.0.0.1:1\n'
           'Traceback (most recent call last):\n'
           '  File "/x/student/tower_to_map.py", line 80, in <module>\n'
           '    TowerToMap(node).mainloop()\n'
           '  File "/x/student/tower_to_map.py", line 46, in mainloop\n'
           '    transform = self.bufer.lookup_transform("world", "tower", LATEST)\n'
           '  File "/venv/lib/python3.11/site-packages/x.py", line 3, in y\n'
           "AttributeError: 'TowerToMap' object has no attribute 'bufer'\n")
    c = crash_in(log, "tower_to_map.py")
    assert (c.file, c.line, c.stopped) == ("tower_to_map.py", 46, True) and c.error.startswith("AttributeError")
    c = crash_in("[world_to_drone] callback on_position failed: NameError(\"name 'x' is not defined\") "
                 "at world_to_drone.py line 41\n", "world_to_drone.py")
    assert (c.file, c.line, c.stopped) == ("world_to_drone.py", 41, False) and "on_position" in c.error
    assert crash_in("[tower_to_map] Publishing Transformed Goal [-4.0, -2.0]\n", "tower_to_map.py") is None


def test_a_submission_knows_its_untouched_and_broken_files(tmp_path):
    write_skeleton(tmp_path / "me")
    shutil.copy(REFERENCE / "tower_to_map.py", tmp_path / "me")
    (tmp_path / "me" / "world_to_drone.py").write_text("import x\nclass (:\n")
    sub = Submission.read(tmp_path / "me")
    assert not sub.untouched("tower_to_map") and sub.untouched("ground_robot_controller")
    assert sub.broken("world_to_drone") == "world_to_drone.py line 2: SyntaxError: invalid syntax"
    assert not sub.all_untouched()


# ----------------------------------------------------------------------------- a class


def test_a_class_of_ten_is_graded_in_one_command_in_parallel_processes(tmp_path):
    subs = tmp_path / "submissions"
    for i in range(10):
        shutil.copytree(REFERENCE, subs / f"student{i:02d}")
    for i, args in ((3, "72.72144 -131.19296 0 0.5235987756 0 0 world tower"),
                    (7, "72.72144 -131.19296 0 -30 0 0 world tower")):
        p = subs / f"student{i:02d}" / "fly.launch"
        p.write_text(p.read_text().replace(TRUE_ARGS, args))
    out = tmp_path / "grades"
    r = subprocess.run([sys.executable, "-m", "tools.cli", "lab", "check", *sorted(map(str, subs.iterdir())),
                        "--checkpoint", "0", "--no-ray", "--jobs", "2", "--out", str(out)],
                       capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 1, r.stdout + r.stderr            # two students fail checkpoint 0
    rows = [ln for ln in r.stdout.splitlines() if re.match(r"student\d\d ", ln)]
    assert len(rows) == 10
    assert [ln.split()[0] for ln in rows if "FAIL" in ln] == ["student03", "student07"]
    reps = json.loads((out / "class.json").read_text())
    assert len({rep["worker_pid"] for rep in reps}) == 2       # two worker processes shared the class
    assert all(rep["worker_pid"] != os.getpid() for rep in reps)
    hint = reps[7]["checkpoints"][0]["hints"][0]
    assert hint["file"] == "fly.launch" and "degrees" in hint["text"]
    assert (out / "class.md").exists() and (out / "student03" / "report.md").exists()
