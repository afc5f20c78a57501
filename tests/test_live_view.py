"""The run as Foxglove sees it: the scene feed (pure), run.mcap, and the live WebSocket view."""
from __future__ import annotations

import math

import pytest

from common.mavlink.dialect import towerlink as tl
from tools.run_mcap import buffer_from_mcap, read_records, write_mcap
from tools.scene_feed import TOPICS, records_of

BRIDGE, DRONE, TOWER = 250, 1, 255


def wire(src: int, msgs):
    """Messages as a receiver decodes them (so get_srcSystem is the sender's)."""
    enc = tl.MAVLink(None, srcSystem=src, srcComponent=1)
    dec = tl.MAVLink(None)
    out = []
    for m in msgs:
        out += dec.parse_buffer(m.pack(enc)) or []
    return out


def transform(t_s: float, parent: str, child: str, xyz, q=(0.0, 0.0, 0.0, 1.0), static=False):
    return tl.MAVLink_towerlink_transform_message(
        0 if static else int(round(t_s * 1e6)), parent.encode(), child.encode(), list(xyz), list(q),
        1 if static else 0)


def flight(n: int = 40, dt: float = 0.1):
    """The tower static, a drone flying north at 2 m/s (yawed 90 deg), a tower goal, follow status."""
    yaw_q = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))
    msgs = wire(BRIDGE, [transform(0, "world", "tower", (10.0, -5.0, 0.0), yaw_q, static=True)])
    msgs += wire(TOWER, [tl.MAVLink_set_position_target_local_ned_message(
        1000, DRONE, 1, 1, 3576, 12.0, 34.0, -9.0, 0, 0, 0, 0, 0, 0, 0, 0)])
    for k in range(n):
        t = 1.0 + k * dt
        msgs += wire(BRIDGE, [transform(t, "world", "drone", (2.0 * (t - 1.0), 0.0, -9.0), yaw_q),
                              tl.MAVLink_towerlink_follow_status_message(
                                  int(t * 1e6), 0, 0, 0.3, 0.0, 0.0, 0.0, 0, 0, 0, 0, 0.0, 0.4,
                                  9.0, 0.05, 0.3, 0.0, 1, 1)])
    return msgs


def test_feed_stamps_every_record_with_sim_time_and_splits_static_from_dynamic():
    recs = list(records_of(flight()))
    tf = [r for r in recs if r.topic == "/tf"]
    static = [r for r in recs if r.topic == "/tf_static"]
    assert len(tf) == 40 and len(static) == 2
    # the feed's one edge of its own: a z-up display frame above the NED world
    disp = static[0].body["transforms"][0]
    assert (disp["parent_frame_id"], disp["child_frame_id"]) == ("world_enu", "world")
    static = static[1:]
    ft = tf[-1].body["transforms"][0]
    assert tf[-1].sim_ns == 4_900_000_000 == ft["timestamp"]["sec"] * 10**9 + ft["timestamp"]["nsec"]
    assert (ft["parent_frame_id"], ft["child_frame_id"]) == ("world", "drone")
    assert ft["translation"] == pytest.approx({"x": 7.8, "y": 0.0, "z": -9.0}, abs=1e-5)
    st = static[0].body["transforms"][0]
    assert (st["parent_frame_id"], st["child_frame_id"], st["translation"]["x"]) == ("world", "tower", 10.0)
    # the tower's goal is drawn in the tower's frame, at the tower's coordinates
    goal = [r for r in recs if r.topic == "/goals"][-1].body["entities"][0]
    assert goal["frame_id"] == "tower"
    assert goal["spheres"][0]["pose"]["position"] == {"x": 12.0, "y": 34.0, "z": -9.0}
    # the drone is drawn in its own frame (so it tilts and turns as the tree says); its track in world
    veh = [r for r in recs if r.topic == "/vehicles"][-1].body["entities"]
    body = next(e for e in veh if e["id"] == "drone")
    track = next(e for e in veh if e["id"].startswith("track_drone"))
    assert body["frame_id"] == "drone" and track["frame_id"] == "world"
    xs = [p["x"] for p in track["lines"][0]["points"]]
    assert xs == sorted(xs) and 7.8 - 0.25 <= xs[-1] <= 7.8 and len(xs) >= 10   # a point every 0.25 m
    # the rover target through both frames, and the running figures
    fol = [r for r in recs if r.topic == "/follow"][-1].body["entities"][0]["spheres"]
    assert [s["pose"]["position"]["x"] for s in fol] == pytest.approx([0.3, 0.0], abs=1e-6)
    summ = [r for r in recs if r.topic == "/summary"][-1].body
    assert summ["wobble_full_rms"] == pytest.approx(0.3, abs=1e-6) and summ["wobble_yaw_rms"] == 0.0
    assert summ["follow_error_rms"] == pytest.approx(0.4, abs=1e-6) and summ["goals_sent"] == 1
    # scene updates at 10 Hz of sim time, not per message
    n_scene = len([r for r in recs if r.topic == "/vehicles"])
    assert 35 <= n_scene <= 41


