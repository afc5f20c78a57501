"""The battery (issue 10): the pack's voltage under load and drain with thrust, AP_BattMonitor's
figures and failsafe with ArduPilot's texts and actions (in-process on the real World), and
BATTERY_STATUS / SYS_STATUS over pymavlink from a real `towerlink sitl`."""
from __future__ import annotations


import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from test_autopilot_behaviour import _fly, _goto, _until
from test_sitl_support import Sitl, command, connect, mav, recv, set_mode, wait_armable
from vehicle.autopilot import modes
from vehicle.autopilot.failsafe import BATTERY_PERIOD
from vehicle.autopilot.battery import (AVIONICS_W, CELL_RESISTANCE, CRITICAL, LOW, NONE, OCV_CURVE,
                                       Battery, cell_ocv)
from vehicle.world import World, WorldConfig

P = {"BATT_MONITOR": 4, "BATT_CAPACITY": 3300, "SIM_BATT_VOLTAGE": 12.6, "SIM_BATT_CAP_AH": 0,
     "BATT_LOW_VOLT": 10.5, "BATT_CRT_VOLT": 0, "BATT_LOW_MAH": 0, "BATT_CRT_MAH": 0,
     "BATT_LOW_TIMER": 10, "BATT_FS_VOLTSRC": 0}


def _drain(load_w, seconds, p=P, armed=True, dt=0.02, b=None):
    b = b or Battery()
    t = 0.0
    events = []
    for _ in range(int(seconds / dt)):
        t += dt
        e = b.update(t, dt, load_w, armed, p)
        if e:
            events.append((round(t, 2), e))
    return b, events


# ---------------------------------------------------------------- the pack (pure)

@settings(max_examples=80, deadline=None)
@given(st.floats(0, 100), st.floats(0, 100))
def test_open_circuit_voltage_rises_with_charge(a, b):
    lo, hi = min(a, b), max(a, b)
    assert cell_ocv(lo) <= cell_ocv(hi)
    assert OCV_CURVE[0][1] <= cell_ocv(a) <= 4.2


@settings(max_examples=80, deadline=None)
@given(st.floats(0, 600), st.floats(0, 3000))
def test_voltage_under_load_is_ocv_minus_i_r_and_pays_for_the_power(load, used):
    b = Battery()
    b.pack_used_mah = used
    b.update(1.0, 1e-9, load, True, P)
    r = 3 * CELL_RESISTANCE
    assert b.voltage == pytest.approx(b.resting_voltage - b.current * r, abs=1e-9)
    assert b.voltage * b.current == pytest.approx(AVIONICS_W + load, rel=1e-6)
    assert b.resting_voltage == pytest.approx(3 * cell_ocv(100 * (1 - used / 3300)), abs=1e-6)


def test_beyond_the_packs_maximum_power_it_gives_its_maximum():
    b = Battery()
    b.update(1.0, 0.01, 5000.0, True, P)              # max power OCV^2 / 4R is ~1 kW
    r = 3 * CELL_RESISTANCE
    assert b.current == pytest.approx(b.resting_voltage / (2 * r))
    assert b.voltage == pytest.approx(b.resting_voltage / 2)


def test_drains_faster_and_sags_more_at_higher_power():
    light, _ = _drain(100.0, 60)
    heavy, _ = _drain(300.0, 60)
    assert heavy.consumed_mah > 2.8 * light.consumed_mah
    assert heavy.voltage < light.voltage - 0.5
    assert heavy.remaining_pct(P) < light.remaining_pct(P) < 100
    # time remaining follows the averaged current: about capacity / current
    r = heavy.reading(P)
    assert r.time_remaining == pytest.approx((3300 - heavy.consumed_mah) / 1000 / heavy.avg_current * 3600, abs=1)


def test_monitor_types():
    b, _ = _drain(100.0, 10)
    assert b.reading({**P, "BATT_MONITOR": 0}).voltage is None           # no battery monitor
    r = b.reading({**P, "BATT_MONITOR": 3})                               # voltage only
    assert r.voltage > 0 and r.current is None and r.remaining_pct is None and r.consumed_mah is None
    r = b.reading(P)
    assert r.current > 0 and r.consumed_mah > 0 and 0 < r.remaining_pct < 100


