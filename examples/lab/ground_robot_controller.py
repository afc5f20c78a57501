#!/usr/bin/env python3
"""ground_robot_controller: the lab's node that keeps the ground robot under the drone.

Checkpoints 2 and 3. The goal is the ground point under the drone, written in the drone's
frame: the drone is h metres up, z points down, so the ground under it is (0, 0, h). Through
the drone frame (--follow-frame: drone, the tilting frame of checkpoint 2, or drone_yaw, the
level one of checkpoint 3) it becomes a point in world, sent to the rover 20 times a second of
sim time, with the velocity of that point (two lookups 0.1 s apart on the drone's clock) so the
rover keeps pace.

    python ground_robot_controller.py --connect udpout:127.0.0.1:14620 --follow-frame drone_yaw
"""
import argparse

from common.mavlink.dialect import towerlink as tl
from common.mavlink.modes import ROVER_GUIDED
from common.tf2_ros import (DEFAULT_URL, LATEST, Buffer, Node, PointStamped, TransformException,
                            TransformListener, do_transform_point)

ROVER_SYSID = 2
POS_VEL = 0b0000_1100_0000_0000 | 0b0001_1100_0000   # type_mask: position and velocity
DT = 0.1                                            # s of drone clock between the two lookups


class RoverDriver:
    """The rover's side (given): GUIDED and armed, goals from world into the rover's own frame.

    The rover's targets are in its local frame, centred where it booted (its EKF origin): the
    bridge publishes the static world -> rover_origin from the rover's GPS_GLOBAL_ORIGIN."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.buffer = Buffer()
        self.listener = TransformListener(self.buffer, node)
        self.state = None                               # the rover's newest HEARTBEAT
        self.asked = -1e9
        node.subscribe("HEARTBEAT", lambda m: setattr(self, "state", m), sysid=ROVER_SYSID)

    def keep_guided_and_armed(self) -> None:
        h, now = self.state, self.node.now()             # sim time in lockstep
        if h is None or now - self.asked < 0.5:
            return
        if h.custom_mode != ROVER_GUIDED:
            self.asked = now
            self.node.send(tl.MAVLink_command_long_message(ROVER_SYSID, 1, tl.MAV_CMD_DO_SET_MODE, 0,
                                                           tl.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ROVER_GUIDED,
                                                           0, 0, 0, 0, 0))
        if not h.base_mode & tl.MAV_MODE_FLAG_SAFETY_ARMED:
            self.asked = now
            self.node.send(tl.MAVLink_command_long_message(ROVER_SYSID, 1, tl.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                                                           1, 0, 0, 0, 0, 0, 0))

    def send_goal(self, t: float, point, velocity) -> None:
        """Drive to `point` (world x, y, z, m) moving at `velocity` (world vx, vy, m/s); t: drone time, s."""
        try:
            to_rover = self.buffer.lookup_transform("rover_origin", "world", LATEST).transform
        except TransformException:
            return                                      # the rover's origin is not known yet
        x, y, z = to_rover.apply_point(point)
        vx, vy, _ = to_rover.apply_vector((velocity[0], velocity[1], 0.0))
        self.node.send(tl.MAVLink_set_position_target_local_ned_message(
            int(t * 1000) & 0xFFFFFFFF, ROVER_SYSID, 1, tl.MAV_FRAME_LOCAL_NED, POS_VEL,
            float(x), float(y), float(z), float(vx), float(vy), 0.0, 0, 0, 0, 0, 0))


class GroundRobotController:
    def __init__(self, node: Node, frame: str = "drone_yaw") -> None:
        self.node, self.frame = node, frame
        self.rover = RoverDriver(node)
        self.last = -1e9                                # drone time of the newest goal sent
        # Instantiate the Buffer and TransformListener
        self.buffer = Buffer()
        self.listener = TransformListener(self.buffer, node)

    def ground_point(self, t: float):
        """The ground point under the drone at drone time t (s), in world (x, y, z), NED m."""
        # Lookup the drone to world transform, at time t
        transform = self.buffer.lookup_transform("world", self.frame, t)
        # the drone is h metres up: its origin's z in world is -h
        h = -transform.transform.translation[2]
        # Convert the goal, (0, 0, h) in the drone frame, to a PointStamped
        point = PointStamped(self.frame, t, (0.0, 0.0, h))
        # Use the do_transform_point function to convert the point using the transform
        new_point = do_transform_point(point, transform)
        return new_point.point

    def step(self) -> None:
        """One goal for the newest drone time (given)."""
        if self.buffer is None:
            return                                      # not done yet: no Buffer
        try:
            t = self.buffer.lookup_transform("world", self.frame, LATEST).stamp
            if t <= self.last:
                return                                  # nothing new from the drone
            p, p0 = self.ground_point(t), self.ground_point(t - DT)
        except TransformException:
            return                                      # no drone frame (yet)
        if p is None or p0 is None:
            return                                      # not done yet: no ground point
        self.last = t
        self.rover.send_goal(t, p, ((p[0] - p0[0]) / DT, (p[1] - p0[1]) / DT))

    def mainloop(self) -> None:
        rate = self.node.rate(20)                       # Set the rate of this loop (sim time)
        while self.node.ok():
            self.rover.keep_guided_and_armed()
            self.step()
            rate.sleep()


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--connect", default=DEFAULT_URL, help="the bridge's node link (default %(default)s)")
    ap.add_argument("--follow-frame", choices=("drone", "drone_yaw"), default="drone_yaw",
                    help="the drone frame the goal is written in (default %(default)s)")
    args, _ = ap.parse_known_args()
    with Node("ground_robot_controller", args.connect) as node:
        try:
            GroundRobotController(node, args.follow_frame).mainloop()
        except KeyboardInterrupt:
            pass
