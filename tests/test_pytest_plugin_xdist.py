"""The plugin under pytest-xdist: two workers, each starting several worlds (threads and
processes) at once with the other, find no port collision and leave no process behind.

Each of the user's tests runs a world of two vehicles at a home of its own, connects to both
vehicles and checks it hears its own world (GLOBAL_POSITION_INT near its home: a port shared
with another test's world would show that world's home or fail to bind), and notes its ports
and wall interval. Afterwards no two tests that ran at the same time held one port, both
workers ran worlds, and no process started by the run is alive.
"""
from __future__ import annotations

import itertools
import json

import pytest

from plugin_support import processes_mentioning, run_pytest

pytestmark = pytest.mark.slow       # a pytest -n 2 of its own, with worlds in both workers

USER_TESTS = '''
import json, os, re, time
import pytest
from pymavlink import mavutil

OUT = os.environ["TOWERLINK_XDIST_OUT"]


@pytest.mark.parametrize("k", range(8))
def test_world(k, request):
    home = (-35.0 + k, 149.0, 500.0)
    request.applymarker(pytest.mark.towerlink(drones=1, rovers=1, home=home, subprocess=k % 4 == 3))
    sitl = request.getfixturevalue("towerlink_sitl")
    t0 = time.time()
    ports = []
    for i in range(2):
        conn = sitl.connection(i)
        ports += [int(conn.rsplit(":", 1)[1]), int(sitl.connection(i, "udp").rsplit(":", 1)[1])]
        m = mavutil.mavlink_connection(conn, source_system=255)
        assert m.wait_heartbeat(timeout=10) is not None
        g = m.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=10)
        assert g is not None and abs(g.lat / 1e7 - home[0]) < 1e-3 and m.target_system == i + 1
        m.close()
    # the workers start seconds apart on a loaded machine: each holds its first and its second
    # world until the other worker has started as many. Of each such pair, the world started
    # first is still open when the other starts, so at least two pairs of worlds overlap
    # however slowly the machine starts them
    me = os.environ.get("PYTEST_XDIST_WORKER")
    open(os.path.join(OUT, f"started-{me}-{k}"), "w").close()
    mine = len([n for n in os.listdir(OUT) if n.startswith(f"started-{me}-")])
    end = time.time() + 60
    while (len([n for n in os.listdir(OUT) if n.startswith("started-") and not n.startswith(f"started-{me}-")])
           < min(mine, 2) and time.time() < end):
        time.sleep(0.05)  # poll
    rec = {"k": k, "worker": os.environ.get("PYTEST_XDIST_WORKER"), "ports": ports, "t0": t0, "t1": time.time()}
    with open(os.path.join(OUT, f"{k}.json"), "w") as f:
        json.dump(rec, f)
'''


def test_two_xdist_workers_with_several_worlds_each_share_no_port_and_leave_nothing(tmp_path):
    (tmp_path / "test_many.py").write_text(USER_TESTS)
    out = tmp_path / "out"
    out.mkdir()
    base = tmp_path / "base"
    r = run_pytest(["-q", "-n", "2", "--dist", "load", "--basetemp", str(base), "test_many.py"], cwd=tmp_path,
                   env={"TOWERLINK_XDIST_OUT": str(out)})
    assert r.returncode == 0 and "8 passed" in r.stdout, r.stdout[-4000:] + r.stderr[-2000:]
    recs = [json.loads(p.read_text()) for p in sorted(out.glob("[0-9]*.json"))]
    assert len(recs) == 8 and {x["worker"] for x in recs} == {"gw0", "gw1"}
    overlapping = 0
    for a, b in itertools.combinations(recs, 2):
        if a["t0"] < b["t1"] and b["t0"] < a["t1"]:
            overlapping += 1
            assert not set(a["ports"]) & set(b["ports"]), (a, b)
    assert overlapping >= 2                         # the workers did run worlds at the same time
    assert processes_mentioning(str(base)) == [] and processes_mentioning("tools.sitl_child") == []
