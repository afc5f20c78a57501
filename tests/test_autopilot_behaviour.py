"""Autopilot behaviours no test watched (issue 8, "the test suite's own blind spots"), in-process
on the real World (fleet physics, estimator, autopilot, link) stepped in sim time:
rover unknown command, GUIDED target timeout and failsafe actions; copter RTL climb before
return, auto-disarm after DISARM_DELAY, FS_GCS_ENABLE actions, FS_GCS_ENABLE=0; the commanded
jerk bound of the shaped position target."""
from __future__ import annotations


import numpy as np
import pytest

from test_sitl_support import mav
from vehicle.autopilot import modes
from vehicle.autopilot.guided import ACC_BITS, POS_BITS, VEL_BITS, YAW_IGNORE, YAW_RATE_IGNORE
from vehicle.world import World, WorldConfig

A = mav


def _world(drones=1, rovers=0) -> World:
    w = World(WorldConfig(drones=drones, rovers=rovers, state_dir=None, tcp_base=None, udp_base=None))
    _until(w, lambda: all(v.ap.est_ok and v.ap.home is not None for v in w.vehicles), 10)
    return w


def _until(w: World, cond, sim_s: float, step: float = 0.02):
    """Step sim time until cond() or sim_s seconds pass; returns the sim time it took (raises on timeout)."""
    t0 = w.t
    while not cond():
        if w.t - t0 > sim_s:
            raise AssertionError(f"not within {sim_s} sim s")
        w.run_for(step)
    return w.t - t0


def _fly(w: World, alt=5.0):
    ap = w.vehicles[0].ap
    assert ap.set_mode(modes.GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    assert ap.command(A.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, alt]) == A.MAV_RESULT_ACCEPTED
    _until(w, lambda: ap.pos[2] < -(alt - 0.2), 30)
    return ap


def _goto(ap, x, y, z):
    """GUIDED to world NED (x, y, z), the frame ap.pos is in; on the wire LOCAL_NED is from
    the vehicle's own EKF origin (where it booted), so the point is sent in that frame."""
    mask = VEL_BITS | ACC_BITS | YAW_IGNORE | YAW_RATE_IGNORE
    local = ap.local_origin.to_local((x, y, z))
    assert ap.position_target_local(A.MAV_FRAME_LOCAL_NED, mask, tuple(local), (0, 0, 0), (0, 0, 0), 0, 0)


# ---------------------------------------------------------------- rover

def _with_texts(w: World):
    """(world, its first vehicle's autopilot, the STATUSTEXTs it says from now on)."""
    ap = w.vehicles[0].ap
    texts = []
    ap.outbox.subscribe(text=lambda sev, t: texts.append(t))
    return w, ap, texts


@pytest.fixture
def rover():
    return _with_texts(_world(drones=0, rovers=1))


def test_rover_unknown_command_unsupported(rover):
    w, ap, _ = rover
    for cmd in (203, A.MAV_CMD_NAV_TAKEOFF, A.MAV_CMD_CONDITION_YAW, 31000):
        assert ap.command(cmd, [0, 0, 0, 0, 0, 0, 0]) == A.MAV_RESULT_UNSUPPORTED


