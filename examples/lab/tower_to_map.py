#!/usr/bin/env python3
"""tower_to_map: the lab's node that turns the tower's goals (tower frame) into the drone's (world).

Checkpoint 1. The tower sends each goal as SET_POSITION_TARGET_LOCAL_NED in its own frame
(the lab's /tower/goal; `towerlink bridge --route-only` routes it here untranslated) and sends
it again until the drone is there. This node looks up world <- tower (the static transform of
fly.launch), transforms the goal into world and publishes it to the drone (the lab's
/uav/input/goal).

    python tower_to_map.py --connect udpout:127.0.0.1:14620
"""
from common.mavlink.dialect import towerlink as tl
from common.mavlink.ids import TOWER_SYSID      # the tower: its goals come from this system
from common.frames import InvalidArgumentException
from common.tf2_ros import (LATEST, Buffer, DroneGoalPublisher, Node, PointStamped, TransformException,
                            TransformListener, do_transform_point, node_args)

DRONE_SYSID = 1


class TowerToMap:
    def __init__(self, node: Node) -> None:
        self.node = node
        # Used by the callback for the tower's goals
        self.goal = None
        # Instantiate the Buffer and TransformListener
        self.buffer = Buffer()
        self.listener = TransformListener(self.buffer, node)
        # Goal publisher: the drone's goal, in world
        self.goal_pub = DroneGoalPublisher(node)
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
                    # Publish the goal
                    self.goal_pub.publish(new_point)
                    # The tower sends its goal again until the drone is there: Reset the goal
                    self.goal = None
                except InvalidArgumentException as exc:     # NaN or inf from the wire: not a goal
                    self.node.log(f"goal dropped: {exc}")
                    self.goal = None
                except TransformException as exc:
                    self.node.log(f"tf2 exception, continuing: {exc}")
            rate.sleep()


if __name__ == "__main__":
    with Node("tower_to_map", node_args(__doc__).connect) as node:
        TowerToMap(node).mainloop()
