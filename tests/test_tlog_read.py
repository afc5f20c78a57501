"""tools.run_data.read_tlog: frames cut by their length give what pymavlink's log reader gives."""
from __future__ import annotations

import struct

from common.mavlink.dialect import towerlink as tl
from tools.run_data import _read_tlog_pymavlink, read_tlog, tlog_frames


def _tlog(path, frames) -> None:
    with open(path, "wb") as f:
        for i, buf in enumerate(frames):
            f.write(struct.pack(">Q", 1_700_000_000_000_000 + i * 1000) + buf)


def _frames():
    drone = tl.MAVLink(None, srcSystem=1, srcComponent=1)
    tower = tl.MAVLink(None, srcSystem=255, srcComponent=190)
    signed = tl.MAVLink(None, srcSystem=2, srcComponent=1)
    signed.signing.secret_key = bytes(range(32))
    signed.signing.sign_outgoing = True
    signed.signing.link_id = 1
    return [tl.MAVLink_heartbeat_message(2, 3, 0, 0, 0, 3).pack(drone),
            tl.MAVLink_local_position_ned_message(1500, 1.0, -2.0, -3.0, 0.5, 0.0, 0.0).pack(drone),
            tl.MAVLink_set_position_target_local_ned_message(1600, 1, 1, 1, 0xDF8, 5.0, 6.0, -7.0, 0, 0, 0,
                                                             0, 0, 0, 0, 0).pack(tower),
            tl.MAVLink_sim_state_message(1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0).pack(signed),
            tl.MAVLink_towerlink_lockstep_message(40000, 0, 3, 0, 40000).pack(drone)]


def _same(a, b) -> bool:
    return len(a) == len(b) and all(x.get_msgbuf() == y.get_msgbuf() and x._timestamp == y._timestamp
                                    for x, y in zip(a, b))


def test_the_fast_reader_gives_what_pymavlink_gives_and_filters_before_decoding(tmp_path):
    p = tmp_path / "x.tlog"
    _tlog(p, _frames())
    fast, slow = list(read_tlog(p)), list(_read_tlog_pymavlink(p, None, None))
    assert len(fast) == 5 and _same(fast, slow)
    assert fast[1]._timestamp == 1_700_000_000.001
    assert [m.get_type() for m in read_tlog(p, ("SIM_STATE", "HEARTBEAT"))] == ["HEARTBEAT", "SIM_STATE"]
    assert [m.get_type() for m in read_tlog(p, sysids=(255,))] == ["SET_POSITION_TARGET_LOCAL_NED"]


def test_a_file_that_is_not_stamps_and_frames_goes_to_pymavlink(tmp_path):
    p = tmp_path / "x.tlog"
    _tlog(p, _frames())
    with open(p, "ab") as f:
        f.write(b"\x00" * 8 + b"garbage, then a cut frame" + _frames()[0][:5])
    assert tlog_frames(p.read_bytes()) is None
    assert _same(list(read_tlog(p)), list(_read_tlog_pymavlink(p, None, None)))
    assert len(list(read_tlog(p))) == 5


def test_load_run_decodes_only_what_it_folds_and_folds_the_same(tmp_path):
    """load_run skips decoding what load_messages takes nothing from (SYS_STATUS, VFR_HUD, ...),
    but keeps every message with a time_boot_ms: a STATUSTEXT is stamped with the sender's
    newest one (here an ATTITUDE's, a message it does not fold)."""
    import pickle

    from tools.run_data import RunData, folded_types, load_messages, load_run
    drone = tl.MAVLink(None, srcSystem=1, srcComponent=1)
    _tlog(tmp_path / "vehicles.tlog", [
        tl.MAVLink_heartbeat_message(2, 3, 0, 0, 0, 3).pack(drone),
        tl.MAVLink_attitude_message(2500, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0).pack(drone),
        tl.MAVLink_sys_status_message(0, 0, 0, 500, 12000, -1, -1, 0, 0, 0, 0, 0, 0).pack(drone),
        tl.MAVLink_vfr_hud_message(0, 0, 0, 0, 0, 0).pack(drone),
        tl.MAVLink_statustext_message(6, b"Reached waypoint #1").pack(drone)])
    assert "ATTITUDE" in folded_types() and "SYS_STATUS" not in folded_types()
    full = load_messages(read_tlog(tmp_path / "vehicles.tlog"), RunData())
    got = load_run(tmp_path)
    assert got.texts[1] == [(2.5, 6, "Reached waypoint #1")]
    assert pickle.dumps(got) == pickle.dumps(full)
