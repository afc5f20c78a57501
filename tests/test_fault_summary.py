"""The summary's fault section (tools.fault_summary) from a recorded run folder: each fault, when
it took effect and was cleared, the failsafes put down to it, and the mission."""
from __future__ import annotations

import json
import struct

from common.mavlink.dialect import encoder
from common.mavlink.dialect import towerlink as tl
from common.scenario import DEFAULT_SCENARIO
from tools.fault_summary import first_failsafe_delay, format_faults, is_failsafe
from tools.run_summary import format_summary, summarize

FAULTS = '''
[[faults]]
t = 10
target = "drone"
SIM_BATT_VOLTAGE = 10.0

[[faults]]
t = 20
until = 28
target = "tower_link"
loss = 1.0

[[faults]]
t = 200
target = "rover"
SIM_BATT_VOLTAGE = 10.0
'''

COPTER, ROVER_TYPE, GUIDED, RTL, HOLD = 2, 10, 4, 6, 4


def record(run, scenario) -> None:
    """A run folder as `towerlink fly` leaves it: vehicles.tlog, faults.json, tower.json, meta.json."""
    events = []     # (sim s, sysid, message)
    for sysid, kind in ((1, COPTER), (2, ROVER_TYPE)):
        for k in range(0, 40):          # heartbeats at x.96 s, a clock (ATTITUDE) every 0.02 s
            t = k + 0.96
            mode = GUIDED if sysid == 1 else 15
            if sysid == 1 and t > 24.3:
                mode = RTL
            if sysid == 2 and 24.3 < t < 25.5:
                mode = HOLD
            events.append((t, sysid, tl.MAVLink_heartbeat_message(kind, 3, 129, mode, 4, 3)))
        for k in range(0, 2000):
            events.append((k * 0.02, sysid, tl.MAVLink_attitude_message(k * 20, 0, 0, 0, 0, 0, 0)))
    texts = [(20.06, 1, "Battery 1 is low 9.34V used 98 mAh"), (20.06, 1, "Battery Failsafe"),
             (24.26, 1, "GCS Failsafe On: RTL"), (24.26, 2, "GCS Failsafe On: Hold"),
             (28.2, 2, "GCS Failsafe Cleared"), (5.0, 2, "Battery Failsafe"),
             (39.5, 2, "GCS Failsafe On: Hold")]       # after the tower ended (35 s): not the run's
    for t, sysid, text in texts:
        events.append((t + 1e-4, sysid, tl.MAVLink_statustext_message(4, text.encode())))
    with open(run / "vehicles.tlog", "wb") as f:
        for t, sysid, msg in sorted(events, key=lambda e: e[0]):
            f.write(struct.pack(">Q", int(t * 1e6)) + msg.pack(encoder(sysid, 1)))
    applied = [{"fault": 0, "kind": "apply", "t": 10.0, "at": 10.0}, {"fault": 1, "kind": "apply", "t": 20.0, "at": 20.0},
               {"fault": 1, "kind": "clear", "t": 28.0, "at": 28.0}]
    (run / "faults.json").write_text(json.dumps({"applied": applied}))
    goals = [{"index": 1, "goal": [-131.039, 73.524, -9.0], "frame": "tower", "reached": True, "reached_sim": 13.2,
              "sent_sim": 10.0, "time_to_reach": 3.2},
             {"index": 2, "goal": [-105.058, 88.524, -9.0], "frame": "tower", "reached": True, "reached_sim": 21.0,
              "sent_sim": 13.2, "time_to_reach": 7.8},
             {"index": 3, "goal": [-120.058, 114.504, -9.0], "frame": "tower", "reached": False, "sent_sim": 21.0}]
    (run / "tower.json").write_text(json.dumps({"ok": False, "goals": goals, "end_sim": 35.0}))
    (run / "meta.json").write_text(json.dumps({"scenario": str(scenario)}))


