#!/usr/bin/env python3
"""tower_to_map: the lab's node that turns the tower's goals (tower frame) into the drone's (world).

Checkpoint 1. The tower sends each goal as SET_POSITION_TARGET_LOCAL_NED in its own frame
(the lab's /tower/goal; `towerlink bridge --route-only` routes it here untranslated) and sends
it again until the drone is there. This node looks up world <- tower (the static transform of
fly.launch), transforms the goal into world and sends it to the drone (the lab's
/uav/input/goal).

    python tower_to_map.py --connect udpout:127.0.0.1:14620
"""
import argparse

from common.mavlink.dialect import towerlink as tl
from common.frames import InvalidArgumentException
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
        # Instantiate the Buffer and TransformListener
        self.buffer = Buffer()
        self.listener = TransformListener(self.buffer, node)
        # Tower goal subscriber: the tower's SET_POSITION_TARGET_LOCAL_NED
        node.subscribe("SET_POSITION_TARGET_LOCAL_NED", self.on_goal, sysid=TOWER_SYSID)

    def on_goal(self, msg) -> None:
        """Callback for the tower's goals: msg.x, msg.y, msg.z in the tower frame (NED, m)."""
        if msg.target_system == DRONE_SYSID and msg.coordinate_frame == tl.MAV_FRAME_LOCAL_NED:
            self.goal = msg

    def mainloop(self) -> None:
        rate = self.node.rate(20)       # Set the rate of this loop (sim time)
        while self.node.ok():
            if self.goal is not None:
                try:
                    # Lookup the tower to world transform
                    transform = self.buffer.lookup_transform("world", "tower", LATEST)
                    # Convert the goal to a PointStamped
                    point = PointStamped("tower", LATEST, (self.goal.x, self.goal.y, self.goal.z))
                    # Use the do_transform_point function to convert the point using the transform
                    new_point = do_transform_point(point, transform)
                    # Publish the goal to the drone, in world
                    self.send_goal(new_point)
                    # The tower sends its goal again until the drone is there: Reset the goal
                    self.goal = None
                except InvalidArgumentException as exc:     # NaN or inf from the wire: not a goal
                    self.node.log(f"goal dropped: {exc}")
                    self.goal = None
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
    args, _ = ap.parse_known_args()          # a launcher may pass options meant for other nodes
    with Node("tower_to_map", args.connect) as node:
        try:
            TowerToMap(node).mainloop()
        except KeyboardInterrupt:
            pass
