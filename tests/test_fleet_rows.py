"""fleet.estimate_rows / truth_row (the per-step snapshots the autopilots and SIM_STATE of a
big world read) give exactly estimate(i) / truth(i), and a fresh snapshot after every step."""
from __future__ import annotations

import numpy as np
import pytest

from vehicle.fleet import CopterFleet, RoverFleet, Setpoint
from vehicle.fleet_base import SCALAR_MAX


def _fleets():
    n = SCALAR_MAX + 3                       # vector fleets; and a scalar one
    home = np.column_stack([np.arange(n) * 3.0, np.zeros(n), np.zeros(n)])
    return [("copter, estimator", CopterFleet(n, seed=1, home=home)),
            ("copter, truth", CopterFleet(n, seed=1, home=home, estimator=False)),
            ("rover, estimator", RoverFleet(n, seed=2, home=home)),
            ("copter, scalar", CopterFleet(2, seed=3, home=home[:2]))]


@pytest.mark.parametrize("name,fleet", _fleets(), ids=lambda x: x if isinstance(x, str) else "")
def test_rows_are_the_estimate_and_the_truth_at_every_step(name, fleet):
    for i in range(fleet.n):
        fleet.set_armed(i, True)
        fleet.set_setpoint(i, Setpoint(pos=fleet.home[i] + [4.0, -2.0, -5.0]))
    for step in range(120):
        fleet.step(0.0025)
        if step % 7:
            continue
        for i in range(fleet.n):
            e, rows = fleet.estimate(i), fleet.estimate_rows(i)
            for want, got in zip((e.pos, e.vel, e.quat, e.rates), rows):
                assert np.array_equal(want, got)
            tr = fleet.truth(i)
            want = np.concatenate([tr.pos, tr.vel, tr.quat, tr.rates, tr.acc]).tolist()
            assert fleet.truth_row(i) == want
            assert all(type(v) is float for v in fleet.truth_row(i))


def test_vector_rows_are_read_only_views():
    fleet = CopterFleet(SCALAR_MAX + 1, seed=0)
    fleet.step(0.0025)
    pos = fleet.estimate_rows(0)[0]
    with pytest.raises(ValueError):
        pos[0] = 1.0                          # a row is shared by the step's readers
    before = pos.copy()
    fleet.set_armed(0, True)
    fleet.set_setpoint(0, Setpoint(pos=[0.0, 0.0, -3.0]))
    for _ in range(40):
        fleet.step(0.0025)
    assert np.array_equal(pos, before)        # an old row keeps its step's value
    assert not np.array_equal(fleet.estimate_rows(0)[0], before)
