"""Timeouts wake on inserts; one writer and many readers see consistent transforms."""
from __future__ import annotations

import threading
import time

import pytest

from support import wait_until

from gcs.frames import (LATEST, Buffer, ExtrapolationException, TimeoutException, Transform,
                           TransformStamped)


def ts(parent, child, stamp, tf=None):
    return TransformStamped(parent, child, stamp, tf or Transform())


def test_lookup_with_timeout_returns_as_soon_as_data_arrives():
    b = Buffer()
    b.set_transform(ts("world", "drone", 1.0))
    waiting = threading.Event()
    result: dict = {}

    def reader():
        waiting.set()
        t0 = time.monotonic()
        try:
            result["ts"] = b.lookup_transform("world", "drone", 2.0, timeout=10.0)
        except Exception as e:  # reported below
            result["error"] = e
        result["elapsed"] = time.monotonic() - t0

    th = threading.Thread(target=reader)
    th.start()
    assert waiting.wait(5.0)
    # make sure the reader is actually blocked in the condition before inserting
    wait_until(lambda: b._waiting > 0, 5.0, "the reader to block", interval=0.001)
    t_insert = time.monotonic()
    b.set_transform(ts("world", "drone", 2.0, Transform((2, 0, 0))))
    th.join(5.0)
    assert not th.is_alive()
    assert "error" not in result, result.get("error")
    assert result["ts"].transform.translation[0] == 2.0
    assert result["elapsed"] < 5.0  # far below the 10 s timeout
    assert time.monotonic() - t_insert < 2.0


def test_lookup_with_timeout_waits_for_new_frame_and_can_transform():
    b = Buffer()
    done = threading.Event()
    out = {}

    def reader():
        out["ok"] = b.can_transform("world", "rover", LATEST, timeout=10.0)
        done.set()

    th = threading.Thread(target=reader)
    th.start()
    wait_until(lambda: b._waiting > 0, 5.0, "the reader to block", interval=0.001)
    b.set_transform_static(ts("world", "rover", 0.0))
    assert done.wait(5.0)
    th.join(5.0)
    assert out["ok"] is True


@pytest.mark.parametrize("timeout", [0.2, 0.5])
def test_timeout_expires_after_about_timeout(timeout):
    b = Buffer()
    b.set_transform(ts("world", "drone", 1.0))
    t0 = time.monotonic()
    with pytest.raises(TimeoutException):
        b.lookup_transform("world", "drone", 5.0, timeout=timeout)
    elapsed = time.monotonic() - t0
    assert timeout * 0.95 <= elapsed < timeout + 0.5
    t0 = time.monotonic()
    assert b.can_transform("world", "drone", 5.0, timeout=timeout) is False
    assert timeout * 0.95 <= time.monotonic() - t0 < timeout + 0.5


def test_unrelated_inserts_do_not_end_the_wait_early():
    b = Buffer()
    b.set_transform(ts("world", "drone", 1.0))
    stop = threading.Event()

    def noise():
        k = 0
        while not stop.is_set():
            k += 1
            b.set_transform(ts("world", "rover", float(k)))
            stop.wait(0.005)

    th = threading.Thread(target=noise)
    th.start()
    try:
        t0 = time.monotonic()
        with pytest.raises(TimeoutException):
            b.lookup_transform("world", "drone", 5.0, timeout=0.3)
        assert time.monotonic() - t0 >= 0.28
    finally:
        stop.set()
        th.join(5.0)


def test_one_writer_many_readers_consistent():
    """The writer stores translation (t, 2t, 3t) and yaw 0.01 t at stamp t, on a two-edge
    chain; every interpolated result a reader sees must satisfy the same invariant."""
    b = Buffer(cache_time=2.0)
    b.set_transform_static(ts("map", "world", 0.0))
    stop = threading.Event()
    errors: list[BaseException] = []
    ok_counts = [0] * 4      # checked results per reader (each reader writes its own slot)
    extrap_counts = [0] * 4
    written = threading.Event()
    dt = 0.001

    def writer():
        k = 0
        try:
            while not stop.is_set():
                t = k * dt
                b.set_transform(ts("world", "drone", t,
                                   Transform.from_euler(yaw=0.01 * t, translation=(t, 2 * t, 3 * t))))
                k += 1
                if k == 50:
                    written.set()
        except BaseException as e:
            errors.append(e)

    def reader(seed):
        import random
        rng = random.Random(seed)
        try:
            while not stop.is_set():
                if rng.random() < 0.5:
                    try:
                        out = b.lookup_transform("map", "drone", LATEST)
                    except ExtrapolationException:
                        extrap_counts[seed] += 1
                        continue
                else:
                    newest = b.get_latest_common_time("map", "drone")
                    t = rng.uniform(newest - 2.5, newest + 0.01)
                    try:
                        out = b.lookup_transform("map", "drone", t)
                    except ExtrapolationException:
                        extrap_counts[seed] += 1
                        continue
                t = out.stamp
                x, y, z = out.transform.xyz
                assert abs(y - 2 * x) < 1e-9 and abs(z - 3 * x) < 1e-9, (t, x, y, z)
                assert abs(x - t) < 1e-9, (t, x)
                yaw = out.transform.yaw_pitch_roll()[0]
                assert abs(yaw - 0.01 * t) < 1e-9, (t, yaw)
                try:  # the writer may have slid the window past t in between
                    back = b.lookup_transform("drone", "map", t).transform
                except ExtrapolationException:
                    extrap_counts[seed] += 1
                    continue
                assert (back * out.transform).almost_equal(Transform.identity(), 1e-9)
                ok_counts[seed] += 1
        except BaseException as e:
            errors.append(e)

    w = threading.Thread(target=writer)
    readers = [threading.Thread(target=reader, args=(i,)) for i in range(4)]
    w.start()
    assert written.wait(10.0)
    for r in readers:
        r.start()
    # let them race until every reader has checked enough results (or one failed)
    try:
        wait_until(lambda: errors or min(ok_counts) >= 500, 30.0, "readers to check 500 results each")
    finally:
        stop.set()
    w.join(10.0)
    for r in readers:
        r.join(10.0)
    assert not errors, errors[0]
    assert min(ok_counts) >= 500, (ok_counts, extrap_counts)
    assert b.edge_stats()["drone"].inserts > 1000