def test_reboot_resets_the_monitor_not_the_pack():
    b, _ = _drain(300.0, 120)
    v, used = b.resting_voltage, b.pack_used_mah
    b.reboot()
    assert b.consumed_mah == 0 and b.failsafe == NONE and b.pack_used_mah == used
    b.update(200.0, 1e-6, 0.0, False, P)
    assert b.resting_voltage == pytest.approx(v, abs=1e-3)


# ---------------------------------------------------------------- the failsafe (pure)

def test_low_voltage_must_last_batt_low_timer():
    p = {**P, "BATT_LOW_VOLT": 12.5, "BATT_LOW_TIMER": 5}               # a 300 W load sags below it at once
    _, ev = _drain(300.0, 20, p)
    assert ev and ev[0][1] == LOW and 5.0 < ev[0][0] <= 5.1
    _, ev = _drain(300.0, 20, {**p, "BATT_LOW_TIMER": 0})                 # 0: no voltage failsafe
    assert ev == []


def test_capacity_failsafes_at_once_and_levels_only_rise():
    p = {**P, "BATT_LOW_MAH": 3250, "BATT_CRT_MAH": 3200}
    b, ev = _drain(300.0, 60, p)
    assert [e for _, e in ev] == [LOW, CRITICAL]
    assert b.failsafe == CRITICAL
    t_low = ev[0][0]
    assert abs(b.consumed_mah * t_low / 60 - 50) < 3                     # triggered when 50 mAh were used
    _, ev = _drain(300.0, 60, {**p, "BATT_MONITOR": 3})                  # no current sensing: no mAh failsafe
    assert ev == []


def test_no_failsafe_while_disarmed_then_it_triggers_on_arming():
    p = {**P, "BATT_LOW_MAH": 3299}
    b, ev = _drain(300.0, 10, p, armed=False)
    assert ev == [] and b.failsafe == NONE
    _, ev = _drain(0.0, 0.04, p, armed=True, b=b)
    assert [e for _, e in ev] == [LOW]


def test_resting_voltage_source():
    p = {**P, "BATT_LOW_VOLT": 12.3, "BATT_LOW_TIMER": 1}
    _, raw = _drain(300.0, 5, p)
    _, rest = _drain(300.0, 5, {**p, "BATT_FS_VOLTSRC": 1})      # sag-compensated: still above 12.3
    assert raw and not rest


def test_failsafe_text_is_ardupilots():
    b, _ = _drain(300.0, 60, {**P, "BATT_LOW_MAH": 3250})
    assert b.failsafe_text() == f"Battery 1 is low {b.voltage:.2f}V used {b.consumed_mah:.0f} mAh"


# ---------------------------------------------------------------- the vehicles (in-process)

def _world(drones=1, rovers=0, **params) -> World:
    w = World(WorldConfig(drones=drones, rovers=rovers, state_dir=None, tcp_base=None, udp_base=None))
    for v in w.vehicles:
        for k, val in params.items():
            assert v.ap.params.set(k, val) is None
    _until(w, lambda: all(v.ap.est_ok and v.ap.home is not None for v in w.vehicles), 10)
    for v in w.vehicles:
        v.texts = []
        v.ap.outbox.subscribe(text=(lambda texts: lambda sev, t: texts.append((sev, t)))(v.texts))
    return w


def test_copter_current_follows_thrust():
    w = _world()
    ap = w.vehicles[0].ap
    disarmed = ap.battery.current
    ap.set_mode(modes.GUIDED)
    ap.arm()
    w.run_for(0.5)
    idle = ap.battery.current
    assert ap.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 20]) == mav.MAV_RESULT_ACCEPTED
    w.run_for(3.0)
    climb = ap.battery.current                                  # climbing at WPNAV_SPEED_UP
    _until(w, lambda: ap.pos[2] < -19.8, 30)
    w.run_for(5.0)
    hover = ap.battery.current
    assert disarmed < 0.5 and disarmed < idle < 2 < hover < climb
    assert 12 < hover < 30                                 # a 1.8 kg quad on 3S: ~19 A
    used = ap.battery.consumed_mah
    w.run_for(10.0)
    assert (ap.battery.consumed_mah - used) == pytest.approx(hover * 10 / 3.6, rel=0.1)


