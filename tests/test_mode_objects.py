"""The flight-mode objects (vehicle/autopilot/mode.py, copter_modes/, rover_modes/) against
ArduPilot's own answers, read from its source:

- ArduCopter/mode.h: each Mode subclass's requires_GPS(), has_manual_throttle(),
  allows_arming(), is_autopilot(), has_user_takeoff(); mode_auto.cpp: ModeAuto::allows_arming
  is AUTO_OPTIONS bit 0 (AllowArming), requires_GPS true outside NAV_ATTITUDE_TIME;
  mode_guided.cpp: ModeGuided::allows_arming is always true from the GCS, from the
  transmitter only with GUID_OPTIONS bit 0.
- Rover/mode.h: requires_position(), requires_velocity(), has_manual_input(),
  is_autopilot_mode(), allows_arming() (defaults true, true, false, false, true).
- GCS_MAVLINK_Rover::base_mode: MANUAL_INPUT_ENABLED from has_manual_input(),
  GUIDED_ENABLED from is_autopilot_mode().

and the structure: every mode number a vehicle names maps to its own Mode subclass in its own
module (no dispatch chain), and mode changes run exit() before the next mode starts.
"""
from __future__ import annotations

import ast
import importlib
from pathlib import Path

import numpy as np
import pytest

from test_autopilot_behaviour import A, _fly, _until, _world
from vehicle.autopilot import modes
from vehicle.autopilot.guided import ACC_BITS, POS_BITS, YAW_IGNORE, YAW_RATE_IGNORE
from vehicle.autopilot.mode import ArmingMethod, Mode

ROOT = Path(__file__).resolve().parent.parent

# ArduCopter/mode.h: (requires_GPS, has_manual_throttle, allows_arming from the GCS, is_autopilot)
COPTER = {
    modes.STABILIZE: (False, True, True, False),
    modes.ALT_HOLD: (False, False, True, False),
    modes.AUTO: (True, False, None, True),          # None: AUTO_OPTIONS bit 0 decides
    modes.GUIDED: (True, False, True, True),
    modes.LOITER: (True, False, True, False),
    modes.RTL: (True, False, False, True),
    modes.LAND: (False, False, False, True),
    modes.POSHOLD: (True, False, True, False),
    modes.BRAKE: (True, False, False, False),
    modes.GUIDED_NOGPS: (False, False, True, True),  # allows_arming: ModeGuided's, inherited
    modes.SMART_RTL: (True, False, False, True),
    modes.FOLLOW: (True, False, False, True),
}
# has_user_takeoff(must_navigate) for must_navigate False, True (default false). GUIDED_NOGPS
# inherits ModeGuided's (True, True) in ArduCopter, whose takeoff it then never flies:
# towerlink refuses the takeoff there (copter_modes/guided_nogps.py says so)
COPTER_USER_TAKEOFF = {modes.ALT_HOLD: (True, False), modes.GUIDED: (True, True), modes.LOITER: (True, True),
                       modes.POSHOLD: (True, True)}
GUIDED_MODES = {modes.GUIDED, modes.GUIDED_NOGPS}           # in_guided_mode()
# where towerlink answers otherwise, and says why in the hook's docstring
COPTER_DIFFERENCES: set = set()      # LAND descends without a position now, as ArduCopter's

# Rover/mode.h: (requires_position, requires_velocity, has_manual_input, is_autopilot_mode, allows_arming)
ROVER = {
    modes.ROVER_MANUAL: (False, False, True, False, True),
    modes.ROVER_ACRO: (False, True, True, False, True),      # velocity: not skid-steered
    modes.ROVER_STEERING: (False, True, True, False, True),
    modes.ROVER_HOLD: (False, False, False, False, True),
    modes.ROVER_LOITER: (True, True, False, True, True),
    modes.ROVER_FOLLOW: (True, True, False, True, True),
    modes.ROVER_AUTO: (True, True, False, True, True),
    modes.ROVER_RTL: (True, True, False, True, False),
    modes.ROVER_SMART_RTL: (True, True, False, True, False),
    modes.ROVER_GUIDED: (True, True, False, True, True),
}


