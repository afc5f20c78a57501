"""GUIDED targets: every type_mask combination and local frame (decoder, pure), then over the
wire on a flying drone: echo, motion, velocity timeout, invalid targets, GLOBAL_INT, GCS failsafe."""
from __future__ import annotations

import math

import numpy as np
import pytest

from vehicle.autopilot.guided import TargetError, decode_local
from test_sitl_support import Sitl, command, connect, goto_local, local_pos, mav, recv, set_mode, wait_armable

POS, VEL, ACC = 0b111, 0b111 << 3, 0b111 << 6
YAW, YAW_RATE, FORCE = 1024, 2048, 512
CUR = np.array([10.0, 20.0, -5.0])
CUR_YAW = math.pi / 2


@pytest.mark.parametrize("frame", [1, 7, 8, 9])
@pytest.mark.parametrize("use", ["pos", "vel", "acc", "posvel", "posvelacc", "velacc"])
@pytest.mark.parametrize("yawbits", [YAW | YAW_RATE, YAW_RATE, YAW, 0])
def test_every_valid_mask_and_frame(frame, use, yawbits):
    mask = yawbits | (0 if "pos" in use else POS) | (0 if "vel" in use else VEL) | (0 if "acc" in use else ACC)
    t = decode_local(frame, mask, (1.0, 2.0, -3.0), (0.5, 0.0, 0.0), (0.2, 0.0, 0.0), 0.3, 0.1, CUR, CUR_YAW)
    body = frame in (8, 9)
    if "pos" in use:
        p = np.array([-2.0, 1.0, -3.0]) if body else np.array([1.0, 2.0, -3.0])
        expect = p + (CUR if frame != 1 else 0)
        assert np.allclose(t.pos, expect)
    else:
        assert t.pos is None
    if "vel" in use:
        assert np.allclose(t.vel, [0.0, 0.5, 0.0] if body else [0.5, 0.0, 0.0], atol=1e-12)
    if "acc" in use:
        assert np.allclose(t.acc, [0.0, 0.2, 0.0] if body else [0.2, 0.0, 0.0], atol=1e-12)
    assert t.kind == {"pos": "pos", "vel": "vel", "acc": "acc", "posvel": "posvel", "posvelacc": "posvel",
                      "velacc": "vel"}[use]
    if yawbits & YAW:
        assert t.yaw is None
    else:
        assert math.isclose(t.yaw, 0.3 + (CUR_YAW if body else 0.0))
    assert (t.yaw_rate is None) == bool(yawbits & YAW_RATE)
    assert t.type_mask & (POS | VEL | ACC) == mask & (POS | VEL | ACC)


@pytest.mark.parametrize("frame,mask,vals,why", [
    (1, POS | VEL | ACC, None, "invalid type_mask"),            # nothing
    (1, VEL, None, "invalid type_mask"),                        # pos + acc without vel
    (1, POS | VEL | FORCE, None, "force"),                      # force set with accel
    (1, 0b110 | VEL | ACC, None, "partial"),                    # x only
    (1, VEL | ACC, ((float("nan"), 0, 0),), "not finite"),
    (1, POS | ACC, (None, (float("inf"), 0, 0)), "not finite"),
    (1, VEL | ACC, ((20000.0, 0, 0),), "away"),
    (1, POS | ACC, (None, (500.0, 0, 0)), "too high"),
    (6, VEL | ACC, None, "frame"),
    (12, VEL | ACC, None, "frame"),
])
def test_invalid_targets_refused(frame, mask, vals, why):
    p, v = (1.0, 1.0, -1.0), (0.0, 0.0, 0.0)
    if vals:
        p = vals[0] if vals[0] is not None else p
        v = vals[1] if len(vals) > 1 else v
    with pytest.raises(TargetError, match=why):
        decode_local(frame, mask, p, v, (0, 0, 0), 0.0, 0.0, CUR, 0.0)


# ---------------------------------------------------------------- over the wire, flying

def _take_off(m, alt=4.0):
    """GUIDED, armed, at `alt` m: whatever state the vehicle is in (each test starts from here)."""
    hb = recv(m, "HEARTBEAT", 5)
    if hb.custom_mode != 4:
        assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
    if not hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED:
        wait_armable(m)
        assert command(m, 400, 1) == mav.MAV_RESULT_ACCEPTED
        assert command(m, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, alt) == mav.MAV_RESULT_ACCEPTED
    recv(m, "LOCAL_POSITION_NED", 40, cond=lambda p: p.z < -(alt - 0.2))


def _start_flying(procs, tmp):
    sitl = Sitl(procs, tmp, drones=1, rovers=0, speedup=5)
    m = connect(sitl.udp[0])
    _take_off(m)
    return sitl, m


@pytest.fixture(scope="module")
def shared_sitl(tmp_path_factory):
    """One flying drone for the tests that leave it flying in GUIDED (order does not matter:
    each test first brings it back to GUIDED at 4 m with `flying`)."""
    from support import Processes
    procs = Processes()
    try:
        yield _start_flying(procs, tmp_path_factory.mktemp("g"))
    finally:
        procs.stop_all()


@pytest.fixture
def flying(shared_sitl):
    sitl, m = shared_sitl
    _take_off(m)
    return sitl, m


@pytest.fixture
def own_flying(tmp_path):
    """A drone of its own, for a test that changes parameters and lands it."""
    from support import Processes
    procs = Processes()
    try:
        yield _start_flying(procs, tmp_path)
    finally:
        procs.stop_all()


def _echo(m, cond, timeout=5):
    return recv(m, "POSITION_TARGET_LOCAL_NED", timeout, cond=cond)


