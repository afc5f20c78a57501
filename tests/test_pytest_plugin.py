"""towerlink's pytest plugin: the marker's spec, the recorder's frame cutting, truth heard
over MAVLink, the fixture's world (a thread, and a process) with its addresses, waits,
port-race retry and clean stop, and the plugin as a user's pytest loads it (failure report,
artefacts, --towerlink-keep-logs)."""
from __future__ import annotations

import math
import socket
import time
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from plugin_support import ROOT, processes_mentioning, run_pytest
from tools import sitl_world
from tools.sitl_fixture import TowerlinkSitl
from tools.sitl_recorder import split_frames
from tools.sitl_spec import SpecError, make_spec, parm_text
from tools.sitl_truth import TruthListener
from vehicle.world import DEFAULT_HOME

# ----------------------------------------------------------------------------- the spec (pure)


def test_spec_defaults_are_one_drone_at_max_speed_in_a_thread():
    s = make_spec({})
    assert (s.drones, s.rovers, s.count, s.speedup, s.subprocess, s.lockstep) == (1, 0, 1, math.inf, False, False)
    assert s.home == DEFAULT_HOME and s.params == {} and s.wind is None and s.speedup_text == "max"


def test_spec_reads_every_marker_keyword_and_round_trips():
    s = make_spec({"drones": 2, "rovers": 1, "speedup": 5, "params": {"fs_gcs_enable": 1}, "wind": (5, 270, 1),
                   "seed": 3, "home": "10,20,30", "lockstep": True, "subprocess": True,
                   "mission": {1: ROOT / "examples/pytest/square.waypoints"}})
    assert (s.count, s.speedup, s.seed, s.home, s.lockstep, s.subprocess) == (3, 5.0, 3, (10.0, 20.0, 30.0), True, True)
    assert s.params == {"FS_GCS_ENABLE": 1.0} and s.wind_text == "5,270,1" and s.wind.speed == 5.0
    assert list(s.missions) == [1]
    assert make_spec(s.marker_kwargs()) == s
    assert parm_text({"B": 2.5, "A": 1}) == "A 1\nB 2.5\n"


def test_run_options_win_over_the_marker():
    s = make_spec({"speedup": 5, "subprocess": True}, speedup="2", mode="thread", keep_logs=True)
    assert (s.speedup, s.subprocess, s.keep_logs) == (2.0, False, True)
    assert make_spec({}, mode="subprocess").subprocess


@pytest.mark.parametrize("kw, says", [
    ({"drone": 1}, "unknown keyword(s) drone"),
    ({"speedup": 0}, "speedup"),
    ({"drones": 0, "rovers": 0}, "at least one vehicle"),
    ({"wind": "fast"}, "wind="),
    ({"home": (100, 0, 0)}, "out of range"),
    ({"mission": "/nonexistent.waypoints"}, "not found"),
    ({"drones": 1, "mission": {3: ROOT / "examples/pytest/square.waypoints"}}, "vehicle 3"),
    ({"params": {"A": "x"}}, "numbers"),
])
def test_a_bad_marker_is_refused_naming_what(kw, says):
    with pytest.raises(SpecError, match=None) as e:
        make_spec(kw)
    assert says in str(e.value)


# ----------------------------------------------------------------------------- frames and truth (pure)


def _packed(msg, signed=False, v1=False) -> bytes:
    m = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    if signed:
        m.signing.secret_key = bytes(32)
        m.signing.sign_outgoing = True
    return msg.pack(m, force_mavlink1=v1)


def test_split_frames_cuts_v1_v2_and_signed_frames_and_skips_garbage():
    hb = mav.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3)
    a, b, c = _packed(hb), _packed(hb, signed=True), _packed(hb, v1=True)
    assert split_frames(a + b + c) == [a, b, c]
    assert split_frames(b"\x00\x01" + a + b"junk" + c) == [a, c]
    assert split_frames(a + b[:-3]) == [a]           # cut short by the datagram's end
    assert split_frames(b"") == []


def _from(msg, sysid=1):
    m = mav.MAVLink(None, srcSystem=sysid, srcComponent=1)
    return m.parse_buffer(msg.pack(m))[0]


