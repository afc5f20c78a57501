"""TransformListener: fill a Buffer from the bridge's TOWERLINK_TRANSFORM stream.

The tf2 TransformListener core of this project (tf-echo and view-frames feed it from a
live link or a tlog). It has one home, :class:`common.tf2_ros.stream.TransformStream`,
shared with the nodes' threaded common.tf2_ros.TransformListener; this name stays for the
bridge's tools.
"""
from __future__ import annotations

from common.tf2_ros.stream import TransformStream as TransformListener

__all__ = ["TransformListener"]
