"""The tower's pure parts: goal parsing and the mission sequence, on a scripted client."""
from __future__ import annotations

import math

import pytest

from gcs.client import GoalTimeout, Position, Reached
from gcs.tower_mission import Mission, format_goals, parse_goals


def test_parse_goals_defaults_z_to_minus_altitude():
    assert parse_goals("-131.04,73.52; -105.06,88.52", 9.0) == [(-131.04, 73.52, -9.0),
                                                                  (-105.06, 88.52, -9.0)]
    assert parse_goals("1,2,-3", 9.0) == [(1.0, 2.0, -3.0)]
    assert parse_goals("1 2;3 4;", 5) == [(1.0, 2.0, -5.0), (3.0, 4.0, -5.0)]


@pytest.mark.parametrize("bad", ["", "1", "1,2,3,4", "a,b", "nan,1", ";;"])
def test_parse_goals_rejects(bad):
    with pytest.raises(ValueError):
        parse_goals(bad, 9.0)


def test_format_goals_round_trip():
    goals = [(-131.039, 73.524, -9.0), (26.0, 28.0, -12.5)]
    assert parse_goals(format_goals(goals), 9.0) == goals


class FakeState:
    def __init__(self):
        self.armed = False
        self.mode_name = "STABILIZE"


class ScriptedClient:
    """Records calls; the drone 'arrives' at each goal after `legs[i]` sim seconds."""

    def __init__(self, legs, fail_at=None, resends_before_arrival=0):
        self.calls = []
        self.t = 10.0
        self.legs = list(legs)
        self.fail_at = fail_at
        self.resends_before_arrival = resends_before_arrival
        self.state = FakeState()
        self.sent = []

    def wait_heartbeat(self, sysid, timeout):
        self.calls.append(("heartbeat", sysid))

    def system(self, sysid):
        return self.state

    def set_mode(self, mode, sysid, timeout=10):
        self.calls.append(("mode", mode))

    def arm(self, sysid, timeout=30):
        self.calls.append(("arm",))
        self.state.armed = True

    def takeoff(self, alt, sysid, timeout=60, tolerance=0.5):
        self.calls.append(("takeoff", alt))
        self.t += 4.0
        return Position(0, 0, -alt, 0, 0, 0, int(self.t * 1000))

    def sim_time(self, sysid):
        return self.t

    def goto(self, x, y, z, sysid, **kw):
        self.sent.append((x, y, z))

    def goto_named(self, frame, x, y, z, sysid, **kw):
        self.sent.append((frame, x, y, z))

    def wait_reached(self, goal, radius, timeout, *, sysid, resend, resend_interval, after_ms):
        i = len([c for c in self.calls if c[0] == "wait"])
        self.calls.append(("wait", tuple(goal), radius, after_ms))
        if self.fail_at == i:
            raise GoalTimeout(goal, radius, 3.2, timeout)
        for _ in range(self.resends_before_arrival):
            resend()
        self.t += self.legs[i]
        p = Position(goal[0] + 0.1, goal[1], goal[2], 0, 0, 0, int(round(self.t * 1000)))
        return Reached(p, 0.1)

    def land(self, sysid, timeout=60):
        self.calls.append(("land",))
        self.t += 5

    def rtl(self, sysid, timeout=60):
        self.calls.append(("rtl",))


GOALS = [(-131.039, 73.524, -9.0), (-105.058, 88.524, -9.0), (-120.058, 114.504, -9.0)]


def test_mission_sequence_and_sim_times():
    c = ScriptedClient(legs=[3.0, 8.5, 8.25], resends_before_arrival=2)
    logs = []
    r = Mission(c, GOALS, altitude=9.0, radius=0.5, log=logs.append).run()
    assert r.ok and r.finished
    kinds = [k[0] for k in c.calls]
    assert kinds == ["heartbeat", "mode", "arm", "takeoff", "wait", "wait", "wait", "land"]
    assert ("mode", "GUIDED") in c.calls and ("takeoff", 9.0) in c.calls
    # one send per goal plus the resends, in order, in the tower frame
    assert c.sent == [g for g in GOALS for _ in range(3)]
    assert [g.time_to_reach for g in r.goals] == pytest.approx([3.0, 8.5, 8.25])
    assert r.goals[0].sent_sim == pytest.approx(14.0)      # after the 4 s takeoff
    assert r.goals[1].sent_sim == pytest.approx(r.goals[0].reached_sim)
    # only samples after the send count
    assert [w[3] for w in c.calls if w[0] == "wait"] == [14000, 17000, 25500]
    assert all(g.sends == 3 for g in r.goals)
    assert any("goal 2/3 reached" in s for s in logs)
    d = r.to_json()
    assert d["goals"][2]["time_to_reach"] == pytest.approx(8.25)


def test_mission_failure_stops_sequence_and_still_lands():
    c = ScriptedClient(legs=[3.0, 8.5, 8.25], fail_at=1)
    logs = []
    r = Mission(c, GOALS, altitude=9.0, radius=0.5, finish="land", log=logs.append).run()
    assert not r.ok
    assert [g.reached for g in r.goals] == [True, False, False]
    assert r.goals[1].distance == pytest.approx(3.2)
    assert "not reached" in r.goals[1].error
    assert c.calls[-1] == ("land",) and r.finished
    assert any("goal 2/3 FAILED" in s for s in logs)


def test_mission_named_frame_and_rtl():
    c = ScriptedClient(legs=[1, 1, 1])
    r = Mission(c, GOALS, altitude=9.0, radius=1.0, frame="world", finish="rtl", log=lambda s: None).run()
    assert r.ok
    assert c.sent[0][0] == "world"
    assert c.calls[-1] == ("rtl",)


def test_mission_error_before_takeoff_does_not_land():
    class NoDrone(ScriptedClient):
        def wait_heartbeat(self, sysid, timeout):
            from gcs.client import HeartbeatTimeout
            raise HeartbeatTimeout("no heartbeat from system 1 in 1 s")

    c = NoDrone(legs=[1])
    r = Mission(c, GOALS[:1], altitude=9.0, radius=1.0, log=lambda s: None).run()
    assert not r.ok and "HeartbeatTimeout" in r.error
    assert ("land",) not in c.calls


def test_position_distance():
    p = Position(3.0, 4.0, -9.0, 0, 0, 0, 1500)
    assert p.t == 1.5
    assert p.distance_to((0, 0, -9.0)) == pytest.approx(5.0)
    assert p.distance_to((0, 0, 0), horizontal=True) == pytest.approx(5.0)
    assert p.distance_to((0, 0, 0)) == pytest.approx(math.sqrt(25 + 81))
