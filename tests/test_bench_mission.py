"""tools/bench_mission.py smoke run on a short mission: every waypoint reached in order and the
flight time sane against the legs' minimum times (the benchmark itself prints the 1 km figure)."""
from __future__ import annotations

from tools.bench_mission import fly, waypoints


def test_short_mission_figure_is_sane():
    legs = (30.0, 40.0)
    assert [round(float(abs(p).sum()), 6) for p in waypoints(legs)] == [30.0, 70.0]
    r = fly(legs)
    assert r["reached"][:3] == [1, 2, 3]
    assert r["legs_m"] == 70.0
    # rest-to-rest minimum vs a flight that switches waypoint 2 m early: close, not equal
    assert 0.8 < r["flight_s"] / r["min_s"] < 1.2, r