def test_rover_guided_velocity_target_times_out(rover):
    w, ap, _ = rover
    assert ap.params["GUID_TIMEOUT"] == 3
    assert ap.set_mode(modes.ROVER_GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    mask = POS_BITS | ACC_BITS | YAW_IGNORE | YAW_RATE_IGNORE
    assert ap.position_target_local(A.MAV_FRAME_LOCAL_NED, mask, (0, 0, 0), (2.0, 0, 0), (0, 0, 0), 0, 0)
    t_send = w.t
    _until(w, lambda: ap.vel[0] > 1.5, 3)
    w.run_for(2.5 - (w.t - t_send))
    assert ap.vel[0] > 1.5 and ap.guided.targets.target is not None          # 2.5 s: still driving
    _until(w, lambda: ap.guided.targets.target is None, 1.0)                   # dropped at GUID_TIMEOUT
    assert 3.0 <= w.t - t_send <= 3.1
    _until(w, lambda: np.linalg.norm(ap.vel[:2]) < 0.05, 3)
    assert ap.mode == modes.ROVER_GUIDED and ap.armed
    # a position target does not time out: the rover drives on to it
    x0 = ap.pos[0]
    assert ap.position_target_local(A.MAV_FRAME_LOCAL_NED, VEL_BITS | ACC_BITS | YAW_IGNORE | YAW_RATE_IGNORE,
                                    (x0 + 30, ap.pos[1], 0), (0, 0, 0), (0, 0, 0), 0, 0)
    w.run_for(6)
    assert ap.guided.targets.target is not None and ap.pos[0] > x0 + 20


@pytest.mark.parametrize("action, mode, text", [(0, modes.ROVER_GUIDED, "GCS Failsafe"),
                                                (1, modes.ROVER_RTL, "GCS Failsafe On: RTL"),
                                                (2, modes.ROVER_HOLD, "GCS Failsafe On: Hold"),
                                                (3, modes.ROVER_SMART_RTL, "GCS Failsafe On: SmartRTL"),
                                                (4, modes.ROVER_SMART_RTL, "GCS Failsafe On: SmartRTL")])
def test_rover_gcs_failsafe_actions(rover, action, mode, text):
    w, ap, texts = rover
    for name, v in (("FS_GCS_ENABLE", 1), ("FS_ACTION", action), ("FS_GCS_TIMEOUT", 2)):
        assert ap.params.set(name, v, save=False) is None
    assert ap.set_mode(modes.ROVER_GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    ap.gcs_heartbeat()
    t_hb = w.t
    took = _until(w, lambda: ap.failsafe.gcs_failsafe, 5)
    assert 2.0 <= took <= 2.1 and w.t - t_hb <= 2.1
    assert ap.mode == mode and ap.armed and text in texts
    ap.gcs_heartbeat()
    assert not ap.failsafe.gcs_failsafe and texts[-1] == "GCS Failsafe Cleared"


def test_rover_failsafe_off_by_default(rover):
    w, ap, texts = rover
    assert ap.params["FS_GCS_ENABLE"] == 0
    assert ap.set_mode(modes.ROVER_GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    ap.gcs_heartbeat()
    w.run_for(20)
    assert not ap.failsafe.gcs_failsafe and ap.mode == modes.ROVER_GUIDED and ap.armed
    assert not any("Failsafe" in t for t in texts)


# ---------------------------------------------------------------- copter

def test_copter_rtl_climbs_to_rtl_alt_before_returning():
    w = _world()
    ap = _fly(w, alt=5.0)
    assert ap.params["RTL_ALT"] == 1500
    _goto(ap, 20.0, 0.0, -5.0)
    _until(w, lambda: abs(ap.pos[0] - 20) < 0.3 and np.linalg.norm(ap.vel) < 0.2, 30)
    assert ap.set_mode(modes.RTL)
    x_start = ap.pos[0]
    track = []
    _until(w, lambda: track.append((ap.pos[0], -ap.pos[2])) or abs(ap.pos[0]) < 0.5, 60)
    # while below RTL_ALT - 0.5 m it has not come home-wards (ArduPilot: climb first, then return)
    low = [x for x, alt in track if alt < 14.5]
    assert low and max(abs(x - x_start) for x in low) < 0.5
    assert max(alt for _, alt in track) > 14.5
    # it returns at RTL_ALT and lands and disarms at home
    _until(w, lambda: not ap.armed, 60)
    assert np.linalg.norm(ap.pos[:2] - ap.home[:2]) < 0.5 and ap.on_ground


def test_copter_rtl_above_rtl_alt_returns_at_its_altitude():
    w = _world()
    ap = _fly(w, alt=20.0)
    _goto(ap, 10.0, 0.0, -20.0)
    _until(w, lambda: abs(ap.pos[0] - 10) < 0.3, 30)
    assert ap.set_mode(modes.RTL)
    alts = []
    _until(w, lambda: alts.append(-ap.pos[2]) or abs(ap.pos[0]) < 0.5, 60)
    assert min(alts) > 19.0             # no descent to RTL_ALT before it is home


@pytest.mark.parametrize("delay", [4, 10])
def test_copter_auto_disarm_after_disarm_delay(delay):
    w = _world()
    ap = w.vehicles[0].ap
    assert ap.params.set("DISARM_DELAY", delay, save=False) is None
    assert ap.set_mode(modes.GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    t_arm = w.t
    took = _until(w, lambda: not ap.armed, delay + 2)
    assert delay - 0.05 <= took <= delay + 0.1, took
    assert w.t - t_arm >= delay - 0.05


def test_copter_disarm_delay_zero_never_disarms():
    w = _world()
    ap = w.vehicles[0].ap
    assert ap.params.set("DISARM_DELAY", 0, save=False) is None
    assert ap.set_mode(modes.GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    w.run_for(30)
    assert ap.armed


@pytest.mark.parametrize("enable, mode", [(1, modes.RTL), (2, modes.RTL), (3, modes.SMART_RTL),
                                          (4, modes.SMART_RTL), (5, modes.LAND), (6, modes.RTL)])
def test_copter_fs_gcs_enable_actions(enable, mode):
    w = _world()
    ap = _fly(w, alt=5.0)
    texts = []
    ap.outbox.subscribe(text=lambda sev, t: texts.append(t))
    for name, v in (("FS_GCS_ENABLE", enable), ("FS_GCS_TIMEOUT", 2)):
        assert ap.params.set(name, v, save=False) is None
    ap.gcs_heartbeat()
    took = _until(w, lambda: ap.failsafe.gcs_failsafe, 5)
    assert 2.0 <= took <= 2.1
    assert ap.mode == mode and ap.armed
    assert texts[0] == {modes.LAND: "GCS Failsafe On: LAND", modes.RTL: "GCS Failsafe On: RTL",
                        modes.SMART_RTL: "GCS Failsafe On: SmartRTL"}[mode]


@pytest.mark.parametrize("enable, fallback, why", [(3, modes.RTL, "SmartRTL Unavailable, Trying RTL Mode"),
                                                   (4, modes.LAND, "SmartRTL Unavailable, Using Land Mode")])
def test_copter_fs_gcs_smartrtl_falls_back_without_a_path(enable, fallback, why):
    w = _world()
    ap = _fly(w, alt=5.0)
    texts = []
    ap.outbox.subscribe(text=lambda sev, t: texts.append(t))
    ap.srtl.deactivate("bad position")               # the path is unusable
    for name, v in (("FS_GCS_ENABLE", enable), ("FS_GCS_TIMEOUT", 2)):
        assert ap.params.set(name, v, save=False) is None
    ap.gcs_heartbeat()
    _until(w, lambda: ap.failsafe.gcs_failsafe, 5)
    assert ap.mode == fallback and ap.armed
    assert texts[:4] == ["SmartRTL deactivated: bad position", "GCS Failsafe On: SmartRTL",
                         "Mode change to SMART_RTL failed: init failed", why]


def test_copter_fs_gcs_on_the_ground_disarms():
    w = _world()
    ap = w.vehicles[0].ap
    assert ap.params.set("FS_GCS_ENABLE", 1, save=False) is None
    assert ap.params.set("DISARM_DELAY", 0, save=False) is None
    assert ap.set_mode(modes.GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    ap.gcs_heartbeat()
    _until(w, lambda: not ap.armed, 7)
    assert ap.failsafe.gcs_failsafe and ap.mode == modes.GUIDED


def test_copter_fs_gcs_disabled_silent_gcs_changes_nothing():
    w = _world()
    ap = _fly(w, alt=5.0)
    assert ap.params["FS_GCS_ENABLE"] == 0
    texts = []
    ap.outbox.subscribe(text=lambda sev, t: texts.append(t))
    ap.gcs_heartbeat()
    here = ap.pos.copy()
    w.run_for(30)                       # six FS_GCS_TIMEOUTs of silence
    assert not ap.failsafe.gcs_failsafe and ap.mode == modes.GUIDED and ap.armed
    assert np.linalg.norm(ap.pos - here) < 0.3 and texts == []
    assert ap.system_status() == A.MAV_STATE_ACTIVE


def test_commanded_jerk_is_bounded():
    """The shaped position target (what the controller is asked to follow) never exceeds
    PSC_JERK_XY in the horizontal or PSC_JERK_Z in the vertical, measured from its velocity."""
    w = _world()
    ap = _fly(w, alt=5.0)
    fleet = w.fleets[0][1]
    jxy, jz = ap.params["PSC_JERK_XY"], ap.params["PSC_JERK_Z"]
    dt = w.dt
    vs = []
    _goto(ap, 25.0, -10.0, -12.0)
    for _ in range(int(12 / dt)):
        w.step()
        c = fleet.ctrl                  # the shaped reference the controller tracks
        vs.append(np.array([c.vx[0], c.vy[0], c.vz[0]], float))
    v = np.array(vs)
    acc = np.diff(v, axis=0) / dt
    jerk = np.diff(acc, axis=0) / dt
    peak_xy = float(np.max(np.linalg.norm(jerk[:, :2], axis=1)))
    peak_z = float(np.max(np.abs(jerk[:, 2])))
    assert np.max(np.linalg.norm(v[:, :2], axis=1)) > 3.0       # it did move: the bound is not vacuous
    assert peak_xy > 0.5 * jxy                                   # and the jerk limit was reached
    assert peak_xy <= jxy * 1.05 and peak_z <= jz * 1.05, (peak_xy, peak_z)
    print(f"commanded jerk peak: xy {peak_xy:.3f} m/s^3 (PSC_JERK_XY {jxy:g}), z {peak_z:.3f} (PSC_JERK_Z {jz:g})")
