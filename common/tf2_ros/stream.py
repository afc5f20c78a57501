"""The transform stream into a Buffer: the pure core of every TransformListener (no sockets).

Feed it decoded MAVLink messages; TOWERLINK_TRANSFORMs go into the buffer, statics as
static, dynamic edges keyed by the sender's clock. A dynamic stamp that goes back by more
than ``reboot_jump`` seconds on an edge means its publisher started over (a restarted
vehicle, node or bridge): that edge's history is dropped first, so lookups never
interpolate across two runs. Anything that does not decode to a valid transform is
counted in ``rejected``, never raised.
"""
from __future__ import annotations

from common.frames import Buffer, TransformStamped

from .wire import transform_from_message

REBOOT_JUMP = 1.0       # s: a publisher's clock that goes back by more than this started over


def clock_went_back(newest: float | None, t: float, jump: float = REBOOT_JUMP) -> bool:
    """Did a clock whose newest reading is `newest` start over, reading `t` now (s)?"""
    return newest is not None and t < newest - jump


def reset_edge(buffer: Buffer, ts: TransformStamped, authority: str = "reset") -> None:
    """Drop the history of the dynamic edge ts.frame_id -> ts.child_frame_id.

    The Buffer replaces an edge when it switches between static and dynamic
    (common.frames.graph), so writing it once as static and then dynamic again empties
    it without touching any other edge.
    """
    buffer.set_transform_static(ts, authority)
    buffer.set_transform(ts, authority)


class TransformStream:
    """Feed decoded MAVLink messages; TOWERLINK_TRANSFORMs go into `buffer`."""

    def __init__(self, buffer: Buffer | None = None, reboot_jump: float = REBOOT_JUMP) -> None:
        self.buffer = buffer if buffer is not None else Buffer()
        self.reboot_jump = reboot_jump
        self.received = 0
        self.rejected = 0
        self.newest_stamp = 0.0
        self._newest: dict[str, float] = {}

    def feed(self, msg) -> bool:
        """True if `msg` was a transform and went into the buffer."""
        if msg is None or msg.get_type() != "TOWERLINK_TRANSFORM":
            return False
        try:
            ts, static = transform_from_message(msg)
            authority = f"mavlink:{msg.get_srcSystem()}"
            if static:
                self.buffer.set_transform_static(ts, authority=authority)
            else:
                child = ts.child_frame_id
                if clock_went_back(self._newest.get(child), ts.stamp, self.reboot_jump):
                    reset_edge(self.buffer, ts)
                    self._newest[child] = ts.stamp
                self._newest[child] = max(ts.stamp, self._newest.get(child, ts.stamp))
                self.buffer.set_transform(ts, authority=authority)
                self.newest_stamp = max(self.newest_stamp, ts.stamp)
        except Exception:  # noqa: BLE001 - a bad transform on the wire is counted, never raised
            self.rejected += 1
            return False
        self.received += 1
        return True
