"""Issue 14's pure and small parts: the generated family, the separation rules at scale,
the family's one tower link, and the bridge's batching under 1,000 vehicles' telemetry."""
from __future__ import annotations

import itertools
import math
import select
import socket
import threading
import time
from types import SimpleNamespace

import pytest
from hypothesis import given, settings, strategies as st

from common.mavlink.dialect import towerlink as tl
from common.family_plan import LanePlan, drone_start, scenario_toml
from common.scenario import ScenarioError, load_scenario
from gcs.tower_family import LayerGates, SeparationWatch
from support import free_port, wait_until


def _load(tmp_path, text, name="f.toml"):
    p = tmp_path / name
    p.write_text(text)
    return load_scenario(p)


# ----------------------------------------------------------------------------- the generated family

def test_shipped_family100_is_the_rule_and_flies_lanes_on_two_layers():
    from common.scenario import scenario_path
    shipped = scenario_path("family100").read_text()
    assert shipped == scenario_toml(LanePlan(drones=100))       # regenerated, never edited by hand
    sc = load_scenario("family100")
    assert len(sc.drones) == 100 and sc.pairs == [] and sc.min_separation == 3.0
    assert sorted({d.altitude for d in sc.drones}) == [5.0, 8.0]
    T = sc.buffer().lookup_transform("world", "tower").transform
    for j, d in enumerate(sc.drones):
        assert d.sysid == j + 1 and d.altitude == (5.0 if j % 2 == 0 else 8.0)
        for g in d.goals:                                          # in its own lane, along +x
            x, y, z = T.apply_point(g)
            assert abs(y - drone_start(j)[1]) < 0.01 and x > 5 and z == pytest.approx(-d.altitude)


@settings(max_examples=25, deadline=None)
@given(drones=st.integers(2, 60), layers=st.integers(2, 4), legs=st.integers(1, 3))
def test_any_lane_plan_with_two_or_more_layers_keeps_neighbours_apart(tmp_path_factory, drones, layers, legs):
    plan = LanePlan(drones=drones, layers=layers, legs=legs)
    sc = _load(tmp_path_factory.mktemp("p"), scenario_toml(plan))     # the loader's check accepts it
    # planned positions (start, goals, at the layer): no two drones closer than min_separation
    pts = {}
    for j, d in enumerate(sc.drones):
        path = [drone_start(j)] + plan.world_goals(j)
        pts[j] = [(x, y, -d.altitude) for x, y in path]
    for a, b in itertools.combinations(range(drones), 2):
        if abs(a - b) > layers:
            continue
        # lanes are parallel and goals of one layer share x: compare the same waypoint index
        for p, q in zip(pts[a], pts[b]):
            assert math.dist(p[1:], q[1:]) >= plan.min_separation or plan.layer(a) != plan.layer(b)
        assert math.hypot(2.0 * (b - a), plan.altitude(a) - plan.altitude(b)) >= plan.min_separation


def test_one_layer_of_lanes_two_metres_apart_is_refused_with_the_reason(tmp_path):
    with pytest.raises(ScenarioError, match=r"drones 'drone1' \(5 m\) and 'drone2' \(5 m\) fly layers 0 m apart "
                                            r"and their paths come 2.00 m close in the horizontal"):
        _load(tmp_path, scenario_toml(LanePlan(drones=3, layers=1)))