@pytest.fixture(scope="module")
def world():
    return _world(drones=1, rovers=1)


@pytest.fixture(scope="module")
def copter(world):
    return world.vehicles[0].ap


@pytest.fixture(scope="module")
def rover(world):
    return world.vehicles[1].ap


def test_copter_hooks_are_arducopters(copter):
    assert set(copter.flightmodes) == set(COPTER) == set(modes.COPTER_MODES)
    for number, (gps, manual, arming, autopilot) in COPTER.items():
        m = copter.flightmodes[number]
        got = {"requires_position": m.requires_position(), "has_manual_throttle": m.has_manual_throttle(),
               "is_autopilot": m.is_autopilot()}
        want = {"requires_position": gps, "has_manual_throttle": manual, "is_autopilot": autopilot}
        for hook in want:
            if (number, hook) in COPTER_DIFFERENCES:
                assert got[hook] != want[hook]
                assert "ArduCopter" in getattr(type(m), hook).__doc__, (m, hook)
            else:
                assert got[hook] == want[hook], (m, hook)
        if arming is not None:
            assert m.allows_arming(ArmingMethod.MAVLINK) is arming, m
        for must_navigate, want_takeoff in zip((False, True), COPTER_USER_TAKEOFF.get(number, (False, False))):
            assert m.has_user_takeoff(must_navigate) is want_takeoff, (m, must_navigate)
        assert m.in_guided_mode() is (number in GUIDED_MODES)
    # ModeGuided: the GCS always may arm it, the transmitter only with GUID_OPTIONS (not modelled)
    guided = copter.flightmodes[modes.GUIDED]
    assert guided.allows_arming(ArmingMethod.MAVLINK) and not guided.allows_arming(ArmingMethod.RUDDER)


def test_copter_auto_allows_arming_with_auto_options_bit_0(copter):
    auto = copter.flightmodes[modes.AUTO]
    try:
        for options, allowed in ((0, False), (1, True), (2, False), (3, True)):
            assert copter.params.set("AUTO_OPTIONS", options, save=False) is None
            assert auto.allows_arming(ArmingMethod.MAVLINK) is allowed, options
    finally:
        copter.params.set("AUTO_OPTIONS", 0, save=False)


def test_rover_hooks_are_ardurovers(rover):
    assert set(rover.flightmodes) == set(ROVER) == set(modes.ROVER_MODES)
    for number, (position, velocity, manual, autopilot, arming) in ROVER.items():
        m = rover.flightmodes[number]
        assert (m.requires_position(), m.requires_velocity(), m.has_manual_input(), m.is_autopilot(),
                m.allows_arming(ArmingMethod.MAVLINK)) == (position, velocity, manual, autopilot, arming), m
        assert m.in_guided_mode() is (number == modes.ROVER_GUIDED)
        # GCS_MAVLINK_Rover::base_mode
        flags = m.base_mode_flags()
        assert bool(flags & A.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED) is manual
        assert bool(flags & A.MAV_MODE_FLAG_GUIDED_ENABLED) is autopilot


def test_copter_base_mode_flags(copter):
    """ArduCopter: STABILIZE and MANUAL_INPUT always; GUIDED_ENABLED in the modes towerlink
    reports it for (ArduCopter: while its position controller runs)."""
    guided_flag = {modes.AUTO, modes.GUIDED, modes.LOITER, modes.RTL, modes.SMART_RTL, modes.FOLLOW}
    for number, m in copter.flightmodes.items():
        flags = m.base_mode_flags()
        assert flags & A.MAV_MODE_FLAG_STABILIZE_ENABLED and flags & A.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        assert bool(flags & A.MAV_MODE_FLAG_GUIDED_ENABLED) is (number in guided_flag), m


@pytest.mark.parametrize("kind, package, names, counterpart", [
    ("copter", "vehicle.autopilot.copter_modes", modes.COPTER_MODES, "ArduCopter/mode_"),
    ("rover", "vehicle.autopilot.rover_modes", modes.ROVER_MODES, "Rover/mode_")])
