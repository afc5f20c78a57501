#!/usr/bin/env python3
"""tower_to_map: turn the tower's goals (tower frame) into the drone's goals (world frame).

Checkpoint 1. The tower sends each goal as SET_POSITION_TARGET_LOCAL_NED in its own frame
(the lab's /tower/goal) and sends it again until the drone is there. This node looks up
world <- tower (the static transform of fly.launch), transforms the goal into world and sends
it to the drone (the lab's /uav/input/goal) with send_goal().

    python tower_to_map.py --connect udpout:127.0.0.1:14620
"""
import argparse

from common.mavlink.dialect import towerlink as tl
from common.tf2_ros import (DEFAULT_URL, LATEST, Buffer, Node, PointStamped, TransformException,
                            TransformListener, do_transform_point)

TOWER_SYSID = 255                   # the tower: its goals come from this system
DRONE_SYSID = 1                     # the drone: its goals go to this system
POSITION_ONLY = 0b1101_1111_1000    # type_mask: use x, y, z; ignore velocity, acceleration, yaw


class TowerToMap:
    def __init__(self, node: Node) -> None:
        self.node = node
        # Used by the callback for the tower's goals
        self.goal = None
        # TODO: Instantiate the Buffer and TransformListener
        # TODO: Tower goal subscriber: the tower's SET_POSITION_TARGET_LOCAL_NED, to self.on_goal
        #       (node.subscribe("SET_POSITION_TARGET_LOCAL_NED", callback, sysid=TOWER_SYSID))

    def on_goal(self, msg) -> None:
        """Callback for the tower's goals: msg.x, msg.y, msg.z in the tower frame (NED, m)."""
        # TODO: keep the goal when it is for the drone (msg.target_system == DRONE_SYSID)
        pass

    def mainloop(self) -> None:
        rate = self.node.rate(20)       # Set the rate of this loop (sim time)
        while self.node.ok():
            if self.goal is not None:
                try:
                    # TODO: Lookup the tower to world transform
                    # TODO: Convert the goal to a PointStamped
                    # TODO: Use the do_transform_point function to convert the point using the transform
                    # TODO: Publish the goal to the drone, in world (self.send_goal)
                    # TODO: Reset the goal (the tower sends it again until the drone is there)
                    pass
                except TransformException as exc:
                    self.node.log(f"tf2 exception, continuing: {exc}")
            rate.sleep()

    def send_goal(self, point: PointStamped) -> None:
        """The drone's goal: `point` in world (NED, m) as SET_POSITION_TARGET_LOCAL_NED."""
        x, y, z = (float(v) for v in point.point)
        self.node.send(tl.MAVLink_set_position_target_local_ned_message(
            0, DRONE_SYSID, 1, tl.MAV_FRAME_LOCAL_NED, POSITION_ONLY, x, y, z, 0, 0, 0, 0, 0, 0, 0, 0))
        self.node.log(f"Publishing Transformed Goal {[round(x, 2), round(y, 2)]}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--connect", default=DEFAULT_URL, help="the bridge's node link (default %(default)s)")
    args, _ = ap.parse_known_args()          # the checker passes options meant for other nodes too
    with Node("tower_to_map", args.connect) as node:
        try:
            TowerToMap(node).mainloop()
        except KeyboardInterrupt:
            pass
