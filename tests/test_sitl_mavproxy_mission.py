"""MAVProxy and the mission protocol, typed on its stdin as a user would: `wp load FILE` uploads a
QGC WPL file, `wp list` shows it back (and saves it: the saved file equals the loaded one),
`fence list` and `rally list` show the fence and rally points a script uploaded."""
from __future__ import annotations



import pytest

from common import wpl
from support import wait_until
from test_sitl_mission_protocol import HOME, WPL, fence_item, item_int, upload
from test_sitl_support import MavProxy, Sitl, connect, mav


@pytest.mark.timeout(120)
def test_mavproxy_wp_load_list_fence_rally(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=1)
    # a script uploads a fence (square + exclusion circle) and two rally points first
    m = connect(sitl.udp[0])
    lat, lon = HOME[:2]
    d = 5e-4
    fence = [fence_item(m, i, mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, 4, lat + a, lon + b)
             for i, (a, b) in enumerate([(-d, -d), (-d, d), (d, d), (d, -d)])]
    fence.append(fence_item(m, 4, mav.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, 12.5, lat + 2e-4, lon))
    assert upload(m, fence, t=1) == mav.MAV_MISSION_ACCEPTED
    rally = [item_int(m, i, mav.MAV_CMD_NAV_RALLY_POINT, lat + 3e-4, lon - 1e-4 * (i + 1), 25 + i, t=2)
             for i in range(2)]
    assert upload(m, rally, t=2) == mav.MAV_MISSION_ACCEPTED
    m.close()

    path = tmp_path / "mission.waypoints"
    path.write_text(WPL)
    mp = MavProxy(processes, tmp_path, sitl.tcp[0])
    proxy, lines, saw, send = mp.proc, mp.lines, mp.saw, mp.send

    try:
        wait_until(lambda: saw("online system 1"), 30, "MAVProxy to see the vehicle")
        send(f"wp load {path}")
        wait_until(lambda: saw("Got MISSION_ACK: TYPE_MISSION: ACCEPTED"), 30, "upload: " + "".join(lines[-8:]))
        assert saw("Sent all 6 waypoints")
        wait_until(lambda: saw("AP: Flight plan received"), 10, "the text after the ACK")
        send("wp list")
        wait_until(lambda: saw("Saved 6 waypoints to"), 30, "wp list: " + "".join(lines[-8:]))
        assert saw("Requesting 6 waypoints")
        listed = [line.split() for line in lines if line.startswith(("16 ", "22 ", "177 ", "21 "))]
        assert [(int(f[0]), int(f[1])) for f in listed][1:] == [(22, 3), (16, 3), (16, 3), (177, 3), (21, 3)]
        saved = wpl.read(str(tmp_path / "way.txt"))
        given = wpl.read(str(path))
        assert [(s.command, s.frame, s.param1, s.param2, s.z) for s in saved[1:]] == \
            [(g.command, g.frame, g.param1, g.param2, g.z) for g in given[1:]]
        assert all(abs(s.x - g.x) < 1e-7 and abs(s.y - g.y) < 1e-7 for s, g in zip(saved[1:], given[1:]))
        send("fence list")
        wait_until(lambda: saw("Saved 5 fence items"), 30, "fence list: " + "".join(lines[-8:]))
        assert saw("Requesting 5 fence items")
        send("rally list")
        wait_until(lambda: saw("Saved 2 rally items"), 30, "rally list: " + "".join(lines[-8:]))
        assert saw("Requesting 2 rally items")
        # what MAVProxy listed (and saved, as QGC WPL) is what the script uploaded
        for name, sent in (("fence-items.txt", fence), ("rally-items.txt", rally)):
            back = wpl.read(str(tmp_path / name))
            assert [(b.command, b.frame, b.param1, b.z) for b in back] == \
                [(s.command, s.frame, s.param1, s.z) for s in sent], name
            assert all(abs(b.x - s.x * 1e-7) < 1e-7 and abs(b.y - s.y * 1e-7) < 1e-7 for b, s in zip(back, sent))
        send("exit")
    finally:
        processes.stop(proxy)
