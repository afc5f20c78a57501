"""One timeline for vehicles on different clocks (bridge.timeline + its wiring in the router).

Unit tests of the offset mapping and the TIMESYNC probe; the router with fake vehicles
whose clocks differ; and two real `towerlink sitl` processes started ~2 s apart (a drone
alone, a rover alone) behind one bridge: their transforms come out on one timeline.
"""
from __future__ import annotations

import time

import pytest

from common.frames import LATEST, TransformException
from bridge.timeline import Timeline, TimesyncProbe
from bridge_fakes import Endpoint, FakeVehicle, bridge_config, running_bridge, sync
from common.mavlink.dialect import towerlink as tl
from support import free_ports, wait_until


def us(seconds: float) -> int:
    return int(round(seconds * 1e6))


# ---------------------------------------------------------------------- Timeline (pure)
def test_first_vehicle_is_the_reference_and_passes_raw():
    t = Timeline()
    t.clock("drone", 5.0, wall=0.0)
    t.clock("rover", 3.0, wall=0.0)
    assert t.ref == "drone"
    assert t.to_ref("drone", 5.0) == 5.0          # the reference's clock is the timeline
    assert t.shift("rover") is None                # no SYSTEM_TIME yet: unknown, held back
    assert t.to_ref("rover", 3.0) is None
    assert t.basis("rover") == "unknown"


def test_offsets_from_system_time_map_onto_the_reference():
    t = Timeline()
    t.system_time("drone", us(1000.0 + 5.0), 5000, wall=0.0)     # booted at unix 1000
    t.system_time("rover", us(1002.0 + 3.0), 3000, wall=0.0)     # booted 2 s later
    assert t.offset("drone") == pytest.approx(1000.0)
    assert t.offset("rover") == pytest.approx(1002.0)
    assert t.shift("rover") == pytest.approx(2.0)
    assert t.to_ref("rover", 3.0) == pytest.approx(5.0)           # same instant, one timeline
    assert t.basis("rover") == "SYSTEM_TIME offset"


def test_one_world_is_unchanged_despite_ms_truncation():
    # one world: time_unix_usec = start + sim us, time_boot_ms = sim ms truncated, so the
    # offsets of its vehicles differ by less than a millisecond; stamps must not move
    t = Timeline()
    start = 1_700_000_000.123456
    t.system_time("drone", us(start + 12.3456789), int(12.3456789 * 1000), wall=0.0)
    t.system_time("rover", us(start + 12.3501), int(12.3501 * 1000), wall=0.0)
    assert t.shift("rover") == 0.0
    assert t.to_ref("rover", 12.35) == 12.35


def test_waiting_for_the_reference_offset_holds_too():
    t = Timeline()
    t.clock("drone", 1.0, wall=0.0)
    t.system_time("rover", us(1002.0 + 3.0), 3000, wall=0.0)
    assert t.shift("rover") is None                # the reference's offset is not known yet
    t.system_time("drone", us(1000.0 + 5.0), 5000, wall=0.1)
    assert t.shift("rover") == pytest.approx(2.0)


def test_grace_presumes_one_world_for_a_peer_without_system_time():
    t = Timeline(grace=1.5)
    t.clock("drone", 1.0, wall=10.0)
    t.clock("rover", 1.0, wall=10.0)
    assert t.expire(11.0) == [] and t.shift("rover") is None
    assert t.expire(11.6) == ["rover"]
    assert t.shift("rover") == 0.0 and t.basis("rover").startswith("presumed")
    assert t.expire(20.0) == []                    # once
    # offsets arriving later take over from the presumption
    t.system_time("drone", us(1000.0 + 2.0), 2000, wall=12.0)
    t.system_time("rover", us(1000.5 + 1.5), 1500, wall=12.0)
    assert t.shift("rover") == pytest.approx(0.5)


