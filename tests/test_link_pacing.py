"""Parameter replies are paced and bounded per peer (issue 8 item 1): the PacedQueue core, and a
real `towerlink sitl` hit with one datagram packed with thousands of PARAM_REQUEST_LIST frames."""
from __future__ import annotations

import time

import pytest
from hypothesis import given, settings, strategies as st

from support import Processes
from test_sitl_support import Sitl, connect, mav, recv
from vehicle.link.paced_queue import PacedQueue


def _stream(n, size=37):
    return ((i, size) for i in range(n))


def test_restart_replaces_the_running_stream():
    q = PacedQueue(bytes_per_s=1e6, max_per_tick=5)
    q.start_stream("params", _stream(100))
    assert q.due(0.0) == [0]               # the first call has no elapsed time: one item
    assert q.due(0.02) == [1, 2, 3, 4, 5]
    for _ in range(1000):                  # a flood of requests: still one list, from the start
        q.start_stream("params", _stream(100))
    got = []
    t = 0.02
    while not q.idle():
        t += 0.02
        got += q.due(t)
    assert got == list(range(100))


def test_single_replies_bounded_and_first():
    q = PacedQueue(bytes_per_s=1e6, max_items=20)
    q.start_stream("params", _stream(10))
    assert all(q.push(("r", i), 37) for i in range(20))
    assert not q.push(("r", 20), 37) and q.dropped == 1
    out = q.due(0.0) + q.due(1.0)
    assert out == [("r", i) for i in range(6)]      # replies before the list, 5 a tick at most


def test_bandwidth_share_paces_bytes():
    # 10 kB/s at 30 %: 3000 B/s; 100-byte items: 3 per second of elapsed time, at least one a call
    q = PacedQueue(bytes_per_s=10_000, share=0.3, max_per_tick=50)
    q.start_stream("k", _stream(1000, size=100))
    q.due(0.0)
    assert len(q.due(1.0)) == 30
    assert len(q.due(1.001)) == 1
    with pytest.raises(ValueError):
        PacedQueue(bytes_per_s=0)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.sampled_from(["push", "list", "tick"]), max_size=300))
def test_held_per_peer_is_bounded(ops):
    q = PacedQueue(max_items=20, max_streams=4)
    t = 0.0
    for op in ops:
        if op == "push":
            q.push(object(), 37)
        elif op == "list":
            q.start_stream("params", _stream(60))
        else:
            t += 0.02
            assert len(q.due(t)) <= 5
        assert len(q.items) <= 20 and len(q.streams) <= 4


@pytest.mark.timeout(90)
def test_param_request_list_flood_yields_one_list_and_real_time(tmp_path):
    procs = Processes()
    try:
        sitl = Sitl(procs, tmp_path, drones=1, rovers=0, speedup=1)
        m = connect(sitl.udp[0])
        one = m.mav.param_request_list_encode(1, 1).pack(m.mav)
        flood = one * (65507 // len(one))
        assert len(flood) > 65000 and len(flood) // len(one) > 4000
        t0 = recv(m, "SYSTEM_TIME", 5)
        w0 = time.monotonic()
        m.write(flood)
        values, count, last = 0, None, time.monotonic()
        while time.monotonic() - last < 2.0:          # until 2 s pass with no PARAM_VALUE
            pv = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.2)
            if pv is not None:
                values += 1
                count = pv.param_count
                last = time.monotonic()
        assert count and count <= values <= 2 * count, (values, count)
        t1 = recv(m, "SYSTEM_TIME", 5)
        w1 = time.monotonic()
        ratio = (t1.time_boot_ms - t0.time_boot_ms) / 1000.0 / (w1 - w0)
        assert ratio > 0.85, f"world ran at {ratio:.2f}x real time"
        print(f"flood of {len(flood) // len(one)} PARAM_REQUEST_LIST: {values} PARAM_VALUE "
              f"({count} parameters), world at {ratio:.2f}x real time")
        # the vehicle still answers a single read afterwards
        m.mav.param_request_read_send(1, 1, b"RTL_ALT", -1)
        assert recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "RTL_ALT").param_value == 1500
        assert sitl.proc.poll() is None
    finally:
        procs.stop_all()