def test_copter_low_then_critical_capacity_failsafe_rtl_then_land():
    w = _world(BATT_LOW_MAH=3250, BATT_CRT_MAH=3200, BATT_FS_LOW_ACT=2, BATT_FS_CRT_ACT=1)
    v = w.vehicles[0]
    ap = _fly(w, 10.0)
    _until(w, lambda: ap.mode == modes.RTL, 30)
    texts = [t for _, t in v.texts]
    low = next(t for t in texts if t.startswith("Battery 1 is low "))
    assert low.endswith(" mAh") and "V used " in low
    assert texts[texts.index(low) + 1] == "Battery Failsafe"
    assert all(sev == mav.MAV_SEVERITY_WARNING for sev, t in v.texts if t.startswith("Battery"))
    _until(w, lambda: ap.mode == modes.LAND, 30)
    assert any(t.startswith("Battery 1 is critical ") for _, t in v.texts)
    assert ap.battery.failsafe == CRITICAL


def test_copter_critical_rtl_does_not_override_a_low_land():
    """ArduCopter's priorities: LAND ranks above RTL, so a critical RTL after a low LAND is
    announced but not taken."""
    w = _world(BATT_LOW_MAH=3250, BATT_CRT_MAH=3220, BATT_FS_LOW_ACT=1, BATT_FS_CRT_ACT=2)
    v = w.vehicles[0]
    ap = _fly(w, 10.0)
    _until(w, lambda: ap.battery.failsafe == CRITICAL, 60)
    assert ap.mode == modes.LAND
    assert [t for _, t in v.texts].count("Battery Failsafe") == 1


def test_copter_low_voltage_failsafe_after_the_timer():
    # hovering sags the pack below 12.3 V at once; BATT_LOW_TIMER 3 s later: LAND
    w = _world(BATT_LOW_VOLT=0, BATT_LOW_TIMER=3, BATT_FS_LOW_ACT=1)
    ap = _fly(w, 5.0)
    assert ap.battery.voltage < 12.3 and ap.mode == modes.GUIDED
    ap.params.set("BATT_LOW_VOLT", 12.3)
    t = _until(w, lambda: ap.mode == modes.LAND, 10)
    # the monitor is read at 10 Hz, as ArduPilot's: the timer starts at the first reading below
    # the level and the action comes at the first reading after it (at most two periods late)
    assert 3.0 < t <= 3.0 + 2 * BATTERY_PERIOD + 1e-6


def test_copter_landed_failsafe_disarms():
    w = _world(BATT_LOW_MAH=3299, BATT_FS_LOW_ACT=2)
    v = w.vehicles[0]
    ap = v.ap
    ap.set_mode(modes.GUIDED)
    assert ap.arm() == mav.MAV_RESULT_ACCEPTED
    _until(w, lambda: not ap.armed, 30)
    assert "Battery Failsafe - Disarming" in [t for _, t in v.texts]
    assert ap.mode == modes.GUIDED


def test_rover_low_battery_holds():
    w = _world(drones=0, rovers=1, BATT_LOW_MAH=3290, BATT_FS_LOW_ACT=2)
    v = w.vehicles[0]
    ap = v.ap
    assert ap.set_mode(modes.ROVER_GUIDED) and ap.arm() == mav.MAV_RESULT_ACCEPTED
    _goto(ap, 200.0, 0.0, 0.0)
    _until(w, lambda: ap.mode == modes.ROVER_HOLD, 60)
    assert any(t.startswith("Battery 1 is low ") for _, t in v.texts)
    assert np.linalg.norm(ap.vel[:2]) > 0.5           # it was driving when the failsafe came


