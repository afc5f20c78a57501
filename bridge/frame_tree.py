"""The bridge's frame tree: the Buffer, its static frames, and the vehicles' dynamic edges.

* Static frames come from the scenario (authority ``scenario``) and, live, from
  TOWERLINK_STATIC_TRANSFORM (authority ``static-transform:<sysid>``); who may add or
  redefine which frame is decided before :meth:`FrameTree.add_static` is called (see
  bridge.trust). Frames the bridge owns (``world`` and every vehicle's ``<name>`` and
  ``<name>_yaw``) are never static. Statics are republished by the loop at 1 Hz wall.
* Each vehicle's paired samples (bridge.pairing), already on the one timeline
  (bridge.timeline), set ``world -> <name>`` and ``world -> <name>_yaw``; a reset (the
  timeline saw its clock go back) empties those two edges first. The stream is thinned
  to ``tf_rate``: a sample closer than half a period to the last published one is stored
  but not published.
* :meth:`FrameTree.fresh_lookup` is the lookup for goals: LATEST, refusing a chain with a
  dynamic edge whose latest common time is older than ``max_age`` against the newest
  vehicle clock (a stale pose would send a drone somewhere it was told not to go).
"""
from __future__ import annotations

from common.frames import LATEST, Buffer, TransformStamped
from common.tf2_ros.stream import reset_edge  # noqa: F401 - one home, shared with every listener

SCENARIO = "scenario"
ORIGIN = "origin"               # world -> <vehicle>_origin, from the vehicle's GPS_GLOBAL_ORIGIN


class StaleTransform(Exception):
    """A dynamic transform chain whose latest common time is too old to use."""


class FrameTree:
    def __init__(self, statics=(), world_frame: str = "world", cache_time: float = 10.0,
                 tf_rate: float = 20.0, max_age: float = 0.5) -> None:
        self.world_frame = world_frame
        self.tf_rate = tf_rate
        self.max_age = max_age
        self.buffer = Buffer(cache_time=cache_time)
        self.statics: dict[str, tuple[TransformStamped, str]] = {}    # child -> (ts, authority)
        self.owned: set[str] = {world_frame}
        self._last_pub: dict[str, float] = {}
        for ts in statics:
            self.add_static(ts, SCENARIO)

    # ------------------------------------------------------------------ static
    def add_vehicle(self, name: str) -> None:
        """`name` and `name`_yaw are dynamic frames the bridge owns, `name`_origin a static one."""
        self.owned |= {name, name + "_yaw", name + "_origin"}

    def authority(self, child: str) -> str | None:
        """Who defined static frame `child` (``scenario``, ``static-transform:N``), or None."""
        got = self.statics.get(child)
        return None if got is None else got[1]

    def add_static(self, ts: TransformStamped, authority: str) -> TransformStamped:
        """Add or replace a static frame (stamp 0); ValueError / TransformException if refused."""
        ts = TransformStamped(ts.frame_id, ts.child_frame_id, 0.0, ts.transform)
        if authority not in (SCENARIO, ORIGIN) and ts.child_frame_id in self.owned:
            raise ValueError(f"{ts.child_frame_id!r} is a frame the bridge owns")
        self.buffer.set_transform_static(ts, authority=authority)
        self.statics[ts.child_frame_id] = (ts, authority)
        return ts

    def static_transforms(self) -> list[TransformStamped]:
        return [ts for ts, _auth in self.statics.values()]

    # ------------------------------------------------------------------ dynamic
    def add_sample(self, name: str, s, reset: bool) -> bool:
        """Store a paired sample of vehicle `name` (stamps on the one timeline).

        Returns True when it is due on the transform stream. Raises TransformException
        when the buffer refuses it.
        """
        if reset:
            reset_edge(self.buffer, s.full, name)
            reset_edge(self.buffer, s.yaw, name)
            self._last_pub.pop(name, None)
        else:
            self.buffer.set_transform(s.full, authority=name)
            self.buffer.set_transform(s.yaw, authority=name)
        last = self._last_pub.get(name)
        if last is None or s.stamp >= last + 0.5 / self.tf_rate - 1e-6 or s.stamp < last:
            self._last_pub[name] = s.stamp
            return True
        return False

    # ------------------------------------------------------------------ lookups
    def lookup(self, target: str, source: str):
        return self.buffer.lookup_transform(target, source, LATEST)

    def is_dynamic(self, target: str, source: str) -> bool:
        """Does the chain between the two frames hold a dynamic (time-varying) edge?"""
        stats = self.buffer.edge_stats()
        return any(f in stats and not stats[f].is_static for f in self.buffer.chain(target, source))

    def fresh_lookup(self, target: str, source: str, now: float | None):
        """lookup_transform(target, source, LATEST), refusing stale dynamic chains.

        `now` is the newest vehicle clock seen (s, one timeline; None: nothing to judge by).
        """
        T = self.buffer.lookup_transform(target, source, LATEST)
        dynamic = self.is_dynamic(target, source)
        if dynamic and now is not None and T.stamp < now - self.max_age:
            raise StaleTransform(f"{source} -> {target} is {now - T.stamp:.2f} s old "
                                 f"(max {self.max_age} s)")
        return T
