"""The lab's three nodes (examples/lab) without sockets: each one's job, message in, message out."""
from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import pytest

from common.mavlink.dialect import towerlink as tl
from common.frames import Transform, TransformStamped
from common.scenario import load_scenario
from common.tf2_ros.wire import transform_from_message, transform_message

LAB = Path(__file__).resolve().parent.parent / "examples" / "lab"


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"lab_{name}", LAB / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


class FakeNode:
    """What the nodes use of common.tf2_ros.Node; `ok()` is True for `turns` loop turns."""

    def __init__(self, turns: int = 1) -> None:
        self.subs, self.sent, self.logs, self.turns = {}, [], [], turns

    def subscribe(self, t, cb, sysid=None):
        self.subs.setdefault(t, []).append((cb, sysid))

    def deliver(self, msg, sysid):
        msg._header.srcSystem = sysid
        for cb, want in self.subs.get(msg.get_type(), []):
            if want in (None, sysid):
                cb(msg)

    def send(self, msg):
        self.sent.append(msg)

    def log(self, text):
        self.logs.append(text)

    def ok(self):
        self.turns -= 1
        return self.turns >= 0

    def rate(self, hz):
        return type("R", (), {"sleep": lambda self: None})()

    def now(self):
        return 0.0


def of_type(node, t):
    return [m for m in node.sent if m.get_type() == t]


def test_world_to_drone_broadcasts_the_full_and_the_yaw_only_frame():
    node = FakeNode()
    load("world_to_drone").WorldToDrone(node)
    T = Transform.from_euler(yaw=1.0, pitch=0.1, roll=0.2, translation=(1.0, 2.0, -9.0))
    x, y, z, w = T.rotation
    node.deliver(tl.MAVLink_local_position_ned_message(1500, 1, 2, -9, 0, 0, 0), 1)   # no attitude yet
    assert node.sent == []
    node.deliver(tl.MAVLink_attitude_quaternion_message(1500, w, x, y, z, 0, 0, 0), 1)
    node.deliver(tl.MAVLink_local_position_ned_message(1500, 1, 2, -9, 0, 0, 0), 1)
    (full, _), (level, _) = [transform_from_message(m) for m in of_type(node, "TOWERLINK_TRANSFORM")]
    assert (full.frame_id, full.child_frame_id, full.stamp) == ("world", "drone", 1.5)
    assert full.transform.almost_equal(T, 1e-6)
    assert level.child_frame_id == "drone_yaw" and level.stamp == 1.5
    assert level.transform.yaw_pitch_roll() == pytest.approx((1.0, 0.0, 0.0), abs=1e-6)
    node.deliver(tl.MAVLink_local_position_ned_message(1550, math.nan, 2, -9, 0, 0, 0), 1)   # bad input
    assert len(node.sent) == 2
    node.deliver(tl.MAVLink_local_position_ned_message(1600, 5, 5, -9, 0, 0, 0), 2)          # not the drone
    assert len(node.sent) == 2


def test_tower_to_map_sends_the_tower_goal_to_the_drone_in_world():
    node = FakeNode(turns=1)
    t2m = load("tower_to_map").TowerToMap(node)
    for ts in load_scenario().static_transforms:
        node.deliver(transform_message(ts, static=True), 250)
    goal = tl.MAVLink_set_position_target_local_ned_message(
        7, 1, 1, tl.MAV_FRAME_LOCAL_NED, 0b110111111000, -131.039, 73.5237, -9.0, 0, 0, 0, 0, 0, 0, 0, 0)
    node.deliver(goal, 255)
    t2m.mainloop()
    (sent,) = of_type(node, "SET_POSITION_TARGET_LOCAL_NED")
    assert (sent.target_system, sent.coordinate_frame, sent.type_mask) == (1, tl.MAV_FRAME_LOCAL_NED, 0b110111111000)
    assert (sent.x, sent.y, sent.z) == pytest.approx((-4.0, -2.0, -9.0), abs=1e-3)   # the lab's house
    assert t2m.goal is None                                   # reset: the tower re-sends until reached
    node.deliver(tl.MAVLink_set_position_target_local_ned_message(
        7, 1, 1, tl.MAV_FRAME_LOCAL_NED, 0, math.nan, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0), 255)
    node.turns = 1
    t2m.mainloop()                                            # NaN from the wire: dropped, said
    assert len(of_type(node, "SET_POSITION_TARGET_LOCAL_NED")) == 1 and t2m.goal is None
    assert "goal dropped" in node.logs[-1]


@pytest.mark.parametrize("frame, ahead, up", [("drone_yaw", 0.0, 0.0),
                                              ("drone", 9.0 * math.sin(0.1), 9.0 * (1 - math.cos(0.1)))])
def test_ground_robot_controller_sends_the_ground_point_under_the_drone(frame, ahead, up):
    node = FakeNode()
    grc = load("ground_robot_controller").GroundRobotController(node, frame)
    # the rover booted 3 m south of world's origin: its targets are from there (rover_origin)
    node.deliver(transform_message(TransformStamped("world", "rover_origin", 0.0, Transform(translation=(-3.0, 0.0, 0.0))),
                                   static=True), 250)
    # flying north at 5 m/s, 9 m up, nose down 0.1 rad: (0, 0, 9) in the tilting frame is
    # 9 sin 0.1 m behind the drone (checkpoint 2's wobble), in the level frame right under it
    for k, t in enumerate((1.0, 1.1)):
        xyz = (10.0 + 0.5 * k, 3.0, -9.0)
        full = Transform.from_euler(pitch=-0.1, translation=xyz)
        for child, tr in (("drone", full), ("drone_yaw", Transform(translation=xyz))):
            node.deliver(transform_message(TransformStamped("world", child, t, tr)), 250)
        node.turns = 1
        grc.mainloop()
    goals = of_type(node, "SET_POSITION_TARGET_LOCAL_NED")
    g = goals[-1]
    # (0, 0, h) through the frame: on the ground (z 0) in the level frame, a little above it when tilted
    assert g.target_system == 2 and g.z == pytest.approx(-up, abs=1e-6) and g.time_boot_ms == 1100
    assert g.x == pytest.approx(10.5 - ahead + 3.0, abs=1e-4) and g.y == pytest.approx(3.0)
    assert (g.vx, g.vy) == pytest.approx((5.0, 0.0), abs=1e-3)   # from the goal 0.1 s before
    assert len(goals) == 2 and (goals[0].vx, goals[0].vy) == (0.0, 0.0)   # at 1.0 there was none before
    node.turns = 1
    grc.mainloop()                                            # no new drone time: no new goal
    assert len(of_type(node, "SET_POSITION_TARGET_LOCAL_NED")) == 2
