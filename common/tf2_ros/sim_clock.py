"""A node's sim clock under lockstep: the bridge's TICKs move it, Rate sleepers wait on it.

rospy with ``/use_sim_time``, for the world's lockstep (common.mavlink.lockstep): the node's
time is the sim time of the newest TICK, and ``Rate.sleep()`` waits for sim time, not wall
time. The node's thread calls :meth:`LockstepClock.advance` for each TICK: it wakes every
sleeper due by then and returns only when each has gone back to sleep (has done its work for
that sim time), so whatever a node's loop sends in reaction goes out before the node's ACK,
and a run's figures do not depend on how fast the machine is.

A loop that does not come back to sleep within ``grace`` wall seconds (it blocks on
something else, or it ended) is not waited for again until it sleeps; ``late`` counts those.
No sockets: the thread that owns the link calls advance().
"""
from __future__ import annotations

import threading
import time

GRACE = 1.0         # wall s a woken loop may run before the TICK is answered without it


class LockstepClock:
    def __init__(self, grace: float = GRACE) -> None:
        self.grace = grace
        self._cond = threading.Condition()
        self._t = 0.0
        self._sleepers: dict[int, float] = {}     # thread ident -> sim deadline
        self._awake: set[int] = set()             # woken by a TICK, not asleep again yet
        self._closed = False
        self.ticks = 0
        self.late = 0

    def now(self) -> float:
        """Sim seconds of the newest TICK (0 before the first)."""
        return self._t

    def advance(self, t: float) -> None:
        """A TICK at sim time `t` (s): wake the sleepers due by then, wait until they sleep again."""
        with self._cond:
            self._t = max(self._t, t)
            self.ticks += 1
            for ident, deadline in list(self._sleepers.items()):
                if deadline <= self._t:
                    del self._sleepers[ident]
                    self._awake.add(ident)
            if not self._awake:
                return
            self._cond.notify_all()
            end = time.monotonic() + self.grace
            while self._awake and not self._closed:
                left = end - time.monotonic()
                if left <= 0:
                    self.late += 1
                    self._awake.clear()
                    return
                self._cond.wait(left)

    def sleep_until(self, deadline: float) -> bool:
        """Block the calling thread until sim time reaches `deadline` (s); False if closed first."""
        me = threading.get_ident()
        with self._cond:
            self._awake.discard(me)
            if self._closed:
                return False
            self._sleepers[me] = deadline
            self._cond.notify_all()            # the TICK waiting for this thread may answer now
            while me in self._sleepers and not self._closed:
                self._cond.wait(0.5)
            self._sleepers.pop(me, None)
            return not self._closed

    def release(self) -> None:
        """The calling thread is done with this TICK's work without sleeping again (it leaves)."""
        with self._cond:
            self._awake.discard(threading.get_ident())
            self._cond.notify_all()

    def close(self) -> None:
        """Wake every sleeper (their sleep returns False) and never wait again."""
        with self._cond:
            self._closed = True
            self._sleepers.clear()
            self._awake.clear()
            self._cond.notify_all()
