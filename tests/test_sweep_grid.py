"""The sweep's pure cores: plans, factors, validation, run ids, scenario copies, fly arguments."""
from __future__ import annotations

import math
import tomllib

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from common.scenario import DEFAULT_SCENARIO, ScenarioError, _build
from tools import sweep_grid as g
from tools.sweep_grid import Plan, SweepError

SC = tomllib.loads(DEFAULT_SCENARIO.read_text())


def expand(plan: Plan, **kw):
    return g.expand(plan, SC, "digest", validate_scenario=lambda d: _build(d, DEFAULT_SCENARIO), **kw)


def test_grid_is_the_cartesian_product_with_each_value_checked_and_typed():
    plan = g.apply_cli(Plan(), ["follow_frame=drone,drone_yaw", "tower_loss=0,0.2"], "1-3")
    runs = expand(plan)
    assert len(runs) == 12
    combos = {(r.factors["follow_frame"], r.factors["tower_loss"], r.factors["seed"]) for r in runs}
    assert combos == {(f, l, s) for f in ("drone", "drone_yaw") for l in (0.0, 0.2) for s in (1, 2, 3)}
    assert all(isinstance(r.factors["tower_loss"], float) and isinstance(r.factors["seed"], int) for r in runs)
    assert g.varying_factors(runs) == ["follow_frame", "tower_loss", "seed"]


def test_seed_1_when_no_factor_names_a_seed():
    runs = expand(g.apply_cli(Plan(), ["tower_loss=0.1"]))
    assert [r.factors for r in runs] == [{"tower_loss": 0.1, "seed": 1}]


def test_sweep_file_grid_crossed_with_its_explicit_runs():
    plan = g.plan_from_toml("""
seeds = [4, 5]
timeout = 90
[grid]
WPNAV_SPEED = [300, 800]
[[runs]]
"mission.altitude" = 6.0
[[runs]]
"mission.altitude" = 12.0
wind = [8, 90]
""")
    assert plan.timeout == 90.0
    runs = expand(plan)
    assert len(runs) == 2 * 2 * 2
    alt12 = [r for r in runs if r.factors["mission.altitude"] == 12.0]
    # a bare [speed, direction] keeps the scenario's (calm: 0) turbulence
    assert all(r.factors["wind"] == [8.0, 90.0, 0.0] for r in alt12)
    assert {r.factors["WPNAV_SPEED"] for r in runs} == {300.0, 800.0}


def test_command_line_replaces_the_files_factor():
    plan = g.plan_from_toml('[grid]\ntower_loss = [0.1, 0.2]\n')
    g.apply_cli(plan, ["tower_loss=0.5"])
    assert [r.factors["tower_loss"] for r in expand(plan)] == [0.5]


@pytest.mark.parametrize("sets, message", [
    (["tower_los=0"], "unknown factor 'tower_los' (did you mean tower_loss?)"),
    (["WPNAV_SPED=300"], "unknown parameter 'WPNAV_SPED' (did you mean WPNAV_SPEED?)"),
    (["WPNAV_SPEED=5"], "WPNAV_SPEED: 5 is outside its range 20..2000"),
    (["tower_loss=1"], "tower_loss: 1 is outside 0 <= loss < 1"),
    (["tower_loss=lots"], "tower_loss: 'lots' is not a finite number"),
    (["follow_frame=base_link"], "follow_frame: 'base_link' is not one of drone, drone_yaw"),
    (["finish=crash"], "finish: 'crash' is not one of land, rtl, none"),
    (["seed=-1"], "seed: '-1' is not a whole number"),
    (["seed=1.5"], "seed: '1.5' is not a whole number"),
    (["wind=41"], "wind: speed 41 m/s is outside 0..40"),
    (["wind=[5,400]"], "wind: direction 400 deg is outside 0..360"),
    (["mission.altitud=3"], "unknown factor 'mission.altitud' (did you mean mission.altitude?)"),
    (["mission.radius=-1"], "mission.radius -1.0 m is outside"),     # the scenario's own check
    (["tower_loss"], "write FACTOR=V1,V2"),
    (["tower_loss=0,,1"], "an empty value"),
    (["Tower-Loss=1"], "unknown factor 'Tower-Loss'"),
])
def test_bad_factors_are_refused_up_front_with_a_clear_message(sets, message):
    with pytest.raises(SweepError) as e:
        expand(g.apply_cli(Plan(), sets))
    assert message in str(e.value)


def test_a_run_and_the_grid_setting_the_same_factor_is_refused():
    plan = g.plan_from_toml('[grid]\nseed = [1, 2]\n[[runs]]\nseed = 3\n')
    with pytest.raises(SweepError, match=r"runs\[0\] sets seed, which the grid also sweeps"):
        expand(plan)