def test_sys_status_battery_bits():
    w = _world(BATT_LOW_MAH=3299)
    link, ap = w.vehicles[0].link, w.vehicles[0].ap
    s = link.telemetry.sys_status()
    assert s.onboard_control_sensors_health & mav.MAV_SYS_STATUS_SENSOR_BATTERY
    assert s.voltage_battery == round(ap.battery.voltage * 1000) and s.battery_remaining == 100
    ap.set_mode(modes.GUIDED)
    ap.arm()
    _until(w, lambda: ap.battery.failsafe == LOW, 10)
    s = link.telemetry.sys_status()
    assert not s.onboard_control_sensors_health & mav.MAV_SYS_STATUS_SENSOR_BATTERY
    assert link.telemetry.battery_status().charge_state == mav.MAV_BATTERY_CHARGE_STATE_LOW
    ap.params.set("BATT_MONITOR", 0)
    s = link.telemetry.sys_status()
    assert not s.onboard_control_sensors_present & mav.MAV_SYS_STATUS_SENSOR_BATTERY
    assert (s.voltage_battery, s.current_battery, s.battery_remaining) == (0, -1, -1)
    assert link.telemetry.battery_status() is None


# ---------------------------------------------------------------- over pymavlink

def test_battery_status_shows_the_drain_over_pymavlink(processes, tmp_path):
    """Also: `sitl --wind` shows in the vehicle's SIM_WIND_* parameters (PARAM_READ)."""
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=10.0, extra=("--wind", "8,270,1"))
    m = connect(sitl.udp[0])
    for name, want in (("SIM_WIND_SPD", 8.0), ("SIM_WIND_DIR", 270.0), ("SIM_WIND_TURB", 1.0)):
        m.mav.param_request_read_send(m.target_system, m.target_component, name.encode(), -1)
        assert recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == name).param_value == want
    m.mav.request_data_stream_send(m.target_system, m.target_component, mav.MAV_DATA_STREAM_EXTRA3, 5, 1)
    rest = recv(m, "BATTERY_STATUS", 10)
    assert rest.current_battery < 50 and rest.voltages[0] > 12400 and rest.battery_remaining == 100
    wait_armable(m)
    assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    assert command(m, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10) == mav.MAV_RESULT_ACCEPTED
    first = recv(m, "BATTERY_STATUS", 20, cond=lambda b: b.current_battery > 1000)    # > 10 A aloft
    later = recv(m, "BATTERY_STATUS", 30, cond=lambda b: b.current_consumed > first.current_consumed + 60)
    assert later.voltages[0] < rest.voltages[0] - 300                  # sag under load
    assert later.battery_remaining < rest.battery_remaining
    assert later.energy_consumed > max(first.energy_consumed, 0)          # hJ
    assert later.time_remaining > 0
    assert later.voltages[1] == 65535 and later.charge_state == mav.MAV_BATTERY_CHARGE_STATE_OK
    s = recv(m, "SYS_STATUS", 5)
    assert s.current_battery > 1000 and abs(s.voltage_battery - later.voltages[0]) < 300
    m.close()


def test_smartrtl_actions_copter_and_rover():
    """BATT_FS_LOW_ACT 3 (SmartRTL or RTL) on the copter, 4 (SmartRTL or Hold) on the rover:
    both enter SMART_RTL, having a recorded path home."""
    w = _world(BATT_LOW_MAH=3200, BATT_FS_LOW_ACT=3)
    ap = _fly(w, 10.0)
    _goto(ap, 20.0, 0.0, -10.0)
    _until(w, lambda: ap.mode == mav.COPTER_MODE_SMART_RTL, 60)
    w = _world(drones=0, rovers=1, BATT_LOW_MAH=3290, BATT_FS_LOW_ACT=4)
    ap = w.vehicles[0].ap
    assert ap.set_mode(modes.ROVER_GUIDED) and ap.arm() == mav.MAV_RESULT_ACCEPTED
    _goto(ap, 200.0, 0.0, 0.0)
    _until(w, lambda: ap.mode == mav.ROVER_MODE_SMART_RTL, 60)
