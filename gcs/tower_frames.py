"""The bridge's transform stream on the tower link, and the questions a tower on a van asks.

:class:`TowerFrames` keeps the TOWERLINK_TRANSFORM stream in a tf2-style Buffer (a
TransformListener in small) and answers where a goal stamped t lies in world and where a world
point lies in the tower frame now (tf2 time travel). Frames: world is the fixed frame; m, NED.
"""
from __future__ import annotations

import math
import threading
from collections.abc import Sequence


class TowerFrames:
    """The bridge's transform stream on the tower link, kept in a Buffer (tf2's TransformListener).

    Fed with the received messages (a Client listener, or subscribed to TOWERLINK_TRANSFORM);
    answers, for a frame hanging on a moving vehicle, where a goal stamped t lies in world and
    where a world point lies in that frame now. Frames: world is the fixed frame; positions are m, NED.
    """

    def __init__(self, fixed: str = "world", cache_time: float = 30.0) -> None:
        from common.frames import Buffer
        from common.tf2_ros.stream import TransformStream
        self.fixed = fixed
        self.buffer = Buffer(cache_time=cache_time)
        self.stream = TransformStream(self.buffer)     # tf2_ros's listener core: stream -> buffer
        self.lock = threading.Lock()

    def on_message(self, msg) -> None:
        """Client listener: every received message (only TOWERLINK_TRANSFORM is kept)."""
        if msg.get_type() == "TOWERLINK_TRANSFORM":
            with self.lock:             # several connections feed one buffer
                self.stream.feed(msg)

    def moving(self, frame: str) -> bool:
        """Does `frame` hang on a dynamic edge below the fixed frame?"""
        from common.frames import TransformException
        with self.lock:
            try:
                stats = self.buffer.edge_stats()
                return any(f in stats and not stats[f].is_static for f in self.buffer.chain(self.fixed, frame))
            except TransformException:
                return False

    def world_point(self, frame: str, p: Sequence[float], stamp: float | None):
        """`p` in `frame` at `stamp`, in the fixed frame (tf2 time travel); None until known."""
        from common.frames import TransformException
        if stamp is None:
            return None
        with self.lock:
            try:
                T = self.buffer.lookup_transform_full(self.fixed, stamp, frame, stamp, self.fixed)
            except TransformException:
                return None
        return tuple(float(v) for v in T.transform.apply_point(p))

    def seen_from(self, frame: str, world: Sequence[float]):
        """A fixed-frame point in `frame` with the latest transform; None if unknown."""
        from common.frames import LATEST, TransformException
        with self.lock:
            try:
                T = self.buffer.lookup_transform(frame, self.fixed, LATEST)
            except TransformException:
                return None
        return tuple(float(v) for v in T.transform.apply_point(world))

    def latest_offset(self, frame: str, p: Sequence[float], world: Sequence[float]) -> float | None:
        """How far `p` in `frame` resolved with the latest transform lands from `world`, m."""
        from common.frames import LATEST, TransformException
        with self.lock:
            try:
                T = self.buffer.lookup_transform(self.fixed, frame, LATEST)
            except TransformException:
                return None
        return float(math.dist(T.transform.apply_point(p), world))
