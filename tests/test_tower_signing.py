"""MAVLink 2 signing for the tower (issue 11 hardening): gcs.client.Client with a signing key
signs all it sends and accepts only packets signed with the key; through a signing bridge only
a client with the key is heard; the world's lockstep takes a signed client's JOIN/ACKs; `towerlink
fly --signing-key` hands the key to every process and never writes it in clear. Real sockets."""
from __future__ import annotations

import json
import math
import shlex
import socket
import sys
import threading
import time

import pytest

from bridge_fakes import Endpoint, bridge_with_fakes, sync
from gcs.client import SIGNING_LINK_ID, Client, ClientError, CommandTimeout, HeartbeatTimeout
from common.mavlink.dialect import towerlink as tl
from common.mavlink.signing import SignatureCheck, key_from_text, masked_argv, setup_signing, signing_timestamp
from support import free_port, udp_listener, wait_until

KEY = key_from_text("tower secret")
WRONG = key_from_text("not the tower secret")


def signed_encoder(sysid: int, compid: int, key: bytes, link_id: int = 0):
    enc = tl.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    setup_signing(enc, key, link_id)
    return enc


def heartbeat(enc) -> bytes:
    return tl.MAVLink_heartbeat_message(tl.MAV_TYPE_QUADROTOR, tl.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                        0, 0, tl.MAV_STATE_STANDBY, 3).pack(enc)


# ----------------------------------------------------------------------------- the client alone


@pytest.fixture
def signed_listener():
    """A Client with the key listening on udpin, and a raw UDP socket to write to it."""
    port = free_port()
    c = Client.connect(f"udpin:127.0.0.1:{port}", signing_key=KEY)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        yield c, (lambda b: s.sendto(b, ("127.0.0.1", port)))
    finally:
        s.close()
        c.close()


def heard(c: Client, what: str, cond) -> None:
    wait_until(lambda: c.poll(0.05) >= 0 and cond(), 5, what)


def test_a_signing_client_drops_unsigned_badly_signed_and_replayed_packets(signed_listener):
    c, send = signed_listener
    send(heartbeat(tl.MAVLink(None, srcSystem=1, srcComponent=1)))
    heard(c, "the unsigned heartbeat refused", lambda: c.signing_refused.get("unsigned") == 1)
    send(heartbeat(signed_encoder(1, 1, WRONG)))
    heard(c, "the wrong key refused", lambda: c.signing_refused.get("bad_signature") == 1)
    assert c.received == 0 and c.system(1).mav_type is None      # neither one taken
    good = heartbeat(signed_encoder(1, 1, KEY))
    send(good)
    heard(c, "the signed heartbeat", lambda: c.system(1).mav_type == tl.MAV_TYPE_QUADROTOR)
    send(good)                                                    # the same bytes again
    heard(c, "the replay refused", lambda: c.signing_refused.get("replay") == 1)
    assert c.received == 1 and c.refused == 3 and c.bad_packets == 3


def test_a_forged_far_future_stamp_does_not_lock_the_real_sender_out(signed_listener):
    # pymavlink's own check stores a new stream's timestamp before it verifies the signature
    c, send = signed_listener
    forger = signed_encoder(1, 1, WRONG)
    forger.signing.timestamp = signing_timestamp() + 10**9          # ~3 hours ahead
    send(heartbeat(forger))
    heard(c, "the forgery refused", lambda: c.signing_refused.get("bad_signature") == 1)
    send(heartbeat(signed_encoder(1, 1, KEY)))                     # the real vehicle, stamped now
    heard(c, "the real vehicle's heartbeat", lambda: c.system(1).mav_type == tl.MAV_TYPE_QUADROTOR)
    assert c.signing_refused == {"bad_signature": 1}


def test_everything_a_signing_client_sends_is_signed_on_its_own_link_id():
    vehicle, port = udp_listener(2.0)
    c = Client.connect(f"udpout:127.0.0.1:{port}", signing_key=KEY)
    try:
        c.send(lambda: c.mav.command_long_send(1, 1, tl.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0))
        frames = []
        parser = tl.MAVLink(None)
        while len(frames) < 2:
            data, _ = vehicle.recvfrom(65535)
            frames += [(m, bytes(m.get_msgbuf())) for m in parser.parse_buffer(data) or []]
        check = SignatureCheck(KEY)
        assert [m.get_type() for m, _ in frames] == ["HEARTBEAT", "COMMAND_LONG"]
        for m, raw in frames:           # (a parser without the key does not mark them signed)
            assert raw[0] == 0xFD and raw[2] & 1 and raw[-13] == SIGNING_LINK_ID
            assert check.check(raw, 255, 190) is None
    finally:
        c.close()
        vehicle.close()


