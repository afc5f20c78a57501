"""A failsafe under test: the ground station goes silent and the drone lands by itself.

FS_GCS_ENABLE 5 (ArduCopter: LAND on GCS failsafe) with FS_GCS_TIMEOUT 3 s, given to the
world by the marker's ``params``. The pymavlink script sends GCS heartbeats while it flies,
then stops. The vehicle's timeout counts sim seconds, so the script's heartbeats must come
often enough at the world's speed: every 0.05 s wall is every 0.5 s sim at speedup 10.

    pytest examples/pytest/test_gcs_failsafe.py
"""
import threading

import pytest
from pymavlink import mavutil

mav = mavutil.mavlink


class Heartbeats:
    """A GCS heartbeat every `period` wall s on connection `m` until stop()."""

    def __init__(self, m, period: float = 0.05) -> None:
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(m, period), daemon=True)
        self._thread.start()

    def _run(self, m, period: float) -> None:
        while not self._stop.wait(period):
            m.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, mav.MAV_STATE_ACTIVE)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()


@pytest.mark.towerlink(drones=1, speedup=10, params={"FS_GCS_ENABLE": 5, "FS_GCS_TIMEOUT": 3})
def test_silent_gcs_makes_the_drone_land(towerlink_sitl):
    sitl = towerlink_sitl
    m = mavutil.mavlink_connection(sitl.connection(0), source_system=255)
    m.wait_heartbeat(timeout=5)
    beats = Heartbeats(m)
    m.set_mode("GUIDED")
    m.arducopter_arm()
    m.motors_armed_wait()
    m.mav.command_long_send(m.target_system, m.target_component, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, 6)
    sitl.wait_for(lambda: sitl.vehicle(0).height > 5.5, sim_timeout=20, what="6 m")
    sitl.wait_for(lambda: sitl.vehicle(0).speed < 0.1, sim_timeout=5, what="hovering")   # still GUIDED
    assert sitl.vehicle(0).mode == "GUIDED"

    beats.stop()                                   # the ground station is gone
    lost_at = sitl.time
    sitl.wait_for(lambda: sitl.vehicle(0).mode == "LAND", sim_timeout=6, what="GCS failsafe: LAND")
    # FS_GCS_TIMEOUT after the last heartbeat the vehicle heard: up to one period (0.5 s sim)
    # before the script stopped, plus the time the world took to read it (its I/O turns come
    # every 20 ms wall, 0.2 s sim at 10x), so never much earlier and never later
    assert 3.0 - 1.0 <= sitl.time - lost_at <= 3.0 + 0.2
    sitl.wait_for(lambda: sitl.vehicle(0).landed, sim_timeout=30, what="landed")
    assert abs(sitl.vehicle(0).north) < 1.0        # it landed where it was, not at some RTL point
    m.close()
