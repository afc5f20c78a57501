"""Who may move the bridge's frames over the wire (issue 8 items 6, 7): a sysid allow-list,
scenario frames protected unless --allow-redefine, MAVLink 2 signing on the tower link,
refusals answered with a reason and counted; and the tower link's UDP peers bounded."""
from __future__ import annotations

import socket

import pytest

from common.mavlink.dialect import mavlink_connection, towerlink as tl
from common.frames import LATEST, Transform, TransformStamped
from bridge_fakes import Endpoint, bridge_with_fakes
from support import free_port, wait_until

KEY = bytes(range(32))


def static_msg(parent: str, child: str, xyz=(1.0, 2.0, 0.0)):
    return tl.MAVLink_towerlink_static_transform_message(0, 0, parent.encode(), child.encode(),
                                                         list(xyz), [0.0, 0.0, 0.0, 1.0])


def answers(ep) -> list[str]:
    return [m.text for m in ep.of_type("STATUSTEXT") if m.text.startswith("static tf")]


def status_of(ep, link: str):
    return ep.wait("TOWERLINK_BRIDGE_STATUS", lambda m: m.link == link)


def test_unknown_sysid_refused_with_reason_and_counted():
    with bridge_with_fakes(rover=False) as w:
        bridge, tower = w["bridge"], w["tower"]
        stranger = Endpoint(66, 190, bridge.tower.port, listen=False, name="stranger")
        try:
            stranger.mav.send(static_msg("world", "tower", (500.0, 0.0, 0.0)))
            text = stranger.wait("STATUSTEXT", lambda m: m.text.startswith("static tf")).text
            assert text == "static tf refused: sysid 66 not trusted"
            assert tower.wait("STATUSTEXT", lambda m: "refused" in m.text).text == text
            # the tower frame did not move, and the refusal is counted on the link and on the wire
            assert bridge.buffer.lookup_transform("world", "tower", LATEST).transform.xyz != pytest.approx((500, 0, 0))
            assert bridge.tower.stats.refused == 1
            tower.clear()
            assert status_of(tower, "tower").refused == 1
        finally:
            stranger.close()


def test_trusted_sysid_accepted_and_trust_list_honoured():
    with bridge_with_fakes(rover=False, trust_sysids=(66,)) as w:
        bridge, tower = w["bridge"], w["tower"]
        tower.mav.send(static_msg("world", "pad"))          # the tower (255) is not on this list
        wait_until(lambda: answers(tower), 5, "verdict for 255")
        assert answers(tower) == ["static tf refused: sysid 255 not trusted"]
        assert not bridge.buffer.can_transform("world", "pad")
        other = Endpoint(66, 190, bridge.tower.port, listen=False, name="trusted")
        try:
            other.mav.send(static_msg("world", "pad"))
            assert other.wait("STATUSTEXT", lambda m: m.text.startswith("static tf")).text == \
                "static tf world->pad added"
            T = bridge.buffer.lookup_transform("world", "pad", LATEST)
            assert T.transform.xyz == pytest.approx((1, 2, 0))
            assert bridge.tower.stats.refused == 1
        finally:
            other.close()


def test_default_trusts_the_tower_sysid_255():
    with bridge_with_fakes(rover=False) as w:
        bridge, tower = w["bridge"], w["tower"]
        tower.mav.send(static_msg("world", "pad"))
        wait_until(lambda: answers(tower), 5, "verdict")
        assert answers(tower) == ["static tf world->pad added"]
        assert bridge.buffer.lookup_transform("world", "pad", LATEST).transform.xyz == pytest.approx((1, 2, 0))


@pytest.mark.parametrize("allow", [False, True])
def test_scenario_frame_redefined_only_with_allow_redefine(allow):
    with bridge_with_fakes(rover=False, allow_redefine=allow) as w:
        bridge, tower = w["bridge"], w["tower"]
        before = bridge.buffer.lookup_transform("world", "tower", LATEST).transform
        tower.mav.send(static_msg("world", "tower", (500.0, 0.0, 0.0)))
        wait_until(lambda: answers(tower), 5, "verdict")
        after = bridge.buffer.lookup_transform("world", "tower", LATEST).transform
        if allow:
            assert answers(tower) == ["static tf world->tower added"]
            assert after.xyz == pytest.approx((500, 0, 0))
        else:
            assert answers(tower) == ["static tf refused: 'tower' is a scenario frame"]
            assert after.almost_equal(before, 1e-12) and bridge.tower.stats.refused == 1


def test_frames_the_bridge_owns_are_never_static():
    with bridge_with_fakes(rover=False, allow_redefine=True) as w:
        w["tower"].mav.send(static_msg("world", "drone_yaw"))
        wait_until(lambda: answers(w["tower"]), 5, "verdict")
        assert answers(w["tower"]) == ["static tf refused: 'drone_yaw' is a bridge frame"]


# ---------------------------------------------------------------------- signing on the tower link
def client(port: int, key: bytes | None, sysid: int = 255):
    """A pymavlink GCS as its users write it: udpout to the bridge, signing set up with the key."""
    conn = mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=sysid, source_component=190)
    if key is not None:
        conn.setup_signing(key, sign_outgoing=True)
    return conn


def verdict(conn, ts: TransformStamped) -> str | None:
    from common.tf2_ros.wire import static_transform_message
    conn.mav.send(static_transform_message(ts))
    m = conn.recv_match(type="STATUSTEXT", blocking=True, timeout=1.0)
    return m.text if m is not None and m.text.startswith("static tf") else None


@pytest.mark.parametrize("key, want", [(None, "static tf refused: signature unsigned"),
                                       (b"\x01" * 32, "static tf refused: signature bad signature"),
                                       (KEY, "static tf world->pad added")])
