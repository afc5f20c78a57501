"""Nodes (common.tf2_ros) through a running bridge (issue 12): a node's frame is looked up by
another node; the bridge keeps each frame's authority and refuses a second publisher with
a reason; a camera frame under `drone` shows in the tree with its rate and points go
through it; --route-only hands the tower's goals to the nodes and publishes no vehicle frames."""
from __future__ import annotations

import numpy as np
import pytest

from common.mavlink.dialect import towerlink as tl
from common.frames import LATEST, Buffer, PointStamped, Transform, TransformStamped
from common.tf2_ros import (MessageFilter, Node, StaticTransformBroadcaster, TransformBroadcaster,
                         TransformListener)
from bridge_fakes import bridge_with_fakes
from support import free_port, wait_until

# a camera 0.2 m ahead of and 0.1 m below the drone's origin (FRD), its optical axis (z) forward
CAM = Transform.from_euler(pitch=np.pi / 2, translation=(0.2, 0.0, 0.1))


@pytest.fixture
def lab():
    port = free_port()
    with bridge_with_fakes(rover=False, out=True, nodes=f"udpin:127.0.0.1:{port}") as w:
        w["node_url"] = f"udpout:127.0.0.1:{port}"
        nodes = []
        w["node"] = lambda name, **kw: nodes.append(Node(name, w["node_url"], **kw)) or nodes[-1]
        try:
            yield w
        finally:
            for n in nodes:
                n.close()


def texts(node_msgs) -> list[str]:
    return [m.text for m in node_msgs]


def fly_drone(drone, t0_ms: int, n: int, step_ms: int = 50):
    for k in range(n):
        t = t0_ms + k * step_ms
        drone.pose(t, (t / 1000.0, 2.0, -9.0))


def test_a_nodes_camera_frame_is_looked_up_by_another_node_through_the_bridge(lab):
    bridge, drone, out = lab["bridge"], lab["drone"], lab["out"]
    cam_node = lab["node"]("camera_driver")
    user = lab["node"]("camera_user")
    buf = Buffer()
    TransformListener(buf, user)
    wait_until(lambda: len(bridge.node_links[0].peers) == 2, 5, "both nodes are peers of the node link")
    br = TransformBroadcaster(cam_node)
    # a gimbal-mounted camera: dynamic, 10 Hz on the drone's clock, while the drone flies at 20 Hz
    for k in range(21):
        t = 1.0 + 0.1 * k
        fly_drone(drone, int(t * 1000), 2)
        br.send_transform(TransformStamped("drone", "camera", t, CAM))
    wait_until(lambda: buf.can_transform("world", "camera", 3.0), 5, "world <- camera in the user's buffer")
    # a point 5 m along the camera's axis, seen at t=2.0 s (drone at (2, 2, -9), level, north):
    # 5.2 m ahead of the drone and 0.1 m below it, in world
    p = buf.transform_point(PointStamped("camera", 2.0, (0.0, 0.0, 5.0)), "world")
    np.testing.assert_allclose(p.point, (7.2, 2.0, -8.9), atol=1e-4)
    # the bridge owns nothing of it: it is the node's, and named so
    assert bridge.node_desk.frames.owners == {"camera": f"node:255/{cam_node.source_component}"}
    assert bridge.buffer.edge_stats()["camera"].authority == f"node:255/{cam_node.source_component}"
    # it is on the bridge's stream: a world-frame --out (what view-frames and the tlogs read) shows
    # camera under drone with its 10 Hz rate
    from tools.view_frames import buffer_from_messages
    wait_until(lambda: buffer_from_messages(out.of_type("TOWERLINK_TRANSFORM"))[0].can_transform("world", "camera", 3.0),
               5, "camera on the stream")
    tree, _ = buffer_from_messages(out.of_type("TOWERLINK_TRANSFORM"))     # what view-frames draws
    st = tree.edge_stats()["camera"]
    assert st.parent == "drone" and not st.is_static and st.rate_hz == pytest.approx(10.0, rel=0.01)
    assert "camera: \n  parent: 'drone'" in tree.all_frames_as_yaml()
    assert any(t == f"tf drone->camera by node:255/{cam_node.source_component}"
               for t in texts(out.of_type("STATUSTEXT")))


def test_a_second_publisher_of_a_frame_is_refused_with_a_reason_and_counted(lab):
    bridge, out = lab["bridge"], lab["out"]
    first = lab["node"]("camera_driver")
    second = lab["node"]("imposter", source_component=99)
    StaticTransformBroadcaster(first).send_transform(TransformStamped("drone", "camera", 0.0, CAM))
    wait_until(lambda: bridge.node_desk.frames.owners.get("camera"), 5, "camera owned")
    said = []
    second.subscribe("STATUSTEXT", said.append)
    moved = TransformStamped("drone", "camera", 0.0, Transform(translation=(50.0, 0, 0)))
    StaticTransformBroadcaster(second).send_transform(moved)
    want = f"tf refused: 'camera' belongs to node:255/{first.source_component}"
    wait_until(lambda: want in texts(said), 5, "the refusal, told to the second node")
    assert want in texts(out.of_type("STATUSTEXT"))
    # the frame did not move; the refusal is counted on the node link and by reason
    assert bridge.buffer.lookup_transform("drone", "camera", LATEST).transform.almost_equal(CAM, 1e-6)
    assert bridge.node_links[0].stats.refused >= 1
    assert bridge.node_desk.frames.refused[want.removeprefix("tf refused: ")] >= 1
    out.clear()
    assert out.wait("TOWERLINK_BRIDGE_STATUS", lambda m: m.link == "nodes" and m.refused >= 1)


