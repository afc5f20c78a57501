"""MAVProxy flies a mission as a user types it: `wp load FILE` (QGC WPL 110), `wp list`,
GUIDED, `arm throttle`, `takeoff 10`, `mode AUTO`; the vehicle's STATUSTEXT (shown as
"AP: ...") walks the mission in order and it lands and disarms at home after the RTL item."""
from __future__ import annotations

import re

import pytest

from common import geo
from support import wait_until
from test_sitl_support import MavProxy, Sitl, connect, wait_armable

HOME = (-35.363261, 149.165230, 584.0)      # towerlink's default home (ArduPilot's SITL CMAC)


def wpl(path, home) -> int:
    """A QGC WPL 110 file: home, TAKEOFF 10 m, two waypoints, RTL; returns the item count."""
    rows = [(0, 1, 0, 16, 0, home[0], home[1], home[2])]
    rows.append((1, 0, 3, 22, 0, 0.0, 0.0, 10.0))
    for seq, (n, e) in enumerate([(20.0, 0.0), (20.0, 20.0)], start=2):
        lat, lon, _ = geo.ned_to_lla(home, [n, e, 0.0])
        rows.append((seq, 0, 3, 16, 0, lat, lon, 10.0))
    rows.append((4, 0, 3, 20, 0, 0.0, 0.0, 0.0))
    with open(path, "w") as f:
        f.write("QGC WPL 110\n")
        for seq, cur, frame, cmd, p1, lat, lon, alt in rows:
            f.write(f"{seq}\t{cur}\t{frame}\t{cmd}\t{p1}\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t{alt:.6f}\t1\n")
    return len(rows)


@pytest.mark.timeout(150)
def test_mavproxy_wp_load_and_mode_auto_fly_the_mission(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=5)
    path = tmp_path / "square.txt"
    n = wpl(path, HOME)
    m = connect(sitl.udp[0])
    wait_armable(m)                  # pre-arm checks pass before MAVProxy is asked to arm
    m.close()
    mp = MavProxy(processes, tmp_path, sitl.tcp[0])
    proxy, lines, saw, send = mp.proc, mp.lines, mp.saw, mp.send

    def tail():
        return "".join(lines[-15:])

    try:
        wait_until(lambda: saw("online system 1"), 30, "MAVProxy online")
        wait_until(lambda: saw("GPS lock"), 30, "position")
        send(f"wp load {path}")
        wait_until(lambda: saw("Flight plan received"), 30, "upload: " + tail())
        send("wp list")
        wait_until(lambda: saw(f"Saved {n} waypoints"), 20, "wp list: " + tail())
        listed = [line.split()[:2] for line in lines if re.match(r"^(16|20|22) \d ", line)]
        assert listed == [["16", "0"], ["22", "3"], ["16", "3"], ["16", "3"], ["20", "3"]], listed
        send("mode GUIDED")
        wait_until(lambda: saw("Mode GUIDED") or saw("GUIDED>"), 20, "GUIDED: " + tail())
        send("arm throttle")
        wait_until(lambda: any(re.search(r"(?<!DIS)ARMED", line) for line in lines), 30, "ARMED: " + tail())
        send("takeoff 10")
        wait_until(lambda: saw("Takeoff to 10.0 m"), 20, "takeoff: " + tail())
        send("mode AUTO")
        wait_until(lambda: saw("Mission: 4 RTL"), 90, "mission: " + tail())
        wait_until(lambda: saw("DISARMED"), 90, "landed: " + tail())
        texts = [line.split("AP: ", 1)[1].strip() for line in lines if "AP: " in line]
        walk = [t for t in texts if t.startswith(("Mission:", "Reached command"))]
        assert walk == ["Mission: 1 Takeoff", "Mission: 2 WP", "Reached command #2", "Mission: 3 WP",
                        "Reached command #3", "Mission: 4 RTL"], texts
        send("exit")
    finally:
        processes.stop(proxy)