@pytest.mark.parametrize("text, message", [
    ("grid = 3", "[grid] must be a table"),
    ("colour = 'red'", "unknown key(s) colour"),
    ("timeout = -5", "timeout must be > 0"),
    ("[grid\n", "not valid TOML"),
    ("seeds = '1-x'", "seeds: '1-x' is not a seed or a range"),
])
def test_bad_sweep_files_are_refused(text, message):
    with pytest.raises(SweepError) as e:
        g.plan_from_toml(text, where="bad.toml")
    assert message in str(e.value)


@pytest.mark.parametrize("spec, seeds", [("1-4", [1, 2, 3, 4]), ("1,3,5", [1, 3, 5]), ("2-3,9", [2, 3, 9]),
                                         ("3,3,1-3", [3, 1, 2]), (7, [7]), ([2, 1], [2, 1])])
def test_parse_seeds(spec, seeds):
    assert g.parse_seeds(spec) == seeds


def test_split_values_keeps_lists_and_quoted_commas_whole():
    assert g.split_values('0,[8,270,1],{speed=3, direction=90}, "a,b"') == \
        ["0", "[8,270,1]", "{speed=3, direction=90}", '"a,b"']
    assert [g.parse_value(v) for v in g.split_values('0.2,drone,[1,2],"x,y",true')] == \
        [0.2, "drone", [1, 2], "x,y", True]


@given(st.dictionaries(st.sampled_from(["seed", "tower_loss", "follow_frame", "WPNAV_SPEED", "mission.altitude"]),
                       st.one_of(st.integers(0, 10 ** 6), st.floats(allow_nan=False, allow_infinity=False),
                                 st.text(max_size=8)), min_size=1))
def test_run_ids_depend_on_the_factors_not_their_order(factors):
    rid = g.run_id(factors, "d")
    assert rid == g.run_id(dict(reversed(list(factors.items()))), "d")
    assert rid.startswith("r") and len(rid) == 12
    assert g.run_id(factors, "other scenario") != rid
    changed = dict(factors, extra_factor=1)
    assert g.run_id(changed, "d") != rid


def test_run_ids_are_stable_across_versions():
    # the resume promise: these exact ids name these runs' folders on disk
    assert g.run_id({"seed": 1}, "") == g.run_id({"seed": 1}, "")
    assert g.run_id({"seed": 1, "tower_loss": 0.2}, "abc") != g.run_id({"seed": 1, "tower_loss": 0.0}, "abc")
    assert g.run_id({"seed": 1}, "") == "r" + __import__("hashlib").sha256(
        b'{"factors":{"seed":1},"scenario":""}').hexdigest()[:11]


def test_scenario_copy_changes_only_the_swept_keys():
    copy = g.scenario_copy(SC, {"seed": 3, "mission.altitude": 12.0, "wind": [8.0, 270.0, 1.0],
                                "follow.offset": [-2.0, 0.0]})
    assert copy["mission"]["altitude"] == 12.0
    assert copy["wind"] == {"speed": 8.0, "direction": 270.0, "turbulence": 1.0}
    assert copy["follow"]["offset"] == [-2.0, 0.0]
    assert copy["mission"]["goals"] == SC["mission"]["goals"] and SC["mission"]["altitude"] == 9.0
    sc = _build(tomllib.loads(g.to_toml(copy)), DEFAULT_SCENARIO)    # what the run flies
    assert sc.altitude == 12.0 and sc.wind == (8.0, 270.0, 1.0) and sc.follow_offset == (-2.0, 0.0)
    assert g.scenario_copy(SC, {"seed": 3, "tower_loss": 0.2, "WPNAV_SPEED": 300.0}) is None


def test_fly_args_for_a_run():
    args = g.fly_args({"seed": 4, "tower_loss": 0.2, "follow_frame": "drone", "finish": "none",
                       "WPNAV_SPEED": 300.0, "FS_GCS_ENABLE": 1}, "/s.toml", "/out/r1", timeout=120)
    assert args[:6] == ["fly", "/s.toml", "--lockstep", "--speedup", "max", "--quiet"]
    pairs = dict(zip(args[6::2], args[7::2]))
    assert pairs["--seed"] == "4" and pairs["--out"] == "/out/r1" and pairs["--timeout"] == "120"
    assert pairs["--tower-loss"] == "0.2" and pairs["--follow-frame"] == "drone" and pairs["--finish"] == "none"
    assert [args[i + 1] for i, a in enumerate(args) if a == "--param"] == ["WPNAV_SPEED=300", "FS_GCS_ENABLE=1"]


