"""The network plan (vehicle/network_plan.py): pure, no sockets.

Properties over N and the bases: no port is used twice, every port is in 1..65535, no two
vehicles share a sysid in one network or on one --out target, and ArduPilot's conventions
hold for small worlds. Refusals carry messages that name the clash.
"""
from __future__ import annotations

import re

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from vehicle.network_plan import MAX_GROUP, PlanError, plan


def _ports(p) -> list[int]:
    return [x for v in p.vehicles for x in (v.tcp, v.udp) if x is not None]


def _ok(p, n: int) -> None:
    assert len(p.vehicles) == n
    ports = _ports(p)
    assert len(ports) == len(set(ports)), "a port used twice"
    assert all(1 <= x <= 65535 for x in ports)
    seen = set()
    for v in p.vehicles:
        assert 1 <= v.sysid <= 254
        assert (v.group, v.sysid) not in seen, f"sysid {v.sysid} twice in network {v.group}"
        seen.add((v.group, v.sysid))
        assert v.group == v.index // p.group_size
    for g in p.groups:                      # each network is a contiguous run of <= group_size
        assert 0 < g.last - g.first + 1 <= p.group_size <= MAX_GROUP


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 9000), tcp=st.integers(0, 65535), udp=st.integers(0, 65535),
       gsize=st.one_of(st.none(), st.integers(1, 254)))
def test_any_accepted_plan_has_no_collision(n, tcp, udp, gsize):
    try:
        p = plan(n, 0, tcp_base=tcp, udp_base=udp, group_size=gsize)
    except PlanError as e:
        # refused only for a real reason, and the message says which
        assert re.search(r"overlap|pass 65535|must be", str(e)), str(e)
        return
    _ok(p, n)
    # the TCP and UDP blocks do not even interleave: their ranges are apart
    if tcp and udp:
        t, u = [v.tcp for v in p.vehicles], [v.udp for v in p.vehicles]
        assert max(t) < min(u) or max(u) < min(t)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 8800))
def test_default_bases_accept_up_to_8800(n):
    p = plan(n, 0)
    _ok(p, n)
    assert p.stride == (10 if n <= 880 else 1)
    assert (p.vehicles[0].tcp, p.vehicles[0].udp) == (5760, 14560)


def test_default_bases_refuse_8801_naming_the_overlap():
    with pytest.raises(PlanError, match=r"TCP \(--tcp-base 5760\) ports 5760-14560 for 8801 vehicles "
                                        r"overlap UDP \(--udp-base 14560\)"):
        plan(8801, 0)
    p = plan(20000, 0, udp_base=0)          # one block alone: dense up to 65535
    assert p.stride == 1 and p.vehicles[-1].tcp == 25759 and p.vehicles[-1].udp is None


def test_ardupilot_conventions_for_small_worlds():
    p = plan(1, 1)
    assert [(v.kind, v.sysid, v.tcp, v.udp, v.group) for v in p.vehicles] == [
        ("copter", 1, 5760, 14560, 0), ("rover", 2, 5770, 14570, 0)]
    assert p.vehicles[1].endpoints == ("tcpin:127.0.0.1:5770", "udpin:127.0.0.1:14570")
    # the old default collided at i = 880 (5760 + 8800 = 14560): the plan goes dense instead
    p = plan(500, 500)
    assert p.stride == 1 and p.vehicles[880].tcp == 6640 and p.vehicles[0].udp == 14560
    assert len(set(_ports(p))) == 2000


def test_networks_of_254_and_one_out_port_each():
    p = plan(500, 500, outs=["udpout:127.0.0.1:14550"])
    assert [(g.first, g.last) for g in p.groups] == [(0, 253), (254, 507), (508, 761), (762, 999)]
    assert [v.sysid for v in p.vehicles[:3]] == [1, 2, 3]
    assert p.vehicles[253].sysid == 254 and p.vehicles[254].sysid == 1 and p.vehicles[999].sysid == 238
    assert p.vehicles[254].endpoints[-1] == "udpout:127.0.0.1:14551"
    assert [g.outs for g in p.groups] == [(f"udpout:127.0.0.1:{14550 + g}",) for g in range(4)]
    d = p.as_dict()
    assert d["vehicles"][300] == {"index": 300, "kind": "copter", "name": "drone300", "group": 1,
                                  "sysid": 47, "tcp": 6060, "udp": 14860,
                                  "endpoints": ["tcpin:127.0.0.1:6060", "udpin:127.0.0.1:14860",
                                                "udpout:127.0.0.1:14551"]}
    assert d["groups"][3]["sysids"] == list(range(1, 239))


