"""AUTO over the wire against a real `towerlink sitl`: pymavlink as ArduPilot users write it
(mavwp upload, GUIDED, arm, MAV_CMD_MISSION_START; MISSION_CURRENT and MISSION_ITEM_REACHED
in order, DO_JUMP repeats, each waypoint passed within WPNAV_RADIUS, the mission's end as
ArduCopter's), a rover's mission in AUTO ("Reached waypoint #N", "Mission Complete", holds in
AUTO), and MAVSDK 4.x mission_raw start_mission with its progress to the end (the MAVSDK
client in its own process, as in test_sitl_mavsdk_mission.py)."""
from __future__ import annotations

import sys
import time

import numpy as np
import pytest

from test_sitl_support import Sitl, command, connect, mav, recv, set_mode, wait_armable  # MAVLINK20 first

from pymavlink import mavwp  # noqa: E402  (after MAVLINK20 is set)
from common import geo  # noqa: E402

REL = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT


def item(m, seq, cmd, n=0.0, e=0.0, alt=0.0, home=None, frame=REL, p=(0, 0, 0, 0)):
    x = y = 0
    if home is not None:
        lat, lon, _ = geo.ned_to_lla(home, [n, e, 0.0])
        x, y = int(round(lat * 1e7)), int(round(lon * 1e7))
    return mav.MAVLink_mission_item_int_message(m.target_system, m.target_component, seq, frame, cmd, 0, 1,
                                                *p, x, y, alt, 0)


def mavwp_upload(m, loader, timeout=30.0) -> int:
    """The classic pymavlink upload loop: clear, count, answer each request, MISSION_ACK."""
    m.waypoint_clear_all_send()
    recv(m, "MISSION_ACK", timeout)
    m.waypoint_count_send(loader.count())
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        msg = m.recv_match(type=["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"], blocking=True, timeout=0.5)
        if msg is None:
            continue
        if msg.get_type() == "MISSION_ACK":
            return msg.type
        m.mav.send(loader.wp(msg.seq))
    raise AssertionError("upload timed out")


@pytest.mark.timeout(180)
def test_pymavlink_flies_a_mission_with_do_jump_in_auto(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=10)
    m = connect(sitl.udp[0])
    wait_armable(m)
    g = recv(m, "GLOBAL_POSITION_INT", 5)
    home = (g.lat * 1e-7, g.lon * 1e-7, g.alt * 1e-3)
    wps = {2: (20.0, 0.0, 10.0), 3: (20.0, 20.0, 12.0), 5: (0.0, 20.0, 10.0)}
    loader = mavwp.MAVWPLoader()
    for it in [item(m, 0, mav.MAV_CMD_NAV_WAYPOINT, home=home, frame=mav.MAV_FRAME_GLOBAL_INT, alt=home[2]),
               item(m, 1, mav.MAV_CMD_NAV_TAKEOFF, alt=10),
               item(m, 2, mav.MAV_CMD_NAV_WAYPOINT, *wps[2], home=home),
               item(m, 3, mav.MAV_CMD_NAV_WAYPOINT, *wps[3], home=home),
               item(m, 4, mav.MAV_CMD_DO_JUMP, frame=mav.MAV_FRAME_MISSION, p=(2, 2, 0, 0)),
               item(m, 5, mav.MAV_CMD_NAV_WAYPOINT, *wps[5], home=home),
               item(m, 6, mav.MAV_CMD_NAV_RETURN_TO_LAUNCH)]:
        loader.add(it)
    assert mavwp_upload(m, loader) == mav.MAV_MISSION_ACCEPTED
    assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
    m.arducopter_arm()
    m.motors_armed_wait()
    assert command(m, mav.MAV_CMD_MISSION_START, 0, 0) == mav.MAV_RESULT_ACCEPTED

    reached, currents, texts, err = [], [], [], []
    last_pos = None
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        msg = recv(m, ["MISSION_ITEM_REACHED", "MISSION_CURRENT", "STATUSTEXT", "GLOBAL_POSITION_INT",
                       "HEARTBEAT"], 10)
        t = msg.get_type()
        if t == "GLOBAL_POSITION_INT":
            last_pos = msg
        elif t == "MISSION_ITEM_REACHED":
            reached.append(msg.seq)
            if msg.seq in wps and last_pos is not None:
                n, e, _ = geo.lla_to_ned(home, last_pos.lat * 1e-7, last_pos.lon * 1e-7, 0.0)
                want = wps[msg.seq]
                err.append(float(np.linalg.norm([n - want[0], e - want[1], last_pos.relative_alt * 1e-3 - want[2]])))
        elif t == "MISSION_CURRENT":
            if not currents or currents[-1][:2] != (msg.seq, msg.mission_state):
                currents.append((msg.seq, msg.mission_state, msg.total))
        elif t == "STATUSTEXT":
            texts.append(msg.text)
        elif t == "HEARTBEAT" and reached and not (msg.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED):
            break
    assert reached == [1, 2, 3, 2, 3, 2, 3, 5, 6], (reached, texts)
    legs = [s for s, state, _ in currents if state == mav.MISSION_STATE_ACTIVE]
    assert legs == [1, 2, 3, 2, 3, 2, 3, 5, 6], currents
    assert all(total == 6 for _, _, total in currents)
    assert "Mission: 4 Jump 1/2" in texts and "Mission: 4 Jump 2/2" in texts
    # each waypoint reached within WPNAV_RADIUS (2 m) + one GLOBAL_POSITION_INT period of travel
    assert len(err) == 7 and max(err) < 2.0 + 0.6, err
    # the end, as ArduCopter: RTL landed at home, disarmed in AUTO, the mission COMPLETE
    hb = recv(m, "HEARTBEAT", 5)
    assert hb.custom_mode == 3 and not hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED
    cur = recv(m, "MISSION_CURRENT", 5)
    assert cur.mission_state == mav.MISSION_STATE_COMPLETE
    p = recv(m, "GLOBAL_POSITION_INT", 5)
    n, e, _ = geo.lla_to_ned(home, p.lat * 1e-7, p.lon * 1e-7, 0.0)
    assert np.hypot(n, e) < 1.0 and p.relative_alt < 300


