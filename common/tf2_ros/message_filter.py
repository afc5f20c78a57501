"""MessageFilter (tf2_ros): hold stamped data until it can be transformed, then deliver it.

Semantics (tf2_ros/message_filter.h, ROS 2):

* ``add(msg)``: `msg` is stamped data (common.frames PointStamped, VectorStamped,
  PoseStamped, or anything with ``frame_id`` and ``stamp``). If the buffer can transform
  ``msg.frame_id`` into the target frame at ``msg.stamp`` now, the callbacks get it at
  once; otherwise it waits in the queue.
* Every time the buffer gets new transforms (the listener tells the filter) and on
  :meth:`MessageFilter.poll`, the waiting messages are tried again, oldest first; each
  one that has become transformable is delivered, in arrival order.
* Dropped, with the reason given to the failure callbacks ``(msg, reason)``:
  ``EmptyFrameID`` (no frame id), ``OutTheBack`` (its stamp is more than the buffer's
  cache_time older than the newest data on the chain: it can never be transformed),
  ``QueueFull`` (the queue held ``queue_size`` messages; the *oldest* is pushed out),
  ``NoTransformFound`` (it waited longer than ``timeout`` wall seconds, tf2_ros's
  buffer_timeout). ``queue_size`` 0 means unbounded; ``timeout`` None waits for ever.

The callbacks get the message itself, as in tf2_ros; transform it with
``buffer.transform_point(msg, target_frame)`` etc., which is then certain to succeed
for a stamped time, or use :meth:`MessageFilter.transform`.

:class:`FilterQueue` is the pure core (no threads, no clock: the caller passes `now`);
:class:`MessageFilter` adds the lock, the callbacks, the listener hook and a timer.
"""
from __future__ import annotations

import enum
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from common.frames import (LATEST, Buffer, ExtrapolationException, PointStamped, PoseStamped,
                        TransformException, VectorStamped)


class FilterFailureReason(enum.Enum):
    """Why a message was dropped (tf2_ros filter_failure_reasons)."""
    Unknown = "unknown"
    OutTheBack = "stamp older than the transform cache"
    EmptyFrameID = "message has no frame id"
    NoTransformFound = "no transform within the timeout"
    QueueFull = "queue full: oldest message dropped"


@dataclass
class _Waiting:
    msg: Any
    since: float            # `now` when added


@dataclass
class FilterResult:
    """What one add/poll decided: messages ready (in order) and messages dropped with reasons."""
    ready: list = field(default_factory=list)
    dropped: list = field(default_factory=list)     # (msg, FilterFailureReason, detail)


class FilterQueue:
    """Pure core: which messages are transformable into `target_frame` now, which wait, which go."""

    def __init__(self, buffer: Buffer, target_frame: str, queue_size: int = 10,
                 timeout: float | None = None) -> None:
        if queue_size < 0:
            raise ValueError(f"queue_size must be >= 0 (0: unbounded), got {queue_size!r}")
        if timeout is not None and not timeout >= 0:
            raise ValueError(f"timeout must be >= 0 s or None, got {timeout!r}")
        self.buffer = buffer
        self.target_frame = target_frame
        self.queue_size = queue_size
        self.timeout = timeout
        self.queue: deque[_Waiting] = deque()

    def __len__(self) -> int:
        return len(self.queue)

    def _state(self, msg) -> tuple[str, str]:
        """('ready' | 'wait' | 'never', detail) for one message now."""
        frame = getattr(msg, "frame_id", "")
        stamp = getattr(msg, "stamp", LATEST)
        try:
            self.buffer.lookup_transform(self.target_frame, frame, stamp)
            return "ready", ""
        except ExtrapolationException as exc:
            # tf2: a request older than the cache window behind the newest data can
            # never be answered (the cache only moves forward)
            try:
                newest = self.buffer.get_latest_common_time(self.target_frame, frame)
            except TransformException:
                return "wait", str(exc)
            if stamp is not LATEST and stamp + self.buffer.cache_time < newest:
                return "never", str(exc)
            return "wait", str(exc)
        except TransformException as exc:
            return "wait", str(exc)

    def add(self, msg, now: float) -> FilterResult:
        out = FilterResult()
        if not getattr(msg, "frame_id", ""):
            out.dropped.append((msg, FilterFailureReason.EmptyFrameID, "empty frame_id"))
            return out
        self._expire(now, out)
        state, detail = self._state(msg)
        if state == "ready":
            out.ready.append(msg)
        elif state == "never":
            out.dropped.append((msg, FilterFailureReason.OutTheBack, detail))
        else:
            if self.queue_size and len(self.queue) + 1 > self.queue_size:
                old = self.queue.popleft()
                out.dropped.append((old.msg, FilterFailureReason.QueueFull,
                                    f"queue_size {self.queue_size} reached"))
            self.queue.append(_Waiting(msg, now))
        return out

    def poll(self, now: float) -> FilterResult:
        """Try every waiting message again (after new transforms, or on a timer)."""
        out = FilterResult()
        self._expire(now, out)
        keep: deque[_Waiting] = deque()
        for w in self.queue:
            state, detail = self._state(w.msg)
            if state == "ready":
                out.ready.append(w.msg)
            elif state == "never":
                out.dropped.append((w.msg, FilterFailureReason.OutTheBack, detail))
            else:
                keep.append(w)
        self.queue = keep
        return out

    def _expire(self, now: float, out: FilterResult) -> None:
        if self.timeout is None:
            return
        keep: deque[_Waiting] = deque()
        for w in self.queue:
            if now - w.since > self.timeout:
                state, detail = self._state(w.msg)
                if state == "ready":            # made it just in time
                    out.ready.append(w.msg)
                else:
                    out.dropped.append((w.msg, FilterFailureReason.NoTransformFound,
                                        f"{w.msg.frame_id} -> {self.target_frame} at {w.msg.stamp!r}: waited "
                                        f"{now - w.since:.2f} s > {self.timeout:g} s: {detail}"))
            else:
                keep.append(w)
        self.queue = keep

    def clear(self) -> None:
        self.queue.clear()