def test_signing_on_the_tower_link(key, want):
    ts = TransformStamped("world", "pad", 0.0, Transform(translation=(3.0, 4.0, 0.0)))
    with bridge_with_fakes(rover=False, signing_key=KEY, tower_heartbeat=False) as w:
        bridge = w["bridge"]
        conn = client(bridge.tower.port, key)
        try:
            if key is None or key == KEY:
                got = wait_until(lambda: verdict(conn, ts), 5, "the bridge's verdict")
            else:   # a client with the wrong key cannot read the (signed) answer: the bridge's log
                wait_until(lambda: verdict(conn, ts) or bridge.tower.stats.refused, 5, "a refusal")
                got = next(line.split("refused: ")[-1] for line in bridge.logs if "refused" in line)
                got = f"static tf refused: {got}"
            assert got == want
            assert bridge.buffer.can_transform("world", "pad") == (key == KEY)
            if key != KEY:
                assert bridge.tower.stats.refused >= 1
                assert bridge.tower.stats.unsigned + bridge.tower.stats.bad_signature >= 1
        finally:
            conn.close()


def test_unsigned_sender_is_no_peer_and_gets_no_stream():
    with bridge_with_fakes(rover=False, signing_key=KEY, tower_heartbeat=False) as w:
        bridge = w["bridge"]
        unsigned, signed = client(bridge.tower.port, None), client(bridge.tower.port, KEY)
        try:
            for c in (unsigned, signed):
                c.mav.heartbeat_send(tl.MAV_TYPE_GCS, tl.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            # the signed GCS gets the bridge's (signed) static frame stream ...
            m = wait_until(lambda: signed.recv_match(type="TOWERLINK_TRANSFORM", blocking=True, timeout=0.5,
                                                     condition="TOWERLINK_TRANSFORM.child_frame_id=='tower'"),
                           10, "stream to the signed GCS")
            assert m.get_signed() and m.child_frame_id == "tower"
            assert len(bridge.tower.peers) == 1
            # ... the unsigned one gets nothing at all (it is not a peer)
            assert unsigned.recv_match(blocking=False) is None
            assert bridge.tower.stats.unsigned >= 1
            # and the drop is on the wire, in the tower link's status
            st = wait_until(lambda: signed.recv_match(type="TOWERLINK_BRIDGE_STATUS", blocking=True, timeout=0.5,
                                                      condition="TOWERLINK_BRIDGE_STATUS.link=='tower'"),
                            5, "tower link status")
            assert st.unsigned >= 1 and st.refused == 0
        finally:
            unsigned.close(); signed.close()


# ---------------------------------------------------------------------- peers: bounded, they expire
class FakeClock:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def _heartbeat(sysid: int = 255) -> bytes:
    from common.mavlink.dialect import encoder
    return tl.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(encoder(sysid, 190))


def test_udp_peers_expire_after_30_s_and_are_bounded_to_the_64_most_recent():
    from bridge.links import Link
    clock = FakeClock()
    link = Link("tower", f"udpin:127.0.0.1:{free_port()}", clock)
    socks = []
    try:
        def peer_writes(s, data):
            s.sendto(data, ("127.0.0.1", link.port))
            wait_until(lambda: link.on_readable(link.sock) or s.getsockname() in link.peers, 2, "datagram read")

        for i in range(70):
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            s.bind(("127.0.0.1", 0))
            socks.append(s)
            clock.t += 0.1
            peer_writes(s, _heartbeat())
        kept = {s.getsockname() for s in socks[-64:]}
        assert len(link.peers) == 64 and all(a in link.peers for a in kept)
        assert not any(s.getsockname() in link.peers for s in socks[:6])
        # garbage does not make a peer
        g = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        g.bind(("127.0.0.1", 0)); socks.append(g)
        g.sendto(b"\xfd" + bytes(40), ("127.0.0.1", link.port))
        wait_until(lambda: link.on_readable(link.sock) or link.malformed, 2, "garbage read")
        assert g.getsockname() not in link.peers
        # 30 s of silence: still a peer; a moment more: gone, the most recent one too
        clock.t += 30.0 - 0.1 * 1
        link.poll()
        assert socks[69].getsockname() in link.peers
        clock.t += 0.2
        link.poll()
        assert len(link.peers) == 0
        link.send(_heartbeat(250))
        socks[69].settimeout(0.2)
        with pytest.raises(socket.timeout):
            socks[69].recvfrom(100)
    finally:
        for s in socks:
            s.close()
        link.close()


# ---------------------------------------------------------------------- common.mavlink.signing, the shared check
def test_signature_check_order_and_reasons():
    from common.mavlink.dialect import encoder
    from common.mavlink.signing import SignatureCheck, setup_signing, signing_timestamp

    def packet(key, ts=None, link_id=0):
        e = encoder(255, 190)
        setup_signing(e, key, link_id)
        if ts is not None:
            e.signing.timestamp = ts
        return tl.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(e)

    check = SignatureCheck(KEY)
    good = packet(KEY)
    assert check.check(good, 255, 190) is None
    assert check.check(good, 255, 190) == "replay"                        # same timestamp again
    assert check.check(packet(b"\x02" * 32), 255, 190) == "bad_signature"
    assert check.check(_heartbeat(), 255, 190) == "unsigned"
    old = packet(KEY, ts=signing_timestamp() - 7_000_000, link_id=3)     # a new stream 70 s old
    assert check.check(old, 255, 190) == "stale"
    # a forged far-future timestamp with the wrong key does not move the receiver's clock
    before = check.clock.timestamp
    assert check.check(packet(b"\x02" * 32, ts=before + 10**9), 255, 190) == "bad_signature"
    assert check.clock.timestamp == before
