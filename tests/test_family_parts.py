"""Issue 12's pure parts: the scenario's family and van, the tower's frames and separation
watch, and the family summary's closest approach."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from common.mavlink.dialect import towerlink as tl
from common.frames import Transform
from common.scenario import ScenarioError, load_scenario
from gcs.tower_family import SeparationWatch
from gcs.tower_frames import TowerFrames
from tools.family_summary import closest_approach, format_family_summary, summarize_family
from tools.run_data import RunData, Track


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


def test_shipped_family_numbers_vehicles_as_towerlink_sitl_does():
    sc = load_scenario("family")
    assert sc.vehicles == [("drone1", 1, "copter"), ("drone2", 2, "copter"), ("drone3", 3, "copter"),
                           ("rover1", 4, "rover"), ("rover2", 5, "rover"), ("rover3", 6, "rover")]
    assert sc.pairs == [(1, 4), (2, 5), (3, 6)]
    assert [d.altitude for d in sc.drones] == [6.0, 10.0, 14.0]
    # each drone's goals sit on its own layer, in the tower's frame
    assert all(g[2] == -d.altitude for d in sc.drones for g in d.goals)
    assert sc.is_family and sc.van is None


def test_shipped_van_hangs_the_tower_on_a_rover_after_the_lab_pair():
    sc = load_scenario("van")
    assert sc.vehicles == [("drone", 1, "copter"), ("rover", 2, "rover"), ("van", 3, "rover")]
    assert sc.van.sysid == 3 and len(sc.van.route) == 4 and sc.van.speed == 3.0
    buf = sc.buffer()
    assert buf.chain("van", "tower") and not buf.can_transform("world", "tower")


def test_the_lab_scenario_is_one_drone_and_its_rover():
    sc = load_scenario()
    assert sc.vehicles == [("drone", 1, "copter"), ("rover", 2, "rover")] and not sc.is_family


TOWER = 'static_transforms = ["0 0 0 0 0 0 world tower"]\n'


@pytest.mark.parametrize("body, why", [
    (TOWER + '[mission]\nmin_separation = 3.0\n[[drones]]\nname = "a"\naltitude = 6\n'
     '[[drones]]\nname = "b"\naltitude = 8\n',
     "drones 'a' (6 m) and 'b' (8 m) fly layers 2 m apart and their paths come 2.00 m close in the "
     "horizontal; mission.min_separation is 3 m"),
    (TOWER + '[[drones]]\nname = "a"\nrover = "a"\n', "vehicle names must differ: ['a'] used twice"),
    (TOWER + '[van]\nroute = [[0, 0], [1, 1]]\n', "van 'van': no static transform hangs a frame on it"),
    ('static_transforms = ["0 0 0 0 0 0 van tower"]\n[van]\nroute = [[0, 0]]\n',
     "van.route needs at least two points"),
    ('static_transforms = ["0 0 0 0 0 0 world tower", "0 0 0 0 0 0 world drone"]\n',
     "'drone' is a vehicle's frame"),
    (TOWER + '[[drones]]\naltitude = "high"\n', "drones[0].altitude must be a finite number"),
])
def test_bad_family_scenarios_are_refused_with_the_reason(tmp_path, body, why):
    with pytest.raises(ScenarioError, match=None) as e:
        load_scenario(write(tmp_path, body))
    assert why in str(e.value)


def test_unknown_scenario_name_lists_the_shipped_ones():
    with pytest.raises(ScenarioError, match="shipped: default, family, family100, van"):
        load_scenario("no-such-scenario")


def tf_msg(parent, child, t, xyz, yaw=0.0, static=False):
    T = Transform.from_euler(yaw=yaw, translation=xyz)
    return tl.MAVLink_towerlink_transform_message(int(round(t * 1e6)), parent.encode(), child.encode(),
                                                  list(T.translation), list(T.rotation),
                                                  tl.TOWERLINK_TRANSFORM_FLAGS_STATIC if static else 0)


def test_tower_frames_time_travel_on_the_van():
    f = TowerFrames()
    f.on_message(tf_msg("van", "tower", 0.0, (0, 0, 0), static=True))
    assert not f.moving("tower")
    for k in range(11):                      # van drives north 2 m/s, turning to face east at t >= 5
        t = k * 0.5
        f.on_message(tf_msg("world", "van", t, (2.0 * t, 0, 0), yaw=0.0 if t < 5 else math.pi / 2))
    assert f.moving("tower")
    # 5 m ahead of the tower, stamped t = 2 (van at x = 4, facing north)
    w = f.world_point("tower", (5.0, 0.0, -9.0), 2.0)
    assert w == pytest.approx((9.0, 0.0, -9.0), abs=1e-9)
    # seen from the tower now (t = 5: van at x = 10 facing east) the point is 1 m behind, 0 right
    assert f.seen_from("tower", w) == pytest.approx((0.0, 1.0, -9.0), abs=1e-9)
    # the latest transform would have put "5 m ahead" at (10, 5): sqrt(1 + 25) from w
    assert f.latest_offset("tower", (5.0, 0.0, -9.0), w) == pytest.approx(math.sqrt(26), abs=1e-9)
    assert f.world_point("tower", (5.0, 0.0, -9.0), 7.0) is None     # not known yet: wait
    f.on_message(tl.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))        # other messages: ignored


def pos(sysid, x, y, z):
    m = tl.MAVLink_local_position_ned_message(0, x, y, z, 0, 0, 0)
    m._header = tl.MAVLink_header(m.id, srcSystem=sysid, srcComponent=1)
    return m


def test_separation_watch_counts_only_airborne_drones_and_logs_a_breach():
    logs = []
    w = SeparationWatch({1: "d1", 2: "d2"}, 3.0, logs.append)
    w.on_message(pos(1, 0, 0, 0))
    w.on_message(pos(2, 0, 2, 0))            # on the ground 2 m apart: not judged
    assert w.closest is None
    w.on_message(pos(1, 0, 0, -6))
    w.on_message(pos(2, 0, 2, -0.5))         # d2 not yet airborne
    assert w.closest is None
    w.on_message(pos(2, 0, 2, -10))
    assert w.closest == pytest.approx(math.hypot(2, 4)) and w.breaches == 0
    w.on_message(pos(2, 0, 2, -6.5))
    assert w.closest == pytest.approx(math.hypot(2, 0.5)) and w.breaches == 1
    assert logs == ["separation: d2 and d1 2.06 m apart (minimum 3 m)"]
    w.on_message(pos(9, 0, 0, -6))           # not a drone of the family
    assert w.breaches == 1


@settings(max_examples=50, deadline=None)
@given(st.floats(1.5, 20), st.floats(1.0, 10.0), st.integers(200, 800))
def test_closest_approach_of_two_crossing_drones(h, dz, k):
    # a flies north along y = 0 at height h, b east along x = 0 at h + dz; they cross at
    # t = k / 100 s (on the sample grid); both took off from the ground before t = 0.01
    t = np.linspace(0, 10, 1001)
    tc = k / 100
    a = Track(t, np.stack([t - tc, np.zeros_like(t), np.full_like(t, -h)], axis=1))
    b = Track(t, np.stack([np.zeros_like(t), t - tc, np.full_like(t, -h - dz)], axis=1))
    a.xyz[0, 2] = b.xyz[0, 2] = 0.0
    got = closest_approach({"a": a, "b": b})
    assert got["pair"] == ["a", "b"]
    assert got["closest_m"] == pytest.approx(dz, abs=1e-9)
    assert got["t"] == pytest.approx(tc, abs=1e-9)
    # on the ground (below 1 m) nothing is judged
    assert closest_approach({"a": Track(t, a.xyz * [1, 1, 0]), "b": b})["closest_m"] is None


def test_family_figures_end_with_the_tower(tmp_path):
    """What is recorded after the tower's end (its last drone's end_sim: the drones hovering
    while fly stops the processes, as long as the machine takes) is in no figure: with
    lockstep a seed gives the same summary whatever the wall time of the shutdown."""
    t = np.arange(0.0, 60.0, 0.1)
    d = RunData()
    for _name, sysid, kind in load_scenario("family").vehicles:
        xyz = np.zeros((t.size, 3))
        xyz[:, 1] = 10.0 * sysid                        # 10 m apart east
        if kind == "copter":
            xyz[t > 1.0, 2] = -(2.0 + 4.0 * sysid)      # up at 1 s, layers 6, 10, 14 m
            tail = t > 40.0                             # after the tower: all drift to y = 0, climbing
            xyz[tail, 1] = np.maximum(0.0, 10.0 * sysid - 2.0 * (t[tail] - 40.0))
            xyz[tail, 2] -= 0.5 * (t[tail] - 40.0)
        d.truth[sysid] = Track(t, xyz)
    tower = {"ok": True, "drones": [{"sysid": s, "goals": [], "end_sim": e}
                                    for s, e in ((1, 40.0), (2, 38.0), (3, 30.0))]}
    s = summarize_family(tmp_path, tower=tower, scenario_path="family", data=d,
                         meta={"speedup": "max", "seed": 1})
    rows = {v["name"]: v for v in s["vehicles"]}
    assert rows["drone1"]["path_m"] == pytest.approx(6.0)            # the climb, not the tail
    assert rows["drone3"]["max_height_m"] == pytest.approx(14.0)
    sep = s["separation"]
    assert sep["pair"] == ["drone1", "drone2"] and sep["closest_m"] == pytest.approx(math.hypot(10, 4))
    assert sep["t"] <= 40.0
    assert "speedup max" in format_family_summary(s).splitlines()[0]


def test_fly_family_command_lines_give_every_vehicle_its_port_and_the_bridge_each_one(tmp_path):
    from tools.fly_plan import FlyPlan
    launch = FlyPlan(tmp_path, scenario="family")
    sitl, bridge = launch.sitl_cmd(), launch.bridge_cmd()
    assert sitl[sitl.index("--drones") + 1] == "3" and sitl[sitl.index("--rovers") + 1] == "3"
    eps = [sitl[i + 1] for i, a in enumerate(sitl) if a == "--endpoint"]
    vehicles = [bridge[i + 1] for i, a in enumerate(bridge) if a == "--vehicle"]
    for sysid in range(1, 7):
        port = launch.ports[f"vehicle{sysid}"]
        assert f"{sysid - 1}=udpin:127.0.0.1:{port}" in eps      # world vehicle index = sysid - 1
        assert f"{sysid}=udpout:127.0.0.1:{port}" in vehicles
    assert "--drone" not in bridge and "--rover" not in bridge
    assert "--lockstep" not in sitl and "--lockstep" not in bridge
    # lockstep: the world waits for three participants, the bridge, the family's one tower link
    # and fly's monitor on the push link
    locked = FlyPlan(tmp_path / "l", scenario="family", lockstep=True)
    sitl = locked.sitl_cmd()
    assert sitl[sitl.index("--lockstep") + 1] == "3"
    assert "--lockstep" in locked.bridge_cmd() and "--lockstep" in locked.tower_cmd()
    van = FlyPlan(tmp_path / "v", scenario="van", lockstep=True).sitl_cmd()
    assert van[van.index("--lockstep") + 1] == "4"           # bridge, the tower link, the monitor, the van's driver
    # pipelined by default (the lab too); not when asked, and never without lockstep
    assert "--lockstep-pipeline" in sitl and "--lockstep-pipeline" in van
    assert "--lockstep-pipeline" in FlyPlan(tmp_path / "p", lockstep=True).sitl_cmd()
    assert "--lockstep-pipeline" not in FlyPlan(tmp_path / "s", lockstep=True, lockstep_pipeline=False).sitl_cmd()
    assert "--lockstep-pipeline" not in FlyPlan(tmp_path / "f", scenario="family").sitl_cmd()


def test_fly_van_route_is_a_looped_mission_on_the_van(tmp_path):
    from common.geo import lla_to_ned
    from common.wpl import read
    from tools.fly_plan import SITL_HOME, FlyPlan
    launch = FlyPlan(tmp_path, scenario="van")
    sitl = launch.sitl_cmd()
    missions = [sitl[i + 1] for i, a in enumerate(sitl) if a == "--mission"]
    assert missions == [f"2={tmp_path / 'van.waypoints'}"]          # the van is vehicle 2 (sysid 3)
    assert f"2=udpin:127.0.0.1:{launch.ports['van_driver']}" in sitl
    items = read(str(tmp_path / "van.waypoints"))
    assert [i.command for i in items] == [16, 178, 16, 16, 16, 16, 177]
    assert items[1].param2 == 3.0                                  # DO_CHANGE_SPEED 3 m/s
    assert (items[-1].param1, items[-1].param2) == (2, -1)         # DO_JUMP to the first waypoint, forever
    route = [lla_to_ned(SITL_HOME, i.x, i.y, SITL_HOME[2])[:2] for i in items[2:6]]
    assert route == [pytest.approx(p, abs=0.01) for p in load_scenario("van").van.route]
