"""A script written with towerlink's own client (gcs.client), tested in lockstep.

With ``lockstep=True`` the world takes the test's client as a participant: it never steps
past a TICK (every 40 ms sim) until the client has acted on it, and the client's waits and
retries run on those TICKs. What the script does then depends on the sim alone, never on
the machine's speed or load: the numbers asserted below are exact, and the same at
``--towerlink-speedup 1`` as at ``max`` (tests/test_pytest_plugin_lockstep.py proves it).

    pytest examples/pytest/test_tower_client_lockstep.py
"""
import pytest

GOAL = (20.0, 10.0, -8.0)           # local NED of the drone (from its EKF origin), m


def mission(c, sysid: int = 1) -> dict:
    """The script under test: GUIDED, arm, take off to 8 m, go to GOAL, land. Returns when
    (vehicle sim time, s) each step was done."""
    c.wait_heartbeat(sysid=sysid, timeout=10)
    c.set_mode("GUIDED", sysid=sysid)
    c.arm(sysid=sysid)
    c.takeoff(8.0, sysid=sysid)
    took_off = c.sim_time(sysid)
    c.goto(*GOAL, sysid=sysid)
    reached = c.wait_reached(GOAL, radius=0.5, timeout=60, sysid=sysid,
                             resend=lambda: c.goto(*GOAL, sysid=sysid))
    at_goal = c.sim_time(sysid)
    c.land(sysid=sysid)
    return {"took_off": took_off, "at_goal": at_goal, "landed": c.sim_time(sysid), "reached": reached}


@pytest.mark.towerlink(drones=1, lockstep=True)
def test_client_flight_is_the_same_at_any_speed(towerlink_sitl):
    sitl = towerlink_sitl
    c = sitl.client(0)                 # a lockstep participant for vehicle 0
    times = mission(c)
    assert times["took_off"] < times["at_goal"] < times["landed"]
    assert times["reached"].distance <= 0.5
    v = sitl.vehicle(0)                # the world stands at the client's TICK: exact numbers
    assert v.landed and not v.armed
    assert v.distance_to(GOAL[0], GOAL[1]) < 1.5
