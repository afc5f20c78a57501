#!/usr/bin/env python3
"""world_to_drone: the lab's node that broadcasts the drone's frames from its pose.

Checkpoints 2 and 3. From the drone's LOCAL_POSITION_NED (its position in world, NED: the
lab's /uav/sensors/gps) and ATTITUDE_QUATERNION it broadcasts, stamped with the drone's own
clock (time_boot_ms, sim seconds), two dynamic transforms:

  world -> drone      the full attitude: the frame tilts as the drone flies (checkpoint 2)
  world -> drone_yaw  roll and pitch zeroed, yaw kept: the level frame (checkpoint 3)

    python world_to_drone.py --connect udpout:127.0.0.1:14620
"""
from common.tf2_ros import (Node, Transform, TransformBroadcaster, TransformException, TransformStamped,
                            euler_from_quaternion, quaternion_from_euler, node_args)

DRONE_SYSID = 1


class WorldToDrone:
    def __init__(self, node: Node) -> None:
        self.attitude = None                    # the drone's newest attitude quaternion (x, y, z, w)
        # Instantiate the Broadcaster
        self.br = TransformBroadcaster(node)
        node.subscribe("ATTITUDE_QUATERNION", self.on_attitude, sysid=DRONE_SYSID)
        # Drone position subscriber: the drone's LOCAL_POSITION_NED
        node.subscribe("LOCAL_POSITION_NED", self.on_position, sysid=DRONE_SYSID)

    def on_attitude(self, m) -> None:
        self.attitude = (m.q2, m.q3, m.q4, m.q1)      # MAVLink's quaternion is w, x, y, z

    def on_position(self, m) -> None:
        """Callback for the drone's position: m.x, m.y, m.z in world (NED, m) at m.time_boot_ms."""
        if self.attitude is None:
            return
        # the stamp: the time of this position on the drone's clock, in seconds
        stamp = m.time_boot_ms / 1000.0
        translation = (m.x, m.y, m.z)
        try:
            # world -> drone: translation from the position, rotation from the attitude
            drone = TransformStamped("world", "drone", stamp,
                                     Transform(translation=translation, rotation=self.attitude))
            # world -> drone_yaw: the same, roll and pitch zeroed (checkpoint 3)
            roll, pitch, yaw = euler_from_quaternion(self.attitude)
            drone_yaw = TransformStamped("world", "drone_yaw", stamp,
                                         Transform(translation=translation,
                                                   rotation=quaternion_from_euler(0.0, 0.0, yaw)))
        except TransformException:              # NaN or a zero quaternion on the wire
            return
        # Broadcast the transforms
        self.br.sendTransform([drone, drone_yaw])


if __name__ == "__main__":
    with Node("world_to_drone", node_args(__doc__).connect) as node:
        WorldToDrone(node)
        node.spin()                             # the callbacks broadcast, in the node's thread
