"""A scenario's [[faults]] (common.scenario_faults) and the run's resolved timeline
(tools.fault_timeline): parsed, checked with messages that say where and why."""
from __future__ import annotations

import pytest

from common.link_settings import LinkSettings
from common.scenario import DEFAULT_SCENARIO, ScenarioError, load_scenario
from common.scenario_faults import Fault
from tools.fault_timeline import FaultTimeline
from tools.vehicle_params import param_table


def scenario(tmp_path, faults: str, base=DEFAULT_SCENARIO):
    p = tmp_path / "s.toml"
    # a top-level key goes before the scenario's tables, [[faults]] after them
    p.write_text(faults + "\n" + base.read_text() if not faults.lstrip().startswith("[") else base.read_text() + "\n" + faults)
    return load_scenario(p)


FAULTS = '''
[[faults]]
t = 12.0
target = "tower_link"
loss = 1.0
up.latency = 0.3
down = { bandwidth = 4000 }
until = 20

[[faults]]
t = 30
target = "drone"
SIM_BATT_VOLTAGE = 10.0

[[faults]]
t = 31
target = "vehicle:1"
FS_GCS_ENABLE = 1
'''


def test_faults_are_parsed(tmp_path):
    sc = scenario(tmp_path, FAULTS)
    a, b, c = sc.faults
    assert a == Fault(0, 12.0, "tower_link", None, link=(("loss", 1.0), ("up.latency", 0.3),
                                                           ("down.bandwidth", 4000.0)), until=20.0)
    assert a.describe() == "t 12 tower_link loss=1 up.latency=0.3 down.bandwidth=4000 until 20"
    assert (b.sysid, b.params, b.until) == (1, (("SIM_BATT_VOLTAGE", 10.0),), None)
    assert (c.sysid, c.target) == (2, "vehicle:1")
    d = scenario(tmp_path, '[[faults]]\nt = 4\nduration = 2.5\ntarget = "rover"\nX = 1\n').faults[0]
    assert d.until == 6.5
    assert load_scenario().faults == ()


def test_faults_of_a_family_name_its_vehicles(tmp_path):
    family = DEFAULT_SCENARIO.with_name("family.toml")
    sc = scenario(tmp_path, '[[faults]]\nt = 1\ntarget = "rover2"\nSIM_BATT_VOLTAGE = 9\n', base=family)
    assert sc.faults[0].sysid == dict((n, s) for n, s, _k in sc.vehicles)["rover2"]


@pytest.mark.parametrize("text, why", [
    ('faults = 3', r"faults must be a list of \[\[faults\]\] tables"),
    ('[[faults]]\ntarget = "drone"\nSIM_BATT_VOLTAGE = 1', r"faults\[0\]: no t "),
    ('[[faults]]\nt = 1\nSIM_BATT_VOLTAGE = 1', r"faults\[0\]: no target"),
    ('[[faults]]\nt = -1\ntarget = "drone"\nX = 1', r"faults\[0\].t -1 s is outside"),
    ('[[faults]]\nt = "soon"\ntarget = "drone"\nX = 1', r"faults\[0\].t must be a finite number"),
    ('[[faults]]\nt = 5\nuntil = 5\ntarget = "drone"\nX = 1', "until 5 s is not after t 5 s"),
    ('[[faults]]\nt = 5\nduration = 0\ntarget = "drone"\nX = 1', "duration must be > 0 s"),
    ('[[faults]]\nt = 5\nduration = 1\nuntil = 9\ntarget = "drone"\nX = 1', "until .* or duration .*, not both"),
    ('[[faults]]\nt = 1\ntarget = "plane"\nX = 1', "target 'plane' is not 'tower_link', 'drone', 'rover'"),
    ('[[faults]]\nt = 1\ntarget = "vehicle:2"\nX = 1', "target 'vehicle:2' is not"),
    ('[[faults]]\nt = 1\ntarget = "drone"', "sets at least one parameter"),
    ('[[faults]]\nt = 1\ntarget = "drone"\nloss = 0.5', "'loss' is not a parameter name"),
    ('[[faults]]\nt = 1\ntarget = "drone"\nSIM_BATT_VOLTAGE = "low"', r"SIM_BATT_VOLTAGE must be a finite number"),
    ('[[faults]]\nt = 1\ntarget = "tower_link"', "changes at least one link setting"),
    ('[[faults]]\nt = 1\ntarget = "tower_link"\nlag = 1', "'lag' is not a link setting"),
    ('[[faults]]\nt = 1\ntarget = "tower_link"\nloss = 1.5', r"faults\[0\].loss: link setting loss 1.5 is outside 0..1"),
    ('[[faults]]\nt = 1\ntarget = "tower_link"\nup = { jitter = -1 }', r"faults\[0\].up.jitter: .* outside"),
    ('[[faults]]\nt = 1\ntarget = "tower_link"\nFS_GCS_ENABLE = 1', "parameters belong to a vehicle's fault"),
])
def test_bad_faults_say_where_and_why(tmp_path, text, why):
    with pytest.raises(ScenarioError, match=why):
        scenario(tmp_path, text)


