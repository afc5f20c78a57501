"""fly's Monitor over loopback UDP: it asks the drone, not whoever sent last, for the scoring
parameters (every vehicle pushes to its one "vehicles" socket, each from its own address)."""
from __future__ import annotations

import socket

from common.mavlink.dialect import towerlink as tl
from support import free_ports, wait_until
from tools.fly_monitor import Monitor
from tools.run_data import DRONE, ROVER
from tools.run_figures import SCORING_PARAMS


def _vehicle(sysid: int):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(0.5)
    return s, tl.MAVLink(None, srcSystem=sysid, srcComponent=1)


def _received(s) -> list:
    p, out = tl.MAVLink(None), []
    while True:
        try:
            data = s.recv(65535)
        except socket.timeout:
            return out
        out += [m for m in p.parse_buffer(data) or [] if m.get_type() == "PARAM_REQUEST_READ"]


def test_scoring_parameters_are_asked_of_the_drone_even_when_the_rover_sent_last(tmp_path):
    vport, bport = free_ports(2)
    mon = Monitor(tmp_path, {"vehicles": vport, "bridge": bport})
    mon.start()
    (drone, dmav), (rover, rmav) = _vehicle(DRONE), _vehicle(ROVER)
    try:
        for s, mav, t in ((drone, dmav, tl.MAV_TYPE_QUADROTOR), (rover, rmav, tl.MAV_TYPE_GROUND_ROVER)):
            s.sendto(tl.MAVLink_heartbeat_message(t, 3, 0, 0, 0, 3).pack(mav), ("127.0.0.1", vport))
        wait_until(lambda: ("vehicles", ROVER) in mon.addr_of and ("vehicles", DRONE) in mon.addr_of,
                   5, "both vehicles heard")
        mon.request_params()
        asked = _received(drone)
        assert sorted(m.param_id for m in asked) == sorted(SCORING_PARAMS)
        assert all(m.target_system == DRONE for m in asked) and _received(rover) == []
        # an answer is kept; the next round asks only for what is still missing
        drone.sendto(tl.MAVLink_param_value_message(b"WPNAV_SPEED", 450.0, tl.MAV_PARAM_TYPE_REAL32, 3, 0)
                     .pack(dmav), ("127.0.0.1", vport))
        wait_until(lambda: mon.params.get("WPNAV_SPEED") == 450.0, 5, "PARAM_VALUE tracked")
        mon.request_params()
        assert sorted(m.param_id for m in _received(drone)) == ["PSC_JERK_XY", "WPNAV_ACCEL"]
    finally:
        mon.stop()
        mon.join(2)
        drone.close()
        rover.close()


def test_a_lockstep_monitor_holds_the_world_until_it_has_read_everything_before_each_tick(tmp_path):
    """At --speedup max on a busy machine the monitor's thread may not run for a while; a
    monitor outside the lockstep then lost the datagrams its receive buffer could not hold
    (SIM_STATE, the truth the summary scores), so one seed gave different figures. As a
    participant it JOINs where each vehicle pushes from (the HEARTBEAT the world sends there
    while it waits at t = 0) and ACKs a TICK only once it read what came before it: the world
    waits for a stalled monitor, and the recording has every sample."""
    import math
    import threading

    from tools.run_data import load_messages, read_tlog
    from vehicle.world import World, WorldConfig

    vport, bport = free_ports(2)
    mon = Monitor(tmp_path, {"vehicles": vport, "bridge": bport}, lockstep=True)
    stalled, release = threading.Event(), threading.Event()

    def starve(m) -> None:           # the monitor's thread stops reading for a while at 1 s sim
        if not stalled.is_set() and getattr(m, "time_boot_ms", 0) >= 1000:
            stalled.set()
            release.wait(10)
    mon.listeners["vehicles"] = starve
    mon.start()
    world = World(WorldConfig(drones=1, rovers=1, state_dir=None, tcp_base=None, udp_base=None,
                              speedup=math.inf, outs=[f"udpout:127.0.0.1:{vport}"], lockstep=1,
                              lockstep_period=0.04, lockstep_timeout=10.0))
    world.start_thread()
    try:
        wait_until(stalled.is_set, 20, "the monitor at 1 s sim")
        t_stall = world.t
        wait_until(lambda: world.lockstep.waits > 0 and world.lockstep.gate.waiting_for(world.lockstep.t_usec()),
                   5, "the world waiting for the monitor")
        threading.Event().wait(0.5)     # the stall: a free-running world would be seconds further on
        assert world.t <= t_stall + 0.04 + 1e-9, "the world ran ahead of a monitor that was not reading"
        release.set()
        wait_until(lambda: mon.sim_time() >= 4.0, 20, "4 s of sim time recorded")
    finally:
        release.set()
        world.stop()
        mon.stop()
    data = load_messages(read_tlog(tmp_path / "vehicles.tlog"))
    for sysid in (DRONE, ROVER):
        t = data.truth[sysid].t
        assert t[-1] >= 3.9 and max(b - a for a, b in zip(t, t[1:])) <= 0.1 + 1e-6, \
            f"SIM_STATE of sysid {sysid} has a gap"