def test_a_key_of_the_wrong_size_is_a_typed_error():
    with pytest.raises(ClientError, match="32 bytes, not 5"):
        Client.connect(f"udpout:127.0.0.1:{free_port()}", signing_key=b"short")


# ----------------------------------------------------------------------------- through a signing bridge


@pytest.mark.parametrize("shared", [False, True], ids=["Client", "SharedClient"])
def test_a_signing_tower_talks_through_a_signing_bridge(shared):
    from gcs.tower_link import SharedClient
    with bridge_with_fakes(rover=False, signing_key=KEY, tower_heartbeat=False) as w:
        bridge, drone = w["bridge"], w["drone"]
        setup_signing(drone.mav, KEY, 0)                  # a vehicle given the key
        if shared:                                        # the family tower's link, its pump reading
            c = SharedClient.connect(f"udpout:127.0.0.1:{bridge.tower.port}", signing_key=KEY).start()
        else:
            c = Client.connect(f"udpout:127.0.0.1:{bridge.tower.port}", signing_key=KEY)
        got = []
        c.add_listener(got.append)
        try:
            wait_until(lambda: bridge.tower.peers, 5, "the signed tower a peer of the bridge")
            # forwarded as the drone signed it. The drone heartbeats again and again, as a vehicle
            # does: SharedClient's pump may read one before a wait_heartbeat that wants a newer one
            def heard() -> bool:
                drone.heartbeat()
                c.poll(0.2)
                return c.system(1).mav_type is not None      # set by a vehicle's HEARTBEAT only
            wait_until(heard, 5, "the drone's signed heartbeat at the tower")
            drone.pose(4200, (1.0, 2.0, -3.0))
            p = c.wait_position(1, timeout=5)              # translated to tower, signed by the bridge
            assert p.time_boot_ms == 4200
            c.arm(1, timeout=5)                            # COMMAND_LONG out, COMMAND_ACK back
            assert drone.armed
            cmd = drone.of_type("COMMAND_LONG", lambda m: m.command == tl.MAV_CMD_COMPONENT_ARM_DISARM)[0]
            raw = bytes(cmd.get_msgbuf())                  # as the tower signed it, forwarded untouched
            assert raw[2] & 1 and raw[-13] == SIGNING_LINK_ID and SignatureCheck(KEY).check(raw, 255, 190) is None
            assert got and all(m.get_signed() for m in got)
            assert c.refused == 0 and c.bad_packets == 0
            assert bridge.tower.stats.unsigned == 0 and bridge.tower.stats.bad_signature == 0
        finally:
            c.close()


@pytest.mark.parametrize("key, counter", [(None, "unsigned"), (WRONG, "bad_signature")])
def test_a_tower_without_the_key_hears_nothing_and_reaches_no_vehicle(key, counter):
    with bridge_with_fakes(rover=False, signing_key=KEY, tower_heartbeat=False) as w:
        bridge, drone = w["bridge"], w["drone"]
        setup_signing(drone.mav, KEY, 0)
        c = Client.connect(f"udpout:127.0.0.1:{bridge.tower.port}", signing_key=key)
        marker = Endpoint(255, 191, bridge.tower.port, listen=False, name="signed tower")
        setup_signing(marker.mav, KEY, 3)
        try:
            wait_until(lambda: getattr(bridge.tower.stats, counter) >= 1, 5, f"its heartbeat counted {counter}")
            drone.heartbeat()
            drone.pose(4200, (1.0, 2.0, -3.0))
            with pytest.raises(HeartbeatTimeout):
                c.wait_heartbeat(1, timeout=1.0)
            before = getattr(bridge.tower.stats, counter)
            with pytest.raises(CommandTimeout):
                c.command_long(1, tl.MAV_CMD_COMPONENT_ARM_DISARM, [1], timeout=0.5, ack_timeout=0.2)
            sync(marker, drone)             # the bridge handled everything the client sent before
            assert getattr(bridge.tower.stats, counter) > before
            assert not drone.of_type("COMMAND_LONG", lambda m: m.command == tl.MAV_CMD_COMPONENT_ARM_DISARM)
            assert not drone.armed
            assert c.received == 0                   # the bridge never made it a peer
            assert ("127.0.0.1", c.master.port.getsockname()[1]) not in bridge.tower.peers
            assert len(bridge.tower.peers) == 1      # the signed marker alone
        finally:
            marker.close()
            c.close()


