"""A vehicle's log folder (vehicle/logs/store.py) as ArduPilot's File backend keeps it, and the
writer thread that appends to it (vehicle/logs/writer.py)."""
from __future__ import annotations

import os
import threading

from vehicle.logs.store import LASTLOG, LogStore, log_name
from vehicle.logs.writer import LogWriter


def test_names_numbers_and_lastlog(tmp_path):
    s = LogStore(tmp_path / "logs")
    assert s.entries() == [] and s.last_number() == 0
    p1 = s.new_log()
    assert p1.name == "00000001.BIN" and log_name(42) == "00000042.BIN"
    assert (tmp_path / "logs" / LASTLOG).read_bytes() == b"1\r\n"
    # an empty newest log is re-used (ArduPilot: a log that got no data takes the same number)
    assert s.new_log() == p1
    # ...unless its bytes are still queued for the disk: a busy number is not re-used
    assert s.new_log(busy={1}).name == "00000002.BIN"
    (tmp_path / "logs" / "00000002.BIN").unlink()
    (tmp_path / "logs" / "LASTLOG.TXT").write_text("1\r\n")
    p1.write_bytes(b"abc")
    p2 = s.new_log()
    assert p2.name == "00000002.BIN" and s.last_number() == 2
    p2.write_bytes(b"defgh")
    es = s.entries()
    assert [(e.num, e.size) for e in es] == [(1, 3), (2, 5)]
    assert s.read(2, 1, 3) == b"efg" and s.read(2, 4, 10) == b"h" and s.read(2, 9, 10) == b""
    assert s.read(7, 0, 10) == b""                       # no such log


def test_numbering_wraps_and_lists_oldest_first(tmp_path):
    s = LogStore(tmp_path, max_files=3)
    for k in range(4):
        s.new_log().write_bytes(b"x" * (k + 1))
    # logs 1..3, then 1 again: the oldest on disk is now 2, then 3, then the new 1
    assert s.last_number() == 1
    assert [(e.num, e.size) for e in s.entries()] == [(2, 2), (3, 3), (1, 4)]


def test_lastlog_missing_or_garbled_falls_back_to_the_files(tmp_path):
    s = LogStore(tmp_path)
    (tmp_path / "00000005.BIN").write_bytes(b"z")
    (tmp_path / "notes.txt").write_text("not a log")
    assert s.new_log().name == "00000006.BIN"
    (tmp_path / LASTLOG).write_text("garbage")
    (tmp_path / "00000006.BIN").write_bytes(b"y")
    assert s.new_log().name == "00000007.BIN"


def test_erase_removes_logs_and_lastlog_only(tmp_path):
    s = LogStore(tmp_path)
    s.new_log().write_bytes(b"1")
    s.new_log()
    (tmp_path / "keep.txt").write_text("x")
    s.erase()
    assert sorted(os.listdir(tmp_path)) == ["keep.txt"]
    assert s.new_log().name == "00000001.BIN"


def test_writer_appends_in_order_and_never_blocks(tmp_path):
    w = LogWriter()
    path = str(tmp_path / "a.BIN")
    for k in range(200):
        assert w.write(path, bytes([k % 256]) * 10)
    assert w.flush(5)
    data = (tmp_path / "a.BIN").read_bytes()
    assert data == b"".join(bytes([k % 256]) * 10 for k in range(200))
    assert w.written == 2000 and w.pending == 0 and w.dropped == 0
    w.stop()


def test_writer_drops_whole_chunks_when_full(tmp_path):
    w = LogWriter(max_pending=100)
    gate = threading.Event()
    w.call(gate.wait)                      # hold the thread: nothing gets written meanwhile
    path = str(tmp_path / "b.BIN")
    assert w.write(path, b"a" * 60)
    assert not w.write(path, b"b" * 60)     # would exceed 100 pending bytes: dropped whole
    assert w.write(path, b"c" * 40)
    gate.set()
    assert w.flush(5)
    assert (tmp_path / "b.BIN").read_bytes() == b"a" * 60 + b"c" * 40
    assert w.dropped == 60
    w.stop()


def test_writer_calls_run_in_queue_order(tmp_path):
    w = LogWriter()
    path = tmp_path / "c.BIN"
    w.write(str(path), b"old")
    w.call(lambda: path.unlink())          # an erase after the queued chunk...
    w.write(str(path), b"new")             # ...and what comes after it
    w.close(str(path))
    assert w.flush(5)
    assert path.read_bytes() == b"new"
    w.stop()