def test_the_monitors_lockstep_frames_are_pymavlinks_signed_or_not(tmp_path):
    """Unsigned, the monitor packs JOIN/ACK/LEAVE with the lockstep codec (its TICK chain's
    share): the very bytes pymavlink packs; signed, pymavlink signs them."""
    from common.mavlink import lockstep as wire
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(5)
    try:
        for key in (None, b"k" * 32):
            sub = tmp_path / ("signed" if key else "plain")
            sub.mkdir()
            mon = Monitor(sub, dict(zip(("vehicles", "bridge"), free_ports(2))), signing_key=key, lockstep=True)
            ref = tl.MAVLink(None, srcSystem=255, srcComponent=158)
            try:
                for kind, t in ((wire.JOIN, 0), (wire.ACK, 40_000), (wire.ACK, 2**40 + 7), (wire.LEAVE, 0)):
                    mon._lockstep_send(kind, t, rx.getsockname())
                    got = rx.recv(300)
                    m = tl.MAVLink(None).decode(bytearray(got))
                    assert (m.kind, m.time_usec, m.participant) == (kind, t, wire.OTHER)
                    if key is None:
                        assert got == bytes(tl.MAVLink_towerlink_lockstep_message(
                            t, 0, kind, wire.OTHER, 0).pack(ref))
                    else:
                        assert got[2] & 1 and len(got) == 12 + got[1] + 13     # signed
            finally:
                mon.stop()
    finally:
        rx.close()


def test_signed_acks_and_parameter_requests_from_two_threads_are_never_a_replay(tmp_path):
    """The monitor's thread sends ACKs while the launcher's asks for parameters, both through one
    signing stream: every frame must leave in the order it was signed, or the vehicle refuses
    the older one as a replay (seen as a vehicle's bad_signature count in a signed lab run)."""
    import sys
    import threading

    from common.mavlink import lockstep as wire
    from common.mavlink.signing import SignatureCheck

    key = b"s" * 32
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
    addr = rx.getsockname()
    mon = Monitor(tmp_path, dict(zip(("vehicles", "bridge"), free_ports(2))), signing_key=key, lockstep=True)
    mon.addr_of[("vehicles", DRONE)] = addr
    n = 3000
    request = tl.MAVLink_param_request_read_message(DRONE, 1, b"WPNAV_SPEED", -1)
    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)         # threads swap as often as they can: the race shows at once
    try:
        acks = threading.Thread(target=lambda: [mon._lockstep_send(wire.ACK, i, addr) for i in range(n)])
        acks.start()
        for _ in range(n):
            assert mon.send_to_vehicle(DRONE, request)
        acks.join(30)
    finally:
        sys.setswitchinterval(switch)
        mon.stop()
    check, refused, got = SignatureCheck(key), [], 0
    rx.settimeout(0.5)
    try:
        while True:
            frame = rx.recv(300)
            got += 1
            why = check.check(frame, 255, 158)
            if why is not None:
                refused.append(why)
    except socket.timeout:
        pass
    finally:
        rx.close()
    assert got == 2 * n
    assert refused == []
