#!/usr/bin/env python3
"""tower_to_map: your node for checkpoint 1 (README.md, step 3).

The tower sends its goals in the tower frame; the drone flies in world. Fill in the TODOs:
keep each tower goal (on_goal), and in the loop look it up, transform it into world and
publish it to the drone. Try it: `towerlink lab check . --checkpoint 1`.
"""
# ruff: noqa: F401  (the skeleton imports the names its TODOs need)
from common.mavlink.dialect import towerlink as tl
from common.mavlink.ids import TOWER_SYSID      # the tower: its goals come from this system
from common.tf2_ros import (LATEST, Buffer, DroneGoalPublisher, Node, PointStamped, TransformException,
                            TransformListener, do_transform_point, node_args)

DRONE_SYSID = 1


class TowerToMap:
    def __init__(self, node: Node) -> None:
        self.node = node
        # Used by the callback for the tower's goals
        self.goal = None
        # TODO: Instantiate the Buffer and TransformListener
        # TODO: Goal publisher: DroneGoalPublisher(node), the lab's /uav/input/goal
        # TODO: Tower goal subscriber: node.subscribe("SET_POSITION_TARGET_LOCAL_NED", ..., sysid=TOWER_SYSID)

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
                    # TODO: Publish the goal
                    # TODO: Reset the goal (the tower sends it again until the drone is there)
                    pass
                except TransformException as exc:
                    self.node.log(f"tf2 exception, continuing: {exc}")
            rate.sleep()


if __name__ == "__main__":
    with Node("tower_to_map", node_args(__doc__).connect) as node:
        TowerToMap(node).mainloop()