@pytest.mark.timeout(120)
def test_wire_frames_echo_and_motion(flying):
    sitl, m = flying
    # disarm in flight refused
    assert command(m, 400, 0) == mav.MAV_RESULT_FAILED
    # takeoff while flying refused
    assert command(m, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 4) == mav.MAV_RESULT_FAILED
    goto_local(m, 3.0, 0.0, -4.0)
    recv(m, "LOCAL_POSITION_NED", 40, cond=lambda p: abs(p.x - 3) < 0.5 and abs(p.y) < 0.5)
    # LOCAL_OFFSET_NED: 2 m east of here
    here = local_pos(m)
    goto_local(m, 0.0, 2.0, 0.0, frame=mav.MAV_FRAME_LOCAL_OFFSET_NED)
    e = _echo(m, lambda e: abs(e.y - (here.y + 2)) < 0.3)
    assert abs(e.x - here.x) < 0.3 and e.type_mask & 0b111 == 0
    # BODY_OFFSET_NED with yaw 0: forward = north
    goto_local(m, 2.0, 0.0, 0.0, frame=mav.MAV_FRAME_BODY_OFFSET_NED)
    here = local_pos(m)
    _echo(m, lambda e: abs(e.x - (here.x + 2)) < 0.5)
    # velocity target east, then it times out (GUID_TIMEOUT 3 s) and the copter stops
    m.mav.set_position_target_local_ned_send(0, 1, 1, mav.MAV_FRAME_LOCAL_NED, POS | ACC | YAW | YAW_RATE,
                                             0, 0, 0, 0.0, 1.5, 0.0, 0, 0, 0, 0, 0)
    e = _echo(m, lambda e: e.type_mask & POS == POS and abs(e.vy - 1.5) < 1e-3)
    recv(m, "LOCAL_POSITION_NED", 20, cond=lambda p: p.vy > 1.0)
    t0 = recv(m, "LOCAL_POSITION_NED", 5).time_boot_ms
    stopped = recv(m, "LOCAL_POSITION_NED", 40, cond=lambda p: abs(p.vy) < 0.1 and p.time_boot_ms - t0 > 3000)
    assert stopped.time_boot_ms - t0 < 9000
    _echo(m, lambda e: e.type_mask & POS == 0)        # holding a position again


@pytest.mark.timeout(120)
def test_wire_invalid_targets_hold(flying):
    sitl, m = flying
    here = local_pos(m)
    for args in ((mav.MAV_FRAME_LOCAL_NED, VEL | ACC | YAW | YAW_RATE, float("nan"), 0.0, -4.0),
                 (mav.MAV_FRAME_LOCAL_NED, VEL | ACC | YAW | YAW_RATE, 50000.0, 0.0, -4.0),
                 (mav.MAV_FRAME_LOCAL_NED, 0b110 | VEL | ACC, 5.0, 0.0, -4.0),
                 (mav.MAV_FRAME_GLOBAL_INT, VEL | ACC, 5.0, 0.0, -4.0)):
        frame, mask, x, y, z = args
        m.mav.set_position_target_local_ned_send(0, 1, 1, frame, mask, x, y, z, 0, 0, 0, 0, 0, 0, 0, 0)
        st = recv(m, "STATUSTEXT", 5, cond=lambda s: s.text.startswith("Guided:"))
        assert st.severity == mav.MAV_SEVERITY_WARNING
    e = _echo(m, lambda e: True)
    assert math.dist((e.x, e.y), (here.x, here.y)) < 1.0
    p = local_pos(m)
    assert math.dist((p.x, p.y, p.z), (here.x, here.y, here.z)) < 1.0
    # terrain frame refused for GLOBAL_INT; RELATIVE_ALT_INT accepted
    m.mav.set_position_target_global_int_send(0, 1, 1, mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, VEL | ACC | YAW | YAW_RATE,
                                              int(-35.363261e7), int(149.16523e7), 5, 0, 0, 0, 0, 0, 0, 0, 0)
    assert "terrain" in recv(m, "STATUSTEXT", 5, cond=lambda s: s.text.startswith("Guided:")).text
    g = recv(m, "GLOBAL_POSITION_INT", 5)
    m.mav.set_position_target_global_int_send(0, 1, 1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, VEL | ACC | YAW | YAW_RATE,
                                              g.lat, g.lon, 6.0, 0, 0, 0, 0, 0, 0, 0, 0)
    _echo(m, lambda e: abs(e.z - (-6.0)) < 0.3)


@pytest.mark.timeout(120)
def test_wire_gcs_failsafe_rtl_then_land(own_flying):
    sitl, m = own_flying
    for name, val in ((b"FS_GCS_ENABLE", 1), (b"FS_GCS_TIMEOUT", 2), (b"RTL_ALT", 600)):
        m.mav.param_set_send(1, 1, name, val, mav.MAV_PARAM_TYPE_INT32)
        recv(m, "PARAM_VALUE", 5, cond=lambda p, n=name: p.param_id == n.decode() and p.param_value == val)
    # stop sending heartbeats: failsafe after 2 sim s -> RTL
    st = recv(m, "STATUSTEXT", 20, cond=lambda s: "GCS Failsafe" in s.text, heartbeat_every=0)
    assert "RTL" in st.text
    recv(m, "HEARTBEAT", 5, cond=lambda h: h.custom_mode == 6, heartbeat_every=0)
    assert recv(m, "HEARTBEAT", 5, heartbeat_every=0).system_status == mav.MAV_STATE_CRITICAL
    # RTL brings it home and disarms
    recv(m, "HEARTBEAT", 90, cond=lambda h: not h.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED, heartbeat_every=0)
    p = local_pos(m)
    assert math.hypot(p.x, p.y) < 1.0 and p.z > -0.3
