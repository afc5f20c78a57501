#!/usr/bin/env python3
"""ground_robot_controller: the lab's node that keeps the ground robot under the drone.

Checkpoints 2 and 3. The goal is the ground point under the drone, written in the drone's
frame: the drone is h metres up, z points down, so the ground under it is (0, 0, h). Through
the drone frame (--follow-frame: drone, the tilting frame of checkpoint 2, or drone_yaw, the
level one of checkpoint 3), at the drone's newest time, it becomes a point in world, published
to the ground robot (the lab's /ground_robot/goal) 20 times a second of sim time.

    python ground_robot_controller.py --connect udpout:127.0.0.1:14620 --follow-frame drone_yaw
"""
from common.tf2_ros import (LATEST, Buffer, Node, PointStamped, RoverGoalPublisher, TransformException,
                            TransformListener, do_transform_point, node_args)


class GroundRobotController:
    def __init__(self, node: Node, frame: str = "drone_yaw") -> None:
        self.node, self.frame = node, frame
        # Instantiate the Buffer and TransformListener
        self.buffer = Buffer()
        self.listener = TransformListener(self.buffer, node)
        # Goal publisher: the ground robot's goal, in world
        self.goal_pub = RoverGoalPublisher(node)

    def mainloop(self) -> None:
        rate = self.node.rate(20)                       # Set the rate of this loop (sim time)
        while self.node.ok():
            try:
                # Lookup the drone to world transform (the newest)
                transform = self.buffer.lookup_transform("world", self.frame, LATEST)
                # the drone is h metres up: its origin's z in world is -h
                h = -transform.transform.translation[2]
                # Convert the goal, (0, 0, h) in the drone frame, to a PointStamped
                point = PointStamped(self.frame, transform.stamp, (0.0, 0.0, h))
                # Use the do_transform_point function to convert the point using the transform
                new_point = do_transform_point(point, transform)
                # Publish the goal, for the drone's time of the transform
                self.goal_pub.publish(transform.stamp, new_point)
            except TransformException:
                pass                                    # no drone frame yet
            rate.sleep()


if __name__ == "__main__":
    args = node_args(__doc__, follow_frame=True)
    with Node("ground_robot_controller", args.connect) as node:
        GroundRobotController(node, args.follow_frame).mainloop()
