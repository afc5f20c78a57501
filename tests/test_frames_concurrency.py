"""Timeouts wake on inserts; one writer and many readers see consistent transforms.

The timeout tests run on a clock passed to the buffer (Buffer(clock=...)), moved by the
test: they check the deadline exactly and never wait out wall time."""
from __future__ import annotations

import threading

import pytest

from support import wait_until

from common.frames import (LATEST, Buffer, ExtrapolationException, TimeoutException, Transform,
                           TransformStamped)


def ts(parent, child, stamp, tf=None):
    return TransformStamped(parent, child, stamp, tf or Transform())


class FakeClock:
    """Stands in for the buffer's wall clock (Buffer's `clock`): it moves only
    when the test moves it, and counts how often the buffer read it."""

    def __init__(self, now: float = 100.0) -> None:
        self.now = now
        self.calls = 0
        self._lock = threading.Lock()

    def __call__(self) -> float:
        with self._lock:
            self.calls += 1
            return self.now

    def advance_to(self, t: float) -> None:
        with self._lock:
            self.now = t


@pytest.fixture
def clock():
    return FakeClock()


class Waiter(threading.Thread):
    """Runs one blocking buffer call; keeps its result or its exception."""

    def __init__(self, b: Buffer, fn) -> None:
        super().__init__(daemon=True)
        self.b, self.fn, self.result, self.error = b, fn, None, None
        self.start()
        wait_until(lambda: b.waiting > 0 or not self.is_alive(), 5.0, "the call to block", interval=0.001)

    def run(self) -> None:
        try:
            self.result = self.fn()
        except Exception as e:  # reported by the test
            self.error = e

    def done(self, timeout: float = 5.0):
        self.join(timeout)
        assert not self.is_alive(), "the call is still blocked"
        return self


def _poke(b: Buffer, k: int = 0) -> None:
    """An insert on an edge nobody waits for: wakes every waiter to re-check."""
    b.set_transform(ts("world", "unrelated", float(k)))


def test_lookup_with_timeout_returns_as_soon_as_data_arrives(clock):
    b = Buffer(clock=clock)
    b.set_transform(ts("world", "drone", 1.0))
    w = Waiter(b, lambda: b.lookup_transform("world", "drone", 2.0, timeout=10.0))
    assert w.is_alive() and w.error is None
    b.set_transform(ts("world", "drone", 2.0, Transform((2, 0, 0))))
    w.done()
    assert w.error is None, w.error
    assert w.result.transform.translation[0] == 2.0 and w.result.stamp == 2.0
    assert clock.now == 100.0      # the clock never moved: the insert, not a timeout, ended it


def test_lookup_with_timeout_waits_for_new_frame_and_can_transform(clock):
    b = Buffer(clock=clock)
    w = Waiter(b, lambda: b.can_transform("world", "rover", LATEST, timeout=10.0))
    assert w.is_alive()
    b.set_transform_static(ts("world", "rover", 0.0))
    assert w.done().result is True


@pytest.mark.parametrize("timeout", [0.2, 0.5])
@pytest.mark.parametrize("call", ["lookup_transform", "can_transform"])
def test_timeout_expires_at_the_deadline_not_before(clock, timeout, call):
    b = Buffer(clock=clock)
    b.set_transform(ts("world", "drone", 1.0))
    w = Waiter(b, lambda: getattr(b, call)("world", "drone", 5.0, timeout=timeout))
    # just before the deadline, woken: it looks at the clock again and keeps waiting
    clock.advance_to(100.0 + timeout * 0.99)
    n = clock.calls
    _poke(b)
    wait_until(lambda: clock.calls > n, 5.0, "the waiter to re-read the clock", interval=0.001)
    assert w.is_alive() and w.error is None and b.waiting == 1
    # at the deadline: it gives up
    clock.advance_to(100.0 + timeout)
    _poke(b, 1)
    w.done()
    if call == "can_transform":
        assert w.error is None and w.result is False
    else:
        assert isinstance(w.error, TimeoutException), w.error
        assert f"Timed out after {timeout:.3f} s" in str(w.error)
        assert isinstance(w.error.last_error, ExtrapolationException)
    assert b.waiting == 0


def test_unrelated_inserts_do_not_end_the_wait_early(clock):
    b = Buffer(clock=clock)
    b.set_transform(ts("world", "drone", 1.0))
    w = Waiter(b, lambda: b.lookup_transform("world", "drone", 5.0, timeout=0.3))
    n = clock.calls
    for k in range(200):                        # every one wakes it; none is what it waits for
        _poke(b, k)
    wait_until(lambda: clock.calls > n, 5.0, "the waiter to wake", interval=0.001)
    assert w.is_alive() and w.error is None
    clock.advance_to(100.3)
    _poke(b, 200)
    assert isinstance(w.done().error, TimeoutException)


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