def test_each_fault_with_its_failsafes_from_a_recorded_run(tmp_path):
    scenario = tmp_path / "faults.toml"
    scenario.write_text(DEFAULT_SCENARIO.read_text() + FAULTS)
    run = tmp_path / "run"
    run.mkdir()
    record(run, scenario)
    s = summarize(run)
    f = s["faults"]
    battery, link, late = f["faults"]
    assert (battery["applied"], battery["cleared"], battery["goals_reached_after"]) == (10.0, None, 2)
    # the battery failsafe 10 s after the voltage dropped is the battery fault's, although the
    # tower link went down in between: a GCS failsafe is put down to the link, the rest to the vehicle
    assert [(x["text"], x["mode"], round(x["after"], 2)) for x in battery["failsafes"]] == \
        [("Battery 1 is low 9.34V used 98 mAh", "GUIDED", 10.06), ("Battery Failsafe", "GUIDED", 10.06)]
    assert (link["applied"], link["cleared"], link["goals_reached_after"]) == (20.0, 28.0, 1)
    assert [(x["vehicle"], x["text"], x["mode"], round(x["after"], 2)) for x in link["failsafes"]] == \
        [("drone", "GCS Failsafe On: RTL", "RTL", 4.26), ("rover", "GCS Failsafe On: Hold", "HOLD", 4.26)]
    assert late["applied"] is None and late["failsafes"] == []
    assert [x["fault"] for x in f["failsafes"]] == [0, 0, 1, None, 1]   # the drone's three, then the rover's two
    assert f["goals_reached_after_first_fault"] == 2
    assert round(first_failsafe_delay(f), 2) == 4.26
    text = format_summary(s)
    assert "[1] t 20 tower_link loss=1 until 28: applied 20.00, cleared 28.00; goals reached after it: 1" in text
    assert "-> drone: 'GCS Failsafe On: RTL' at 24.26 (+4.26 s), mode RTL" in text
    assert "[2] t 200 rover SIM_BATT_VOLTAGE=10: never applied (the run ended first)" in text
    assert "failsafe without a fault: rover: 'Battery Failsafe' at 5.00, mode GUIDED" in text
    assert text.startswith("MISSION FAILED: 2/3 goals reached")


def test_a_run_without_faults_has_no_section():
    assert format_faults({"faults": [], "failsafes": [], "goals_reached_after_first_fault": None}) == []
    assert first_failsafe_delay(None) is None
    assert is_failsafe("GCS Failsafe On: RTL") and is_failsafe("Battery Failsafe")
    assert is_failsafe("Battery 1 is low 9.34V used 98 mAh") and is_failsafe("Battery 2 is critical 9.0V used 1 mAh")
    assert not is_failsafe("GCS Failsafe Cleared") and not is_failsafe("Battery 1 is fine")


def test_the_estimator_failsafes_go_to_the_sensor_fault_and_the_battery_one_to_the_battery():
    """ArduCopter's EKF check texts count (not their clearing, nor the GPS glitch warning), and each failsafe
    goes to the latest fault that can cause it: "EKF variance" to the GPS fault although the
    battery sag came later, the battery's to the sag."""
    from common.scenario_faults import Fault
    from tools.fault_summary import fault_section
    from tools.run_data import RunData
    assert is_failsafe("EKF variance") and is_failsafe("EKF Failsafe: changed to LAND Mode") and is_failsafe("EKF failsafe")
    assert not is_failsafe("GPS Glitch") and not is_failsafe("GPS Glitch cleared") and not is_failsafe("EKF Failsafe Cleared")
    assert not is_failsafe("EKF failsafe cleared")
    gps = Fault(0, 5.0, "drone", 1, params=(("SIM_GPS1_ENABLE", 0.0),))
    sag = Fault(1, 6.0, "drone", 1, params=(("SIM_BATT_VOLTAGE", 10.0),))
    data = RunData()
    data.texts[1] = [(13.0, 2, "EKF variance"), (13.0, 2, "EKF Failsafe: changed to LAND Mode"),
                     (16.0, 4, "Battery Failsafe")]
    applied = [{"fault": 0, "kind": "apply", "at": 5.0}, {"fault": 1, "kind": "apply", "at": 6.0}]
    s = fault_section([gps, sag], applied, data, {1: "drone"}, [])
    assert [x["fault"] for x in s["failsafes"]] == [0, 0, 1]
    assert [x["after"] for x in s["faults"][0]["failsafes"]] == [8.0, 8.0]
