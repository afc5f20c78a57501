"""The ArduPilot parameters ground stations read by default (issue 10): present on both
vehicles with ArduPilot's types, ranges and units; on the wire with ArduPilot's PARAM_VALUE
types; `towerlink sitl --params` reading a real-world .parm file whose names are partly unknown
(warned about, not fatal); LAND_ALT_LOW doing what it says."""
from __future__ import annotations

import numpy as np
import pytest

from test_autopilot_behaviour import _fly, _until, _world
from test_sitl_support import Sitl, connect, mav, recv
from vehicle.autopilot import modes
from vehicle.autopilot.params import COPTER_TABLE, ROVER_TABLE, ParamStore, core_table, file_warnings

I8, I16, I32, F = (mav.MAV_PARAM_TYPE_INT8, mav.MAV_PARAM_TYPE_INT16, mav.MAV_PARAM_TYPE_INT32,
                   mav.MAV_PARAM_TYPE_REAL32)

# what QGroundControl's setup pages, MAVProxy and MAVSDK look up on an ArduPilot vehicle
GCS_READS = ["FRAME_CLASS", "FRAME_TYPE", "BATT_MONITOR", "BATT_CAPACITY", "BATT_LOW_VOLT", "BATT_LOW_MAH",
             "BATT_FS_LOW_ACT", "BATT_ARM_VOLT", "FENCE_ENABLE", "FENCE_TYPE", "FENCE_ACTION", "FENCE_RADIUS",
             "SYSID_THISMAV", "SYSID_MYGCS", "SYSID_ENFORCE", "FS_GCS_ENABLE", "FS_THR_ENABLE", "ARMING_CHECK",
             "FOLL_ENABLE", "FOLL_SYSID", "FOLL_OFS_X", "FOLL_OFS_TYPE", "SIM_WIND_SPD", "SIM_WIND_DIR",
             "RC1_MIN", "RC1_MAX", "RC1_TRIM", "RC4_REVERSED", "RC8_OPTION", "COMPASS_USE", "INS_ACCOFFS_X",
             "LOG_BITMASK", "SRTL_POINTS", "SRTL_ACCURACY", "FORMAT_VERSION"]
COPTER_READS = ["RTL_ALT", "RTL_ALT_FINAL", "RTL_LOIT_TIME", "WPNAV_SPEED", "WPNAV_RADIUS", "LAND_SPEED",
                "LAND_ALT_LOW", "PILOT_SPEED_UP", "PILOT_TKOFF_ALT", "FLTMODE1", "FLTMODE_CH", "ANGLE_MAX",
                "PHLD_BRAKE_ANGLE", "LOIT_SPEED"]
ROVER_READS = ["CRUISE_SPEED", "WP_SPEED", "WP_RADIUS", "RTL_SPEED", "MODE1", "MODE_CH", "LOIT_RADIUS", "TURN_RADIUS"]


def _store(kind):
    return ParamStore(core_table(kind) + (COPTER_TABLE if kind == "copter" else ROVER_TABLE))


@pytest.mark.parametrize("kind, extra, at_least", [("copter", COPTER_READS, 240), ("rover", ROVER_READS, 180)])
def test_ground_station_parameters_present_with_defaults_in_range(kind, extra, at_least):
    s = _store(kind)
    missing = [n for n in GCS_READS + extra if n not in s]
    assert not missing
    assert len(s) >= at_least
    for n in s.names:
        d = s.defs[n]
        assert d.lo <= s[n] <= d.hi, n
        assert len(n) <= 16, n                        # PARAM_VALUE.param_id
        if d.mav_type != F:
            assert float(s[n]).is_integer(), n


def test_arducopters_types_and_units():
    s = _store("copter")
    want = {"FRAME_CLASS": (I8, ""), "SYSID_THISMAV": (I16, ""), "BATT_CAPACITY": (I32, "mAh"),
            "BATT_LOW_VOLT": (F, "V"), "RTL_ALT": (I32, "cm"), "RTL_LOIT_TIME": (I32, "ms"),
            "WPNAV_SPEED": (F, "cm/s"), "ANGLE_MAX": (I16, "cdeg"), "LAND_SPEED": (I16, "cm/s"),
            "FOLL_OFS_X": (F, "m"), "SIM_WIND_DIR": (F, "deg"), "RC1_MIN": (I16, "PWM"), "FENCE_RADIUS": (F, "m")}
    for n, (t, u) in want.items():
        assert (s.defs[n].mav_type, s.defs[n].units) == (t, u), n
    assert s["FRAME_CLASS"] == 1 and s["FRAME_TYPE"] == 1            # quad X: the simulated airframe
    r = _store("rover")
    assert r["FRAME_CLASS"] == 1 and r.defs["RTL_SPEED"].units == "m/s"   # Rover's RTL_SPEED is m/s


