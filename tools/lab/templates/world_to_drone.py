#!/usr/bin/env python3
"""world_to_drone: your node for checkpoints 2 and 3 (README.md, steps 4 and 6).

Broadcast where the drone is, each time its position comes (the lab's /uav/sensors/gps):
world -> drone with its full attitude (checkpoint 2), then world -> drone_yaw with roll and
pitch zeroed (checkpoint 3). Fill in the TODOs; try it: `towerlink lab check . --checkpoint 2`.
"""
# ruff: noqa: F401  (the skeleton imports the names its TODOs need)
from common.tf2_ros import (Node, Transform, TransformBroadcaster, TransformException, TransformStamped,
                            euler_from_quaternion, quaternion_from_euler, node_args)

DRONE_SYSID = 1


class WorldToDrone:
    def __init__(self, node: Node) -> None:
        self.attitude = None                    # the drone's newest attitude quaternion (x, y, z, w)
        # TODO: Instantiate the Broadcaster
        node.subscribe("ATTITUDE_QUATERNION", self.on_attitude, sysid=DRONE_SYSID)
        # TODO: Drone position subscriber: the drone's LOCAL_POSITION_NED, to self.on_position

    def on_attitude(self, m) -> None:
        self.attitude = (m.q2, m.q3, m.q4, m.q1)      # MAVLink's quaternion is w, x, y, z

    def on_position(self, m) -> None:
        """Callback for the drone's position: m.x, m.y, m.z in world (NED, m) at m.time_boot_ms."""
        if self.attitude is None:
            return
        try:
            # TODO: the stamp: the time of this position on the drone's clock, in seconds
            # TODO: world -> drone: a TransformStamped(frame_id, child_frame_id, stamp, Transform(...)),
            #       translation from the position, rotation from the attitude
            # TODO (checkpoint 3): world -> drone_yaw: the same with roll and pitch zeroed
            #       (euler_from_quaternion, then quaternion_from_euler(0, 0, yaw))
            pass
        except TransformException:              # NaN or a zero quaternion on the wire
            return
        # TODO: Broadcast the transforms (sendTransform takes one or a list)


if __name__ == "__main__":
    with Node("world_to_drone", node_args(__doc__).connect) as node:
        WorldToDrone(node)
        node.spin()                             # the callbacks broadcast, in the node's thread
