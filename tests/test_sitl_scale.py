"""A world larger than one MAVLink network (real `towerlink sitl`, real sockets, pymavlink).

300 vehicles: network 0 holds vehicles 0-253 (sysids 1-254), network 1 vehicles 254-299
(sysids 1-46). A sample of vehicles in every network answers HEARTBEAT and
PARAM_REQUEST_READ on its own UDP and TCP ports; each network's --out push carries only
its own vehicles; an explicit sysid clash and a port overlap are refused at start.
"""
from __future__ import annotations

import json
import os
import random
import socket
import subprocess
import sys

import numpy as np
import pytest

from support import wait_until
from test_sitl_support import mav, mavutil

N_DRONES, N_ROVERS = 150, 150
N = N_DRONES + N_ROVERS
SAMPLE = [0, 1, 149, 150, 253, 254, 255, 299]     # both ends of each network, drones and rovers


def _free_block(kind: int, bases: range, n: int, stride: int = 10) -> int:
    """A base below the ephemeral range whose n ports (stride apart) are all free now."""
    for base in random.sample(list(bases), 40):
        socks = []
        try:
            for i in range(n):
                s = socket.socket(socket.AF_INET, kind)
                socks.append(s)
                s.bind(("127.0.0.1", base + stride * i))
            return base
        except OSError:
            continue
        finally:
            for s in socks:
                s.close()
    raise RuntimeError("no free port block")


def _sitl(args: list[str], **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "tools.cli", "sitl", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True, **kw)


@pytest.fixture
def world(processes, tmp_path):
    tcp = _free_block(socket.SOCK_STREAM, range(20000, 22000), N)       # blocks 3000 wide, apart
    udp = _free_block(socket.SOCK_DGRAM, range(25000, 27000), N)
    outs = []
    for _ in range(2):     # the two networks' --out listeners, on consecutive ports
        o = _free_block(socket.SOCK_DGRAM, range(30000, 32000), 2, stride=1)
        socks = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(2)]
        try:
            for g, s in enumerate(socks):
                s.bind(("127.0.0.1", o + g))
            outs = socks
            break
        except OSError:
            for s in socks:
                s.close()
    assert outs, "no two consecutive free UDP ports"
    plan_file = tmp_path / "plan.json"
    proc = processes.start(["towerlink", "sitl", "--drones", str(N_DRONES), "--rovers", str(N_ROVERS),
                            "--rate", "50", "--speedup", "1", "--state-dir", str(tmp_path / "state"),
                            "--tcp-base", str(tcp), "--udp-base", str(udp),
                            "--out", f"udpout:127.0.0.1:{outs[0].getsockname()[1]}", "--plan-out", str(plan_file)])
    lines: list[str] = []
    import threading
    threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True).start()
    wait_until(lambda: plan_file.exists() and any(l.startswith(f"  vehicle {N - 1}:") for l in lines)
               or proc.poll() is not None, 60, "sitl start")
    assert proc.poll() is None, "".join(lines)
    try:
        yield json.loads(plan_file.read_text()), lines, outs
    finally:
        for s in outs:
            s.close()