def test_each_mode_is_its_own_class_in_its_own_module(world, kind, package, names, counterpart):
    ap = next(v.ap for v in world.vehicles if v.kind == kind)
    seen = set()
    for number, m in ap.flightmodes.items():
        cls = type(m)
        assert isinstance(m, Mode) and cls.number == number and m.name == names[number]
        module = importlib.import_module(cls.__module__)
        assert module.__name__.startswith(package + ".") and module.__name__ not in seen, cls
        seen.add(module.__name__)
        # the module says which ArduPilot mode it is: its file and class
        assert counterpart in module.__doc__ and cls.__name__ in module.__doc__, module.__name__
    assert ap.flightmode is ap.flightmodes[ap.mode]


def test_no_mode_dispatch_chain():
    """Nothing in the autopilot compares the current mode's number: it asks the mode object."""
    for path in sorted((ROOT / "vehicle" / "autopilot").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Compare):
                for side in [node.left, *node.comparators]:
                    assert not (isinstance(side, ast.Attribute) and side.attr == "mode"), \
                        f"{path.relative_to(ROOT)}:{node.lineno} compares .mode"


def test_mode_change_exits_the_old_mode_before_the_new_one_starts():
    """BRAKE then POSHOLD at once: BRAKE's exit gives WPNAV_ACCEL back before POSHOLD's stop
    raises it again (were it the other way round, POSHOLD would stop at WPNAV_ACCEL)."""
    w = _world()
    ap = _fly(w, alt=5.0)
    mask = POS_BITS | ACC_BITS | YAW_IGNORE | YAW_RATE_IGNORE            # a velocity target
    ap.position_target_local(A.MAV_FRAME_LOCAL_NED, mask, (0, 0, 0), (4, 0, 0), (0, 0, 0), 0, 0)
    _until(w, lambda: ap.vel[0] > 3.5, 20)
    assert ap.set_mode(modes.BRAKE) and ap.fleet.params_of(0)["WPNAV_ACCEL"] == 750.0
    assert ap.set_mode(modes.POSHOLD)
    assert ap.fleet.params_of(0)["WPNAV_ACCEL"] > ap.params["WPNAV_ACCEL"]     # POSHOLD's stop
    _until(w, lambda: ap.flightmodes[modes.POSHOLD].stop.stop_time is not None, 15)
    assert ap.fleet.params_of(0)["WPNAV_ACCEL"] == ap.params["WPNAV_ACCEL"]    # given back


def test_failed_init_leaves_the_mode_as_it_was(copter):
    before = copter.flightmode
    assert copter.params.get("FOLL_ENABLE") == 0
    texts = []
    copter.outbox.subscribe(text=lambda sev, t: texts.append(t))
    assert not copter.set_mode(modes.FOLLOW)
    assert copter.flightmode is before
    assert texts[-2:] == ["Set FOLL_ENABLE = 1", "Mode change to FOLLOW failed: init failed"]


def test_pilot_input_is_read_before_every_run():
    w = _world()
    ap = w.vehicles[0].ap
    calls = []
    mode = ap.flightmode
    mode.read_pilot_input = lambda: calls.append(("input", w.t))      # a transmitter plugs in here
    run = mode.run
    mode.run = lambda dt: calls.append(("run", w.t)) or run(dt)
    w.run_for(0.1)
    assert calls and calls[0][0] == "input" and len(calls) % 2 == 0
    assert all(a[0] == "input" and b[0] == "run" and a[1] == b[1] for a, b in zip(calls[::2], calls[1::2]))


def test_pause_and_resume_only_where_the_mode_has_them():
    w = _world()
    ap = _fly(w, alt=5.0)
    for number in (modes.LOITER, modes.ALT_HOLD, modes.RTL):
        assert ap.set_mode(number)
        assert not ap.flightmode.pause() and not ap.flightmode.resume()
    assert ap.set_mode(modes.GUIDED)
    assert ap.flightmode.pause() and ap.flightmode.resume()
    w.run_for(1)
    assert np.linalg.norm(ap.vel) < 1.0 and ap.armed