def test_truth_listener_reads_sim_state_heartbeat_and_landed_state():
    home = DEFAULT_HOME
    lst = TruthListener(home, [1, 2])
    assert not lst.ready(0)
    with pytest.raises(LookupError):
        lst.truth(0)
    from common import geo
    lat, lon, alt = geo.ned_to_lla(home, (12.0, -5.0, -7.0))
    lst.on_message(_from(mav.MAVLink_sim_state_message(1, 0, 0, 0, 0.1, 0.2, 0.3, 0, 0, 0, 0, 0, 0, lat, lon, alt,
                                                       0, 0, 1.0, 2.0, -0.5, int(round(lat * 1e7)),
                                                       int(round(lon * 1e7)))))
    lst.on_message(_from(mav.MAVLink_heartbeat_message(2, 3, 129, 4, 4, 3)))        # armed, GUIDED
    lst.on_message(_from(mav.MAVLink_extended_sys_state_message(0, 2)))            # in air
    lst.on_message(_from(mav.MAVLink_attitude_message(4250, 0, 0, 0, 0, 0, 0)))
    lst.on_message(_from(mav.MAVLink_heartbeat_message(2, 3, 0, 0, 3, 3), sysid=9))  # not ours
    v = lst.truth(0)
    assert lst.ready(0) and not lst.ready(1)
    assert v.ned == pytest.approx((12.0, -5.0, -7.0), abs=0.02) and v.height == pytest.approx(7.0, abs=0.01)
    assert (v.mode, v.armed, v.landed, v.t, v.sysid) == ("GUIDED", True, False, 4.25, 1)
    assert v.vel_ned == (1.0, 2.0, -0.5) and v.attitude == pytest.approx((0.1, 0.2, 0.3))


# ----------------------------------------------------------------------------- the fixture's world


def _bindable(port: int, kind: int) -> bool:
    with socket.socket(socket.AF_INET, kind) as s:
        try:
            s.bind(("127.0.0.1", port))
            return True
        except OSError:
            return False


def test_thread_world_is_past_start_up_serves_its_addresses_and_stops_clean(tmp_path):
    from pymavlink import mavutil
    sitl = TowerlinkSitl(make_spec({"drones": 1, "rovers": 1}), tmp_path / "w").start()
    try:
        w = sitl.world
        assert all(v.ap.est_ok and v.ap.home is not None and v.ap.prearm_ok() for v in w.vehicles)
        assert all(v.ap.ekf_origin() is not None for v in w.vehicles)
        assert 0.5 < sitl.time < 30
        tcp, udp = sitl.connection(1), sitl.connection(1, "udp")
        assert tcp.startswith("tcp:127.0.0.1:") and udp.startswith("udpout:127.0.0.1:")
        assert sitl.mavsdk_address(1) == "tcpout://127.0.0.1:" + tcp.rsplit(":", 1)[1]
        assert (sitl.sysid(0), sitl.sysid(1)) == (1, 2)
        with pytest.raises(IndexError):
            sitl.connection(2)
        m = mavutil.mavlink_connection(tcp, source_system=255)
        hb = m.wait_heartbeat(timeout=5)
        assert hb is not None and m.target_system == 2 and hb.type == mav.MAV_TYPE_GROUND_ROVER
        m.close()
        rover = sitl.vehicle(1)
        assert rover.ned == pytest.approx((-3.0, 0.0, 0.0), abs=1e-6) and rover.landed and not rover.armed
        assert rover.mode == w.vehicles[1].ap.mode_name and rover.t == pytest.approx(sitl.time, abs=0.1)
        t0 = sitl.time
        assert sitl.wait_for(lambda: sitl.time > t0 + 2 and "later", sim_timeout=10) == "later"
        with pytest.raises(AssertionError, match=r"waiting for flying: 1 sim s passed[\s\S]*vehicle 0: STABILIZE"):
            sitl.wait_for(lambda: sitl.vehicle(0).height > 1, sim_timeout=1, what="flying")
        ports = [int(tcp.rsplit(":", 1)[1]), int(udp.rsplit(":", 1)[1])]
    finally:
        sitl.stop()
    assert not sitl._runner.alive() and not (tmp_path / "w").exists()
    assert _bindable(ports[0], socket.SOCK_STREAM) and _bindable(ports[1], socket.SOCK_DGRAM)


def test_a_port_taken_meanwhile_gets_the_world_new_ports(tmp_path, monkeypatch):
    blocker = socket.socket()
    blocker.bind(("127.0.0.1", 0))
    blocker.listen()
    taken = blocker.getsockname()[1]
    picks = []
    real = sitl_world.Ports.pick

    def pick(n):             # the first pick loses the race: its TCP port is someone else's
        p = real(n)
        if not picks:
            p = sitl_world.Ports(p.udp, (taken,) + p.tcp[1:])
        picks.append(p)
        return p
    monkeypatch.setattr(sitl_world.Ports, "pick", staticmethod(pick))
    sitl = TowerlinkSitl(make_spec({}), tmp_path / "w")
    try:
        sitl.start()
        assert len(picks) == 2 and sitl.connection(0) != f"tcp:127.0.0.1:{taken}"
        assert sitl.world.ready.is_set()
    finally:
        sitl.stop()
        blocker.close()
    assert _bindable(picks[0].udp[0], socket.SOCK_DGRAM)     # the lost try closed what it had bound


