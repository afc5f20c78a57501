"""What fly's helpers read while the run flies (tools.run_data_tail, tools.fly_frames): the run's data
and the frame tree, the same as read from the finished tlogs; and how the launcher ends a run
(tools.fly_processes, tools.fly_progress)."""
from __future__ import annotations

import pickle
import signal
import struct
import subprocess
import sys
import time

import pytest

from common.geo import ned_to_lla
from common.mavlink.dialect import towerlink as tl
from tests.test_fly_helpers import _gone
from tests.test_run_recording import T0, _run_tlogs, write_growing
from tools.fly_drawings import Drawings, DrawingWorker
from tools.fly_frames import LiveFrames, draw_frames
from tools.fly_processes import ProcessGroup
from tools.fly_progress import TowerOutput
from tools.run_data import load_run
from tools.run_data_tail import LiveRunData

HOME = (-35.3632621, 149.1652374, 584.0)


def _vehicles_tlog(n: int = 200) -> bytes:
    """vehicles.tlog of a short flight: the drone's and the rover's origin, truth, attitude,
    heartbeats (a mode change), a parameter and a STATUSTEXT."""
    out = bytearray()
    mavs = {s: tl.MAVLink(None, srcSystem=s, srcComponent=1) for s in (1, 2)}

    def put(us: int, msg, sysid: int) -> None:
        out.extend(struct.pack(">Q", T0 + us) + bytes(msg.pack(mavs[sysid])))

    for s in (1, 2):
        put(0, tl.MAVLink_gps_global_origin_message(int(HOME[0] * 1e7), int(HOME[1] * 1e7), int(HOME[2] * 1e3)), s)
    put(1, tl.MAVLink_param_value_message(b"WPNAV_SPEED", 400.0, 9, 100, 3), 1)
    for k in range(n):
        t = 0.02 * k
        for s, (x, y, z) in ((1, (3.0 * t, 0.5 * t, -9.0)), (2, (3.0 * t - 1.0, 0.5 * t, 0.0))):
            put(1000 * k, tl.MAVLink_attitude_message(int(t * 1000), 0.01, 0.02, 0.3, 0, 0, 0), s)
            put(1000 * k, tl.MAVLink_local_position_ned_message(int(t * 1000), x, y, z, 3.0, 0.5, 0), s)
            lat, lon, _ = ned_to_lla(HOME, (x, y, z))
            put(1000 * k + 1, tl.MAVLink_sim_state_message(1, 0, 0, 0, 0, 0.1, 0, 0, 0, 0, 0, 0, 0, lat, lon,
                                                           HOME[2] - z, 0, 0, 3.0, 0.5, 0,
                                                           int(round(lat * 1e7)), int(round(lon * 1e7))), s)
            if k % 50 == 0:
                put(1000 * k + 2, tl.MAVLink_heartbeat_message(2, 3, 129 if k else 1, 4 if k else 0, 4, 3), s)
        if k == 120:
            put(1000 * k + 3, tl.MAVLink_statustext_message(6, b"Reached waypoint #2"), 1)
    return bytes(out)


def _tlogs() -> dict[str, bytes]:
    return {"vehicles.tlog": _vehicles_tlog(), **_run_tlogs(200)}


def _finished(path, tlogs: dict[str, bytes]):
    path.mkdir(parents=True)
    for name, data in tlogs.items():
        (path / name).write_bytes(data)
    return path


@pytest.mark.parametrize("seed", [1, 2])
def test_the_run_data_read_while_the_tlogs_grow_are_load_runs(tmp_path, seed):
    tlogs = _tlogs()
    after = _finished(tmp_path / "after", tlogs)
    live_dir = tmp_path / "live"
    live_dir.mkdir()
    live = LiveRunData(live_dir)
    write_growing(live_dir, tlogs, seed, live.poll)
    data, ref = live.finish(), load_run(after)
    assert not live.broken
    assert len(ref.truth[1]) == 200 and ref.follow and ref.transforms and ref.modes[1] and ref.texts[1]
    assert pickle.dumps(data) == pickle.dumps(ref)


def test_a_tlog_that_is_not_whole_frames_gives_load_runs_data(tmp_path):
    tlogs = _tlogs()
    tlogs["vehicles.tlog"] = tlogs["vehicles.tlog"][:5000] + b"not a frame" + tlogs["vehicles.tlog"][5000:]
    after = _finished(tmp_path / "after", tlogs)
    live_dir = tmp_path / "live"
    live_dir.mkdir()
    live = LiveRunData(live_dir)
    write_growing(live_dir, tlogs, 1, live.poll)
    data = live.finish()
    assert live.broken
    assert pickle.dumps(data) == pickle.dumps(load_run(after))


