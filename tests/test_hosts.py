"""`towerlink fly --world-host` (tools/hosts.py): who binds where, and how the world is started there.

The flight across two hosts is tests/test_system_hosts.py (slow, network namespaces); these
check the commands and addresses it rests on, without starting anything.
"""
from __future__ import annotations

import argparse
import ipaddress
import shlex

import pytest

import netns
from tools import hosts
from tools.cli import main
from tools.fly_launch import Launch
from tools.fly_plan import FlyPlan
from tools.hosts import WorldHost

NETNS = WorldHost(addr="10.9.8.1", local="10.9.8.2", prefix=("ip", "netns", "exec", "simA"))


def parse(*argv: str) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    hosts.add_arguments(p)
    return p.parse_args(list(argv))


def test_no_world_host_means_the_world_runs_here():
    assert hosts.from_args(parse()) is None


@pytest.mark.parametrize("argv", [("--world-cmd-prefix", "ssh box"), ("--local-host", "10.0.0.1")])
def test_world_options_without_world_host_are_refused(argv):
    with pytest.raises(ValueError, match="need --world-host ADDR"):
        hosts.from_args(parse(*argv))


def test_local_address_is_the_source_of_the_route_to_the_world():
    w = hosts.from_args(parse("--world-host", "127.0.0.1", "--world-cmd-prefix", "ip netns exec simA"))
    assert w == WorldHost("127.0.0.1", "127.0.0.1", ("ip", "netns", "exec", "simA"))
    assert hosts.local_address_towards("127.0.0.5") == "127.0.0.1"
    given = hosts.from_args(parse("--world-host", "127.0.0.1", "--local-host", "192.0.2.7"))
    assert given.local == "192.0.2.7" and given.attach


def test_a_broken_prefix_is_a_value_error():
    with pytest.raises(ValueError, match="--world-cmd-prefix"):
        hosts.from_args(parse("--world-host", "127.0.0.1", "--world-cmd-prefix", "ssh 'box"))


def test_exec_prefix_gets_the_argv_word_by_word():
    argv = ["/venv/bin/python", "-m", "tools.cli", "sitl", "--seed", "1"]
    assert NETNS.command(argv) == ["ip", "netns", "exec", "simA", *argv]
    assert not NETNS.via_ssh


@pytest.mark.parametrize("ssh", ["ssh", "/usr/bin/ssh"])
def test_ssh_gets_one_quoted_towerlink_command_the_remote_shell_splits_back(ssh):
    w = WorldHost("10.9.8.1", "10.9.8.2", (ssh, "-tt", "sim-box"))
    argv = ["/venv/bin/python", "-m", "tools.cli", "sitl", "--home=-35.36,149.16,584", "--wind", "3;4 5",
            "--out", "udpout:10.9.8.2:14550"]
    cmd = w.command(argv)
    assert cmd[:3] == [ssh, "-tt", "sim-box"] and len(cmd) == 4
    assert shlex.split(cmd[3]) == ["towerlink", *argv[3:]]     # what the remote shell runs


def test_world_on_another_host_listens_on_all_its_interfaces_and_pushes_here(tmp_path):
    launch = FlyPlan(tmp_path, world=NETNS, lockstep=True)
    p = launch.ports
    sitl, bridge = launch.sitl_cmd(), launch.bridge_cmd()
    words = shlex.join(sitl)
    assert f"--endpoint 0=udpin:0.0.0.0:{p['drone']}" in words
    assert f"--endpoint 1=udpin:0.0.0.0:{p['rover']}" in words
    assert f"--out udpout:10.9.8.2:{p['vehicles']}" in words          # the launcher's monitor, here
    assert launch.world_cmd() == ["ip", "netns", "exec", "simA", *sitl]
    words = shlex.join(bridge)
    assert f"--drone udpout:10.9.8.1:{p['drone']} --rover udpout:10.9.8.1:{p['rover']}" in words
    assert f"--tower udpin:127.0.0.1:{p['tower']}" in words          # the tower stays with the bridge
    assert f"--out udpout:127.0.0.1:{p['bridge']}" in words
    assert launch.tower_url() == f"udpout:127.0.0.1:{p['tower']}"


def test_a_family_world_on_another_host(tmp_path):
    launch = FlyPlan(tmp_path, scenario="family", world=NETNS)
    sitl, bridge = shlex.join(launch.sitl_cmd()), shlex.join(launch.bridge_cmd())
    for _name, sysid, _kind in launch.sc.vehicles:
        port = launch.ports[f"vehicle{sysid}"]
        assert f"{sysid - 1}=udpin:0.0.0.0:{port}" in sitl
        assert f"--vehicle {sysid}=udpout:10.9.8.1:{port}" in bridge
    assert f"--out udpout:10.9.8.2:{launch.ports['vehicles']}" in sitl


def test_attach_prints_the_world_command_and_starts_nothing(tmp_path, capsys):
    launch = Launch(tmp_path, world=WorldHost("10.9.8.1", "10.9.8.2"), lockstep=True)
    launch.start_world()
    out = capsys.readouterr().out
    assert out.startswith("towerlink fly: start the world on 10.9.8.1:\n  towerlink sitl ")
    assert shlex.split(out.splitlines()[1]) == ["towerlink", *launch.plan.sitl_cmd()[3:]]
    assert launch.procs == {}
    assert launch.plan.world_cmd()[:2] == ["towerlink", "sitl"]          # meta.json's record of it


def test_fly_refuses_a_prefix_without_a_world_host(tmp_path, capsys):
    rc = main(["fly", "--world-cmd-prefix", "ssh box", "--out", str(tmp_path / "run")])
    assert rc == 2
    assert "towerlink fly: --world-cmd-prefix and --local-host need --world-host ADDR" in capsys.readouterr().err
    assert not (tmp_path / "run" / "meta.json").exists()


def test_test_hosts_get_a_private_slash_30_each():
    pairs = {netns.subnet(i) for i in range(5000)}
    assert len(pairs) == 5000                                    # no two runs share one
    assert netns.subnet(0) == ("10.211.0.1", "10.211.0.2") and netns.subnet(16384) == netns.subnet(0)
    assert all(ipaddress.ip_address(a) in netns.SUBNETS for a, _b in pairs)


def test_test_hosts_say_why_they_cannot_be_made(monkeypatch):
    monkeypatch.setattr(netns.os, "geteuid", lambda: 1000)
    with pytest.raises(netns.NetnsUnavailable, match="need root"):
        with netns.two_hosts():
            pass
    monkeypatch.setattr(netns.os, "geteuid", lambda: 0)
    monkeypatch.setattr(netns.shutil, "which", lambda name: None)
    with pytest.raises(netns.NetnsUnavailable, match=r"no `ip` command \(iproute2\)"):
        with netns.two_hosts():
            pass
