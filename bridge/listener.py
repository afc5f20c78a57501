"""TransformListener: fill a Buffer from the bridge's TOWERLINK_TRANSFORM stream.

The tf2 TransformListener of this project, used by tf-echo and view-frames on a live
link or a tlog. Static transforms go in as static; dynamic edges are keyed by the
sender's clock, and a dynamic stamp that went back (bridge.timeline's one rule,
:func:`~bridge.timeline.clock_went_back`) resets that edge: a restarted vehicle or bridge.
"""
from __future__ import annotations

from bridge.codec import transform_from_message
from bridge.frame_tree import reset_edge
from bridge.timeline import REBOOT_JUMP, clock_went_back
from gcs.frames import Buffer


class TransformListener:
    """Feed decoded MAVLink messages; TOWERLINK_TRANSFORMs go into `buffer`."""

    def __init__(self, buffer: Buffer | None = None, reboot_jump: float = REBOOT_JUMP) -> None:
        self.buffer = buffer if buffer is not None else Buffer()
        self.reboot_jump = reboot_jump
        self.received = 0
        self.rejected = 0
        self.newest_stamp = 0.0
        self._newest: dict[str, float] = {}

    def feed(self, msg) -> bool:
        if msg is None or msg.get_type() != "TOWERLINK_TRANSFORM":
            return False
        try:
            ts, static = transform_from_message(msg)
        except Exception:
            self.rejected += 1
            return False
        try:
            if static:
                self.buffer.set_transform_static(ts, authority=f"mavlink:{msg.get_srcSystem()}")
            else:
                child = ts.child_frame_id
                if clock_went_back(self._newest.get(child), ts.stamp, self.reboot_jump):
                    reset_edge(self.buffer, ts)
                    self._newest[child] = ts.stamp
                self._newest[child] = max(ts.stamp, self._newest.get(child, ts.stamp))
                self.buffer.set_transform(ts, authority=f"mavlink:{msg.get_srcSystem()}")
                self.newest_stamp = max(self.newest_stamp, ts.stamp)
        except Exception:
            self.rejected += 1
            return False
        self.received += 1
        return True