def test_restart_forgets_the_offset():
    t = Timeline()
    t.system_time("drone", us(1000.0 + 50.0), 50000, wall=0.0)
    t.system_time("rover", us(1002.0 + 48.0), 48000, wall=0.0)
    assert t.shift("rover") == pytest.approx(2.0)
    assert t.clock("rover", 0.2, wall=1.0)         # clock went back: a restart
    assert t.shift("rover") is None
    assert t.system_time("rover", us(1050.8 + 0.3), 300, wall=1.1) is None   # relearned, not "changed"
    assert t.shift("rover") == pytest.approx(50.8)
    # a reference restart drops everyone's presumption (the timeline itself moved)
    t2 = Timeline(grace=0.0)
    t2.clock("drone", 9.0, wall=0.0); t2.clock("rover", 9.0, wall=0.0)
    t2.expire(0.0)
    assert t2.shift("rover") == 0.0
    t2.clock("drone", 0.1, wall=1.0)
    assert t2.shift("rover") is None


def test_system_time_without_unix_time_gives_no_offset():
    t = Timeline()
    t.system_time("drone", 0, 5000, wall=0.0)
    assert t.offset("drone") is None


def test_timesync_probe_round_trip():
    p = TimesyncProbe(keep=4)
    ts1 = p.request(1_000_000_000)
    assert p.reply(0, ts1, 1_000_500_000) is None          # tc1 0 is a request, not an answer
    assert p.reply(77, 123, 1_000_500_000) is None          # not ours
    assert p.reply(77, ts1, 1_002_000_000) == pytest.approx(0.002)
    assert p.reply(77, ts1, 1_003_000_000) is None          # answered once
    for k in range(10):
        p.request(2_000_000_000 + k)
    assert p.reply(1, 2_000_000_000, 2_100_000_000) is None  # forgotten (keep 4)
    assert p.reply(1, 2_000_000_009, 2_000_000_009 + 1_000_000) == pytest.approx(0.001)
    assert p.rtt_min == pytest.approx(0.001) and p.count == 2


# ---------------------------------------------------------------------- router, fake vehicles
def _answer_timesync(ep, m):
    if m.get_type() == "TIMESYNC" and m.tc1 == 0:
        ep.mav.timesync_send(424242, m.ts1)


def test_router_maps_a_vehicle_on_another_clock():
    tport, dport, rport, oport = free_ports(4)
    drone = FakeVehicle(1, dport, name="drone")
    rover = FakeVehicle(2, rport, tl.MAV_TYPE_GROUND_ROVER, name="rover")
    out = Endpoint(255, 190, oport, listen=True, name="out")
    for v in (drone, rover):
        v.handlers.append(_answer_timesync)
    try:
        cfg = bridge_config(tport, dport, rport, outs=[f"udpout:127.0.0.1:{oport}"], follow=False)
        with running_bridge(cfg) as bridge:
            wait_until(lambda: drone.peer and rover.peer, 5, "bridge reaching the vehicles")
            drone.heartbeat(); rover.heartbeat()
            # the drone booted at unix 1000, the rover 2 s later: at one instant they read 5 s and 3 s
            drone.mav.system_time_send(us(1005.0), 5000)
            drone.pose(5000, (1, 0, -5))
            wait_until(lambda: bridge.timeline.ref == "drone" and bridge.buffer.can_transform("world", "drone"),
                       5, "drone on the buffer")
            rover.pose(3000, (2, 0, 0))
            wait_until(lambda: bridge.timeline.held("rover") >= 2, 5, "rover samples held back")
            assert not bridge.buffer.can_transform("world", "rover"), "an unknown timeline entered the buffer"
            rover.mav.system_time_send(us(1005.0), 3000)
            wait_until(lambda: bridge.buffer.can_transform("world", "rover"), 5, "rover released")
            T = bridge.buffer.lookup_transform("world", "rover", LATEST)
            assert T.stamp == pytest.approx(5.0) and T.transform.xyz == pytest.approx((2, 0, 0))
            assert bridge.timeline.newest("rover")[0] == pytest.approx(5.0)
            rover.pose(3050, (2.5, 0, 0))       # later samples pass mapped, not held
            st = out.wait("TOWERLINK_TRANSFORM", lambda m: m.child_frame_id == "rover" and m.time_usec == 5_050_000)
            assert list(st.translation) == pytest.approx([2.5, 0, 0])
            # TIMESYNC: the bridge probes each link, logs the round trip, keeps its answers
            wait_until(lambda: bridge.vehicles[1].probe.count and bridge.vehicles[2].probe.count, 5, "round trips")
            assert any("drone: TIMESYNC round trip" in s for s in bridge.logs)
            assert any("rover: TIMESYNC round trip" in s for s in bridge.logs)
            sync(drone, out)            # whatever the bridge sent out so far has arrived
            sync(rover, out)
            assert not out.of_type("TIMESYNC", lambda m: m.tc1 == 424242), "probe answers forwarded to a GCS"
            assert any("held back" in s for s in bridge.logs)
    finally:
        drone.close(); rover.close(); out.close()


