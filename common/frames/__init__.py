"""towerlink's frame library: rigid transforms and a tf2-grade, time-aware buffer.

Pure (numpy only): no sockets, no clocks, no MAVLink. tf2 names and
semantics; quaternions are (x, y, z, w). See :mod:`common.frames.buffer` for the
buffer's semantics, :mod:`common.frames.transform` for the math of one transform and
:mod:`common.frames.batch` for the same math on (n, 4) / (n, 3) arrays.
"""
from .buffer import Buffer, EdgeStats
from .errors import (ConnectivityException, ExtrapolationException,
                     FutureExtrapolationException, InvalidArgumentException,
                     LookupException, PastExtrapolationException, TimeoutException,
                     TransformException)
from .stamped import LATEST, PointStamped, PoseStamped, TransformStamped, VectorStamped
from .transform import (Transform, euler_from_quaternion, quaternion_from_euler,
                        quaternion_slerp)

__all__ = [
    "Transform", "TransformStamped", "Buffer", "EdgeStats", "LATEST",
    "PointStamped", "VectorStamped", "PoseStamped",
    "TransformException", "LookupException", "ConnectivityException",
    "ExtrapolationException", "PastExtrapolationException", "FutureExtrapolationException",
    "InvalidArgumentException", "TimeoutException",
    "euler_from_quaternion", "quaternion_from_euler", "quaternion_slerp",
]
