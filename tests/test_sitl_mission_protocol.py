"""The mission protocol against the SITL world, with pymavlink over loopback UDP as
ArduPilot users write it: a 6-item mission built in code, a QGC WPL file uploaded with
mavwp.MAVWPLoader, both downloaded back equal; refusals on the wire (NaN, out of sequence);
a lossy link whose dropped items are re-requested; fence and rally; persistence across a
restart and `--mission I=FILE`.

The world is the towerlink_sitl fixture's (towerlink's pytest plugin) at real time, as the
wall-clock deadlines here expect; the restart test runs `towerlink sitl` processes itself."""
from __future__ import annotations

import math
import subprocess
import sys
import time

import numpy as np
import pytest

from support import free_port
from test_sitl_support import Sitl, command, connect, mav, recv  # sets MAVLINK20 before pymavlink loads

from pymavlink import mavwp  # noqa: E402  (after MAVLINK20 is set: mavutil picks its dialect on import)
from common.link_settings import LinkSettings
from tools.link_proxy import LinkProxy

REL = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
HOME = (-35.363261, 149.165230, 584.0)


def item_int(m, seq, cmd, lat=0.0, lon=0.0, alt=0.0, frame=REL, p=(0, 0, 0, 0), t=0):
    return mav.MAVLink_mission_item_int_message(m.target_system, m.target_component, seq, frame, cmd, 0, 1, *p,
                                                int(round(lat * 1e7)), int(round(lon * 1e7)), alt, t)


def six(m):
    lat, lon = HOME[:2]
    return [item_int(m, 0, 16, *HOME, frame=mav.MAV_FRAME_GLOBAL),
            item_int(m, 1, mav.MAV_CMD_NAV_TAKEOFF, alt=10),
            item_int(m, 2, 16, lat + 2e-4, lon, 10, p=(2, 0, 0, 0)),
            item_int(m, 3, mav.MAV_CMD_DO_CHANGE_SPEED, p=(1, 3, -1, 0)),
            item_int(m, 4, 16, lat + 2e-4, lon + 2e-4, 15.5, frame=mav.MAV_FRAME_GLOBAL_INT),
            item_int(m, 5, mav.MAV_CMD_NAV_RETURN_TO_LAUNCH)]


def upload(m, items, t=0, timeout=60.0, log=None):
    """MISSION_COUNT, then answer every MISSION_REQUEST(_INT) with its item, until MISSION_ACK;
    the count is sent again after 3 s of silence (a lossy link). Returns the ACK's type."""
    m.mav.mission_count_send(m.target_system, m.target_component, len(items), t)
    deadline, last = time.monotonic() + timeout, time.monotonic()
    while time.monotonic() < deadline:
        msg = m.recv_match(type=["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"], blocking=True, timeout=0.2)
        if msg is None or msg.mission_type != t:
            if time.monotonic() - last > 3.0:
                m.mav.mission_count_send(m.target_system, m.target_component, len(items), t)
                last = time.monotonic()
            continue
        last = time.monotonic()
        if msg.get_type() == "MISSION_ACK":
            return msg.type
        if log is not None:
            log.append(msg.seq)
        m.mav.send(items[msg.seq])
    raise AssertionError("upload timed out")


def download(m, t=0, timeout=30.0):
    """MISSION_REQUEST_LIST, MISSION_REQUEST_INT for each item (asked again after 0.5 s), ACK."""
    deadline = time.monotonic() + timeout
    n = None
    while n is None:
        assert time.monotonic() < deadline, "no MISSION_COUNT"
        m.mav.mission_request_list_send(m.target_system, m.target_component, t)
        c = m.recv_match(type="MISSION_COUNT", blocking=True, timeout=0.5)
        n = c.count if c is not None and c.mission_type == t else None
    got = []
    while len(got) < n:
        assert time.monotonic() < deadline, f"download stalled at {len(got)}/{n}"
        m.mav.mission_request_int_send(m.target_system, m.target_component, len(got), t)
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            it = m.recv_match(type="MISSION_ITEM_INT", blocking=True, timeout=0.1)
            if it is not None and it.seq == len(got) and it.mission_type == t:
                got.append(it)
                break
    m.mav.mission_ack_send(m.target_system, m.target_component, mav.MAV_MISSION_ACCEPTED, t)
    return got


def fields(it):
    return (it.seq, it.frame, it.command, it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z,
            it.autocontinue, it.mission_type)


# one drone at real time: the tests that take `sitl` get the plugin's world with this marker
REAL_TIME_DRONE = pytest.mark.towerlink(drones=1, rovers=0, speedup=1)