def test_same_layer_allowed_only_when_paths_stay_apart(tmp_path):
    head = 'static_transforms = ["0 0 0 0 0 0 world tower"]\n[mission]\nmin_separation = 3.0\n'
    far = head + ('[[drones]]\nname = "a"\naltitude = 6\ngoals = [[10, 0]]\n'
                  '[[drones]]\nname = "b"\naltitude = 6\ngoals = [[0, 10]]\n')
    # a flies (0,0)->(10,0), b (0,2)->(0,10): their starts are 2 m apart
    with pytest.raises(ScenarioError, match="paths come 2.00 m close"):
        _load(tmp_path, far)
    # a and c share a layer; their starts are 4 m apart and they fly away from each other
    apart = head + ('[[drones]]\nname = "a"\naltitude = 6\ngoals = [[10, -10]]\n'
                    '[[drones]]\nname = "b"\naltitude = 9\ngoals = [[20, 2]]\n'
                    '[[drones]]\nname = "c"\naltitude = 6\ngoals = [[10, 40]]\n')
    sc = _load(tmp_path, apart, "ok.toml")
    assert [d.name for d in sc.drones] == ["a", "b", "c"]
    crossing = head + ('[[drones]]\nname = "a"\naltitude = 6\ngoals = [[10, 20]]\n'
                       '[[drones]]\nname = "b"\naltitude = 7\ngoals = [[10, -20]]\n')
    with pytest.raises(ScenarioError, match="paths come 0.00 m close"):
        _load(tmp_path, crossing, "x.toml")


# ----------------------------------------------------------------------------- the tower's watch and gates

def _lpn(sysid, x, y, z):
    m = tl.MAVLink_local_position_ned_message(1000, x, y, z, 0, 0, 0)
    m._header = SimpleNamespace(srcSystem=sysid, srcComponent=1)
    return m


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-40, 40), st.floats(-40, 40), st.floats(-12, -2)), min_size=2, max_size=25))
def test_grid_watch_finds_the_brute_force_closest_pair_within_its_cell(points):
    logs = []
    w = SeparationWatch({k + 1: f"d{k + 1}" for k in range(len(points))}, 3.0, logs.append, cell=10.0)
    for k in range(len(points)):
        w.on_message(_lpn(k + 1, 0.0, 0.0, 0.0))       # where each was first seen: its ground
    for k, p in enumerate(points):
        w.on_message(_lpn(k + 1, *p))
    best = min(math.dist(a, b) for a, b in itertools.combinations(points, 2))
    if best <= 10.0:
        assert w.closest == pytest.approx(best)
    assert w.closest is None or w.closest >= best - 1e-9
    assert (w.breaches > 0) == (w.closest is not None and w.closest < 3.0)


def test_layer_gates_take_the_highest_layer_first_and_a_failed_drone_counts_once():
    g = LayerGates({1: 5.0, 2: 8.0, 3: 5.0, 4: 8.0, 5: 11.0})
    assert g.above(5) is None and g.above(2) == 11.0 and g.above(1) == 8.0
    assert not g.held(11.0)
    g.done(5)
    assert g.held(11.0) and not g.held(8.0)
    g.done(2)
    g.done(2)                               # after_takeoff and the thread's finally: once
    assert not g.held(8.0)
    g.done(4)
    assert g.held(8.0)


# ----------------------------------------------------------------------------- the family's one link

class _FakeMaster:
    """A pymavlink-like connection: recv_match hands out queued messages."""

    def __init__(self, events):
        self.events = events
        self.inbox = []
        self.lock = threading.Lock()
        master = self

        class Mav:
            def towerlink_lockstep_send(self, t_usec, target, kind, who, period):
                events.append(("sent", kind, t_usec))

            def heartbeat_send(self, *a):
                pass

            def command_long_send(self, *a):
                master.events.append(("command", a[0]))
        self.mav = Mav()

    def put(self, msg, sysid=250):
        msg._header = SimpleNamespace(srcSystem=sysid, srcComponent=1)
        with self.lock:
            self.inbox.append(msg)

    def recv_match(self, blocking=False, timeout=None):
        end = time.monotonic() + (timeout or 0)
        while True:
            with self.lock:
                if self.inbox:
                    return self.inbox.pop(0)
            if not blocking or time.monotonic() >= end:
                return None
            time.sleep(0.002)                # poll: the fake's inbox, as recv_match(blocking) does

    def close(self):
        pass