class MessageFilter:
    """tf2_ros.MessageFilter over a TransformListener (or a bare Buffer you feed yourself).

    ``MessageFilter(listener, "world", queue_size=10, timeout=1.0)``; then
    ``register_callback(fn(msg))``, ``register_failure_callback(fn(msg, reason))`` and
    ``add(msg)``. With a listener the queue is tried again whenever a transform arrives
    and, when a timeout is set, on a timer; with a Buffer call :meth:`poll` yourself.
    Callbacks run in the thread that caused the delivery (add's caller, the listener's
    thread, or the timer), never under the filter's lock.
    """

    def __init__(self, source, target_frame: str, queue_size: int = 10, timeout: float | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        buffer = source if isinstance(source, Buffer) else getattr(source, "buffer", None)
        if not isinstance(buffer, Buffer):
            raise TypeError(f"MessageFilter needs a TransformListener or a Buffer, got {type(source).__name__}")
        self.core = FilterQueue(buffer, target_frame, queue_size, timeout)
        self.buffer = buffer
        self.target_frame = target_frame
        self.clock = clock
        self._lock = threading.Lock()
        self._callbacks: list[Callable] = []
        self._failure_callbacks: list[Callable] = []
        self.delivered = 0
        self.dropped: dict[FilterFailureReason, int] = {r: 0 for r in FilterFailureReason}
        self.last_drop: tuple | None = None          # (msg, reason, detail)
        self._stop = threading.Event()
        if not isinstance(source, Buffer) and hasattr(source, "add_callback"):
            source.add_callback(self.poll)
            if timeout is not None:
                period = min(max(timeout / 4, 0.01), 0.1)
                threading.Thread(target=self._timer, args=(period,), daemon=True,
                                 name=f"message-filter-{target_frame}").start()

    def register_callback(self, fn: Callable[[Any], None]) -> None:
        self._callbacks.append(fn)

    def register_failure_callback(self, fn: Callable[[Any, FilterFailureReason], None]) -> None:
        self._failure_callbacks.append(fn)

    registerCallback = register_callback
    registerFailureCallback = register_failure_callback

    def add(self, msg) -> None:
        with self._lock:
            res = self.core.add(msg, self.clock())
        self._emit(res)

    def poll(self) -> None:
        with self._lock:
            res = self.core.poll(self.clock())
        self._emit(res)

    def transform(self, msg):
        """`msg` (a PointStamped, VectorStamped or PoseStamped) in the target frame."""
        if isinstance(msg, PointStamped):
            return self.buffer.transform_point(msg, self.target_frame)
        if isinstance(msg, VectorStamped):
            return self.buffer.transform_vector(msg, self.target_frame)
        if isinstance(msg, PoseStamped):
            return self.buffer.transform_pose(msg, self.target_frame)
        raise TypeError(f"cannot transform a {type(msg).__name__}")

    @property
    def waiting(self) -> int:
        with self._lock:
            return len(self.core)

    def clear(self) -> None:
        with self._lock:
            self.core.clear()

    def close(self) -> None:
        self._stop.set()

    def _timer(self, period: float) -> None:
        while not self._stop.wait(period):
            if len(self.core):
                self.poll()

    def _emit(self, res: FilterResult) -> None:
        for msg, reason, detail in res.dropped:
            self.dropped[reason] += 1
            self.last_drop = (msg, reason, detail)
            for fn in self._failure_callbacks:
                fn(msg, reason)
        for msg in res.ready:
            self.delivered += 1
            for fn in self._callbacks:
                fn(msg)
