#!/usr/bin/env python3
"""world_to_drone: the lab's node that broadcasts the drone's frames from its pose.

From the drone's LOCAL_POSITION_NED (world, NED) and ATTITUDE_QUATERNION (the lab's GPS
topic) it broadcasts, stamped with the drone's clock (time_boot_ms, sim seconds):

  world -> drone      the full attitude: the frame that tilts as the drone flies (checkpoint 2)
  world -> drone_yaw  roll and pitch zeroed, yaw kept: the fix of checkpoint 3

    python examples/lab/world_to_drone.py --connect udpout:127.0.0.1:14620
"""
import argparse

from common.frames import (Transform, TransformException, TransformStamped, euler_from_quaternion,
                        quaternion_from_euler)
from common.tf2_ros import DEFAULT_URL, Node, TransformBroadcaster


class WorldToDrone:
    def __init__(self, node: Node, drone: int = 1) -> None:
        self.attitude = None                               # (x, y, z, w), newest
        self.br = TransformBroadcaster(node)
        node.subscribe("ATTITUDE_QUATERNION", self.on_attitude, sysid=drone)
        node.subscribe("LOCAL_POSITION_NED", self.on_position, sysid=drone)

    def on_attitude(self, m) -> None:
        self.attitude = (m.q2, m.q3, m.q4, m.q1)           # MAVLink is w, x, y, z

    def on_position(self, m) -> None:
        if self.attitude is None:
            return
        t = m.time_boot_ms / 1000.0
        xyz = (m.x, m.y, m.z)
        try:
            full = Transform(translation=xyz, rotation=self.attitude)
            roll, pitch, yaw = euler_from_quaternion(full.rotation)
            level = Transform(translation=xyz, rotation=quaternion_from_euler(0.0, 0.0, yaw))
        except TransformException:                         # NaN or a zero quaternion on the wire
            return
        self.br.send_transform([TransformStamped("world", "drone", t, full),
                                TransformStamped("world", "drone_yaw", t, level)])


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--connect", default=DEFAULT_URL, help="the bridge's node link (default %(default)s)")
    args, _ = ap.parse_known_args()
    with Node("world_to_drone", args.connect) as node:
        WorldToDrone(node)
        try:
            node.spin()                                    # broadcasts from the node's thread
        except KeyboardInterrupt:
            pass