def test_shared_link_acks_a_tick_only_after_every_mission_thread_acted_on_it():
    from common.mavlink.lockstep import ACK, TICK
    from gcs.tower_link import SharedClient
    events = []
    master = _FakeMaster(events)
    c = SharedClient(master, lockstep=True, lockstep_timeout=5.0)
    c.start()
    seen = {"a": [], "b": []}

    def mission(name, work):
        c.member()
        try:
            while len(seen[name]) < 3:
                c.poll(0.05)
                seen[name].append(c.tick_usec)
                time.sleep(work)                # simulated work acting on the TICK (slow for "b"), not a wait
                events.append((name, c.tick_usec))
        finally:
            c.leave()
    threads = [threading.Thread(target=mission, args=(n, w)) for n, w in (("a", 0.0), ("b", 0.1))]
    for t in threads:
        t.start()
    for k in range(1, 4):
        master.put(tl.MAVLink_towerlink_lockstep_message(40000 * k, 0, TICK, 0, 40000))
        wait_until(lambda k=k: ("b", 40000 * k) in events, 5, f"both threads acting on TICK {k}")
    for t in threads:
        t.join(5)
    master.put(tl.MAVLink_towerlink_lockstep_message(160000, 0, TICK, 0, 40000))
    wait_until(lambda: ("sent", ACK, 120000) in events, 5, "the last ACK")
    c.close()
    for k in (1, 2, 3):
        t = 40000 * k
        ack = events.index(("sent", ACK, t))
        assert events.index(("a", t)) < ack and events.index(("b", t)) < ack, events
    assert seen["a"] == seen["b"] == [40000, 80000, 120000]    # nobody skipped a TICK


def test_shared_link_without_lockstep_wakes_waiting_threads_on_new_messages():
    from gcs.tower_link import SharedClient
    master = _FakeMaster([])
    c = SharedClient(master).start()
    try:
        got = []
        t = threading.Thread(target=lambda: got.append(c.wait_heartbeat(7, timeout=5.0)))
        t.start()
        # heartbeats until the waiting thread has one, as a vehicle sends them: the pump may read
        # the first before the thread's wait began (it wants one newer than its call)
        end = time.monotonic() + 5
        while t.is_alive() and time.monotonic() < end:
            master.put(tl.MAVLink_heartbeat_message(tl.MAV_TYPE_QUADROTOR, tl.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                     217, 4, 4, 3), sysid=7)
            t.join(0.1)
        assert got and got[0].sysid == 7 and got[0].mav_type == tl.MAV_TYPE_QUADROTOR
    finally:
        c.close()


# ----------------------------------------------------------------------------- the bridge's batching

def _packet(sysid, k=0):
    return bytes(tl.MAVLink_attitude_message(k, 0.1, 0.2, 0.3, 0, 0, 0).pack(tl.MAVLink(None, sysid, 1)))