def test_with_vehicle_signing_the_bridge_drops_an_unsigned_vehicle_packet():
    with bridge_with_fakes(rover=False, signing_key=KEY, vehicle_signing=True, heartbeats=False,
                           tower_heartbeat=False) as w:
        bridge, drone = w["bridge"], w["drone"]
        c = Client.connect(f"udpout:127.0.0.1:{bridge.tower.port}", signing_key=KEY)
        try:
            wait_until(lambda: bridge.tower.peers, 5, "the signed tower a peer of the bridge")
            drone.pose(1000, (5.0, 0.0, -1.0))             # unsigned: would go out signed by the bridge
            wait_until(lambda: bridge.vehicles[1].link.stats.unsigned >= 1, 5, "the unsigned pose counted")
            setup_signing(drone.mav, KEY, 0)
            drone.heartbeat()
            c.wait_heartbeat(1, timeout=5)
            assert c.system(1).position is None           # the forged-looking pose never reached it
        finally:
            c.close()


# ----------------------------------------------------------------------------- lockstep


def _signing_world():
    """A lockstep world (one drone, --speedup max) whose endpoint on a free port takes only
    packets signed with KEY; started on a thread. Returns (world, port)."""
    from vehicle.world import World, WorldConfig
    port = free_port()
    w = World(WorldConfig(drones=1, rovers=0, state_dir=None, tcp_base=None, udp_base=None, speedup=math.inf,
                          endpoints={0: [f"udpin:127.0.0.1:{port}"]}, lockstep=1, lockstep_period=0.04,
                          lockstep_timeout=30.0, signing_key=KEY))
    w.start_thread()
    return w, port


def test_a_signing_clients_join_and_acks_are_taken_by_a_signing_world():
    w, port = _signing_world()
    c = None
    try:
        # the van's driver's way: a participant for vehicle 1 alone, on its own endpoint
        c = Client.connect(f"udpout:127.0.0.1:{port}", lockstep=True, lockstep_target=1,
                           source_component=200, signing_key=KEY)
        c.lockstep_timeout = 10.0
        ticks = []
        while len(ticks) < 6:
            c.poll()                                       # ACKs the last TICK, waits for the next
            ticks.append(c.tick_usec)
        assert ticks == [k * 40000 for k in range(6)]      # the world went on only on our ACKs
        assert set(w.lockstep.gate.participants) == {(255, 200)}
        stats = w.vehicles[0].link.stats
        assert stats["unsigned"] == 0 and stats["bad_signature"] == 0
        assert c.refused == 0 and c.system(1).mav_type is not None   # its signed telemetry taken
    finally:
        if c is not None:
            c.close()
        w.stop()


def test_an_unsigned_client_does_not_join_a_signing_world():
    w, port = _signing_world()
    c = Client.connect(f"udpout:127.0.0.1:{port}", lockstep=True, lockstep_target=1, source_component=200)
    c.lockstep_timeout = 1.0
    try:
        with pytest.raises(ClientError, match="no TICK"):
            c.poll()
        assert w.lockstep.gate.participants == {} and w.steps == 0
        assert w.vehicles[0].link.stats["unsigned"] >= 1
    finally:
        c.close()
        w.stop()


# ----------------------------------------------------------------------------- the CLIs