def timeline(faults, base=None, start=None):
    return FaultTimeline(faults, base, {1: "copter", 2: "rover"},
                         {"copter": param_table("copter"), "rover": param_table("rover")}, start)


def test_the_timeline_orders_events_and_restores_the_start_values(tmp_path):
    sc = scenario(tmp_path, FAULTS + '\n[[faults]]\nt = 40\nuntil = 50\ntarget = "drone"\nWPNAV_SPEED = 300\n')
    tl = timeline(sc.faults, start={"WPNAV_SPEED": 800})
    assert [(e.t, e.fault, e.kind) for e in tl.events] == [
        (12.0, 0, "apply"), (20.0, 0, "clear"), (30.0, 1, "apply"), (31.0, 2, "apply"), (40.0, 3, "apply"),
        (50.0, 3, "clear")]
    clear = tl.events[-1].params[0]
    assert (clear.sysid, clear.name, clear.value) == (1, "WPNAV_SPEED", 800.0)      # the run's own value
    batt = tl.events[2].params[0]
    assert (batt.name, batt.value, batt.ptype) == ("SIM_BATT_VOLTAGE", 10.0, 9)     # MAV_PARAM_TYPE_REAL32
    c = tl.cursor()
    assert [e.t for e in c.advance(19.99)] == [12.0] and [e.t for e in c.advance(31)] == [20.0, 30.0, 31.0]
    assert c.advance(31) == []


def test_the_link_over_time_is_the_run_s_own_under_the_active_faults(tmp_path):
    sc = scenario(tmp_path, FAULTS + '\n[[faults]]\nt = 15\ntarget = "tower_link"\nloss = 0.2\n')
    base = {"up": LinkSettings(latency=0.1), "down": LinkSettings(latency=0.1)}
    tl = timeline(sc.faults, base)
    assert tl.link_at(0) == base and tl.touches_link
    assert tl.link_at(12.0) == {"up": LinkSettings(loss=1.0, latency=0.3),
                                "down": LinkSettings(loss=1.0, latency=0.1, bandwidth=4000)}
    assert tl.link_at(15.0)["up"].loss == 0.2               # written later: applied over the earlier one
    assert tl.link_at(20.0) == {d: LinkSettings(loss=0.2, latency=0.1) for d in ("up", "down")}
    assert not timeline([]).touches_link


@pytest.mark.parametrize("text, why", [
    ('SIM_BATT_VOLTAG = 10', "the copter has no parameter SIM_BATT_VOLTAG \\(did you mean SIM_BATT_VOLTAGE\\?\\)"),
    ('SIM_BATT_VOLTAGE = 1000', "SIM_BATT_VOLTAGE 1000 is outside 0..100"),
    ('FS_GCS_ENABLE = 0.5', "FS_GCS_ENABLE 0.5 is outside 0..6, a whole number"),
])
def test_the_timeline_checks_each_vehicle_s_parameters(tmp_path, text, why):
    sc = scenario(tmp_path, f'[[faults]]\nt = 1\ntarget = "drone"\n{text}\n')
    with pytest.raises(ValueError, match=why):
        timeline(sc.faults)