@pytest.fixture
def sitl(towerlink_sitl):
    return towerlink_sitl


@pytest.mark.timeout(90)
@REAL_TIME_DRONE
def test_six_items_built_in_code_round_trip_and_refusals(sitl):
    m = connect(sitl.udp_port(0))
    items = six(m)
    assert upload(m, items) == mav.MAV_MISSION_ACCEPTED
    recv(m, "STATUSTEXT", 5, cond=lambda s: s.text == "Flight plan received")
    got = download(m)
    assert len(got) == 6
    assert [fields(g) for g in got[1:]] == [fields(i) for i in items[1:]]
    home = got[0]
    assert (home.command, home.frame) == (16, mav.MAV_FRAME_GLOBAL)
    # item 0 is the vehicle's home: the one HOME_POSITION reports (set from its first good
    # estimate: the start, within GPS noise)
    hp = recv(m, "HOME_POSITION", 5)
    assert abs(home.x - hp.latitude) <= 1 and abs(home.y - hp.longitude) <= 1
    assert abs(home.x - round(HOME[0] * 1e7)) <= 100 and abs(home.y - round(HOME[1] * 1e7)) <= 100
    cur = recv(m, "MISSION_CURRENT", 5)
    assert (cur.total, cur.mission_state) == (5, mav.MISSION_STATE_NOT_STARTED)
    # the current item, set by command and by the legacy message, shows in MISSION_CURRENT
    assert command(m, mav.MAV_CMD_DO_SET_MISSION_CURRENT, 4) == mav.MAV_RESULT_ACCEPTED
    recv(m, "MISSION_CURRENT", 5, cond=lambda c: c.seq == 4)
    m.mav.mission_set_current_send(m.target_system, m.target_component, 2)
    recv(m, "MISSION_CURRENT", 5, cond=lambda c: c.seq == 2)
    # refusals, on the wire
    bad = items[:2] + [item_int(m, 2, 16, HOME[0], HOME[1], 10, p=(math.nan, 0, 0, 0))]
    assert upload(m, bad) == mav.MAV_MISSION_INVALID_PARAM1
    m.mav.mission_count_send(m.target_system, m.target_component, 3, 0)
    assert recv(m, "MISSION_REQUEST_INT", 5).seq == 0
    m.mav.send(items[2])
    assert recv(m, "MISSION_ACK", 5).type == mav.MAV_MISSION_INVALID_SEQUENCE
    m.mav.mission_count_send(m.target_system, m.target_component, 0, 0)     # end it (a count of 0: clear)
    assert recv(m, "MISSION_ACK", 5).type == mav.MAV_MISSION_ACCEPTED
    assert len(download(m)) == 0
    # capabilities now claimed, since they work
    assert command(m, mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1) == mav.MAV_RESULT_ACCEPTED
    caps = recv(m, "AUTOPILOT_VERSION", 5).capabilities
    assert caps & mav.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE and caps & mav.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
    # DO_SET_MISSION_CURRENT is answered by the link: a bad seq FAILED, NaN DENIED
    assert command(m, mav.MAV_CMD_DO_SET_MISSION_CURRENT, 99) == mav.MAV_RESULT_FAILED
    assert command(m, mav.MAV_CMD_DO_SET_MISSION_CURRENT, math.nan) == mav.MAV_RESULT_DENIED


WPL = """QGC WPL 110
0\t1\t0\t16\t0\t0\t0\t0\t-35.363261\t149.165230\t584.000000\t1
1\t0\t3\t22\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t20.000000\t1
2\t0\t3\t16\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t-35.36230000\t149.16540000\t20.000000\t1
3\t0\t3\t16\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t-35.36240000\t149.16610000\t30.000000\t1
4\t0\t3\t177\t2.00000000\t1.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.000000\t1
5\t0\t3\t21\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.000000\t1
"""