def test_every_network_reachable(world, tmp_path):
    plan, lines, outs = world
    out = "".join(lines)
    assert "2 MAVLink network(s) of up to 254 vehicles, ports every 10:" in out
    vs = plan["vehicles"]
    tcp0, udp0 = vs[0]["tcp"], vs[0]["udp"]
    assert f"  network 0: vehicles 0-253, sysids 1-254, tcp {tcp0}-{tcp0 + 2530} step 10" in out
    assert f"  network 1: vehicles 254-299, sysids 1-46, tcp {tcp0 + 2540}-{tcp0 + 2990} step 10" in out
    assert [(v["group"], v["sysid"]) for v in vs] == [(i // 254, 1 + i % 254) for i in range(N)]
    assert json.loads((tmp_path / "state" / "network_plan.json").read_text()) == plan

    # all sampled vehicles at once, as a GCS script watching several would: heartbeat in,
    # then PARAM_REQUEST_READ SYSID_THISMAV answered with the planned sysid
    conns = {}
    for i in SAMPLE:
        v = vs[i]
        assert v["udp"] == udp0 + 10 * i and v["kind"] == ("copter" if i < N_DRONES else "rover")
        url = f"tcp:127.0.0.1:{v['tcp']}" if i in (0, 254, 299) else f"udpout:127.0.0.1:{v['udp']}"
        conns[i] = mavutil.mavlink_connection(url, source_system=255)   # a TCP client in each network
    hb: dict[int, object] = {}
    pv: dict[int, object] = {}
    try:
        def poll() -> bool:
            for i, m in conns.items():
                sysid = vs[i]["sysid"]
                m.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                if i in hb and i not in pv:
                    m.mav.param_request_read_send(sysid, 1, b"SYSID_THISMAV", -1)
                while (msg := m.recv_match(blocking=False)) is not None:
                    if msg.get_type() == "HEARTBEAT" and msg.get_srcSystem() == sysid:
                        hb[i] = msg
                    elif msg.get_type() == "PARAM_VALUE" and msg.param_id == "SYSID_THISMAV":
                        pv[i] = msg
            return len(pv) == len(SAMPLE)
        wait_until(poll, 20, "HEARTBEAT and PARAM_VALUE from every sampled vehicle", interval=0.2)
    finally:
        for m in conns.values():
            m.close()
    for i in SAMPLE:
        v = vs[i]
        assert hb[i].type == (mav.MAV_TYPE_QUADROTOR if v["kind"] == "copter" else mav.MAV_TYPE_GROUND_ROVER)
        assert pv[i].get_srcSystem() == v["sysid"] and pv[i].param_value == v["sysid"], (i, pv[i])

    # each network's push goes to its own port: 254 sysids on --out P, 46 on P+1, never mixed
    heard: list[set[int]] = [set(), set()]
    parser = [mavutil.mavlink.MAVLink(None) for _ in outs]
    for s in outs:
        s.settimeout(0.05)

    def drain() -> bool:
        for g, s in enumerate(outs):
            try:
                while True:
                    data = s.recv(65536)
                    for msg in parser[g].parse_buffer(data) or []:
                        heard[g].add(msg.get_srcSystem())
            except (socket.timeout, BlockingIOError):
                pass
        return heard[0] == set(range(1, 255)) and heard[1] == set(range(1, 47))
    wait_until(drain, 20, f"every vehicle on its network's --out (heard {len(heard[0])} + {len(heard[1])})")
    assert heard[1] <= set(range(1, 47))


def test_overlaps_refused_with_their_message(tmp_path, capsys):
    # a real process: exit status 2, the message, no traceback, nothing written
    p = _sitl(["--drones", "3", "--rovers", "0", "--sysid", "2=1", "--state-dir", str(tmp_path / "s")])
    try:
        out, _ = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == 2 and "Traceback" not in out, out
    assert "towerlink sitl: refused: sysid 1 used twice in network 0: vehicles 0 and 2" in out, out
    assert not os.path.exists(tmp_path / "s" / "network_plan.json")
    # the other refusals through the same CLI, in this process
    from tools.cli import main
    cases = [
        (["--drones", "2", "--rovers", "0", "--tcp-base", "21000", "--udp-base", "26000",
          "--endpoint", "0=udpin:127.0.0.1:21010"],
         "towerlink sitl: refused: port 21010 used twice: --endpoint 0=udpin:127.0.0.1:21010 and vehicle 1's TCP port"),
        (["--drones", "500", "--rovers", "500", "--out", "udpout:127.0.0.1:14560"],
         "towerlink sitl: refused: --out udpout:127.0.0.1:14560: port 14560-14563 (one per network) overlaps the UDP"),
        (["--drones", "9000", "--rovers", "0"],
         "towerlink sitl: refused: TCP (--tcp-base 5760) ports 5760-14759 for 9000 vehicles overlap UDP"),
        (["--drones", "9000", "--rovers", "0", "--workers", "2"],
         "towerlink sitl: refused: TCP (--tcp-base 5760) ports 5760-14759 for 9000 vehicles overlap UDP"),
        # (--workers with --lockstep is a world held together: tests/test_lockstep.py flies it)
        (["--workers", "2", "--speedup", "max"], "towerlink sitl: --workers needs a finite --speedup, or --lockstep"),
    ]
    for args, msg in cases:
        assert main(["sitl", *args, "--state-dir", str(tmp_path / "s")]) == 2
        err = capsys.readouterr().err
        assert msg in err, err
    assert not os.path.exists(tmp_path / "s" / "network_plan.json")


def test_saved_sysid_clash_refused(tmp_path):
    """A PARAM_SET SYSID_THISMAV saved before a restart is an explicit sysid too."""
    from vehicle.network_plan import PlanError
    from vehicle.world import World, WorldConfig
    (tmp_path / "drone1.parm").write_text("SYSID_THISMAV 1\n")
    with pytest.raises(PlanError, match=r"sysid 1 used twice in network 0: vehicles 0 and 1 "
                                        r"\(check its saved SYSID_THISMAV"):
        World(WorldConfig(drones=2, rovers=0, state_dir=str(tmp_path), tcp_base=None, udp_base=None))
    (tmp_path / "drone1.parm").write_text("SYSID_THISMAV 9\n")
    w = World(WorldConfig(drones=2, rovers=0, state_dir=str(tmp_path), tcp_base=None, udp_base=None))
    assert [v.sysid for v in w.vehicles] == [1, 9] and [v.sysid for v in w.plan.vehicles] == [1, 9]


def test_workers_share_one_world(processes, tmp_path):
    """--workers 2: the vehicles of one plan in two processes, every one reachable on its
    planned port, all on one sim clock (SYSTEM_TIME: the same unix instant at t = 0)."""
    tcp = _free_block(socket.SOCK_STREAM, range(20000, 23000), 6)
    udp = _free_block(socket.SOCK_DGRAM, range(26000, 29000), 6)
    plan_file = tmp_path / "plan.json"
    proc = processes.start(["towerlink", "sitl", "--drones", "3", "--rovers", "3", "--group-size", "4",
                            "--workers", "2", "--rate", "100", "--no-save", "--tcp-base", str(tcp),
                            "--udp-base", str(udp), "--plan-out", str(plan_file)])
    lines: list[str] = []
    import threading
    threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True).start()
    wait_until(lambda: any(l.startswith("  vehicle 5:") for l in lines) or proc.poll() is not None, 60,
               "sitl start")
    assert proc.poll() is None, "".join(lines)
    assert lines[0].rstrip().endswith(", 2 worker processes"), lines[0]
    vs = json.loads(plan_file.read_text())["vehicles"]
    assert [(v["group"], v["sysid"]) for v in vs] == [(0, 1), (0, 2), (0, 3), (0, 4), (1, 1), (1, 2)]
    conns = {i: mavutil.mavlink_connection(f"udpout:127.0.0.1:{vs[i]['udp']}", source_system=255)
             for i in range(6)}
    starts: dict[int, float] = {}
    hb: dict[int, int] = {}
    try:
        def poll() -> bool:
            for i, m in conns.items():
                m.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                while (msg := m.recv_match(blocking=False)) is not None:
                    if msg.get_type() == "HEARTBEAT":
                        hb[i] = msg.type
                    elif msg.get_type() == "SYSTEM_TIME":
                        starts[i] = msg.time_unix_usec - msg.time_boot_ms * 1000
            return len(starts) == 6 and len(hb) == 6
        wait_until(poll, 20, "HEARTBEAT and SYSTEM_TIME from all six vehicles", interval=0.2)
    finally:
        for m in conns.values():
            m.close()
    assert [hb[i] for i in range(6)] == [mav.MAV_TYPE_QUADROTOR] * 3 + [mav.MAV_TYPE_GROUND_ROVER] * 3
    # vehicles 0-2 run in one process, 3-5 in the other: one t = 0 (time_boot_ms is whole ms)
    assert max(starts.values()) - min(starts.values()) <= 2000, starts
    processes.stop(proc)
    out = "".join(lines)
    assert out.count("stats: ") == 2 and "Traceback" not in out, out


def test_a_share_of_the_world_flies_the_same_vehicles():
    """--workers: vehicles 2-4 built by a process running only them are vehicles 2-4 of the
    whole world (same sysid, start and sensor noise), step for step."""
    from vehicle.world import World, WorldConfig
    whole = World(WorldConfig(drones=3, rovers=3, state_dir=None, tcp_base=None, udp_base=None, rate=100))
    part = World(WorldConfig(drones=3, rovers=3, state_dir=None, tcp_base=None, udp_base=None, rate=100,
                             share=(2, 5)))
    assert [(v.index, v.kind, v.kind_index, v.sysid) for v in part.vehicles] == \
        [(v.index, v.kind, v.kind_index, v.sysid) for v in whole.vehicles[2:5]] == \
        [(2, "copter", 2, 3), (3, "rover", 0, 4), (4, "rover", 1, 5)]
    whole.run_for(3.0)
    part.run_for(3.0)
    for a, b in zip(whole.vehicles[2:5], part.vehicles):
        ea, eb = a.ap.fleet.estimate(a.ap.i), b.ap.fleet.estimate(b.ap.i)
        assert np.array_equal(ea.pos, eb.pos) and np.array_equal(ea.vel, eb.vel), (a.index, ea.pos, eb.pos)
    assert "vehicle 5: rover sysid 6" in part.banner()          # the banner is the whole world's