def test_non_finite_transforms_are_dropped_not_drawn():
    msgs = wire(BRIDGE, [transform(1.0, "world", "drone", (math.nan, 0.0, 0.0))])
    assert [r for r in records_of(msgs) if r.topic == "/tf"] == []


def test_mcap_holds_every_channel_in_sim_time_order_and_reads_back_as_a_buffer(tmp_path):
    path = tmp_path / "run.mcap"
    n = write_mcap(records_of(flight()), path)
    recs = list(read_records(path))
    assert len(recs) == n
    assert {t for t, _, _ in recs} == set(TOPICS)
    times = [ns for _, ns, _ in recs]
    assert times == sorted(times) and times[-1] == 4_900_000_000
    from mcap.reader import make_reader
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    schemas = {summary.schemas[c.schema_id].name for c in summary.channels.values()}
    assert {"foxglove.FrameTransforms", "foxglove.SceneUpdate"} <= schemas
    assert all(c.message_encoding == "json" for c in summary.channels.values())
    buf, stamps, latest = buffer_from_mcap(path)
    assert latest == pytest.approx(4.9)
    ts = buf.lookup_transform("tower", "drone", 3.0)       # through the static and the dynamic edge
    # world->drone at 3 s is (4, 0, -9); in the tower frame (at (10,-5), yawed 90 deg):
    # R^T (p - t) = R^T (-6, 5, -9) = (5, 6, -9)
    assert ts.transform.translation == pytest.approx([5.0, 6.0, -9.0], abs=1e-4)
    assert len(stamps["drone"]) == 40


def test_mcap_write_is_atomic_and_leaves_no_temporary_on_failure(tmp_path):
    path = tmp_path / "run.mcap"
    path.write_bytes(b"old")

    def broken():
        yield from records_of(flight(3))
        raise RuntimeError("the tlog ended badly")

    with pytest.raises(RuntimeError):
        write_mcap(broken(), path)
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["run.mcap"]


def test_live_view_serves_transforms_on_the_sim_clock():
    pytest.importorskip("foxglove")
    from tools.foxglove_client import FoxgloveClient
    from tools.live_view import LiveView

    view = LiveView(port=0)
    client = None
    try:
        topics = ("/tf", "/tf_static", "/vehicles", "/goals")
        client = FoxgloveClient(view.url, topics)
        # the server has taken the subscriptions (not just the client sent them): nothing is lost
        client.wait_for(lambda: all(view.channels[t].has_sinks() for t in topics), 10, "the subscriptions")
        for m in flight():
            view.on_message(m)
        client.wait_for(lambda: len(client.of("/tf")) == 40 and client.of("/goals"), 10, "40 transforms")
        tf = client.of("/tf")
        assert [t for t, _ in tf] == [int(round((1.0 + k * 0.1) * 1e9)) for k in range(40)]
        last_t, last = tf[-1]
        assert last["transforms"][0]["translation"]["x"] == pytest.approx(7.8, abs=1e-5)
        assert [b["transforms"][0]["child_frame_id"] for _, b in client.of("/tf_static")] == ["world", "tower"]
        assert client.of("/goals")[-1][1]["entities"][0]["frame_id"] == "tower"
        client.wait_for(lambda: client.times and client.times[-1] == last_t, 10, "the sim time broadcast")
    finally:
        if client is not None:
            client.stop()
        view.stop()


