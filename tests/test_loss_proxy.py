"""The seeded lossy UDP proxy used for the 20 % loss scenario drops what it says it drops."""
from __future__ import annotations

import socket

from support import free_port, wait_until
from tools.loss_proxy import LossProxy


def test_drops_about_the_asked_fraction_each_way_and_is_replayable():
    counts = []
    for _ in range(2):
        upstream = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        upstream.bind(("127.0.0.1", 0))
        client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        client.bind(("127.0.0.1", 0))
        proxy = LossProxy(free_port(), upstream.getsockname(), loss=0.2, seed=4)
        proxy.start()
        try:
            front = ("127.0.0.1", proxy.front.getsockname()[1])
            back = proxy.back.getsockname()
            upstream.settimeout(2)
            got = []
            for way, sock, dest in (("up", client, front), ("down", upstream, back)):
                # batches small enough for the kernel's socket buffers: nothing lost but by the proxy
                for batch in range(20):
                    for k in range(100 * batch, 100 * batch + 100):
                        sock.sendto(b"%s%d" % (way.encode(), k), dest)
                    wait_until(lambda: proxy.passed[way] + proxy.dropped[way] >= 100 * batch + 100, 10,
                               f"the proxy handling {way}link batch {batch}")
                    while way == "up" and len(got) < proxy.passed["up"]:
                        got.append(upstream.recv(100))
            for way in ("up", "down"):
                assert 0.17 < proxy.dropped[way] / 2000 < 0.23, (way, proxy.dropped)
            # what passed really arrived, in order
            assert got == sorted(got, key=lambda b: int(b[2:])) and len(set(got)) == len(got)
            counts.append(dict(proxy.dropped))
        finally:
            proxy.stop()
            upstream.close()
            client.close()
    assert counts[0] == counts[1]        # same seed, same packets: the same losses


def test_spared_datagrams_always_pass_and_draw_nothing_from_the_seeded_rng():
    # `towerlink fly --tower-loss` in lockstep spares TOWERLINK_LOCKSTEP (a lost ACK would hold the world)
    from common.mavlink import lockstep as L
    upstream = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    upstream.bind(("127.0.0.1", 0))
    upstream.settimeout(2)
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    proxy = LossProxy(free_port(), upstream.getsockname(), loss=0.9, seed=4, spare=L.is_lockstep)
    proxy.start()
    try:
        front = ("127.0.0.1", proxy.front.getsockname()[1])
        acks = [L.pack(L.ACK, k * 40000, participant=L.TOWER, sysid=255, compid=190) for k in range(50)]
        for ack in acks:
            client.sendto(ack, front)
        assert [upstream.recv(100) for _ in acks] == acks        # all of them, in order
        assert proxy.dropped["up"] == 0
        rng = proxy.rng.getstate()
        client.sendto(b"radio traffic", front)
        wait_until(lambda: proxy.passed["up"] + proxy.dropped["up"] == 1, 5, "the proxy handling it")
        assert proxy.rng.getstate() != rng                     # ordinary datagrams still draw
    finally:
        proxy.stop()
        upstream.close()
        client.close()