def test_sysid_base_shrinks_the_network():
    p = plan(300, 0, sysid_base=10)
    assert p.group_size == 245 and p.vehicles[244].sysid == 254 and p.vehicles[245].sysid == 10
    with pytest.raises(PlanError, match=r"--group-size 250: must be 1\.\.245"):
        plan(3, 0, sysid_base=10, group_size=250)


@settings(max_examples=100, deadline=None)
@given(n=st.integers(2, 600), gsize=st.integers(1, 254), data=st.data())
def test_explicit_sysid_twice_in_a_network_is_refused(n, gsize, data):
    a = data.draw(st.integers(0, n - 1))
    b = data.draw(st.integers(0, n - 1))
    assume(a != b)
    explicit = {a: 200, b: 200}
    sids = [explicit.get(i, 1 + i % gsize) for i in range(n)]
    clash = len({(i // gsize, s) for i, s in enumerate(sids)}) < n
    try:
        p = plan(n, 0, group_size=gsize, sysids=explicit)
    except PlanError as e:
        assert clash, str(e)
        assert re.search(r"sysid \d+ used twice in network \d+: vehicles \d+ and \d+", str(e))
        return
    assert not clash
    assert p.vehicles[a].sysid == p.vehicles[b].sysid == 200
    _ok(p, n)


def test_refusal_messages():
    cases = [
        (dict(drones=2, rovers=0, sysids={1: 1}),
         "sysid 1 used twice in network 0: vehicles 0 and 1 (check --sysid"),
        (dict(drones=2, rovers=0, group_size=1, sysids={1: 1}, outs=[], endpoints={}), None),
        (dict(drones=2, rovers=0, endpoints={0: ["udpin:127.0.0.1:5770"]}),
         "port 5770 used twice: --endpoint 0=udpin:127.0.0.1:5770 and vehicle 1's TCP port (--tcp-base 5760)"),
        (dict(drones=3000, rovers=0, outs=["udpout:127.0.0.1:14550"]),
         "--out udpout:127.0.0.1:14550: port 14550-14561 (one per network) overlaps the UDP ports"),
        (dict(drones=3, rovers=0, udp_base=65534), "UDP (--udp-base 65534) ports 65534-65536 for 3 vehicles pass 65535"),
        (dict(drones=2, rovers=0, outs=["udpin:127.0.0.1:30000"]),
         "a listening endpoint cannot be shared by 2 vehicles"),
        (dict(drones=2, rovers=0, sysids={5: 3}), "vehicle 5 does not exist: there are 2 vehicles (0..1)"),
        (dict(drones=2, rovers=0, endpoints={2: ["udpin:127.0.0.1:30000"]}), "vehicle 2 does not exist"),
        (dict(drones=1, rovers=0, sysids={0: 256}), "--sysid 0=256: a sysid is 1..255"),
        (dict(drones=1, rovers=0, tcp_base=70000), "--tcp-base 70000: must be 1..65535"),
        (dict(drones=3, rovers=0, group_size=2, tcp_base=0, udp_base=0,
              endpoints={0: ["udpout:127.0.0.1:30000"], 2: ["udpout:127.0.0.1:30000"]}),
         "sysid 1 used twice in the link to udpout:127.0.0.1:30000: vehicles 0 and 2"),
    ]
    for kw, msg in cases:
        if msg is None:
            plan(**kw)        # group size 1: the same sysid in two networks is fine
            continue
        with pytest.raises(PlanError) as e:
            plan(**kw)
        assert msg in str(e.value), (kw, str(e.value))


def test_saved_sysid_clash_is_refused():
    p = plan(3, 0)
    assert [v.sysid for v in p.with_sysids([1, 2, 7]).vehicles] == [1, 2, 7]
    with pytest.raises(PlanError, match="sysid 2 used twice in network 0: vehicles 1 and 2 "
                                        r"\(check its saved SYSID_THISMAV"):
        p.with_sysids([1, 2, 2])


def test_summary_lines():
    p = plan(3, 2, group_size=2, tcp_base=40000, udp_base=41000, outs=["udpout:127.0.0.1:42000"])
    assert p.summary() == [
        "  network 0: vehicles 0-1, sysids 1-2, tcp 40000-40010 step 10, udp 41000-41010 step 10, out udpout:127.0.0.1:42000",
        "  network 1: vehicles 2-3, sysids 1-2, tcp 40020-40030 step 10, udp 41020-41030 step 10, out udpout:127.0.0.1:42001",
        "  network 2: vehicles 4-4, sysids 1-1, tcp 40040, udp 41040, out udpout:127.0.0.1:42002"]