@pytest.mark.timeout(90)
@REAL_TIME_DRONE
def test_wpl_file_uploaded_with_mavwp_and_downloaded_back(sitl, tmp_path):
    path = tmp_path / "mission.waypoints"
    path.write_text(WPL)
    m = connect(sitl.udp_port(0))
    said = []
    m.message_hooks.append(lambda _m, msg: said.append(msg.text) if msg.get_type() == "STATUSTEXT" else None)
    # as pymavlink's examples upload a waypoint file
    wp = mavwp.MAVWPLoader(target_system=m.target_system, target_component=m.target_component)
    assert wp.load(str(path)) == 6
    m.waypoint_clear_all_send()
    assert recv(m, "MISSION_ACK", 5).type == mav.MAV_MISSION_ACCEPTED
    m.waypoint_count_send(wp.count())
    for _ in range(wp.count()):
        msg = recv(m, ["MISSION_REQUEST", "MISSION_REQUEST_INT"], 5)
        m.mav.send(wp.wp(msg.seq))
    assert recv(m, "MISSION_ACK", 5).type == mav.MAV_MISSION_ACCEPTED
    recv(m, "STATUSTEXT", 5, cond=lambda s: s.text == "Flight plan received")
    assert said.count("got MISSION_ITEM; GCS should send MISSION_ITEM_INT") == 1
    # back with MISSION_REQUEST_INT: equal to the file (MISSION_ITEM carried float32 degrees)
    got = download(m)
    assert len(got) == 6
    for g in got[1:]:
        w = wp.wp(g.seq)
        assert (g.frame, g.command, g.param1, g.param2, g.z) == (w.frame, w.command, w.param1, w.param2, w.z)
        # MISSION_ITEM carries float32 degrees (0.8 m steps at 149 deg); stored exactly what arrived
        assert (g.x, g.y) == (round(float(np.float32(w.x)) * 1e7), round(float(np.float32(w.y)) * 1e7))
        assert abs(g.x * 1e-7 - w.x) < 8e-6 and abs(g.y * 1e-7 - w.y) < 8e-6
    # and with the legacy MISSION_REQUEST pymavlink's waypoint_request_send uses
    m.waypoint_request_list_send()
    assert recv(m, "MISSION_COUNT", 5).count == 6
    m.waypoint_request_send(3)
    it = recv(m, "MISSION_ITEM", 5)
    assert (it.seq, it.command) == (3, 16) and abs(it.x - (-35.3624)) < 8e-6 and abs(it.y - 149.1661) < 8e-6


@pytest.mark.timeout(120)
@REAL_TIME_DRONE
def test_dropped_items_rerequested_over_a_lossy_link(sitl):
    port = free_port()
    lossy = LinkSettings(loss=0.2)
    proxy = LinkProxy(port, ("127.0.0.1", sitl.udp_port(0)), up=lossy, down=lossy, seed=7)
    proxy.start()
    try:
        m = connect(port, timeout=20)
        lat, lon = HOME[:2]
        items = [item_int(m, i, 16, lat + 1e-5 * i, lon, 10 + i) for i in range(12)]
        asked = []
        assert upload(m, items, log=asked) == mav.MAV_MISSION_ACCEPTED
        assert proxy.dropped["up"] > 0 and proxy.dropped["down"] > 0
        # a seq asked for again after its item went out: the vehicle re-requested it
        assert len(asked) > len(set(asked)), asked
        got = download(m)
        assert [fields(g) for g in got[1:]] == [fields(i) for i in items[1:]]
    finally:
        proxy.stop()


def fence_item(m, seq, cmd, p1, lat, lon):
    return item_int(m, seq, cmd, lat, lon, 0, frame=mav.MAV_FRAME_GLOBAL_INT, p=(p1, 0, 0, 0), t=1)


@pytest.mark.timeout(90)
@REAL_TIME_DRONE
def test_fence_and_rally_upload_download(sitl):
    m = connect(sitl.udp_port(0))
    lat, lon = HOME[:2]
    d = 5e-4
    fence = [fence_item(m, i, mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, 4, lat + a, lon + b)
             for i, (a, b) in enumerate([(-d, -d), (-d, d), (d, d), (d, -d)])]
    fence.append(fence_item(m, 4, mav.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, 12.5, lat + 2e-4, lon))
    assert upload(m, fence, t=1) == mav.MAV_MISSION_ACCEPTED
    assert [fields(g) for g in download(m, t=1)] == [fields(f) for f in fence]
    rally = [item_int(m, i, mav.MAV_CMD_NAV_RALLY_POINT, lat + 1e-4 * i, lon - 1e-4, 25 + i, t=2) for i in range(2)]
    assert upload(m, rally, t=2) == mav.MAV_MISSION_ACCEPTED
    recv(m, "STATUSTEXT", 5, cond=lambda s: s.text == "Rally points received")
    assert [fields(g) for g in download(m, t=2)] == [fields(r) for r in rally]
    # a fence whose polygon is short of a vertex is refused with ArduPilot's words
    assert upload(m, fence[:3], t=1) == mav.MAV_MISSION_ERROR
    recv(m, "STATUSTEXT", 5, cond=lambda s: s.text == "Fence validation failed")
    assert len(download(m, t=1)) == 5
    m.mav.mission_clear_all_send(m.target_system, m.target_component, 2)
    assert recv(m, "MISSION_ACK", 5, cond=lambda a: a.mission_type == 2).type == mav.MAV_MISSION_ACCEPTED
    assert download(m, t=2) == []


