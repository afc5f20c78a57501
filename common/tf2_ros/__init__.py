"""tf2_ros for towerlink: nodes that broadcast and listen to transforms over MAVLink.

The names and behaviour of tf2_ros, usable from any Python process::

    from common.frames import Buffer, PointStamped, Transform, TransformStamped
    from common.tf2_ros import (Node, TransformBroadcaster, StaticTransformBroadcaster,
                             TransformListener, MessageFilter)

    node = Node("camera_node", "udpout:127.0.0.1:14620")   # a bridge's node link (--nodes)
    br = TransformBroadcaster(node)
    br.send_transform(TransformStamped("drone", "camera", stamp, Transform(...)))

    buf = Buffer()
    listener = TransformListener(buf, node)                # fills buf in the node's thread
    buf.lookup_transform("world", "camera", LATEST)

    mf = MessageFilter(listener, "world", queue_size=10, timeout=1.0)
    mf.register_callback(lambda p: print(buf.transform_point(p, "world")))
    mf.add(PointStamped("camera", stamp, (1, 0, 0)))

For the lab's nodes the names a ROS node imports from tf2_ros, geometry_msgs,
tf.transformations and tf2_geometry_msgs are all here: Buffer, the exceptions, PointStamped,
TransformStamped, Transform, LATEST (rospy.Time()), euler_from_quaternion,
quaternion_from_euler and do_transform_point; and the lab's goal topics (/uav/input/goal,
/ground_robot/goal) as DroneGoalPublisher and RoverGoalPublisher (common.tf2_ros.goal_publishers).

On the wire a node sends TOWERLINK_TRANSFORM (static flag for statics) to the bridge;
the bridge keeps each frame's authority (the first trusted node that publishes a child
frame owns it), stores it and republishes it on its transform stream, which every
listener (and tf-echo, view-frames, the tlogs) reads.
"""
from common.frames import (LATEST, Buffer, ConnectivityException, ExtrapolationException, LookupException,
                           PointStamped, Transform, TransformException, TransformStamped, euler_from_quaternion,
                           quaternion_from_euler)

from .broadcaster import StaticTransformBroadcaster, TransformBroadcaster
from .geometry import do_transform_point
from .goal_publishers import DroneGoalPublisher, RoverGoalPublisher
from .listener import TransformListener
from .message_filter import FilterFailureReason, FilterQueue, MessageFilter
from .node import DEFAULT_URL, Node, Rate, node_args
from .stream import TransformStream

__all__ = ["Node", "Rate", "DEFAULT_URL", "node_args", "TransformBroadcaster", "StaticTransformBroadcaster",
           "TransformListener", "TransformStream", "MessageFilter", "FilterQueue",
           "FilterFailureReason", "do_transform_point", "DroneGoalPublisher", "RoverGoalPublisher",
           # re-exported from common.frames, for nodes written the ROS way
           "Buffer", "LATEST", "PointStamped", "Transform", "TransformStamped", "TransformException",
           "LookupException", "ConnectivityException", "ExtrapolationException",
           "euler_from_quaternion", "quaternion_from_euler"]
