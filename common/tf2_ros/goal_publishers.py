"""The lab's goal topics as publishers: a world goal to the drone, a world goal to the ground robot.

ROS's lab publishes a Vector3 on /uav/input/goal and /ground_robot/goal and the simulator does
the rest. Here a node sends MAVLink to the vehicles through the bridge's node link, and these
two do the rest: the message, the frame and (for the rover) its mode.

* :class:`DroneGoalPublisher`: a point in world (NED, m) as SET_POSITION_TARGET_LOCAL_NED,
  position only (the drone's local frame is world: its EKF origin is world's origin).
* :class:`RoverGoalPublisher`: a point in world, for a drone time t. It goes with the point's
  velocity, from the goal published about 0.1 s of drone time before, so the rover keeps pace;
  a goal for a drone time already published is not sent again. The rover's targets are in its
  own local frame, centred where it booted: the point goes through the static
  world -> rover_origin edge the bridge publishes from the rover's GPS_GLOBAL_ORIGIN (no goal
  until it is known). Each publish also asks for GUIDED and arming until the rover's HEARTBEAT
  says so, at most every 0.5 s of node time.
"""
from __future__ import annotations

from collections import deque

from common.frames import LATEST, Buffer, PointStamped, TransformException
from common.mavlink.dialect import towerlink as tl
from common.mavlink.modes import ROVER_GUIDED

from .listener import TransformListener
from .node import Node

DRONE_SYSID, ROVER_SYSID = 1, 2
POSITION_ONLY = 0b1101_1111_1000                        # type_mask: x, y, z; no velocity, acceleration, yaw
POSITION_VELOCITY = 0b0000_1100_0000_0000 | 0b0001_1100_0000   # x, y, z and vx, vy, vz
ASK_PERIOD = 0.5                                        # node s between mode / arm requests
VELOCITY_SPAN = 0.1                                     # drone s between the two goals of a velocity


def _xyz(point) -> tuple[float, float, float]:
    p = point.point if isinstance(point, PointStamped) else point
    return float(p[0]), float(p[1]), float(p[2])


class DroneGoalPublisher:
    """/uav/input/goal: send the drone a goal in world."""

    def __init__(self, node: Node, sysid: int = DRONE_SYSID) -> None:
        self.node, self.sysid = node, sysid

    def publish(self, point) -> None:
        """`point`: a PointStamped in world, or (x, y, z) world NED m."""
        x, y, z = _xyz(point)
        self.node.send(tl.MAVLink_set_position_target_local_ned_message(
            0, self.sysid, 1, tl.MAV_FRAME_LOCAL_NED, POSITION_ONLY, x, y, z, 0, 0, 0, 0, 0, 0, 0, 0))
        self.node.log(f"Publishing Transformed Goal {[round(x, 2), round(y, 2)]}")


class RoverGoalPublisher:
    """/ground_robot/goal: drive the rover to a point in world, GUIDED and armed."""

    def __init__(self, node: Node, sysid: int = ROVER_SYSID) -> None:
        self.node, self.sysid = node, sysid
        self.buffer = Buffer()
        self.listener = TransformListener(self.buffer, node)     # for world -> rover_origin
        self.state = None                                       # the rover's newest HEARTBEAT
        self.asked = -1e9
        self.recent: deque = deque(maxlen=16)                   # (drone time, world x, y) published
        node.subscribe("HEARTBEAT", self._on_heartbeat, sysid=sysid)

    def _on_heartbeat(self, m) -> None:
        self.state = m

    def keep_guided_and_armed(self) -> None:
        h, now = self.state, self.node.now()          # node time: sim time in lockstep
        if h is None or now - self.asked < ASK_PERIOD:
            return
        if h.custom_mode != ROVER_GUIDED:
            self.asked = now
            self.node.send(tl.MAVLink_command_long_message(self.sysid, 1, tl.MAV_CMD_DO_SET_MODE, 0,
                                                           tl.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ROVER_GUIDED,
                                                           0, 0, 0, 0, 0))
        if not h.base_mode & tl.MAV_MODE_FLAG_SAFETY_ARMED:
            self.asked = now
            self.node.send(tl.MAVLink_command_long_message(self.sysid, 1, tl.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                                                           1, 0, 0, 0, 0, 0, 0))

    def velocity(self, t: float, x: float, y: float) -> tuple[float, float]:
        """World (vx, vy) m/s from the goal published VELOCITY_SPAN s of drone time before t."""
        back = [r for r in self.recent if r[0] <= t - VELOCITY_SPAN + 1e-6]
        if not back or t - back[-1][0] > 4 * VELOCITY_SPAN:
            return 0.0, 0.0
        t0, x0, y0 = back[-1]
        return (x - x0) / (t - t0), (y - y0) / (t - t0)

    def publish(self, t: float, point) -> bool:
        """Drive to `point` (a PointStamped in world, or world x, y, z NED m), the ground point for
        drone time t (s). False when not sent: t already published, or the rover's origin unknown."""
        self.keep_guided_and_armed()
        if self.recent and t <= self.recent[-1][0]:
            return False
        try:
            to_rover = self.buffer.lookup_transform("rover_origin", "world", LATEST).transform
        except TransformException:
            return False
        wx, wy, wz = _xyz(point)
        vx, vy = self.velocity(t, wx, wy)
        self.recent.append((t, wx, wy))
        x, y, z = to_rover.apply_point((wx, wy, wz))
        vx, vy, _ = to_rover.apply_vector((vx, vy, 0.0))
        self.node.send(tl.MAVLink_set_position_target_local_ned_message(
            int(t * 1000) & 0xFFFFFFFF, self.sysid, 1, tl.MAV_FRAME_LOCAL_NED, POSITION_VELOCITY,
            float(x), float(y), float(z), float(vx), float(vy), 0.0, 0, 0, 0, 0, 0))
        return True
