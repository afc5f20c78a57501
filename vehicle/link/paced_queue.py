"""A per-peer outbox for replies that ArduPilot spreads over the link's bandwidth (pure: no
sockets, no clocks; the caller passes sim time and sends what `due()` returns).

ArduPilot (GCS_Param.cpp queued_param_send) sends a parameter list a few PARAM_VALUE at a
time from its deferred-message loop, using at most 30 % of the link's bandwidth and, without
flow control, at most 5 per call; a new PARAM_REQUEST_LIST restarts the list from the first
parameter instead of queueing a second one, and single replies (PARAM_REQUEST_READ) wait in
a small fixed-size queue (20) that drops requests when full. This is that, for any reply kind:

    q = PacedQueue(bytes_per_s=1_000_000)
    q.start_stream("params", gen)      # gen yields (msg, nbytes); replaces any "params" stream
    q.push(msg, nbytes)                # a single reply; False (dropped, counted) when full
    for msg in q.due(now_s): send(msg)

Single replies go before stream items (ArduPilot sends the async replies first). What one
peer can make a vehicle hold is bounded: `max_items` single replies plus one iterator per
stream key, and `max_streams` keys.
"""
from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from typing import Any

Item = tuple[Any, int]          # (message, its size on the wire in bytes)


class PacedQueue:
    """Replies for one peer, released at `share` of `bytes_per_s`, at most `max_per_tick` a call."""

    def __init__(self, bytes_per_s: float = 1_000_000.0, share: float = 0.3, max_items: int = 20,
                 max_per_tick: int = 5, max_streams: int = 4) -> None:
        if bytes_per_s <= 0 or not 0 < share <= 1:
            raise ValueError("bytes_per_s must be > 0 and 0 < share <= 1")
        self.rate = bytes_per_s * share          # bytes per second this queue may use
        self.max_items = max_items
        self.max_per_tick = max_per_tick
        self.max_streams = max_streams
        self.items: deque[Item] = deque()
        self.streams: dict[str, Iterator[Item]] = {}
        self.dropped = 0                         # single replies refused because the queue was full
        self.last: float | None = None           # sim time of the last due()
        # an item taken out that did not fit the budget, with its stream key (None: a single reply)
        self._held: tuple[Item, str | None] | None = None

    def __len__(self) -> int:
        return len(self.items) + len(self.streams) + (self._held is not None)

    def idle(self) -> bool:
        return not self.items and not self.streams and self._held is None

    def push(self, msg: Any, nbytes: int) -> bool:
        """Queue one reply; False (and counted in `dropped`) when `max_items` are waiting."""
        if len(self.items) >= self.max_items:
            self.dropped += 1
            return False
        self.items.append((msg, int(nbytes)))
        return True

    def start_stream(self, key: str, items: Iterator[Item]) -> bool:
        """Send `items` paced; a stream already running under `key` is replaced (restarted).
        False when `max_streams` other keys are running (the new stream is dropped)."""
        if key not in self.streams and len(self.streams) >= self.max_streams:
            self.dropped += 1
            return False
        self.streams[key] = iter(items)
        if self._held is not None and self._held[1] == key:
            self._held = None                 # restarted: the old stream's next item is stale
        return True

    def cancel(self, key: str) -> None:
        self.streams.pop(key, None)
        if self._held is not None and self._held[1] == key:
            self._held = None

    def clear(self) -> None:
        self.items.clear()
        self.streams.clear()
        self._held = None

    def due(self, now: float) -> list[Any]:
        """Messages to send at sim time `now` (seconds): as many as the byte budget since the
        previous call allows, at least one, at most `max_per_tick`."""
        if self.idle():
            self.last = now
            return []
        elapsed = 0.0 if self.last is None else max(0.0, now - self.last)
        self.last = now
        budget = self.rate * elapsed
        out: list[Any] = []
        while len(out) < self.max_per_tick:
            nxt = self._next()
            if nxt is None:
                break
            (msg, nbytes), key = nxt
            if out and budget < nbytes:
                self._held = ((msg, nbytes), key)   # over budget: first in line next time
                break
            budget -= nbytes                  # the first always goes: a slow link still progresses
            out.append(msg)
        return out

    def _next(self) -> tuple[Item, str | None] | None:
        if self._held is not None:
            held, self._held = self._held, None
            return held
        if self.items:
            return self.items.popleft(), None
        for key in list(self.streams):
            item = next(self.streams[key], None)
            if item is None:
                del self.streams[key]
                continue
            return item, key
        return None
