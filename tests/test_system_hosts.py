"""Issue 11, across machines: the world on one host, the bridge and the tower on another, in lockstep.

The two hosts are Linux network namespaces joined by a veth pair (tests/netns.py). The link
gets latency on both ends where `tc` can: netem's 2 ms, or, where the kernel has no netem, a
2 Mbit/s token bucket that makes the world's bursts of telemetry queue for a varying few ms.
On host B, `towerlink fly --world-host ADDR_A --world-cmd-prefix "ip netns exec A"` runs the
world on host A, as a user runs it on another machine; at the same time the same mission,
seed and flags fly on one host (loopback). With lockstep the figures (every summary.json
number but where and how fast it ran, system_support.WALL_FIELDS) must be equal: the link
between the hosts and its latency change nothing.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from netns import NetnsUnavailable, two_hosts
from system_support import figures, tower_goals

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parent.parent
#: a short mission: the lab's house (world [-4, -2]), then 10 m east; the drone hovers after
GOALS = tower_goals([(-4.0, -2.0), (6.0, -2.0)])


@pytest.fixture
def hosts():
    try:
        with two_hosts("2ms") as pair:
            yield pair
    except NetnsUnavailable as exc:
        pytest.skip(f"cannot make test hosts as network namespaces: {exc}")


def start_fly(out: Path, *, prefix: list[str] = (), extra: list[str] = ()) -> subprocess.Popen:
    """`towerlink fly --lockstep --speedup max` of the short mission, run after `prefix`."""
    cmd = [*prefix, sys.executable, "-m", "tools.cli", "fly", "--lockstep", "--speedup", "max", "--seed", "1",
           f"--goals={GOALS}", "--finish", "none", "--out", str(out), "-q", "--timeout", "60", *extra]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    # output to a file: two flights run at once, and a pipe nobody reads could fill
    with open(out.with_suffix(".out"), "w") as log:
        return subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=ROOT,
                                start_new_session=True)


def stop(p: subprocess.Popen) -> None:
    if p.poll() is None:            # SIGTERM: fly stops everything it started, then exits
        os.killpg(p.pid, signal.SIGTERM)
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(5)


def link_packets(host) -> tuple[int, int]:
    """(rx, tx) packets on the host's end of the veth pair."""
    r = subprocess.run(["ip", "-n", host.netns, "-s", "-j", "link", "show", "dev", host.dev],
                       capture_output=True, text=True, timeout=10, check=True)
    stats = json.loads(r.stdout)[0]["stats64"]
    return stats["rx"]["packets"], stats["tx"]["packets"]


def test_world_on_another_host_flies_the_same_figures(hosts, tmp_path):
    a, b = hosts.a, hosts.b
    print(f"link latency: {hosts.latency}")           # pytest -rP shows it
    # both at once (lockstep: neither's figures depend on the other's load); separate
    # namespaces, so their free ports cannot collide
    flights = {"across": start_fly(tmp_path / "across", prefix=b.prefix(),
                                   extra=["--world-host", a.addr, "--world-cmd-prefix", " ".join(a.prefix())]),
               "one": start_fly(tmp_path / "one")}
    try:
        for name, p in flights.items():
            rc = p.wait(90)
            assert rc == 0, f"{name}: fly exit {rc}\n" + (tmp_path / f"{name}.out").read_text()[-3000:]
    finally:
        for p in flights.values():
            stop(p)

    # the world ran on A, listening on all its interfaces and pushing to B; the bridge on B
    # reached it at A's address; and the flight's traffic went over the pair
    meta = json.loads((tmp_path / "across" / "meta.json").read_text())
    sitl, bridge = meta["commands"]["sitl"], meta["commands"]["bridge"]
    assert sitl.startswith(f"ip netns exec {a.netns} ")
    assert f"--endpoint 0=udpin:0.0.0.0:{meta['ports']['drone']}" in sitl
    assert f"--out udpout:{b.addr}:{meta['ports']['vehicles']}" in sitl
    assert f"--drone udpout:{a.addr}:{meta['ports']['drone']}" in bridge
    assert f"--tower udpin:127.0.0.1:{meta['ports']['tower']}" in bridge
    rx, tx = link_packets(a)
    assert rx > 500 and tx > 500, f"world host's link carried rx {rx}, tx {tx} packets"

    s_across = json.loads((tmp_path / "across" / "summary.json").read_text())
    s_one = json.loads((tmp_path / "one" / "summary.json").read_text())
    assert s_across["ok"] and s_one["ok"] and s_across["goals_reached"] == 2
    assert s_across["limits_assumed"] == s_one["limits_assumed"] == []
    x, y = figures(s_across), figures(s_one)
    assert len(x) > 40 and "follow_error.rms" in x and "goals[1].time_to_reach" in x
    assert "limits.WPNAV_SPEED" in x        # the monitor's PARAM_REQUEST_READ reached the world and back
    diff = {k: (x.get(k), y.get(k)) for k in sorted(set(x) | set(y)) if x.get(k) != y.get(k)}
    assert diff == {}, (f"figures that differ between the world on another host (link latency: "
                        f"{hosts.latency}) and one host: {diff}")
