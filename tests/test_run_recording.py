"""run.mcap recorded while the run flies (tools.run_recording, tools.tlog_tail): the same file,
byte for byte, as tools.run_mcap.write_run_mcap writes from the finished tlogs."""
from __future__ import annotations

import heapq
import random
import struct
from types import SimpleNamespace

import pytest

from common.mavlink.dialect import towerlink as tl
from tools.run_data import read_tlog, tlog_frames, tlog_prefix_frames
from tools.run_mcap import write_run_mcap
from tools.run_recording import LiveRecording, StableMerge
from tools.tlog_tail import NotATlog, TlogTail

BRIDGE, DRONE, TOWER = 250, 1, 255
T0 = 1_700_000_000_000_000      # us: the tlogs' wall stamps


def _transform(t_s: float, child: str, xyz, static: bool = False):
    return tl.MAVLink_towerlink_transform_message(0 if static else int(round(t_s * 1e6)), b"world", child.encode(),
                                                  list(xyz), [0.0, 0.0, 0.0, 1.0], 1 if static else 0)


def _run_tlogs(n: int = 300) -> dict[str, bytes]:
    """bridge.tlog and tower.tlog of a short flight: transforms, follow status and the drone's
    telemetry on the bridge's link, goals and heartbeats on the tower's (some stamps equal
    across the two, so the merge's ties count)."""
    bridge, drone = tl.MAVLink(None, srcSystem=BRIDGE, srcComponent=1), tl.MAVLink(None, srcSystem=DRONE, srcComponent=1)
    tower, other = tl.MAVLink(None, srcSystem=TOWER, srcComponent=190), tl.MAVLink(None, srcSystem=7, srcComponent=1)
    out = {"bridge.tlog": bytearray(), "tower.tlog": bytearray()}

    def put(name: str, us: int, frame: bytes) -> None:
        out[name] += struct.pack(">Q", T0 + us) + bytes(frame)

    put("bridge.tlog", 0, _transform(0, "tower", (10.0, -5.0, 0.0), static=True).pack(bridge))
    for k in range(n):
        t = 1.0 + 0.05 * k
        us = 1000 * k
        put("bridge.tlog", us, _transform(t, "drone", (2.0 * k * 0.05, 0.1 * k, -9.0)).pack(bridge))
        put("bridge.tlog", us + 1, tl.MAVLink_local_position_ned_message(int(t * 1000), 0.1 * k, 0.0, -9.0,
                                                                          0.0, 0.0, 0.0).pack(drone))
        put("bridge.tlog", us + 1, tl.MAVLink_towerlink_follow_status_message(
            int(t * 1e6), 0, 0, 0.3, 0.0, 0.0, 0.0, 0, 0, 0, 0, 0.0, 0.4, 9.0, 0.05, 0.3, 0.0, 1, 1).pack(bridge))
        if k % 7 == 0:
            put("tower.tlog", us + 1, tl.MAVLink_set_position_target_local_ned_message(
                int(t * 1000), DRONE, 1, 1, 3576, 12.0 + k, 34.0, -9.0, 0, 0, 0, 0, 0, 0, 0, 0).pack(tower))
            put("tower.tlog", us, tl.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(other))  # not the tower's
        if k % 5 == 0:
            put("tower.tlog", us, tl.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(tower))
    return {k: bytes(v) for k, v in out.items()}


def _record_growing(run_dir, tlogs: dict[str, bytes], seed: int) -> LiveRecording:
    """Write the tlogs in random pieces (a piece may end inside a frame, or inside a stamp),
    polling a LiveRecording after each; then finish it."""
    rng = random.Random(seed)
    rec = LiveRecording(run_dir)
    pos = dict.fromkeys(tlogs, 0)
    files = {name: open(run_dir / name, "wb") for name in tlogs}
    try:
        rec.poll()                              # before the files have anything
        while any(pos[n] < len(b) for n, b in tlogs.items()):
            for name, data in tlogs.items():
                step = rng.choice((0, 1, 3, 9, 17, 64, 700, 5000))
                files[name].write(data[pos[name]:pos[name] + step])
                files[name].flush()
                pos[name] += step
            rec.poll()
    finally:
        for f in files.values():
            f.close()
    rec.finish()
    return rec


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_recorded_while_growing_is_byte_for_byte_the_file_made_after(tmp_path, seed):
    tlogs = _run_tlogs()
    after, live = tmp_path / "after", tmp_path / "live"
    after.mkdir()
    live.mkdir()
    for name, data in tlogs.items():
        (after / name).write_bytes(data)
    write_run_mcap(after)
    rec = _record_growing(live, tlogs, seed)
    assert not rec.broken
    assert rec.records, "records were made while the tlogs grew"
    assert (live / "run.mcap").read_bytes() == (after / "run.mcap").read_bytes()


def test_a_tlog_that_is_not_whole_frames_is_recorded_from_the_finished_files(tmp_path):
    tlogs = _run_tlogs(60)
    tlogs["tower.tlog"] += b"\x00" * 8 + b"garbage that is no frame" + tlogs["tower.tlog"][:5]
    after, live = tmp_path / "after", tmp_path / "live"
    after.mkdir()
    live.mkdir()
    for name, data in tlogs.items():
        (after / name).write_bytes(data)
    write_run_mcap(after)           # pymavlink's robust reader for tower.tlog
    rec = _record_growing(live, tlogs, 1)
    assert rec.broken
    assert (live / "run.mcap").read_bytes() == (after / "run.mcap").read_bytes()


