"""fly's helper children (tools.fly_child, tools.fly_drawings, tools.fly_recorder): forked at launch,
they give the same pictures and the same run.mcap as the launcher makes itself after the flight,
and they are always stopped and reaped."""
from __future__ import annotations

import os
import signal

from tests.test_run_recording import _run_tlogs
from tools.fly_child import ForkedHelper
from tools.fly_drawings import Drawings, DrawingWorker
from tools.fly_recorder import Recorder
from tools.run_data import load_run
from tools.run_mcap import write_run_mcap


def _gone(pid: int) -> bool:
    """The process is neither running nor a zombie of ours."""
    try:
        os.waitpid(pid, os.WNOHANG)
    except ChildProcessError:
        pass
    else:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def _busy(conn) -> None:
    conn.recv()         # blocks until the parent closes the pipe or sends
    while True:         # then works until stopped
        pass


def test_close_stops_and_reaps_a_child_that_ignores_ctrl_c():
    helper = ForkedHelper("test-helper", _busy)
    helper.start()
    pid = helper._child.pid
    os.kill(pid, signal.SIGINT)             # a Ctrl-C at the terminal: the launcher's to handle
    helper.send("work")
    assert helper._child.is_alive()
    helper.close()
    assert _gone(pid)
    helper.close()                          # idempotent


def test_a_child_that_ended_is_reaped_and_jobs_to_it_are_dropped():
    helper = ForkedHelper("test-helper", lambda conn: None)
    helper.start()
    pid = helper._child.pid
    helper._child.join(10)
    helper.send("late")                     # no error: its work is left out
    helper.wait()
    assert _gone(pid)


def _folder(path):
    path.mkdir(parents=True)
    for name, data in _run_tlogs(120).items():
        (path / name).write_bytes(data)
    return path


def test_the_worker_draws_what_the_launcher_draws(tmp_path):
    here, there = _folder(tmp_path / "a" / "run"), _folder(tmp_path / "b" / "run")    # a title names the folder
    Drawings(here, None).tracks(load_run(here))
    worker = DrawingWorker(there, None)
    worker.start()
    pid = worker.helper._child.pid
    try:
        worker.flight_begins()
        worker.flight_over()
        worker.tracks(load_run(there))
        worker.wait()
    finally:
        worker.close()
    assert _gone(pid)
    for name in ("tracks.png", "frames.png", "frames.yaml"):
        assert (there / name).read_bytes() == (here / name).read_bytes(), name
    assert (there / "frames.pdf").exists()


def test_the_recorder_writes_the_run_mcap_the_launcher_writes(tmp_path):
    ref, run = _folder(tmp_path / "ref"), tmp_path / "run"
    write_run_mcap(ref)
    run.mkdir()
    (run / "bridge.tlog").write_bytes(b"an earlier run's bridge.tlog: not read")
    recorder = Recorder(run)
    recorder.start()
    pid = recorder.helper._child.pid
    try:
        for name, data in _run_tlogs(120).items():     # this run's tlogs, opened before the flight begins
            (run / name).write_bytes(data)
        recorder.flight_begins()
        recorder.flight_over()
        recorder.wait()
    finally:
        recorder.close()
    assert _gone(pid)
    assert (run / "run.mcap").read_bytes() == (ref / "run.mcap").read_bytes()


def test_a_run_that_never_flew_is_still_drawn_and_recorded(tmp_path):
    """A run that failed in its start-up: the helpers never heard that the flight began."""
    run = _folder(tmp_path / "b" / "run")
    ref = _folder(tmp_path / "a" / "run")
    write_run_mcap(ref)
    Drawings(ref, None).tracks(load_run(ref))
    worker, recorder = DrawingWorker(run, None), Recorder(run)
    worker.start()
    recorder.start()
    try:
        worker.flight_over()
        recorder.flight_over()
        worker.tracks(load_run(run))
        worker.wait()
        recorder.wait()
    finally:
        worker.close()
        recorder.close()
    for name in ("tracks.png", "frames.png", "frames.yaml", "run.mcap"):
        assert (run / name).read_bytes() == (ref / name).read_bytes(), name


def test_no_helpers_on_one_cpu(tmp_path):
    """Pinned to one CPU (a sweep's run under taskset, a one-core bench) the helpers' work during
    the flight would only slow the lockstep chain: everything is then done after the flight."""
    import subprocess
    import sys
    code = ("import os, sys; from pathlib import Path; from tools.fly import _helpers; "
            "os.sched_setaffinity(0, {min(os.sched_getaffinity(0))}); "
            "print(_helpers(Path(sys.argv[1]), None))")
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path / "run")], capture_output=True, text=True,
                         check=True, timeout=60).stdout
    assert out.strip() == "(None, None)"


def test_one_read_of_bridge_tlog_gives_what_each_reader_reads_for_itself(tmp_path):
    """With one CPU the launcher reads bridge.tlog once (tools.fly_run_folder.read_bridge) for
    run.mcap, the scores and the frame tree: the same files and data as each reading for itself."""
    import pickle

    from tools.fly_run_folder import read_bridge, write_run_mcap_quietly
    here, there = _folder(tmp_path / "a" / "run"), _folder(tmp_path / "b" / "run")
    (here / "vehicles.tlog").write_bytes((here / "bridge.tlog").read_bytes())    # the bridge's own: from bridge.tlog
    (there / "vehicles.tlog").write_bytes((there / "bridge.tlog").read_bytes())
    write_run_mcap(here)
    Drawings(here, None).tracks(load_run(here))
    bridge = read_bridge(there)
    assert bridge is not None and any(m.get_type() == "TOWERLINK_FOLLOW_STATUS" for m in bridge)
    write_run_mcap_quietly(there, bridge)
    data = load_run(there, bridge)
    Drawings(there, None, bridge).tracks(data)
    assert pickle.dumps(data) == pickle.dumps(load_run(here))
    for name in ("run.mcap", "tracks.png", "frames.png", "frames.yaml"):
        assert (there / name).read_bytes() == (here / name).read_bytes(), name
    assert read_bridge(tmp_path) is None            # no bridge.tlog: each reads for itself


def test_no_helpers_forks_none_and_helpers_forks_them_on_any_machine(tmp_path):
    """fly --no-helpers (what a sweep passes): no child; --helpers: both, even with one CPU."""
    from tools.fly import _helpers
    assert _helpers(tmp_path / "a", None, False) == (None, None)
    drawings, recorder = _helpers(tmp_path / "b", None, True)
    try:
        assert isinstance(drawings, DrawingWorker) and isinstance(recorder, Recorder)
        pids = [drawings.helper._child.pid, recorder.helper._child.pid]
    finally:
        drawings.close()
        recorder.close()
    assert all(_gone(pid) for pid in pids)