@pytest.mark.timeout(120)
def test_pymavlink_rover_runs_a_mission_in_auto(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=0, rovers=1, speedup=10)
    m = connect(sitl.udp[0])
    assert m.messages["HEARTBEAT"].type == mav.MAV_TYPE_GROUND_ROVER
    wait_armable(m)
    g = recv(m, "GLOBAL_POSITION_INT", 5)
    home = (g.lat * 1e-7, g.lon * 1e-7, g.alt * 1e-3)
    loader = mavwp.MAVWPLoader()
    for it in [item(m, 0, mav.MAV_CMD_NAV_WAYPOINT, home=home, frame=mav.MAV_FRAME_GLOBAL_INT, alt=home[2]),
               item(m, 1, mav.MAV_CMD_NAV_WAYPOINT, 15.0, 0.0, home=home),
               item(m, 2, mav.MAV_CMD_NAV_WAYPOINT, 15.0, 15.0, home=home)]:
        loader.add(it)
    assert mavwp_upload(m, loader) == mav.MAV_MISSION_ACCEPTED
    m.arducopter_arm()
    m.motors_armed_wait()
    assert set_mode(m, "AUTO") == mav.MAV_RESULT_ACCEPTED
    reached, texts = [], []
    while "Mission Complete" not in texts:
        msg = recv(m, ["MISSION_ITEM_REACHED", "STATUSTEXT"], 30)
        if msg.get_type() == "MISSION_ITEM_REACHED":
            reached.append(msg.seq)
        else:
            texts.append(msg.text)
    assert reached == [1, 2], (reached, texts)
    assert [t for t in texts if t.startswith("Reached waypoint")] == ["Reached waypoint #1", "Reached waypoint #2"]
    assert recv(m, "MISSION_CURRENT", 5).mission_state == mav.MISSION_STATE_COMPLETE
    assert recv(m, "HEARTBEAT", 5).custom_mode == 10                  # still AUTO, holding


# ----- MAVSDK ---------------------------------------------------------------------------
def client(port: int) -> int:
    from mavsdk_client import autopilot, step, wait
    from mavsdk.plugins.action import Action
    from mavsdk.plugins.mission_raw import MissionItem, MissionRaw
    from mavsdk.plugins.telemetry import Telemetry

    system = autopilot(port)
    tel, action, raw = Telemetry(system), Action(system), MissionRaw(system)
    wait(lambda: tel.health().is_global_position_ok and tel.health().is_armable, 30, "armable")
    pos = tel.position()
    home = (pos.latitude_deg, pos.longitude_deg, pos.absolute_altitude_m)
    rel = 6
    items = [MissionItem(0, 0, 16, 1, 1, 0, 0, 0, 0, int(home[0] * 1e7), int(home[1] * 1e7), home[2], 0),
             MissionItem(1, rel, 22, 0, 1, 0, 0, 0, 0, 0, 0, 8.0, 0)]
    for i, (n, e) in enumerate([(15, 0), (15, 15), (0, 15)], start=2):
        lat, lon, _ = geo.ned_to_lla(home, [n, e, 0])
        items.append(MissionItem(i, rel, 16, 0, 1, 0, 0, 0, 0, int(round(lat * 1e7)), int(round(lon * 1e7)), 8.0, 0))
    raw.upload_mission(items)
    step("uploaded")
    progress = []
    raw.subscribe_mission_progress(lambda p, ud: progress.append((p.current, p.total)))
    action.set_takeoff_altitude(8.0)
    action.arm()
    action.takeoff()
    wait(lambda: tel.position().relative_altitude_m >= 7.0, 40, "takeoff")
    step("airborne")
    raw.start_mission()
    step("started")
    wait(lambda: progress and progress[-1][1] > 0 and progress[-1][0] >= progress[-1][1], 60,
         f"mission progress to the end (so far {progress})")
    seen = [c for c, _ in progress]
    # MAVSDK counts the raw mission with its home item: the end is (5, 5)
    if seen != sorted(seen) or progress[-1] != (len(items), len(items)):
        raise SystemExit(f"MISMATCH progress {progress}")
    step(f"progress {progress}")
    print("MAVSDK AUTO OK", flush=True)
    return 0


@pytest.mark.timeout(150)
def test_mavsdk_mission_raw_start_mission_progress_to_the_end(processes, tmp_path):
    from test_sitl_support import run_client_script
    run_client_script(processes, tmp_path, __file__, "MAVSDK AUTO OK", speedup=3)


if __name__ == "__main__":
    sys.path.insert(0, __import__("os").path.dirname(__file__))
    sys.exit(client(int(sys.argv[1])))