@pytest.mark.timeout(90)
def test_param_set_flood_echoes_once_saves_once_and_real_time(tmp_path):
    """One datagram of PARAM_SETs (1871 frames): each parameter is echoed once to every peer
    and the file written once a tick, so the world keeps real time (it stalled 2.3 s writing
    the file 1871 times)."""
    procs = Processes()
    try:
        sitl = Sitl(procs, tmp_path, drones=1, rovers=0, speedup=1)
        m = connect(sitl.udp[0])
        a = m.mav.param_set_encode(1, 1, b"RTL_ALT", 2000, mav.MAV_PARAM_TYPE_INT32).pack(m.mav)
        b = m.mav.param_set_encode(1, 1, b"DISARM_DELAY", 6, mav.MAV_PARAM_TYPE_INT32).pack(m.mav)
        flood = (a + b) * (65507 // (len(a) + len(b)))
        t0 = recv(m, "SYSTEM_TIME", 5)
        w0 = time.monotonic()
        m.write(flood)
        echoes = []
        m.mav.param_request_read_send(1, 1, b"WPNAV_SPEED", -1)   # answered after the echoes
        while True:
            pv = recv(m, "PARAM_VALUE", 10)
            if pv.param_id == "WPNAV_SPEED":
                break
            echoes.append((pv.param_id, pv.param_value))
        assert sorted(echoes) == [("DISARM_DELAY", 6), ("RTL_ALT", 2000)]
        t1 = recv(m, "SYSTEM_TIME", 5, cond=lambda s: s.time_boot_ms > t0.time_boot_ms + 2000)
        ratio = (t1.time_boot_ms - t0.time_boot_ms) / 1000.0 / (time.monotonic() - w0)
        assert ratio > 0.85, f"world ran at {ratio:.2f}x real time"
        saved = (tmp_path / "state" / "drone0.parm").read_text()
        assert "RTL_ALT 2000" in saved and "DISARM_DELAY 6" in saved
    finally:
        procs.stop_all()


def test_statustext_per_received_chunk_is_bounded():
    """A datagram of a thousand mode changes to an unknown mode: at most 30 STATUSTEXT (ArduPilot's
    queue), yet every command gets its COMMAND_ACK; texts of later datagrams go out again."""
    from test_command_nonfinite import Gcs
    from vehicle.world import World, WorldConfig
    w = World(WorldConfig(drones=1, rovers=0, state_dir=None, tcp_base=None, udp_base=None))
    link = w.vehicles[0].link
    sent = []
    link.endpoints = [type("E", (), {"send": lambda self, b: sent.append(b), "close": lambda self: None})()]
    gcs = Gcs(link)
    one = gcs.enc.command_long_encode(1, 1, mav.MAV_CMD_DO_SET_MODE, 0, 1, 77, 0, 0, 0, 0, 0).pack(gcs.enc)
    assert link.on_data(one * 1000, gcs.ch)
    acks = [m for m in gcs.got if m.get_type() == "COMMAND_ACK"]
    texts = [m for b in sent for m in gcs.dec.parse_buffer(b) or [] if m.get_type() == "STATUSTEXT"]
    assert len(acks) == 1000 and all(a.result == mav.MAV_RESULT_FAILED for a in acks)
    assert len(texts) == 30 and texts[0].text == "No such mode 77"         # AP_Vehicle's words
    assert link.stats["text_dropped"] == 970
    sent.clear()
    assert link.on_data(one, gcs.ch)
    assert len([m for b in sent for m in gcs.dec.parse_buffer(b) or [] if m.get_type() == "STATUSTEXT"]) == 1
