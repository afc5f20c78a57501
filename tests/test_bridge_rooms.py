"""The bridge's rooms (issue 9): pairing is pure, the timeline alone decides that a clock
went back, and a tower goal becomes a drone target in one hop (GoalDesk.try_goal), never
on a stale transform."""
from __future__ import annotations

import ast
import inspect

import pytest

import bridge.pairing
import bridge.timeline
from bridge.codec import Codec
from bridge.frame_tree import FrameTree
from bridge.goals import GoalDesk, PendingGoal
from bridge.links import LinkStats
from bridge.pairing import VehicleFrames
from bridge_fakes import bridge_with_fakes
from common.mavlink.dialect import towerlink as tl
from common.frames import Transform, TransformStamped
from support import wait_until


# ---------------------------------------------------------------------- pairing: pure
def test_pairing_imports_no_io_and_does_not_judge_the_clock():
    imported = {a.name.split(".")[0] for n in ast.walk(ast.parse(inspect.getsource(bridge.pairing)))
                if isinstance(n, (ast.Import, ast.ImportFrom)) for a in (n.names if isinstance(n, ast.Import)
                                                                         else [ast.alias(n.module or "")])}
    assert not imported & {"socket", "selectors", "time", "asyncio", "bridge"}, imported
    vf = VehicleFrames("drone")
    vf.on_local_position(50_000, 1, 0, 0, 0, 0, 0)
    assert len(vf.on_attitude_quaternion(50_000, 1, 0, 0, 0)) == 1
    # the clock goes back 50 s: pairing pairs the new sample but starts nothing over by
    # itself (the timeline decides restarts) ...
    out = vf.on_local_position(20, 7, 0, 0, 0, 0, 0) + vf.on_attitude_quaternion(20, 1, 0, 0, 0)
    assert [s.stamp for s in out] == [0.02] and vf.resets == 0
    assert vf.on_local_position(50_000, 9, 0, 0, 0, 0, 0) == [] and vf.duplicates == 1   # still known
    # ... until it is told to
    vf.reset()
    assert len(vf.on_local_position(50_000, 9, 0, 0, 0, 0, 0) + vf.on_attitude_quaternion(50_000, 1, 0, 0, 0)) == 1


# ---------------------------------------------------------------------- timeline: the one judge
def _reboot(drone, bridge):
    for ms in (1000, 1100, 1200, 1300):
        drone.pose(ms, (ms / 1000.0, 0, -5))
    wait_until(lambda: (bridge.buffer.edge_stats().get("drone") or 0) and
               bridge.buffer.edge_stats()["drone"].samples == 4, 5, "4 samples")
    drone.pose(100, (42, 0, -5))            # the drone's clock restarts at 0.1 s


def test_reboot_is_noticed_by_the_timeline():
    with bridge_with_fakes(rover=False, heartbeats=False) as w:
        bridge, drone = w["bridge"], w["drone"]
        _reboot(drone, bridge)
        wait_until(lambda: bridge.buffer.edge_stats()["drone"].most_recent == 0.1, 5, "edge reset")
        assert bridge.buffer.edge_stats()["drone"].samples == 1
        assert bridge.timeline.clocks["drone"].restarts == 1 and bridge.vehicles[1].frames.resets == 1


def test_reboot_is_noticed_only_by_the_timeline(monkeypatch):
    # with the timeline's one rule switched off, nothing else in the bridge resets the drone
    monkeypatch.setattr(bridge.timeline, "clock_went_back", lambda *a, **k: False)
    with bridge_with_fakes(rover=False, heartbeats=False) as w:
        br, drone = w["bridge"], w["drone"]
        _reboot(drone, br)
        drone.pose(1400, (1.4, 0, -5))      # a later sample that can only arrive after 0.1's
        wait_until(lambda: br.buffer.edge_stats()["drone"].most_recent == 1.4, 5, "1.4 stored")
        st = br.buffer.edge_stats()["drone"]
        assert st.samples == 6 and st.oldest == 0.1     # old history kept, no reset anywhere
        assert not any("reboot" in line for line in br.logs)


# ---------------------------------------------------------------------- goals: one hop
class Sent(list):
    def __call__(self, target: int, data: bytes) -> bool:
        self.append((target, data))
        return True


def drone_sample(stamp: float, xyz):
    from bridge.pairing import FrameSample
    T = Transform(translation=xyz)
    return FrameSample(stamp, TransformStamped("world", "drone", stamp, T),
                       TransformStamped("world", "drone_yaw", stamp, T), (0.0, 0.0, 0.0))


def test_goal_desk_never_sends_on_a_stale_transform_and_sends_once_fresh():
    tree = FrameTree(max_age=0.5)
    tree.add_vehicle("drone")
    tree.add_sample("drone", drone_sample(1.0, (10.0, 20.0, -5.0)), reset=False)
    now = {"world": 2.0}                      # the newest vehicle clock: the drone's pose is 1 s old
    sent, stats, texts = Sent(), LinkStats(), []
    desk = GoalDesk(tree, Codec(250, 191), sent, stats, lambda: now["world"], lambda: 0.0,
                    lambda s: None, texts.append)
    goal = tl.MAVLink_towerlink_position_target_message(1500, 1, 1, b"drone", 0b110111111000,
                                                        1.0, 2.0, -3.0, 0, 0, 0, 0, 0)
    g = PendingGoal("named", goal, (255, 190, 7, True), "drone", 1, since=0.0)
    desk.submit(g)
    assert sent == [] and desk.pending[1] is g and stats.deferred == 1
    assert texts == ["goal waits: no drone->world tf"]
    desk.retry()
    assert sent == [] and stats.deferred == 2
    # a fresh pose: the retry sends it, translated into world, as the tower's own packet
    tree.add_sample("drone", drone_sample(1.9, (11.0, 20.0, -5.0)), reset=False)
    desk.retry()
    assert len(sent) == 1 and not desk.pending and stats.translated == 1
    target, data = sent[0]
    m = tl.MAVLink(None).decode(bytearray(data))
    assert target == 1 and m.get_type() == "SET_POSITION_TARGET_LOCAL_NED"
    assert (m.get_srcSystem(), m.get_srcComponent(), m.get_seq()) == (255, 190, 7)
    assert m.coordinate_frame == tl.MAV_FRAME_LOCAL_NED
    assert (m.x, m.y, m.z) == pytest.approx((12.0, 22.0, -8.0))
    desk.retry()
    assert len(sent) == 1                     # sent once, not again
