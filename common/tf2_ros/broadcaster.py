"""TransformBroadcaster and StaticTransformBroadcaster (tf2_ros names) over MAVLink.

Both send TOWERLINK_TRANSFORM to the node's link (a bridge's node link: the bridge
checks the sender's trust and the frame's authority, stores it, and republishes it on
its stream). A static transform carries the static flag; it is *latched* as tf2_ros's
/tf_static is: the broadcaster re-sends every static it was given once a second, so a
bridge or listener that starts later still gets it.
"""
from __future__ import annotations

from collections.abc import Iterable

from common.frames import TransformStamped

from .node import Node
from .wire import transform_message

LATCH_PERIOD = 1.0      # wall s between re-sends of the latched statics


def _as_list(ts) -> list[TransformStamped]:
    items = [ts] if isinstance(ts, TransformStamped) else list(ts)
    for t in items:
        if not isinstance(t, TransformStamped):
            raise TypeError(f"send_transform takes TransformStamped (or a list of them), got {type(t).__name__}")
    return items


class TransformBroadcaster:
    """Sends dynamic transforms, stamped by the caller (sim seconds, the vehicle's clock)."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.sent = 0

    def send_transform(self, transform: TransformStamped | Iterable[TransformStamped]) -> None:
        """Send one TransformStamped or a list; ValueError for a frame id over 16 bytes."""
        msgs = [transform_message(t) for t in _as_list(transform)]   # all checked before any is sent
        for m in msgs:
            self.node.send(m)
        self.sent += len(msgs)

    sendTransform = send_transform      # the ROS 1 spelling the lab uses


class StaticTransformBroadcaster:
    """Sends static transforms now and re-sends them every second (latched)."""

    def __init__(self, node: Node, period: float = LATCH_PERIOD) -> None:
        self.node = node
        self._latched: dict[str, TransformStamped] = {}
        self.sent = 0
        node.every(period, self._resend)

    def send_transform(self, transform: TransformStamped | Iterable[TransformStamped]) -> None:
        """Latch and send; a later transform of the same child frame replaces the earlier one."""
        items = _as_list(transform)
        msgs = [transform_message(t, static=True) for t in items]
        for t in items:
            self._latched[t.child_frame_id] = t
        for m in msgs:
            self.node.send(m)
        self.sent += len(msgs)

    sendTransform = send_transform

    def _resend(self) -> None:
        for t in list(self._latched.values()):
            self.node.send(transform_message(t, static=True))
            self.sent += 1
