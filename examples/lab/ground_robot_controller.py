#!/usr/bin/env python3
"""ground_robot_controller: the lab's node that keeps the ground robot under the drone.

Its goal is the ground point under the drone written in the drone's frame, (0, 0, height):
transformed into world with the listener's buffer and sent to the rover (z 0, GUIDED,
armed), 10 times a second of the drone's clock. --follow-frame drone goes through the
tilting frame (checkpoint 2: it wobbles), drone_yaw through the level one (checkpoint 3).
The drone's velocity, from two lookups 0.1 s apart on its clock, goes with the goal so
the rover keeps pace. The rover's targets are in its own local frame, centred where it
booted (its EKF origin): goal and velocity go through the static world -> rover_origin
edge the bridge publishes from the rover's GPS_GLOBAL_ORIGIN; without it, no goal.

    python examples/lab/ground_robot_controller.py --connect udpout:127.0.0.1:14620 --follow-frame drone_yaw
"""
import argparse

from common.mavlink.dialect import towerlink as tl
from common.frames import LATEST, Buffer, PointStamped, TransformException
from common.mavlink.modes import ROVER_GUIDED
from common.tf2_ros import DEFAULT_URL, Node, TransformListener

POS_VEL = 0b0000_1100_0000_0000 | 0b0001_1100_0000   # ignore acceleration, yaw, yaw rate
DT = 0.1                                            # s of drone clock between the two lookups


class GroundRobotController:
    def __init__(self, node: Node, frame: str = "drone_yaw", rover: int = 2, hz: float = 10.0) -> None:
        self.node, self.frame, self.rover, self.hz = node, frame, rover, hz
        self.last = -1e9                                   # drone time of the last goal sent
        self.buffer = Buffer()
        self.listener = TransformListener(self.buffer, node)
        self.rover_state = None                            # its newest HEARTBEAT
        self._asked = -1e9
        node.subscribe("HEARTBEAT", lambda m: setattr(self, "rover_state", m), sysid=rover)

    def keep_guided_and_armed(self) -> None:
        h, now = self.rover_state, self.node.now()        # sim time in lockstep
        if h is None or now - self._asked < 0.5:
            return
        if h.custom_mode != ROVER_GUIDED:
            self._asked = now
            self.node.send(tl.MAVLink_command_long_message(self.rover, 1, tl.MAV_CMD_DO_SET_MODE, 0,
                                                           tl.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ROVER_GUIDED, 0, 0, 0, 0, 0))
        if not h.base_mode & tl.MAV_MODE_FLAG_SAFETY_ARMED:
            self._asked = now
            self.node.send(tl.MAVLink_command_long_message(self.rover, 1, tl.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                                                           1, 0, 0, 0, 0, 0, 0))

    def ground_point(self, t):
        """The ground point under the drone at drone time t, in world (x, y)."""
        height = -self.buffer.lookup_transform("world", self.frame, t).transform.translation[2]
        p = self.buffer.transform_point(PointStamped(self.frame, t, (0.0, 0.0, height)), "world")
        return p.point[0], p.point[1]

    def on_transform(self) -> None:
        """After each transform the listener stores: a goal every 1/hz s of the drone's clock."""
        try:
            t = self.buffer.lookup_transform("world", self.frame, LATEST).stamp
            if t < self.last + 1.0 / self.hz:
                return
            x, y = self.ground_point(t)
            x0, y0 = self.ground_point(t - DT)
            to_rover = self.buffer.lookup_transform("rover_origin", "world", LATEST).transform
        except TransformException:
            return                                         # no drone frame or rover origin (yet)
        self.last = t
        vx, vy, _ = to_rover.apply_vector(((x - x0) / DT, (y - y0) / DT, 0.0))
        x, y, _ = to_rover.apply_point((x, y, 0.0))
        self.node.send(tl.MAVLink_set_position_target_local_ned_message(
            int(t * 1000) & 0xFFFFFFFF, self.rover, 1, tl.MAV_FRAME_LOCAL_NED, POS_VEL,
            float(x), float(y), 0.0, float(vx), float(vy), 0.0, 0, 0, 0, 0, 0))

    def mainloop(self) -> None:
        self.listener.add_callback(self.on_transform)      # follow on the drone's clock, not the wall's
        rate = self.node.rate(10)
        while self.node.ok():
            self.keep_guided_and_armed()
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
