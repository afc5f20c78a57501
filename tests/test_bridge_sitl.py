"""The bridge with the real SITL world: arm and fly the drone to a tower-frame goal through
the bridge, see the rover head for the ground point under the drone, kill and restart the
bridge mid-flight (the drone holds; routing resumes)."""
from __future__ import annotations

import math
import time

import pytest

from common.mavlink.dialect import mavlink_connection
from common.mavlink.dialect import towerlink as tl
from common.scenario import load_scenario
from support import free_ports, wait_until

pytestmark = [pytest.mark.slow, pytest.mark.alone]     # at --speedup 5 on the wall clock

SPEEDUP = 5.0


class Tower:
    """A minimal pymavlink GCS on the bridge's tower port (tower frame)."""

    def __init__(self, port: int) -> None:
        self.conn = mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255, source_component=190)
        self.last: dict = {}
        self.texts: list[str] = []

    def pump(self, dt: float = 0.05) -> None:
        end = time.monotonic() + dt
        self.conn.mav.heartbeat_send(tl.MAV_TYPE_GCS, tl.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        while time.monotonic() < end:
            m = self.conn.recv_match(blocking=True, timeout=0.02)
            if m is None:
                continue
            key = (m.get_type(), m.get_srcSystem())
            self.last[key] = m
            if m.get_type() == "STATUSTEXT":
                self.texts.append(m.text)

    def get(self, t: str, sysid: int):
        return self.last.get((t, sysid))

    def wait(self, cond, timeout, what):
        def poll():
            self.pump()
            return cond()
        return wait_until(poll, timeout, what, interval=0)

    def command(self, sysid, cmd, *p):
        p = list(p) + [0] * (7 - len(p))
        self.conn.mav.command_long_send(sysid, 1, cmd, 0, *p)


def test_fly_tower_goal_and_rover_follows(processes):
    tport, dport, rport, dtcp, rtcp = free_ports(5)
    sitl = processes.start(["towerlink", "sitl", "--speedup", str(SPEEDUP), "--no-save",
                            "--udp-base", "0", "--tcp-base", "0",
                            "--endpoint", f"0=udpin:127.0.0.1:{dport}",
                            "--endpoint", f"1=udpin:127.0.0.1:{rport}"])
    bridge_cmd = ["towerlink", "bridge", "--tower", f"udpin:127.0.0.1:{tport}",
                  "--drone", f"udpout:127.0.0.1:{dport}", "--rover", f"udpout:127.0.0.1:{rport}",
                  "--speedup", str(SPEEDUP), "--follow-frame", "drone_yaw"]
    bridge = processes.start(bridge_cmd)
    tower = Tower(tport)
    try:
        tower.wait(lambda: tower.get("HEARTBEAT", 1) and tower.get("HEARTBEAT", 2), 30, "both vehicles")
        assert tower.get("HEARTBEAT", 1).type == tl.MAV_TYPE_QUADROTOR
        # position telemetry arrives in the tower frame: the drone at world home (0,0) is
        # at the tower-frame image of the world origin
        sc = load_scenario()
        T_TW = sc.buffer().lookup_transform("tower", "world").transform
        lp = tower.wait(lambda: tower.get("LOCAL_POSITION_NED", 1), 20, "local position")
        home_t = T_TW.apply_point((0, 0, 0))
        assert math.hypot(lp.x - home_t[0], lp.y - home_t[1]) < 1.0
        # GUIDED, arm, take off to 9 m through the bridge
        tower.wait(lambda: (tower.command(1, tl.MAV_CMD_DO_SET_MODE, 1, 4) or True) and
                   tower.get("HEARTBEAT", 1).custom_mode == 4, 20, "GUIDED")
        tower.wait(lambda: (tower.command(1, tl.MAV_CMD_COMPONENT_ARM_DISARM, 1) or True) and
                   tower.get("HEARTBEAT", 1).base_mode & tl.MAV_MODE_FLAG_SAFETY_ARMED, 30, "armed")
        tower.command(1, tl.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 9.0)
        tower.wait(lambda: tower.get("LOCAL_POSITION_NED", 1).z < -8.0, 60, "take off to 9 m")
        # the rover was put in GUIDED and armed by the follow loop
        tower.wait(lambda: tower.get("HEARTBEAT", 2).custom_mode == 15 and
                   tower.get("HEARTBEAT", 2).base_mode & tl.MAV_MODE_FLAG_SAFETY_ARMED, 30, "rover GUIDED")
        # goal in the tower frame: the lab's house, world [-4, -2] -> tower (-131.039, 73.524)
        gx, gy = -131.039, 73.524
        mask = 0b0000_1111_1111_1000
        def goal_sent_and_reached():
            tower.conn.mav.set_position_target_local_ned_send(0, 1, 1, tl.MAV_FRAME_LOCAL_NED, mask,
                                                              gx, gy, -9.0, 0, 0, 0, 0, 0, 0, 0, 0)
            lp = tower.get("LOCAL_POSITION_NED", 1)
            return math.hypot(lp.x - gx, lp.y - gy) < 1.0
        tower.wait(goal_sent_and_reached, 90, "drone at the tower-frame goal")
        # the rover heads for the ground point under the drone (reported in the tower frame)
        def rover_near():
            d, r = tower.get("LOCAL_POSITION_NED", 1), tower.get("LOCAL_POSITION_NED", 2)
            return r is not None and math.hypot(r.x - d.x, r.y - d.y) < 1.5
        tower.wait(rover_near, 90, "rover under the drone")
        fs = tower.wait(lambda: tower.get("TOWERLINK_FOLLOW_STATUS", 250), 10, "follow status")
        assert fs.follow_frame == 1 and fs.height == pytest.approx(9.0, abs=1.0)

        # kill the bridge mid-flight: the drone holds its GUIDED position
        processes.stop(bridge)
        # the outage lasts 5 s of the drone's own clock, watched straight on its UDP port
        # (the vehicle answers every peer that writes to it); meanwhile it holds at 9 m
        watch = mavlink_connection(f"udpout:127.0.0.1:{dport}", source_system=254, source_component=190)
        try:
            seen = []

            def outage_over():
                watch.mav.heartbeat_send(tl.MAV_TYPE_GCS, tl.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                m = watch.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=0.2)
                if m is not None and m.get_srcSystem() == 1:
                    seen.append(m)
                return len(seen) > 1 and seen[-1].time_boot_ms - seen[0].time_boot_ms >= 5000
            wait_until(outage_over, 30, "5 s of drone time with the bridge down")
        finally:
            watch.close()
        # seen straight from the drone, so in world: the house is world [-4, -2]
        assert seen and all(math.hypot(m.x + 4.0, m.y + 2.0) < 1.5 and m.z < -8.0 for m in seen)
        bridge2 = processes.start(bridge_cmd)
        tower.last.clear()
        tower.wait(lambda: tower.get("LOCAL_POSITION_NED", 1), 30, "telemetry through the new bridge")
        lp = tower.get("LOCAL_POSITION_NED", 1)
        assert math.hypot(lp.x - gx, lp.y - gy) < 1.5 and lp.z < -8.0
        hb = tower.wait(lambda: tower.get("HEARTBEAT", 1), 10, "heartbeat through the new bridge")
        assert hb.custom_mode == 4 and hb.base_mode & tl.MAV_MODE_FLAG_SAFETY_ARMED
        # and it flies the next goal
        gx, gy = -105.058, 88.524   # world [26, -2]
        tower.wait(goal_sent_and_reached, 120, "second goal after the bridge restart")
        assert bridge2.poll() is None and sitl.poll() is None
    finally:
        tower.conn.close()