@pytest.mark.parametrize("sysid, child, reason", [
    (66, "camera", "sysid 66 not trusted"),
    (255, "drone", "'drone' is a bridge frame"),          # the bridge pairs the drone's own telemetry
    (255, "tower", "'tower' is a scenario frame"),
])
def test_untrusted_senders_and_protected_frames_are_refused(lab, sysid, child, reason):
    bridge = lab["bridge"]
    node = lab["node"]("n", source_system=sysid)
    said = []
    node.subscribe("STATUSTEXT", said.append)
    parent = "world"
    TransformBroadcaster(node).send_transform(TransformStamped(parent, child, 5.0, Transform(translation=(9, 9, 9))))
    wait_until(lambda: f"tf refused: {reason}" in texts(said), 5, reason)
    assert child not in bridge.node_desk.frames.owners


def test_route_only_sends_tower_goals_to_the_nodes_and_publishes_no_vehicle_frames():
    port = free_port()
    with bridge_with_fakes(rover=False, route_only=True, nodes=f"udpin:127.0.0.1:{port}") as w:
        bridge, tower, drone = w["bridge"], w["tower"], w["drone"]
        with Node("tower_to_map", f"udpout:127.0.0.1:{port}") as node:
            goals = []
            node.subscribe("SET_POSITION_TARGET_LOCAL_NED", goals.append, sysid=255)
            wait_until(lambda: bridge.node_links[0].peers, 5, "the node is a peer")
            fly_drone(drone, 1000, 5)
            tower.mav.set_position_target_local_ned_send(0, 1, 1, tl.MAV_FRAME_LOCAL_NED, 0b110111111000,
                                                         -131.0, 73.5, -9.0, 0, 0, 0, 0, 0, 0, 0, 0)
            g = wait_until(lambda: goals, 5, "the tower goal at the node")[0]
            assert (g.x, g.y, g.z) == pytest.approx((-131.0, 73.5, -9.0))     # untranslated: tower frame
            assert g.target_system == 1
            # the drone never got it (a tower-frame goal read as world would send it 150 m away)
            assert not drone.of_type("SET_POSITION_TARGET_LOCAL_NED")
            # a world goal from the node is routed to the drone as sent
            node.send(tl.MAVLink_set_position_target_local_ned_message(
                0, 1, 1, tl.MAV_FRAME_LOCAL_NED, 0b110111111000, -4.0, -2.0, -9.0, 0, 0, 0, 0, 0, 0, 0, 0))
            m = drone.wait("SET_POSITION_TARGET_LOCAL_NED")
            assert (m.x, m.y, m.get_srcSystem(), m.get_srcComponent()) == (-4.0, -2.0, 255, node.source_component)
            # no world->drone of the bridge's own: the frame is free for a node to publish
            assert "drone" not in bridge.buffer.frames() and not bridge.cfg.follow
            TransformBroadcaster(node).send_transform(TransformStamped("world", "drone", 1.2, Transform()))
            wait_until(lambda: bridge.buffer.can_transform("world", "drone", 1.2), 5, "the node's drone frame")


def test_message_filter_in_a_node_waits_for_another_nodes_frame_and_drops_stale_data(lab):
    from common.tf2_ros import FilterFailureReason
    bridge, drone = lab["bridge"], lab["drone"]
    user = lab["node"]("detector")
    buf = Buffer()
    mf = MessageFilter(TransformListener(buf, user), "world", queue_size=5, timeout=1.0)
    got, dropped = [], []
    mf.register_callback(lambda p: got.append(mf.transform(p)))
    mf.register_failure_callback(lambda p, why: dropped.append((p, why)))
    seen = PointStamped("camera", 2.0, (0.0, 0.0, 5.0))
    mf.add(seen)                                        # no camera frame anywhere yet: it waits
    assert got == [] and mf.waiting == 1
    wait_until(lambda: bridge.node_links[0].peers, 5, "the detector is a peer")
    cam = lab["node"]("camera_driver")
    StaticTransformBroadcaster(cam).send_transform(TransformStamped("drone", "camera", 0.0, CAM))
    fly_drone(drone, 1900, 4)                           # the drone's frame at 1.9 .. 2.05 s
    wait_until(lambda: got, 5, "the filter's delivery once world <- camera exists at 2.0 s")
    np.testing.assert_allclose(got[0].point, (7.2, 2.0, -8.9), atol=1e-4)
    assert got[0].frame_id == "world" and got[0].stamp == 2.0 and dropped == []
    # a frame no node publishes: dropped after the timeout, with tf2_ros's reason
    lost = PointStamped("lidar", 2.0, (1.0, 0.0, 0.0))
    mf.add(lost)
    wait_until(lambda: dropped, 5, "the drop")
    assert dropped == [(lost, FilterFailureReason.NoTransformFound)]
    assert "lidar" in mf.last_drop[2] and mf.delivered == 1
    mf.close()


def test_a_static_transform_request_cannot_take_a_nodes_frame(lab):
    from common.tf2_ros.wire import static_transform_message
    bridge, tower = lab["bridge"], lab["tower"]
    cam = lab["node"]("camera_driver")
    TransformBroadcaster(cam).send_transform(TransformStamped("world", "beacon", 1.0, Transform(translation=(1, 1, 0))))
    wait_until(lambda: bridge.node_desk.frames.owners.get("beacon"), 5, "beacon owned by the node")
    tower.mav.send(static_transform_message(TransformStamped("world", "beacon", 0.0, Transform())))
    m = tower.wait("STATUSTEXT", lambda m: m.text.startswith("static tf"))
    assert m.text == f"static tf refused: 'beacon' belongs to node:255/{cam.source_component}"
    assert not bridge.buffer.edge_stats()["beacon"].is_static
