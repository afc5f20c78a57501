"""tf2_geometry_msgs' do_transform_point for towerlink's stamped types (common.frames).

``do_transform_point(point, transform)`` applies a TransformStamped (as looked up with
``Buffer.lookup_transform(target, source, time)``) to a PointStamped given in the
transform's child (source) frame, and returns it in the transform's parent (target) frame,
stamped with the transform's stamp. As in ROS, the frames are not compared: a point in the
wrong frame, or a transform looked up the wrong way round, gives a wrong point, not an error.
"""
from __future__ import annotations

from common.frames import PointStamped, TransformStamped
from common.frames.stamped import transformed


def do_transform_point(point: PointStamped, transform: TransformStamped) -> PointStamped:
    """`point` (in transform.child_frame_id) expressed in transform.frame_id (m)."""
    if not isinstance(point, PointStamped):
        raise TypeError(f"do_transform_point takes a PointStamped, got {type(point).__name__}")
    if not isinstance(transform, TransformStamped):
        raise TypeError(f"do_transform_point takes a TransformStamped (from lookup_transform), "
                        f"got {type(transform).__name__}")
    return transformed(point, transform)