def test_fly_parses_what_the_sweep_passes():
    import argparse
    from tools import fly
    p = argparse.ArgumentParser()
    fly.add_arguments(p)
    a = p.parse_args(g.fly_args({"seed": 2, "tower_loss": 0.1, "WPNAV_SPEED": 300.0}, "/s.toml", "/o",
                                timeout=60, goal_timeout=30)[1:])
    assert (a.scenario, a.lockstep, math.isinf(a.speedup), a.seed, a.tower_loss, a.param, a.goal_timeout, a.helpers) == \
        ("/s.toml", True, True, 2, 0.1, ["WPNAV_SPEED=300"], 30.0, False)


toml_values = st.recursive(
    st.one_of(st.booleans(), st.integers(-2 ** 63, 2 ** 63 - 1), st.floats(allow_nan=False),
              st.text(max_size=12)),
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.text(min_size=1, max_size=6), inner, max_size=4)),
    max_leaves=12)


@settings(max_examples=200)
@given(st.dictionaries(st.text(min_size=1, max_size=8), toml_values, max_size=6))
@example({"0\n": []})           # a key ending in a newline once passed as a bare key
def test_to_toml_round_trips_through_tomllib(data):
    assert tomllib.loads(g.to_toml(data)) == data


def test_the_default_scenario_round_trips():
    assert tomllib.loads(g.to_toml(SC)) == SC


def test_scenario_errors_are_scenario_errors():
    with pytest.raises(ScenarioError):
        _build(g.scenario_copy(SC, {"mission.finish": "crash"}), DEFAULT_SCENARIO)


@pytest.mark.parametrize("item", ["=5", "WPNAV_SPEED", "WPNAV_SPEED=fast"])
def test_fly_param_without_a_name_or_a_number_is_refused_before_anything_starts(tmp_path, capsys, item):
    from tools.cli import main
    rc = main(["fly", "--param", item, "--out", str(tmp_path / "run")])
    assert rc == 2
    assert f"towerlink fly: --param {item!r}: write NAME=VALUE, e.g. WPNAV_SPEED=300" in capsys.readouterr().err
    assert not (tmp_path / "run" / "params.parm").exists()


# the example sweep's scenario: fault 0 the tower link down at t = 20 for 10 s, fault 1 the drone's battery
FAULTS_LAB = DEFAULT_SCENARIO.parent.parent.parent / "examples" / "sweep" / "faults_lab.toml"
FAULTED = tomllib.loads(FAULTS_LAB.read_text())


def test_tower_link_settings_and_a_fault_s_values_are_factors():
    plan = g.apply_cli(Plan(), ["tower_link.latency=0,0.2", "tower_link.up.loss=0.1", "faults.0.t=15,20",
                                "faults.1.SIM_BATT_VOLTAGE=10.5"])
    runs = g.expand(plan, FAULTED, "d", validate_scenario=lambda d: _build(d, FAULTS_LAB))
    assert len(runs) == 4 and g.varying_factors(runs) == ["tower_link.latency", "faults.0.t"]
    r = next(r for r in runs if r.factors["tower_link.latency"] == 0.2 and r.factors["faults.0.t"] == 15)
    copy = g.scenario_copy(FAULTED, r.factors)
    sc = _build(tomllib.loads(g.to_toml(copy)), FAULTS_LAB)             # what the run flies
    assert sc.faults[0].t == 15.0 and sc.faults[1].params == (("SIM_BATT_VOLTAGE", 10.5),)
    assert FAULTED["faults"][0]["t"] == 20                                # the plan's own is untouched
    assert (sc.faults[0].until, sc.faults[1].t) == (25.0, 30.0)           # duration 10 after t 15
    args = g.fly_args(r.factors, "/s.toml", "/o", timeout=60)
    assert args[args.index("--tower-link") + 1] == "latency=0.2,up.loss=0.1"
    from tools import fly
    import argparse
    p = argparse.ArgumentParser()
    fly.add_arguments(p)
    assert p.parse_args(args[1:]).tower_link == "latency=0.2,up.loss=0.1"


@pytest.mark.parametrize("sets, message", [
    (["tower_link.lag=1"], "tower_link.lag: unknown link setting 'lag'"),
    (["tower_link.side.loss=0.1"], "tower_link.side.loss: link setting 'side.loss': write NAME, up.NAME or down.NAME"),
    (["tower_link.loss=2"], "tower_link.loss: link setting loss 2 is outside 0..1"),
    (["tower_link.latency=soon"], "tower_link.latency: 'soon' is not a finite number"),
    (["faults.2.t=5"], "unknown factor 'faults.2.t'"),
    (["faults.0.duration=0"], "faults[0]: duration must be > 0 s"),          # the scenario's own check
])
def test_bad_fault_factors_are_refused_up_front(sets, message):
    with pytest.raises(SweepError) as e:
        g.expand(g.apply_cli(Plan(), sets), FAULTED, "d", validate_scenario=lambda d: _build(d, FAULTS_LAB))
    assert message in str(e.value)