def test_queued_packets_leave_in_order_in_datagrams_of_at_most_1400_bytes():
    from bridge.links import BATCH_BYTES, Link
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(2.0)
    link = Link("out", f"udpout:127.0.0.1:{rx.getsockname()[1]}")
    try:
        pkts = [_packet(1, k) for k in range(60)]          # 39 bytes each
        for p in pkts[:50]:
            link.queue(p)
        link.send(pkts[50])                                 # after what is queued
        for p in pkts[51:]:
            link.queue(p)
        link.flush()
        grams = []
        while sum(len(g) for g in grams) < sum(map(len, pkts)):
            grams.append(rx.recv(65535))
        assert b"".join(grams) == b"".join(pkts)            # every packet, in order
        assert all(len(g) <= BATCH_BYTES for g in grams)
        k = grams.index(pkts[50])                           # the sent one: a datagram of its own
        assert b"".join(grams[:k]) == b"".join(pkts[:50]) and b"".join(grams[k + 1:]) == b"".join(pkts[51:])
        assert k == math.ceil(50 * len(pkts[0]) / (BATCH_BYTES // len(pkts[0]) * len(pkts[0])))
        assert link.stats.tx_packets == 60                   # packets, not datagrams
    finally:
        link.close()
        rx.close()


def _readable(sock) -> bool:
    return bool(select.select([sock], [], [], 0)[0])


def test_a_tower_goal_is_handled_before_a_burst_of_telemetry_and_between_its_batches():
    from bridge import socket_loop as sl
    from bridge.config import BridgeConfig
    from bridge.loop import Bridge
    tport, vport = free_port(), free_port()
    vsock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    vsock.bind(("127.0.0.1", vport))
    cfg = BridgeConfig(tower=f"udpin:127.0.0.1:{tport}", drone=None, rover=None, quiet=True,
                       vehicles=[("drone1", f"udpout:127.0.0.1:{vport}", 1)], follow=False)
    b = Bridge(cfg)
    tower = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    order = []

    def recorded(on):
        def handle(link, pkt):
            order.append(link.name)
            if link.name == "drone1" and order.count("drone1") == sl.VEHICLE_BATCH:
                tower.sendto(_packet(255, 2), ("127.0.0.1", tport))       # arrives mid-burst
                wait_until(lambda: _readable(b.tower.sock), 2, "the mid-burst goal at the bridge")
            on(link, pkt)
        return handle
    # the bridge's own loop, its two sides recorded on their way in
    loop = sl.PacketLoop(b.router.gcs_links, [v.link for v in b.vehicles.values()],
                         recorded(b.gcs_side.on_packet), recorded(b.vehicle_side.on_packet),
                         b.upkeep.tick, b.clock, b.warn_once)
    try:
        b.vehicles[1].link.send(b"\xfe\x00\x00\xfa\xbf\x00\x00\x00")   # so vsock learns its address
        vsock.settimeout(2.0)
        _d, link_addr = vsock.recvfrom(65535)
        for k in range(100):
            vsock.sendto(_packet(1 + k % 50, k), link_addr)
        tower.sendto(_packet(255, 1), ("127.0.0.1", tport))
        wait_until(lambda: _readable(b.tower.sock) and _readable(b.vehicles[1].link.sock), 2,
                   "the goal and the burst at the bridge")
        loop.run_once(0.5)
        assert order[0] == "tower"                         # the tower's first, though both were ready
        second = order.index("tower", 1)
        assert second == 1 + sl.VEHICLE_BATCH, order       # right after the batch it arrived in
        assert order.count("drone1") == 100
    finally:
        loop.close()
        b.close()
        tower.close()
        vsock.close()


def test_bench_counts_messages_per_coalesced_datagram():
    from tools.bench_bridge_probe import BRIDGE_SYSID, messages_in
    own = bytes(tl.MAVLink_heartbeat_message(0, 0, 0, 0, 0, 3).pack(tl.MAVLink(None, BRIDGE_SYSID, 191)))
    v1 = tl.MAVLink(None, 3, 1)
    v1.WIRE_PROTOCOL_VERSION = "1.0"
    m1 = bytes(tl.MAVLink_attitude_message(1, 0, 0, 0, 0, 0, 0).pack(v1, force_mavlink1=True))
    assert m1[0] == 0xFE
    assert messages_in(_packet(1) + own + m1 + _packet(2)) == 3
    assert messages_in(own) == 0 and messages_in(b"") == 0


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 5), st.integers(0, 3)), min_size=1, max_size=80))
def test_bridge_barrier_is_the_lowest_newest_tick_over_every_link(steps):
    """The desk's counted barrier equals min(newest TICK per link), TICKs in any order."""
    from bridge.lockstep_desk import LockstepDesk
    links = 6
    vehicles = {s: SimpleNamespace(name=f"v{s}", sysid=s, link=SimpleNamespace(send=lambda d: None))
                for s in range(links)}
    barriers = []
    desk = LockstepDesk(vehicles, lambda m: m, lambda m: None, barriers.append, lambda line: None, lambda: 0.0)
    newest: dict[int, int] = {}
    for link, frame in steps:
        t = frame * 40000
        desk.on_vehicle(vehicles[link], tl.MAVLink_towerlink_lockstep_message(t, 0, tl.TOWERLINK_LOCKSTEP_KIND_TICK, 0, 40000))
        newest[link] = max(newest.get(link, -1), t)
        if len(newest) == links:
            assert desk.barrier_usec == min(newest.values())
    assert barriers == sorted(set(barriers))          # each barrier once, in order
