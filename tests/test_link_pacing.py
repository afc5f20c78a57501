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
