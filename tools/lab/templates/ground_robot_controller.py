#!/usr/bin/env python3
"""ground_robot_controller: your node for checkpoints 2 and 3 (README.md, step 5).

The ground robot wants to be right under the drone: in the drone's frame that is (0, 0, h),
h metres down its z axis. Fill in the TODOs. The checker runs this with --follow-frame drone
(checkpoint 2) and drone_yaw (checkpoint 3): `towerlink lab check . --checkpoint 2`.
"""
# ruff: noqa: F401  (the skeleton imports the names its TODOs need)
from common.tf2_ros import (LATEST, Buffer, Node, PointStamped, RoverGoalPublisher, TransformException,
                            TransformListener, do_transform_point, node_args)


class GroundRobotController:
    def __init__(self, node: Node, frame: str = "drone_yaw") -> None:
        self.node, self.frame = node, frame     # self.frame: the drone frame, from --follow-frame
        # TODO: Instantiate the Buffer and TransformListener
        # TODO: Goal publisher: RoverGoalPublisher(node), the lab's /ground_robot/goal

    def mainloop(self) -> None:
        rate = self.node.rate(20)                       # Set the rate of this loop (sim time)
        while self.node.ok():
            try:
                # TODO: Lookup the drone to world transform (the newest: LATEST)
                # TODO: the drone is h metres up: its origin's z in world is -h
                # TODO: Convert the goal, (0, 0, h) in the drone frame, to a PointStamped
                # TODO: Use the do_transform_point function to convert the point using the transform
                # TODO: Publish the goal: publish(the transform's stamp, the point)
                pass
            except TransformException:
                pass                                    # no drone frame yet
            rate.sleep()


if __name__ == "__main__":
    args = node_args(__doc__, follow_frame=True)
    with Node("ground_robot_controller", args.connect) as node:
        GroundRobotController(node, args.follow_frame).mainloop()