def test_a_tlog_cut_inside_a_frame_at_the_end_is_not_taken_as_whole(tmp_path):
    tlogs = _run_tlogs(20)
    tlogs["bridge.tlog"] = tlogs["bridge.tlog"][:-3]
    for name, data in tlogs.items():
        (tmp_path / name).write_bytes(data)
    rec = LiveRecording(tmp_path)
    rec.finish()
    assert rec.broken and (tmp_path / "run.mcap").exists()


def test_prefix_frames_stop_before_a_frame_still_being_written():
    data = _run_tlogs(5)["bridge.tlog"]
    whole = tlog_frames(data)
    for cut in range(len(data) + 1):
        frames, end = tlog_prefix_frames(data[:cut])
        assert frames == [f for f in whole if f[3] <= cut]
        assert end == (frames[-1][3] if frames else 0)
        assert (tlog_frames(data[:cut]) is not None) == (end == cut)   # a cut header: None, no IndexError
    assert tlog_prefix_frames(b"\x00" * 8 + b"\x55" * 12) is None


def test_the_tail_reads_what_read_tlog_reads_piece_by_piece(tmp_path):
    data = _run_tlogs(40)["tower.tlog"]
    p = tmp_path / "tower.tlog"
    tail = TlogTail(p, sysids=(TOWER,))
    assert tail.read() == []                    # no file yet
    got = []
    with open(p, "wb") as f:
        for i in range(0, len(data), 11):
            f.write(data[i:i + 11])
            f.flush()
            got += tail.read()
    assert tail.complete
    want = list(read_tlog(p, sysids=(TOWER,)))
    assert [(m.get_msgbuf(), m._timestamp) for m in got] == [(m.get_msgbuf(), m._timestamp) for m in want]
    with open(p, "ab") as f:
        f.write(b"\x00" * 8 + b"\x55" * 12)
    with pytest.raises(NotATlog):
        tail.read()
    tail.close()


def test_the_merge_in_pieces_is_heapq_merge_of_the_whole_streams():
    rng = random.Random(5)
    for _ in range(50):
        streams = [sorted(rng.choice((0.0, 0.5, 1.0, 1.5, 2.0)) + rng.random() * rng.choice((0, 1))
                          for _ in range(rng.randrange(30))) for _ in range(2)]
        items = [[SimpleNamespace(_timestamp=t, k=k, i=i) for i, t in enumerate(s)] for k, s in enumerate(streams)]
        want = list(heapq.merge(*items, key=lambda m: m._timestamp))
        merge, got, pos = StableMerge(), [], [0, 0]
        while pos[0] < len(items[0]) or pos[1] < len(items[1]):
            for k in (0, 1):
                step = rng.randrange(4)
                merge.add(k, items[k][pos[k]:pos[k] + step])
                pos[k] += step
            got += merge.take()
        got += merge.take(final=True)
        assert [(m.k, m.i) for m in got] == [(m.k, m.i) for m in want]


def test_scene_messages_make_the_records_of_every_message_decoded(tmp_path):
    """tools.run_mcap.scene_messages decodes only what SceneFeed reads: the records are those of every
    message decoded by read_tlog, also with signed frames, MAVLink 1, zero-trimmed payloads, a
    bad checksum, messages without a time and unknown ids in the tlog."""
    from common.mavlink.signing import setup_signing
    from tools.scene_feed import SceneFeed, records_of
    from tools.run_mcap import scene_messages
    data = bytearray(_run_tlogs(80)["bridge.tlog"])
    drone = tl.MAVLink(None, srcSystem=DRONE, srcComponent=1)
    signed = tl.MAVLink(None, srcSystem=DRONE, srcComponent=1)
    setup_signing(signed, b"k" * 32, 1)
    v1 = tl.MAVLink(None, srcSystem=DRONE, srcComponent=1)
    v1.WIRE_PROTOCOL_VERSION = "1.0"
    frames = [
        tl.MAVLink_local_position_ned_message(9000, 1.0, 2.0, 3.0, 0, 0, 0).pack(signed),
        tl.MAVLink_attitude_message(9100, 0.1, 0.2, 0.3, 0, 0, 0).pack(drone),
        tl.MAVLink_attitude_message(0, 0.0, 0.0, 0.0, 0, 0, 0).pack(drone),        # all zero: trimmed to 1 byte
        tl.MAVLink_sim_state_message(*([0.5] * 21)).pack(drone),                   # no time field
        tl.MAVLink_system_time_message(123456789, 9300).pack(drone),               # time_boot_ms after a u64
        tl.MAVLink_heartbeat_message(2, 3, 0, 0, 0, 3).pack(v1),
        tl.MAVLink_attitude_message(9400, 0.1, 0.2, 0.3, 0, 0, 0).pack(v1),
        _transform(9.5, "drone", (1.0, 2.0, 3.0)).pack(drone),
    ]
    bad = bytearray(tl.MAVLink_attitude_message(9999, 0.1, 0.2, 0.3, 0, 0, 0).pack(drone))
    bad[-1] ^= 0xFF                                                                 # a bad checksum
    unknown = bytearray(tl.MAVLink_attitude_message(9200, 0.1, 0.2, 0.3, 0, 0, 0).pack(drone))
    unknown[7:10] = (60000).to_bytes(3, "little")                                  # an id not in the dialect
    for k, f in enumerate([*frames[:3], bad, unknown, *frames[3:]]):
        data += struct.pack(">Q", T0 + 10_000_000 + k) + bytes(f)
    p = tmp_path / "bridge.tlog"
    p.write_bytes(bytes(data))
    full = list(records_of(read_tlog(p), SceneFeed()))
    assert [r for r in records_of(scene_messages(p), SceneFeed())] == full
    assert any(r.sim_ns == 9_400_000_000 for r in full), "the added frames made records"
    stamps = [m._timestamp for m in scene_messages(p)]
    assert stamps == sorted(stamps)
