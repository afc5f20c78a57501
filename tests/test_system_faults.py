"""Faults on the full system (world, bridge, tower as processes over loopback, at speedup).

* the bridge killed (SIGKILL) mid-mission and restarted: the drone holds, the mission completes
* 20 % packet loss both ways on the tower link (seeded proxy): the mission completes
* garbage and malformed packets on every bridge port: counted, dropped, nothing else changes
"""
from __future__ import annotations

import math
import os
import random

import pytest

from support import wait_until
from system_support import HOUSE, finish, launched, tower_goals, wait_goal

pytestmark = [pytest.mark.slow, pytest.mark.alone]     # not lockstep: on the wall clock

SHORT = [HOUSE, (10.0, -2.0), (10.0, 6.0)]


def test_bridge_killed_and_restarted_mid_mission(tmp_path):
    with launched(tmp_path, goals=tower_goals(SHORT), finish="none") as launch:
        wait_goal(launch, 2, "sent", timeout=60)
        start = launch.monitor.snapshot()["drone"]
        # kill it mid-leg: once the drone is on its way to goal 2
        wait_until(lambda: (p := launch.monitor.snapshot()["drone"]) is not None and start is not None
                   and math.dist(p[:2], start[:2]) > 1.0, 60, "the drone under way to goal 2")
        launch.kill_bridge()
        # without the bridge the drone keeps its last GUIDED target and hovers: sample truth
        # over 20 s of the world's own clock (however fast the loaded machine runs it): time
        # to finish the leg it was on and hover at its end
        samples = []
        sim0 = launch.monitor.snapshot()["sim"]

        def sampled_20_sim_s():
            snap = launch.monitor.snapshot()
            if not samples or snap["sim"] > samples[-1][0]:
                samples.append((snap["sim"], snap["drone"]))
            return snap["sim"] >= sim0 + 20.0
        wait_until(sampled_20_sim_s, 60, "20 s of the world's clock with the bridge down", interval=0.1)
        assert launch.alive()["bridge"] is False and launch.alive()["tower"] is True
        assert len(samples) >= 6, samples
        heights = [-p[2] for _, p in samples if p]
        assert min(heights) > 7.0, "the drone stayed in the air"
        (t0, p0), (t1, p1) = samples[-6], samples[-1]
        assert math.dist(p0[:2], p1[:2]) / max(t1 - t0, 1e-3) < 0.5, "and held its position"
        assert launch.goal_state.n == 2 and launch.goal_state.last == "sent"
        launch.restart_bridge()
        s = finish(launch, timeout=90)
    assert s["ok"] and s["goals_reached"] == 3
    assert s["bridge_restarts"] == 1


def test_twenty_percent_loss_on_the_tower_link(tmp_path):
    with launched(tmp_path, goals=tower_goals(SHORT), finish="land", tower_loss=0.2, loss_seed=4) as launch:
        s = finish(launch, timeout=120)
    assert s["ok"] and s["goals_reached"] == 3
    p = s["proxy"]
    # The proxy really lost packets both ways. The tower sends only a few dozen datagrams in a
    # short mission, too few to pin a rate on; the rate itself is tested in test_link_proxy.py,
    # and here on the downlink and in total, where thousands of datagrams pass.
    assert p["dropped"]["up"] >= 1 and p["passed"]["up"] >= 10, p
    down = p["passed"]["down"] + p["dropped"]["down"]
    assert down > 1000 and 0.15 < p["dropped"]["down"] / down < 0.25, p
    total = sum(p["passed"].values()) + sum(p["dropped"].values())
    assert 0.15 < sum(p["dropped"].values()) / total < 0.25, p
    import json
    t = json.loads((tmp_path / "tower.json").read_text())
    assert t["finished"] and all(g["sends"] >= 1 for g in t["goals"])


def _udp_ports_of(pid: int) -> list[int]:
    """Local UDP ports held by a process (Linux /proc)."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            link = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if link.startswith("socket:["):
            inodes.add(link[8:-1])
    ports = []
    with open("/proc/net/udp") as f:
        next(f)
        for line in f:
            cols = line.split()
            if cols[9] in inodes:
                ports.append(int(cols[1].split(":")[1], 16))
    return sorted(set(ports))


def _garbage(rng: random.Random) -> list[bytes]:
    """Random bytes, bad CRCs, truncated packets, unknown ids, huge length fields."""
    from common.mavlink.dialect import encoder
    from common.mavlink.dialect import towerlink as tl
    mav = encoder(77, 1)
    good = tl.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(mav)
    target = tl.MAVLink_set_position_target_local_ned_message(
        0, 1, 1, 1, 0b110111111000, 500.0, 500.0, -50.0, 0, 0, 0, 0, 0, 0, 0, 0).pack(mav)
    bad_crc = bytearray(target)
    bad_crc[-1] ^= 0xFF
    unknown = bytearray(good)
    unknown[7:10] = (60000).to_bytes(3, "little")   # msgid nobody knows (CRC then also wrong)
    out = [bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 300))) for _ in range(20)]
    out += [bytes(bad_crc), bytes(target[:len(target) // 2]), bytes(unknown),
            b"\xfd\xff" + bytes(10), b"\xfe\x05\x00", b"\xfd" * 50, bytes(bad_crc) * 3]
    return out


def test_garbage_on_every_bridge_port_is_counted_and_dropped(tmp_path):
    import socket
    rng = random.Random(11)
    with launched(tmp_path, goals=tower_goals(SHORT), finish="none") as launch:
        wait_goal(launch, 1, "reached", timeout=60)
        pid = launch.procs["bridge"].pid
        ports = _udp_ports_of(pid)
        assert launch.ports["tower"] in ports and len(ports) >= 4   # tower in, drone, rover, out
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sent = 0
        try:
            for _ in range(3):
                for port in ports:
                    for pkt in _garbage(rng):
                        s.sendto(pkt, ("127.0.0.1", port))
                        sent += 1
                # the next burst 1 s of the world's clock later: spread over the mission
                sim = launch.monitor.snapshot()["sim"]
                wait_until(lambda: launch.monitor.snapshot()["sim"] >= sim + 1.0, 30, "1 s of sim time")
        finally:
            s.close()
        assert launch.alive()["bridge"]
        res = finish(launch, timeout=90)
    assert res["ok"] and res["goals_reached"] == 3
    # every link's malformed counter moved; nothing was routed to the vehicles from the garbage
    status = res["bridge_status"]
    assert {"tower", "drone", "rover"} <= set(status)
    for link in ("tower", "drone", "rover"):
        assert status[link]["malformed"] > 0, (link, status)
    # the bogus 500 m target (bad CRC) never reached the drone: it flew only the mission
    from tools.run_data import load_run
    d = load_run(tmp_path)
    assert max(abs(x) for x in d.truth[1].xyz[:, :2].ravel()) < 15.0