def test_the_frame_tree_read_while_bridge_tlog_grows_is_the_one_drawn_after(tmp_path):
    tlogs = _run_tlogs(200)
    after = _finished(tmp_path / "a" / "run", tlogs)        # the title names the folder
    draw_frames(after)
    live_dir = tmp_path / "b" / "run"
    live_dir.mkdir(parents=True)
    frames = LiveFrames(live_dir)
    write_growing(live_dir, tlogs, 3, frames.poll)
    frames.finish()
    assert not frames.broken
    for name in ("frames.png", "frames.yaml"):
        assert (live_dir / name).read_bytes() == (after / name).read_bytes(), name
    assert (live_dir / "frames.pdf").exists()


def test_the_worker_hands_back_the_data_it_read_and_draws_from_them(tmp_path):
    tlogs = _tlogs()
    here = _finished(tmp_path / "a" / "run", tlogs)
    ref = load_run(here)
    Drawings(here, None).tracks(ref)
    there = tmp_path / "b" / "run"
    there.mkdir(parents=True)
    worker = DrawingWorker(there, None)
    worker.start()
    pid = worker.helper._child.pid
    try:
        for name in tlogs:                  # this run's tlogs, opened before the flight begins
            (there / name).write_bytes(b"")
        worker.flight_begins()
        for name, data in tlogs.items():    # written while it flies
            (there / name).write_bytes(data)
        worker.flight_over()
        data = worker.run_data()
        worker.wait()
    finally:
        worker.close()
    assert _gone(pid)
    assert pickle.dumps(data) == pickle.dumps(pickle.loads(pickle.dumps(ref)))     # (both through a pipe)
    for name in ("tracks.png", "frames.png", "frames.yaml"):
        assert (there / name).read_bytes() == (here / name).read_bytes(), name


def test_a_worker_that_never_prepared_has_no_data_and_draws_what_it_is_given(tmp_path):
    tlogs = _tlogs()
    here, there = _finished(tmp_path / "a" / "run", tlogs), _finished(tmp_path / "b" / "run", tlogs)
    Drawings(here, None).tracks(load_run(here))
    worker = DrawingWorker(there, None)
    worker.start()
    try:
        worker.flight_over()
        assert worker.run_data() is None
        worker.tracks(load_run(there))
        worker.wait()
    finally:
        worker.close()
    for name in ("tracks.png", "frames.png", "frames.yaml"):
        assert (there / name).read_bytes() == (here / name).read_bytes(), name


def _sleeper(group: ProcessGroup, name: str, code: str = "") -> subprocess.Popen:
    """A child that logs each SIGTERM it gets and ends 0.3 s after the first (or runs `code` once
    its handler is in)."""
    prog = ("import signal, sys, time\n"
            "n = 0\n"
            "def on(*_):\n"
            "    global n\n"
            "    n += 1\n"
            "    print('term', n, flush=True)\n"
            "signal.signal(signal.SIGTERM, on)\n"
            "print('ready', flush=True)\n"
            + (code or "while n < 1:\n    signal.pause()\ntime.sleep(0.3)\nprint('bye', n, flush=True)\n"))
    return group.start(name, [sys.executable, "-c", prog])


def _ready(group: ProcessGroup, name: str) -> None:
    end = time.monotonic() + 20
    while "ready" not in (group.dir / f"{name}.log").read_text().splitlines():     # (the command line has it too)
        assert time.monotonic() < end
        time.sleep(0.01)  # poll


def test_a_process_told_to_stop_is_signalled_once_and_stop_then_waits(tmp_path):
    group = ProcessGroup(tmp_path)
    p = _sleeper(group, "w")
    _ready(group, "w")
    group.tell_to_stop("w", signal.SIGTERM)
    group.tell_to_stop("w", signal.SIGTERM)       # once only
    group.stop("w", signal.SIGTERM)               # waits; no second signal in its last steps
    group.close_logs()
    assert p.returncode == 0
    log = (tmp_path / "w.log").read_text()
    assert "term 1" in log and "term 2" not in log and "bye 1" in log


def test_wait_gives_the_exit_status_when_it_ends_and_none_while_it_runs(tmp_path):
    group = ProcessGroup(tmp_path)
    _sleeper(group, "w", "signal.pause()\nsys.exit(3)\n")
    _ready(group, "w")
    assert group.wait("w", 0.05) is None
    group.tell_to_stop("w", signal.SIGTERM)
    t = time.monotonic()
    assert group.wait("w", 20) == 3
    assert time.monotonic() - t < 10
    group.close_logs()


def test_the_towers_last_line_says_the_mission_is_over():
    out = TowerOutput()
    out.feed("tower: goal 1/1 reached at t=12.3 s")
    assert not out.over.is_set()
    out.feed("tower: MISSION FAILED: 0/1 goals reached (interrupted)")
    assert out.over.is_set()