@pytest.mark.parametrize("cmd", ["tower", "fly", "bridge"])
def test_help_teaches_the_signing_key(cmd, capsys):
    from tools.cli import main
    with pytest.raises(SystemExit):
        main([cmd, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--signing-key PASSPHRASE|HEX64" in text and "MAVProxy's 'signing setup'" in text


def test_masked_argv_hides_the_key_in_every_spelling():
    ssh_cmd = shlex.join(["towerlink", "sitl", "--signing-key", "p q r", "--seed", "1"])
    got = masked_argv(["x", "--signing-key", "p q r", "--signing-key=abc", "ssh", ssh_cmd, "--seed", "2"])
    assert got == ["x", "--signing-key", "***", "--signing-key=***", "ssh",
                   "towerlink sitl --signing-key '***' --seed 1", "--seed", "2"]
    assert masked_argv(["a", "b"]) == ["a", "b"]


def test_fly_passes_the_key_to_every_process_and_never_writes_it(tmp_path):
    from tools.fly_plan import FlyPlan
    from tools.fly_processes import ProcessGroup
    from tools.fly_run_folder import write_meta
    secret = "correct horse battery staple"
    launch = FlyPlan(tmp_path, signing_key=secret, lockstep=True)
    for cmd in (launch.sitl_cmd(), launch.bridge_cmd(), launch.tower_cmd()):
        i = cmd.index("--signing-key")
        assert cmd[i + 1] == secret
    assert "--vehicle-signing" in launch.bridge_cmd()
    write_meta(launch)
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert meta["signed"] is True and secret not in json.dumps(meta)
    assert "--signing-key '***'" in meta["commands"]["tower"]
    procs = ProcessGroup(tmp_path)
    p = procs.start("echo", [sys.executable, "-c", "pass", "--signing-key", secret])
    p.wait(10)
    procs.close_logs()
    text = (tmp_path / "echo.log").read_text()
    assert secret not in text and "--signing-key '***'" in text
    family = FlyPlan(tmp_path / "f", scenario="family", signing_key=secret, lockstep=True)
    assert family.sitl_cmd()[family.sitl_cmd().index("--signing-key") + 1] == secret
    with pytest.raises(ValueError, match="--nodes"):
        FlyPlan(tmp_path / "n", signing_key=secret, nodes="examples/lab")


def test_bridge_vehicle_signing_needs_a_key(capsys):
    from tools.cli import main
    rc = main(["bridge", "--vehicle-signing", "--drone", "udpout:127.0.0.1:9", "--duration", "0.1"])
    assert rc == 2 and "--vehicle-signing needs --signing-key" in capsys.readouterr().err


def test_a_world_on_another_host_gets_the_key_and_no_record_shows_it(tmp_path, capsys):
    from tools.fly_launch import Launch
    from tools.fly_plan import FlyPlan
    from tools.fly_run_folder import write_meta
    from tools.hosts import WorldHost
    secret = "remote world secret"
    ssh = FlyPlan(tmp_path / "ssh", world=WorldHost("10.9.8.1", "10.9.8.2", ("ssh", "-tt", "sim-box")),
                 signing_key=secret, lockstep=True)
    remote = shlex.split(ssh.world_cmd()[-1])                        # what the remote shell runs
    assert remote[remote.index("--signing-key") + 1] == secret
    write_meta(ssh)
    assert secret not in (tmp_path / "ssh" / "meta.json").read_text()
    attach = Launch(tmp_path / "attach", world=WorldHost("10.9.8.1", "10.9.8.2"), signing_key=secret,
                    lockstep=True)
    attach.start_world()
    out = capsys.readouterr().out
    assert secret not in out and "--signing-key '***'" in out and "put your --signing-key where *** stands" in out


def test_with_vehicle_signing_a_forged_tick_does_not_cut_the_vehicles_frames():
    """Pipelined lockstep: an unsigned TICK far ahead on a signed vehicle link is refused, and is
    no frame end for the bridge's hold either: the next frame's packets are handled at its real
    TICK, not held until the forged time."""
    from common.mavlink import lockstep as L
    period = 40000
    with bridge_with_fakes(rover=False, signing_key=KEY, vehicle_signing=True, lockstep=True, heartbeats=False,
                           tower_heartbeat=False) as w:
        bridge, drone = w["bridge"], w["drone"]
        setup_signing(drone.mav, KEY, 0)
        sig = drone.mav.signing

        def tick(t: int, signed: bool = True) -> bytes:
            signing = None
            if signed:
                signing, sig.timestamp = (KEY, sig.link_id, sig.timestamp), sig.timestamp + 1
            return L.pack(L.TICK, t, period_usec=period, sysid=1, compid=1, signing=signing, lag=1)

        def acked(t: int) -> None:
            drone.wait("TOWERLINK_LOCKSTEP", lambda m: m.kind == L.ACK and m.time_usec == t, what=f"ACK({t})")

        drone.send_bytes(tick(period))
        acked(period)
        drone.send_bytes(tick(10**12, signed=False))            # forged: refused by the signature check
        wait_until(lambda: bridge.vehicles[1].link.stats.unsigned >= 1, 5, "the forged TICK refused")
        answered = threading.Event()    # set after the fake's own handler has sent the origin

        def on_message(_ep, m) -> None:
            if m.get_type() == "COMMAND_LONG" and m.command == tl.MAV_CMD_REQUEST_MESSAGE and int(m.param1) == 49:
                answered.set()
        drone.handlers.append(on_message)
        drone.heartbeat()           # signed: the bridge, once it handles it, asks for the origin
        drone.send_bytes(tick(2 * period))
        acked(2 * period)
        wait_until(answered.is_set, 5, "the origin asked for and sent")   # in the frame ending at 3t
        drone.send_bytes(tick(3 * period))
        acked(3 * period)
        wait_until(lambda: bridge.origins.known("drone"), 5, "the drone's origin handled at its frame's TICK")