def test_file_warnings_name_unknown_and_out_of_range():
    s = _store("rover")
    msgs = file_warnings({"RTL_ALT": 2000, "ANGLE_MAX": 4500, "CRUISE_SPEED": 3, "WP_RADIUS": 500},
                         s.defs, "rover", "x.parm")
    assert msgs == ["x.parm: 2 parameter(s) unknown to the rover, skipped: ANGLE_MAX, RTL_ALT",
                    "x.parm: WP_RADIUS 500 out of range 0.1..100 for the rover, default kept"]


def test_land_alt_low_sets_where_land_slows(monkeypatch):
    w = _world()
    ap = _fly(w, alt=9.0)
    assert ap.params.set("LAND_ALT_LOW", 500, save=False) is None    # 5 m instead of 10 m
    assert ap.set_mode(modes.LAND)
    _until(w, lambda: -ap.pos[2] < 7.5, 20)
    assert ap.vel[2] > 1.3                       # above LAND_ALT_LOW: WPNAV_SPEED_DN (1.5 m/s)
    _until(w, lambda: -ap.pos[2] < 3.5, 20)
    assert 0.4 < ap.vel[2] < 0.6                 # below: LAND_SPEED (0.5 m/s)


# ---------------------------------------------------------------- over the wire

PARM = """# saved by MAVProxy from an ArduCopter 4.5 SITL (abridged), then edited by hand
FRAME_CLASS      1
FRAME_TYPE       1
AHRS_TRIM_X      0.003
BATT_CAPACITY    5200
BATT_LOW_VOLT    10.8
EK3_IMU_MASK     3
FENCE_RADIUS     150
GPS1_TYPE        1
INS_GYROFFS_X    0.0012
RTL_ALT          2500
SERVO1_FUNCTION  33
WPNAV_SPEED,800
LAND_SPEED       9999
"""


@pytest.mark.timeout(60)
def test_sitl_params_takes_a_real_parm_file(processes, tmp_path):
    f = tmp_path / "copter.parm"
    f.write_text(PARM)
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=2, extra=["--params", str(f)])
    m = connect(sitl.udp[0])
    got = {}
    for name in ("FRAME_CLASS", "BATT_CAPACITY", "BATT_LOW_VOLT", "FENCE_RADIUS", "RTL_ALT", "WPNAV_SPEED",
                 "LAND_SPEED"):
        m.mav.param_request_read_send(1, 1, name.encode(), -1)
        p = recv(m, "PARAM_VALUE", 5, cond=lambda p, n=name: p.param_id == n)
        got[name] = (p.param_value, p.param_type)
    assert got["FRAME_CLASS"] == (1, I8)
    assert got["BATT_CAPACITY"] == (5200, I32)
    assert got["BATT_LOW_VOLT"][0] == pytest.approx(10.8) and got["BATT_LOW_VOLT"][1] == F
    assert got["FENCE_RADIUS"][0] == 150 and got["RTL_ALT"][0] == 2500 and got["WPNAV_SPEED"][0] == 800
    assert got["LAND_SPEED"][0] == 50                                 # 9999 out of range: default kept
    out = sitl.output()
    assert "5 parameter(s) unknown to the copter, skipped: AHRS_TRIM_X, EK3_IMU_MASK, GPS1_TYPE, " \
           "INS_GYROFFS_X, SERVO1_FUNCTION" in out
    assert "LAND_SPEED 9999 out of range 30..200 for the copter, default kept" in out
    assert sitl.proc.poll() is None


@pytest.mark.parametrize("loit_ms, final_cm", [(5000, 0), (2000, 300)])
def test_rtl_loit_time_and_rtl_alt_final(loit_ms, final_cm):
    from test_autopilot_behaviour import _goto
    w = _world()
    ap = _fly(w, alt=6.0)
    for n, v in (("RTL_LOIT_TIME", loit_ms), ("RTL_ALT_FINAL", final_cm), ("RTL_ALT", 1000)):
        assert ap.params.set(n, v, save=False) is None
    _goto(ap, 20, 0, -10)
    _until(w, lambda: np.linalg.norm(ap.pos - [20, 0, -10]) < 0.5, 40)
    assert ap.set_mode(modes.RTL)
    _until(w, lambda: ap.flightmodes[modes.RTL].stage == "loiter", 40)
    t_over = w.t
    _until(w, lambda: ap.flightmodes[modes.RTL].stage != "loiter", 70)
    assert abs((w.t - t_over) - loit_ms / 1000.0) < 0.1            # RTL_LOIT_TIME above home
    if final_cm == 0:
        _until(w, lambda: not ap.armed, 60)                         # then lands and disarms
    else:
        w.run_for(15)                                               # RTL_ALT_FINAL: hovers there
        assert ap.armed and ap.mode == modes.RTL
        assert abs((ap.home[2] - ap.pos[2]) - final_cm / 100.0) < 0.3
