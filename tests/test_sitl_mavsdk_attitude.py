"""MAVSDK 4.x's offboard attitude control against the SITL drone, written as MAVSDK's own
offboard attitude example is: arm, a first setpoint, offboard start (GUIDED on ArduPilot),
"go up at 70% thrust", roll 20 deg, back to level, offboard stop, land.

ArduCopter reads the thrust as a climb rate (0.7: +1 m/s with WPNAV_SPEED_UP 2.5 m/s, 0.5:
hold), so the copter lifts off and holds its altitude while it rolls.

As in test_sitl_mavsdk.py the client runs in its own process (this file as a script). The
world runs at 2x: on the ground after arming, ArduCopter's DISARM_DELAY (10 s) disarms the
copter unless a climb comes first, and MAVSDK's calls take wall time.
"""
from __future__ import annotations

import sys

import pytest


def client(port: int) -> int:
    from mavsdk_client import autopilot, land_and_finish, step, wait
    from mavsdk.plugins.action import Action
    from mavsdk.plugins.offboard import Attitude, Offboard
    from mavsdk.plugins.telemetry import Telemetry

    system = autopilot(port)
    tel, act, off = Telemetry(system), Action(system), Offboard(system)

    def healthy():
        h = tel.health()
        return h.is_global_position_ok and h.is_home_position_ok and h.is_armable
    wait(healthy, 30, "health")
    act.arm()
    off.set_attitude(Attitude(0.0, 0.0, 0.0, 0.0))
    off.start()
    step("offboard started")
    off.set_attitude(Attitude(0.0, 0.0, 0.0, 0.7))            # go up at 70% thrust
    wait(lambda: tel.position_velocity_ned().position.down_m < -3.0, 30, "lift off at thrust 0.7")
    step("lifted off")
    off.set_attitude(Attitude(0.0, 0.0, 0.0, 0.5))            # hold
    wait(lambda: abs(tel.position_velocity_ned().velocity.down_m_s) < 0.1, 20, "climb rate 0")
    alt = tel.position_velocity_ned().position.down_m
    off.set_attitude(Attitude(20.0, 0.0, 0.0, 0.5))           # roll 20 deg
    wait(lambda: abs(tel.attitude_euler().roll_deg - 20.0) < 1.0, 20, "20 deg of roll")
    rolls = []

    def sampled():
        rolls.append(tel.attitude_euler().roll_deg)
        return len(rolls) >= 10
    wait(sampled, 10, "roll samples", period=0.1)
    print("ROLL", " ".join(f"{r:.2f}" for r in rolls), flush=True)
    print(f"ALT {alt:.2f} {tel.position_velocity_ned().position.down_m:.2f}", flush=True)
    off.set_attitude(Attitude(0.0, 0.0, 0.0, 0.5))
    wait(lambda: abs(tel.attitude_euler().roll_deg) < 1.0, 20, "level")
    off.stop()
    return land_and_finish(act, tel)


@pytest.mark.timeout(150)
def test_mavsdk_offboard_attitude(processes, tmp_path):
    from test_sitl_support import run_client_script
    out = run_client_script(processes, tmp_path, __file__, "MAVSDK OK", speedup=2)
    rolls = [float(v) for v in next(l for l in out.splitlines() if l.startswith("ROLL")).split()[1:]]
    assert all(abs(r - 20.0) < 1.5 for r in rolls), rolls
    before, during = (float(v) for v in next(l for l in out.splitlines() if l.startswith("ALT")).split()[1:])
    assert before < -3.0 and abs(during - before) < 1.0            # up, and held while rolling


if __name__ == "__main__":
    sys.exit(client(int(sys.argv[1])))
