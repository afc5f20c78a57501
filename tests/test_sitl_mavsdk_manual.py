"""MAVSDK 4.x's ManualControl plugin flying the copter, written as a MAVSDK user writes it
(the ArduPilot way: SYSID_MYGCS set to MAVSDK's system id 245 first, the sticks sent
continuously from a loop of its own): start_altitude_control (ALT_HOLD), arm with the
throttle mid stick, climb on z, hold on release; start_position_control, forward on x,
stop and hold on release; Action.land.

As in test_sitl_mavsdk.py the client runs in its own process (this file as a script) so a
hang in the native library cannot outlive the test; the vehicle pushes to it with --out
udpout.
"""
from __future__ import annotations

import math
import sys
import threading
import time

import pytest

MAVSDK_SYSID = 245          # MAVSDK's ground-station system id


def client(port: int) -> int:
    from mavsdk_client import autopilot, land_and_finish, step, wait
    from mavsdk.plugins.action import Action
    from mavsdk.plugins.manual_control import ManualControl
    from mavsdk.plugins.param import Param
    from mavsdk.plugins.telemetry import Telemetry

    system = autopilot(port)
    tel, act, man, par = Telemetry(system), Action(system), ManualControl(system), Param(system)
    wait(lambda: tel.health().is_armable and tel.health().is_global_position_ok, 30, "health")
    par.set_param_int("SYSID_MYGCS", MAVSDK_SYSID)        # ArduPilot takes sticks from its GCS only
    sticks = [0.0, 0.0, 0.5, 0.0]                           # x fwd, y right, z throttle 0..1, r yaw
    stop = threading.Event()
    pumped = [0]

    def pump():
        while not stop.is_set():
            man.set_manual_control_input(*sticks)
            pumped[0] += 1
            time.sleep(0.02)           # the joystick's rate: 50 Hz
    threading.Thread(target=pump, daemon=True).start()
    try:
        wait(lambda: pumped[0] >= 25, 10, "inputs flowing")   # before the mode starts, as MAVSDK asks
        man.start_altitude_control()
        act.arm()
        wait(lambda: tel.armed(), 10, "armed")
        step("armed in altitude control")
        sticks[2] = 1.0                                     # full throttle: climb
        wait(lambda: tel.position_velocity_ned().position.down_m < -6.0, 60, "climb")
        sticks[2] = 0.5                                     # released: hold
        wait(lambda: abs(tel.position_velocity_ned().velocity.down_m_s) < 0.1, 30, "stopped climbing")
        d0 = tel.position_velocity_ned().position.down_m
        time.sleep(2.0)                # the hold window itself: drift measured over 2 s (MAVSDK has no sim clock)
        d1 = tel.position_velocity_ned().position.down_m
        print(f"HOLD_ALT {abs(d1 - d0):.3f}", flush=True)
        man.start_position_control()
        yaw = math.radians(tel.attitude_euler().yaw_deg)

        def forward():
            v = tel.position_velocity_ned().velocity
            return v.north_m_s * math.cos(yaw) + v.east_m_s * math.sin(yaw)
        sticks[0] = 0.7                                     # forward
        wait(lambda: forward() > 3.0, 30, "forward")
        step("forward")
        sticks[0] = 0.0
        wait(lambda: math.hypot(tel.velocity_ned().north_m_s, tel.velocity_ned().east_m_s) < 0.1, 30, "stopped")
        p0 = tel.position_velocity_ned().position
        time.sleep(2.0)                # the hold window itself, as above
        p1 = tel.position_velocity_ned().position
        print(f"HOLD_POS {math.hypot(p1.north_m - p0.north_m, p1.east_m - p0.east_m):.3f}", flush=True)
        return land_and_finish(act, tel)       # the joystick stays connected until landed
    finally:
        stop.set()


@pytest.mark.timeout(240)
def test_mavsdk_manual_control_flies_alt_hold_and_position(processes, tmp_path):
    from test_sitl_support import run_client_script
    out = run_client_script(processes, tmp_path, __file__, "MAVSDK OK", speedup=2, timeout=200)
    held = {line.split()[0]: float(line.split()[1]) for line in out.splitlines() if line.startswith("HOLD_")}
    assert held["HOLD_ALT"] < 0.5 and held["HOLD_POS"] < 0.5, out[-2000:]
    assert "Radio Failsafe" not in out, out[-2000:]


if __name__ == "__main__":
    sys.exit(client(int(sys.argv[1])))
