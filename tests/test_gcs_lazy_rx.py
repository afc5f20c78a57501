"""gcs.client.lazy_rx: the client's receive path that cuts frames and decodes only what it reads.

What a client knows after a stream of packets must be what pymavlink's decode-everything path
knows: the vehicle time of every message (read from the payload, MAVLink 2 truncation aware),
positions, heartbeats, texts, subscribers, and the tlog's bytes.
"""
from __future__ import annotations

import os
import socket
import time

os.environ.setdefault("MAVLINK20", "1")

from common.mavlink.dialect import towerlink as tl  # noqa: E402
from gcs.client import Client  # noqa: E402
from gcs.client.lazy_rx import LazyReceiver  # noqa: E402


def _packets() -> list[bytes]:
    """Telemetry of sysid 1 as a vehicle sends it, one message a kind with time_boot_ms where it
    sits first, after a u64, and truncated away (time 0 ends a MAVLink 2 payload)."""
    mav = tl.MAVLink(None, 1, 1)
    msgs = [tl.MAVLink_heartbeat_message(tl.MAV_TYPE_QUADROTOR, tl.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                         tl.MAV_MODE_FLAG_SAFETY_ARMED, 4, 4, 3),
            tl.MAVLink_attitude_message(3000, 0.1, 0.2, 0.3, 0, 0, 0),
            tl.MAVLink_system_time_message(1_700_000_000_000_000, 2500),
            tl.MAVLink_local_position_ned_message(2600, 1.0, 2.0, -3.0, 0.1, 0.2, 0.3),
            tl.MAVLink_vfr_hud_message(0, 0, 0, 0, 0, 0),
            tl.MAVLink_statustext_message(tl.MAV_SEVERITY_INFO, b"PreArm: hello"),
            tl.MAVLink_nav_controller_output_message(0, 0, 0, 0, 0, 0, 0, 0)]
    return [bytes(m.pack(mav)) for m in msgs]


def test_time_boot_ms_is_read_from_the_payload_as_pymavlink_decodes_it():
    master = type("M", (), {"mav": tl.MAVLink(None), "port": None, "first_byte": False})()
    rx = LazyReceiver(master)
    decoder = tl.MAVLink(None)
    trunc = bytes(tl.MAVLink_attitude_message(0, 0, 0, 0, 0, 0, 0).pack(tl.MAVLink(None, 1, 1)))
    assert trunc[1] < 28                                   # the zeros were cut off the payload
    v1 = tl.MAVLink(None, 1, 1)
    v1.WIRE_PROTOCOL_VERSION = "1.0"
    old = bytes(tl.MAVLink_attitude_message(777, 1, 0, 0, 0, 0, 0).pack(v1, force_mavlink1=True))
    seen = 0
    for raw in [*_packets(), trunc, old]:
        (pkt,) = rx.parser.feed(raw, datagram=True)
        want = getattr(decoder.decode(bytearray(raw)), "time_boot_ms", None)
        assert rx.time_boot_ms(pkt) == want, rx.name(pkt)
        seen += want is not None
    assert seen == 5


def test_a_udpout_client_knows_what_the_pymavlink_path_knows(tmp_path):
    vehicle = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    vehicle.bind(("127.0.0.1", 0))
    vehicle.settimeout(5.0)
    url = f"udpout:127.0.0.1:{vehicle.getsockname()[1]}"
    fast = Client.connect(url, tlog=str(tmp_path / "fast.tlog"))
    slow = Client.connect(url, tlog=str(tmp_path / "slow.tlog"))
    slow._rx = None                                         # pymavlink's recv_match, as with signing
    try:
        assert fast._rx is not None
        heard = []
        fast.subscribe("VFR_HUD", heard.append)             # a subscriber's message is decoded
        addrs = set()
        while len(addrs) < 2:
            addrs.add(vehicle.recvfrom(65535)[1])           # each client's heartbeat: its address
        pkts = _packets()
        for addr in addrs:
            vehicle.sendto(b"".join(pkts[:4]), addr)        # several packets in one datagram
            vehicle.sendto(b"garbage" + pkts[4], addr)
            for p in pkts[5:]:
                vehicle.sendto(p, addr)
        for c in (fast, slow):
            end = time.monotonic() + 5
            while c.received < len(pkts) and time.monotonic() < end:
                c.poll(0.05)
        a, b = fast.system(1), slow.system(1)
        assert fast.received == slow.received == len(pkts)
        assert fast.bad_packets == slow.bad_packets == 1
        assert a.time_boot_ms == b.time_boot_ms == 3000          # ATTITUDE: undecoded on the fast path
        assert a.position == b.position and a.position.xyz == (1.0, 2.0, -3.0)
        assert (a.armed, a.custom_mode, a.mav_type) == (b.armed, b.custom_mode, b.mav_type) == \
            (True, 4, tl.MAV_TYPE_QUADROTOR)
        assert [t[2] for t in a.statustexts] == [t[2] for t in b.statustexts] == ["PreArm: hello"]
        assert [m.get_type() for m in heard] == ["VFR_HUD"]
    finally:
        fast.close()
        slow.close()
        vehicle.close()
    received = [_received(tmp_path / f"{n}.tlog") for n in ("fast", "slow")]
    assert received[0] == received[1] == _packets()


def _received(path) -> list[bytes]:
    """The packets of sysid 1 in a tlog (8-byte stamp, then the packet)."""
    data, out, i = path.read_bytes(), [], 0
    while i < len(data):
        i += 8
        n = (10 + data[i + 1] + 2) if data[i] == 0xFD else (6 + data[i + 1] + 2)
        if data[i] == 0xFD and data[i + 2] & 1:
            n += 13
        if data[i + (5 if data[i] == 0xFD else 3)] == 1:
            out.append(data[i:i + n])
        i += n
    return out