# ---------------------------------------------------------------------- two real worlds
@pytest.mark.slow
@pytest.mark.alone          # two --speedup 1 worlds whose stream stamps are compared
def test_two_sitl_processes_one_timeline(processes):
    tport, dport, rport, oport = free_ports(4)
    common = ["--speedup", "1", "--no-save", "--udp-base", "0", "--tcp-base", "0"]
    t_start = time.monotonic()
    processes.start(["towerlink", "sitl", "--drones", "1", "--rovers", "0", *common,
                     "--endpoint", f"0=udpin:127.0.0.1:{dport}"])
    out = Endpoint(255, 190, oport, listen=True, name="out")
    cfg = bridge_config(tport, dport, rport, outs=[f"udpout:127.0.0.1:{oport}"], speedup=1.0)
    try:
        with running_bridge(cfg) as bridge:
            wait_until(lambda: bridge.timeline.offset("drone") is not None and
                       bridge.buffer.can_transform("world", "drone"), 30, "the drone's clock and frames")
            assert bridge.timeline.ref == "drone"
            # the deliberate start gap: the rover's process starts once the drone's own clock
            # has run 2 s on from where the bridge first saw it (sim time, however slowly the
            # loaded machine runs it), so the rover's boot clock is >= 2 s behind the drone's
            gap_from = bridge.timeline.clocks["drone"].newest
            wait_until(lambda: bridge.timeline.clocks["drone"].newest >= gap_from + 2.0, 30,
                       "2 s of the drone's clock")
            processes.start(["towerlink", "sitl", "--drones", "0", "--rovers", "1", "--sysid-base", "2",
                             *common, "--endpoint", f"0=udpin:127.0.0.1:{rport}"])

            def newest(child):
                ms = out.of_type("TOWERLINK_TRANSFORM", lambda m: m.child_frame_id == child)
                return ms[-1].time_usec / 1e6 if ms else None

            wait_until(lambda: bridge.buffer.can_transform("world", "rover") and newest("rover"), 30,
                       "rover transforms on the stream")
            # both streams move on together: compare the newest stamps of each after fresh samples
            out.clear()
            wait_until(lambda: newest("drone") and newest("rover"), 5, "fresh stream samples")
            d_stream, r_stream = newest("drone"), newest("rover")
            clocks = bridge.timeline.clocks
            raw_gap = clocks["drone"].newest - clocks["rover"].newest
            assert abs(d_stream - r_stream) < 0.3, (d_stream, r_stream)
            assert raw_gap > 1.5, f"time_boot_ms of the two processes differ by only {raw_gap:.2f} s"
            shift = bridge.timeline.shift("rover")
            assert shift == pytest.approx(raw_gap, abs=0.3)
            assert bridge.timeline.offset("rover") - bridge.timeline.offset("drone") == pytest.approx(shift)
            # the buffer agrees: world <- rover at the drone's latest stamp
            t_drone = bridge.buffer.lookup_transform("world", "drone", LATEST).stamp

            def rover_at_drone_time():
                try:
                    return bridge.buffer.lookup_transform("world", "rover", t_drone)
                except TransformException:
                    return None
            T = wait_until(rover_at_drone_time, 3, "world <- rover at the drone's latest stamp")
            assert T.stamp == t_drone and abs(T.transform.xyz[2]) < 0.5
            # TIMESYNC (1 Hz probes) measured both links' round trips
            wait_until(lambda: bridge.vehicles[1].probe.count and bridge.vehicles[2].probe.count, 5,
                       "TIMESYNC round trips of both links")
            assert any("rover: TIMESYNC round trip" in s for s in bridge.logs)
            print("\n".join(bridge.logs))
            print(f"raw boot clocks differ by {raw_gap:.3f} s; stream stamps drone {d_stream:.3f} "
                  f"rover {r_stream:.3f}; shift {shift:+.3f} s; {time.monotonic() - t_start:.1f} s wall")
    finally:
        out.close()
