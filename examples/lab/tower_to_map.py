#!/usr/bin/env python3
"""tower_to_map: the lab's node that turns the tower's goals (tower frame) into the drone's (world).

Listens for the tower's SET_POSITION_TARGET_LOCAL_NED (MAV_FRAME_LOCAL_NED in the tower
frame; `towerlink bridge --route-only` routes it here untranslated), looks up
world <- tower in the transform stream (the scenario's static frame, the lab's
static_transform_publisher), and sends the goal in world to the drone.

    python examples/lab/tower_to_map.py --connect udpout:127.0.0.1:14620
"""
import argparse

from common.mavlink.dialect import towerlink as tl
from common.frames import LATEST, Buffer, InvalidArgumentException, PointStamped, TransformException
from common.tf2_ros import DEFAULT_URL, Node, TransformListener

TOWER_SYSID = 255
IGNORE_YAW = 1 << 10


class TowerToMap:
    def __init__(self, node: Node, drone: int = 1) -> None:
        self.node, self.drone = node, drone
        self.goal = None                                   # set by the callback for the tower's goals
        self.buffer = Buffer()
        self.listener = TransformListener(self.buffer, node)
        node.subscribe("SET_POSITION_TARGET_LOCAL_NED", self.on_goal, sysid=TOWER_SYSID)

    def on_goal(self, msg) -> None:
        if msg.target_system == self.drone and msg.coordinate_frame == tl.MAV_FRAME_LOCAL_NED:
            self.goal = msg

    def mainloop(self) -> None:
        rate = self.node.rate(20)
        while self.node.ok():
            g = self.goal
            if g is not None:
                try:
                    T = self.buffer.lookup_transform("world", "tower", LATEST)
                    p = self.buffer.transform_point(PointStamped("tower", LATEST, (g.x, g.y, g.z)), "world").point
                    yaw = g.yaw if g.type_mask & IGNORE_YAW else g.yaw + T.transform.yaw_pitch_roll()[0]
                    self.node.send(tl.MAVLink_set_position_target_local_ned_message(
                        g.time_boot_ms, self.drone, 1, tl.MAV_FRAME_LOCAL_NED, g.type_mask,
                        *p, 0, 0, 0, 0, 0, 0, yaw, 0))
                    self.node.log(f"Publishing Transformed Goal {[round(float(v), 2) for v in p[:2]]}")
                    self.goal = None        # the tower re-sends its goal until the drone is there
                except InvalidArgumentException as exc:       # NaN/inf from the wire: not a goal
                    self.node.log(f"goal dropped: {exc}")
                    self.goal = None
                except TransformException as exc:
                    self.node.log(f"tf2 exception, continuing: {exc}")
            rate.sleep()


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--connect", default=DEFAULT_URL, help="the bridge's node link (default %(default)s)")
    args, _ = ap.parse_known_args()          # a launcher may pass options meant for other nodes
    with Node("tower_to_map", args.connect) as node:
        try:
            TowerToMap(node).mainloop()
        except KeyboardInterrupt:
            pass