@pytest.mark.timeout(120)
def test_missions_survive_a_restart_and_mission_file_given_at_start(processes, tmp_path):
    state = tmp_path / "state"
    sitl = Sitl(processes, tmp_path, drones=1, rovers=1, speedup=1, state_dir=state)
    m, r = connect(sitl.udp[0]), connect(sitl.udp[1])
    items = six(m)
    assert upload(m, items) == mav.MAV_MISSION_ACCEPTED
    rally = [item_int(r, 0, mav.MAV_CMD_NAV_RALLY_POINT, HOME[0], HOME[1] + 1e-4, 15, t=2)]
    assert upload(r, rally, t=2) == mav.MAV_MISSION_ACCEPTED
    m.close(); r.close()
    assert sitl.stop() == 0
    assert (state / "drone0.missions.json").exists() and (state / "rover0.missions.json").exists()
    sitl2 = Sitl(processes, tmp_path, drones=1, rovers=1, speedup=1, state_dir=state)
    m, r = connect(sitl2.udp[0]), connect(sitl2.udp[1])
    assert [fields(g) for g in download(m)[1:]] == [fields(i) for i in items[1:]]
    assert [fields(g) for g in download(r, t=2)] == [fields(i) for i in rally]
    assert download(r) == []
    m.close(); r.close()
    sitl2.stop()
    # --mission 1=FILE replaces the rover's saved mission at start
    path = tmp_path / "m.waypoints"
    path.write_text(WPL)
    sitl3 = Sitl(processes, tmp_path, drones=1, rovers=1, speedup=1, state_dir=state,
                 extra=["--mission", f"1={path}"])
    r = connect(sitl3.udp[1])
    got = download(r)
    assert [(g.seq, g.command) for g in got] == [(0, 16), (1, 22), (2, 16), (3, 16), (4, 177), (5, 21)]
    assert (got[3].x, got[3].y, got[3].z) == (-353624000, 1491661000, 30.0)
    m = connect(sitl3.udp[0])
    assert len(download(m)) == 6                       # the drone kept its own


@pytest.mark.parametrize("content,arg,message", [
    ("QGC WPL 110\n0\t1\t0\t16\t0\n", "0={path}", "expected 12 fields"),
    (WPL.replace("\t3\t16\t0.0", "\t10\t16\t0.0", 1), "0={path}", "item 2 refused: MAV_MISSION_UNSUPPORTED_FRAME"),
    (WPL, "5={path}", "there are only 2 vehicles"),
    (None, "0={path}", "No such file"),
])
def test_bad_mission_file_is_a_clear_cli_error(tmp_path, content, arg, message):
    path = tmp_path / "bad.waypoints"
    if content is not None:
        path.write_text(content)
    r = subprocess.run([sys.executable, "-m", "tools.cli", "sitl", "--no-save", "--mission", arg.format(path=path)],
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 2
    assert message in r.stderr and "Traceback" not in r.stderr


@pytest.mark.timeout(90)
@REAL_TIME_DRONE
def test_second_gcs_denied_during_an_upload_and_answered_on_its_own_link(sitl):
    """GCS A (sysid 255, UDP) uploads; GCS B (sysid 254, TCP) starting its own upload or a
    download meanwhile is DENIED on its link (ArduPilot's MissionItemProtocol), and A's upload
    completes; afterwards B downloads what A stored."""
    a = connect(sitl.udp_port(0))
    b = connect(sitl.tcp_port(0), tcp=True, sysid=254)
    items = six(a)
    a.mav.mission_count_send(1, 1, 6, 0)
    first = recv(a, "MISSION_REQUEST_INT", 5)
    assert (first.seq, first.target_system) == (0, 255)
    b.mav.mission_count_send(1, 1, 2, 0)
    ack = recv(b, "MISSION_ACK", 5)
    assert (ack.type, ack.target_system) == (mav.MAV_MISSION_DENIED, 254)
    b.mav.mission_request_list_send(1, 1, 0)
    assert recv(b, "MISSION_ACK", 5).type == mav.MAV_MISSION_DENIED
    a.mav.send(items[0])
    while True:
        msg = recv(a, ["MISSION_REQUEST_INT", "MISSION_ACK"], 5)
        if msg.get_type() == "MISSION_ACK":
            assert msg.type == mav.MAV_MISSION_ACCEPTED
            break
        a.mav.send(items[msg.seq])
    assert [fields(g) for g in download(b)[1:]] == [fields(i) for i in items[1:]]