def test_process_world_gives_truth_over_mavlink_and_leaves_no_process(tmp_path):
    from pymavlink import mavutil
    sitl = TowerlinkSitl(make_spec({"drones": 1, "subprocess": True, "params": {"WPNAV_SPEED": 750}}),
                         tmp_path / "w").start()
    try:
        assert sitl.world is None
        pid = sitl._runner.proc.pid
        m = mavutil.mavlink_connection(sitl.connection(0), source_system=255)
        assert m.wait_heartbeat(timeout=10) is not None
        m.mav.param_request_read_send(1, 1, b"WPNAV_SPEED", -1)
        p = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=5)
        assert p is not None and p.param_value == 750.0          # the marker's params reached it
        m.close()
        v = sitl.vehicle(0)
        assert v.ned == pytest.approx((0.0, 0.0, 0.0), abs=0.02) and v.landed and v.mode == "STABILIZE"
        t0 = sitl.time
        sitl.wait_for(lambda: sitl.time > t0 + 1, sim_timeout=5)
    finally:
        sitl.stop()
    assert not Path(f"/proc/{pid}").exists() or "zombie" in Path(f"/proc/{pid}/status").read_text()
    assert processes_mentioning(str(tmp_path)) == []


# ----------------------------------------------------------------------------- as a user's pytest runs it

USER_TESTS = '''
import pytest
from pymavlink import mavutil


@pytest.mark.towerlink(drones=1)
def test_passes(towerlink_sitl):
    m = mavutil.mavlink_connection(towerlink_sitl.connection(0))
    assert m.wait_heartbeat(timeout=5) is not None
    m.close()


@pytest.mark.towerlink(drones=1, rovers=1)
def test_fails(towerlink_sitl):
    towerlink_sitl.wait_for(lambda: towerlink_sitl.vehicle(1).armed, sim_timeout=0.5, what="the rover armed")


@pytest.mark.towerlink(drone=1)
def test_bad_marker(towerlink_sitl):
    pass
'''


def test_plugin_reports_a_failing_tests_tlog_and_plot_and_keeps_nothing_of_passing_ones(tmp_path):
    (tmp_path / "test_user.py").write_text(USER_TESTS)
    base = tmp_path / "base"
    r = run_pytest(["-q", "--basetemp", str(base), "test_user.py"], cwd=tmp_path)
    out = r.stdout + r.stderr
    assert r.returncode == 1 and "1 passed" in out and "1 failed" in out and "1 error" in out, out
    assert "towerlink: waiting for the rover armed" in out
    assert "unknown keyword(s) drone" in out
    tlog = next(line.split(": ", 1)[1] for line in out.splitlines() if line.startswith("towerlink tlog: "))
    png = next(line.split(": ", 1)[1] for line in out.splitlines() if line.startswith("towerlink track plot: "))
    assert Path(tlog).stat().st_size > 1000 and Path(png).read_bytes()[:4] == b"\x89PNG"
    assert Path(tlog).is_relative_to(base / "test_fails0")
    assert not (base / "test_passes0" / "towerlink").exists()
    r = run_pytest(["-q", "--basetemp", str(base), "--towerlink-keep-logs", "test_user.py::test_passes"],
                   cwd=tmp_path)
    assert r.returncode == 0, r.stdout
    assert (base / "test_passes0" / "towerlink" / "world.tlog").stat().st_size > 1000
    assert (base / "test_passes0" / "towerlink" / "world.png").exists()
    assert "--towerlink-speedup" in run_pytest(["--help"], cwd=tmp_path).stdout


def test_pyproject_registers_the_plugin_and_runs_the_examples():
    import tomllib
    proj = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert proj["project"]["entry-points"]["pytest11"] == {"towerlink": "tools.pytest_plugin"}
    assert "examples/pytest" in proj["tool"]["pytest"]["ini_options"]["testpaths"]


@pytest.mark.alone          # a wall-clock figure: measured with the cores to itself
def test_first_heartbeat_comes_within_half_a_second_of_the_start(tmp_path):
    from pymavlink import mavutil
    best = math.inf
    for k in range(3):          # the best of three: the machine is shared
        t0 = time.monotonic()
        sitl = TowerlinkSitl(make_spec({}), tmp_path / f"w{k}").start()
        try:
            m = mavutil.mavlink_connection(sitl.connection(0), source_system=255)
            assert m.wait_heartbeat(timeout=5) is not None
            best = min(best, time.monotonic() - t0)
            m.close()
        finally:
            sitl.stop()
    assert best < 0.5