def test_live_view_does_no_work_for_channels_nobody_watches(monkeypatch):
    pytest.importorskip("foxglove")
    from tools.live_view import LiveView

    view = LiveView(port=0)
    try:
        logged = []

        class Watched:      # the real channel's subscriber check, its log recorded
            def __init__(self, ch):
                self.ch = ch

            def has_sinks(self):
                return self.ch.has_sinks()

            def log(self, *a, **k):
                logged.append(a)

        view.channels = {t: Watched(ch) for t, ch in view.channels.items()}
        for m in flight(5):
            view.on_message(m)
        assert logged == []
    finally:
        view.stop()


def test_the_shipped_layout_is_what_the_generator_writes_and_shows_the_feeds_topics():
    pytest.importorskip("foxglove")
    import json
    from pathlib import Path

    from tools.foxglove_layout import DEFAULT_OUT, build

    shipped = json.loads(Path(DEFAULT_OUT).read_text())
    assert shipped == build()           # regenerate with: python -m tools.foxglove_layout
    text = json.dumps(shipped)
    for topic in ("/vehicles", "/goals", "/follow", "/summary.follow_error_rms"):
        assert f'"{topic}' in text
    assert '"fixedFrame": "world_enu"' in text   # the feed's z-up display frame


def test_bridge_view_serves_its_frame_tree_to_a_foxglove_client(processes):
    """`towerlink bridge --view PORT`: a Foxglove client sees the bridge's frames (its scenario's
    static tower frame) with no vehicle connected, and nothing is left running afterwards."""
    pytest.importorskip("foxglove")
    import socket

    from support import free_port, free_ports, wait_until
    from tools.foxglove_client import FoxgloveClient

    view_port = free_port(socket.SOCK_STREAM)
    tower, drone, rover = free_ports(3)
    bridge = processes.start(["towerlink", "bridge", "--tower", f"udpin:127.0.0.1:{tower}",
                              "--drone", f"udpout:127.0.0.1:{drone}", "--rover", f"udpout:127.0.0.1:{rover}",
                              "--view", str(view_port), "-q"])

    def connect():
        try:
            return FoxgloveClient(f"ws://127.0.0.1:{view_port}", ("/tf_static",))
        except Exception:   # noqa: BLE001 - refused, or a handshake before the server is up
            return None

    client = wait_until(connect, 30, "the bridge's Foxglove server")
    try:
        wait_until(lambda: any(ft["child_frame_id"] == "tower" for _, b in client.of("/tf_static")
                               for ft in b["transforms"]), 30, "world -> tower from the bridge")
        ft = next(ft for _, b in client.of("/tf_static") for ft in b["transforms"] if ft["child_frame_id"] == "tower")
        assert ft["parent_frame_id"] == "world"
        from common.scenario import load_scenario
        want = load_scenario(None).buffer().lookup_transform("world", "tower").transform.translation
        assert [ft["translation"][k] for k in "xyz"] == pytest.approx(list(want), abs=1e-3)
    finally:
        client.stop()
    processes.stop(bridge)
    assert bridge.returncode is not None


def test_run_mcap_encodes_every_record_as_json_dumps_does():
    """tools.run_mcap.encode takes each track's points as the feed wrote them (TrackPoints.json):
    the bytes json.dumps makes of the whole body, over several segments and their resends."""
    import json

    from tools.run_mcap import encode
    from tools.scene_feed import TRACK_SEGMENT, TrackPoints
    recs = list(records_of(flight(1500)))
    tracks = [ln["points"] for r in recs if r.topic == "/vehicles" for e in r.body["entities"]
              for ln in e.get("lines", [])]
    assert tracks and all(isinstance(p, TrackPoints) for p in tracks)
    assert max(len(p) for p in tracks) == TRACK_SEGMENT + 1 and len({id(p) for p in tracks}) == len(tracks)
    for r in recs:
        assert encode(r) == (r.sim_ns, r.topic, json.dumps(r.body).encode())
