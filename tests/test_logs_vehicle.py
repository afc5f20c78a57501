"""A vehicle's onboard log on the real World stepped in sim time, as the world keeps it (each
vehicle's link ticks it; files in <state_dir>/vehicles/<index>/logs/): when logs open and
close (arming, LOG_DISARMED, LOG_FILE_DSRMROT, LOG_BACKEND_TYPE, reboot, LOG_ERASE), what a
log starts with, and its samples read back by DFReader against the simulation's truth."""
from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink import DFReader
from pymavlink.dialects.v20 import ardupilotmega as A

from common import geo
from vehicle.autopilot import modes
from vehicle.autopilot.mission_store import MISSION, MissionItem
from vehicle.logs import messages
from vehicle.telemetry import version
from vehicle.world import World, WorldConfig


class LoggedWorld:
    """A headless World with a state dir in tmp, stepped in sim time, the truth of vehicle 0
    taken every autopilot tick."""

    def __init__(self, tmp_path, drones=1, rovers=0, params=None):
        self.state = tmp_path / "state"
        self.w = w = World(WorldConfig(drones=drones, rovers=rovers, state_dir=str(self.state), tcp_base=None,
                                       udp_base=None))
        for v in w.vehicles:
            for k, val in (params or {}).items():
                v.ap.params.set(k, val, save=False)
        self.writer = w.logs.writer
        self.logs = [v.link.logs.log for v in w.vehicles]
        self.truth: list[tuple[float, list[float]]] = []      # (t, truth row of vehicle 0)

    def run_for(self, seconds: float) -> None:
        w = self.w
        end = w.steps + round(seconds / w.dt)
        while w.steps < end:
            w.step()
            if w.steps % w.ap_every == 0:
                self.truth.append((w.t, w.fleets[0][1].truth_row(0)))

    def until(self, cond, sim_s: float, step: float = 0.02) -> None:
        t0 = self.w.t
        while not cond():
            if self.w.t - t0 > sim_s:
                raise AssertionError(f"not within {sim_s} sim s")
            self.run_for(step)

    def ready(self):
        self.until(lambda: all(v.ap.est_ok and v.ap.home is not None for v in self.w.vehicles), 20)

    def arm(self, i=0, seconds=0.0):
        """Vehicle i in GUIDED and armed, then `seconds` of sim time."""
        ap = self.w.vehicles[i].ap
        assert ap.set_mode(modes.GUIDED if ap.kind == "copter" else modes.ROVER_GUIDED)
        assert ap.arm() == A.MAV_RESULT_ACCEPTED
        self.run_for(seconds)
        return ap

    def folder(self, i=0):
        return self.state / "vehicles" / str(i) / "logs"

    def files(self, i=0):
        self.writer.flush()
        return [(e.num, e.size) for e in self.logs[i].store.entries()]

    def read(self, i=0, num=None):
        self.writer.flush()
        store = self.logs[i].store
        num = num if num is not None else store.entries()[-1].num
        r = DFReader.DFReader_binary(str(store.path(num)), zero_time_base=True)
        out = []
        while (m := r.recv_match()) is not None:
            out.append(m)
        return r, out


def of(msgs, kind):
    return [m for m in msgs if m.get_type() == kind]


def test_no_log_until_armed_then_one_per_boot(tmp_path):
    lw = LoggedWorld(tmp_path)
    lw.ready()
    lw.run_for(2.0)
    assert lw.files() == []                                # LOG_DISARMED 0: nothing before arming
    ap = lw.arm(seconds=1.0)
    assert ap.disarm() == A.MAV_RESULT_ACCEPTED
    lw.run_for(2.0)
    size = lw.files()[0][1]
    lw.run_for(2.0)
    assert lw.files() == [(1, size)]                       # disarmed: open, nothing written
    assert ap.arm() == A.MAV_RESULT_ACCEPTED               # the same boot: the same log goes on
    lw.run_for(1.0)
    ap.disarm()
    lw.run_for(0.5)
    assert [n for n, _ in lw.files()] == [1]
    _, msgs = lw.read()
    assert [m.ArmState for m in of(msgs, "ARM")] == [1, 0, 1, 0]
    assert [m.Id for m in of(msgs, "EV")] == [messages.EV_ARMED, messages.EV_DISARMED] * 2
    # a reboot closes it; the next arming opens the next number
    lw.w.vehicles[0].link.commands.reboot()
    lw.run_for(2.0)
    assert [n for n, _ in lw.files()] == [1]
    lw.ready()
    lw.arm(seconds=0.5)
    assert [n for n, _ in lw.files()] == [1, 2]
    assert sorted(p.name for p in lw.folder().iterdir()) == ["00000001.BIN", "00000002.BIN", "LASTLOG.TXT"]
    assert (lw.folder() / "LASTLOG.TXT").read_bytes() == b"2\r\n"


def test_dsrmrot_gives_a_log_per_arming(tmp_path):
    lw = LoggedWorld(tmp_path, params={"LOG_FILE_DSRMROT": 1})
    lw.ready()
    for _ in range(3):
        ap = lw.arm(seconds=0.5)
        ap.disarm()
        lw.run_for(0.5)
    assert [n for n, _ in lw.files()] == [1, 2, 3]
    for num in (1, 2, 3):
        _, msgs = lw.read(num=num)
        assert [m.ArmState for m in of(msgs, "ARM")] == [1, 0]


@pytest.mark.parametrize("value", [1, 3])
def test_log_disarmed_logs_from_boot(tmp_path, value):
    lw = LoggedWorld(tmp_path, params={"LOG_DISARMED": value})
    lw.run_for(1.5)
    assert [n for n, _ in lw.files()] == [1]
    _, msgs = lw.read()
    assert of(msgs, "ATT") and not of(msgs, "ARM")
    lw.w.vehicles[0].link.close()              # as the world does when it stops
    lw.writer.flush()
    # LOG_DISARMED 3: a log that never saw arming is discarded when it closes
    assert [n for n, _ in lw.files()] == ([1] if value == 1 else [])


def test_backend_off_logs_nothing(tmp_path):
    lw = LoggedWorld(tmp_path, params={"LOG_BACKEND_TYPE": 0, "LOG_DISARMED": 1})
    lw.ready()
    lw.arm(seconds=1.0)
    assert lw.files() == [] and not lw.folder().exists()


def test_erase_while_logging_starts_afresh(tmp_path):
    lw = LoggedWorld(tmp_path, params={"LOG_DISARMED": 1, "LOG_FILE_DSRMROT": 1})
    lw.ready()
    lw.arm(seconds=0.5).disarm()
    lw.run_for(0.5)
    assert len(lw.files()) == 2
    log = lw.logs[0]
    log.erase()
    assert log.entries() == []                 # erasing, or erased: nothing to list
    lw.until(lambda: lw.files() != [], 5.0, step=0.5)
    # the erase ran on the writer thread before the new log's bytes: only a fresh log 1
    assert [n for n, _ in lw.files()] == [1]
    _, msgs = lw.read()
    assert of(msgs, "FMT") and of(msgs, "PARM")


def test_log_contents_against_the_truth(tmp_path):
    lw = LoggedWorld(tmp_path, drones=1, rovers=1)
    lw.ready()
    w = lw.w
    ap, rover = w.vehicles[0].ap, w.vehicles[1].ap
    items = [MissionItem(0, 0, A.MAV_CMD_NAV_WAYPOINT, x=int(-35.3632621e7), y=int(149.1652374e7), z=0),
             MissionItem(1, 3, A.MAV_CMD_NAV_TAKEOFF, z=10),
             MissionItem(2, 3, A.MAV_CMD_NAV_WAYPOINT, x=int(-35.3630e7), y=int(149.1654e7), z=10)]
    ap.missions.replace_all(MISSION, items)
    ap.mission_uploaded(MISSION)
    assert ap.set_mode(modes.GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    assert ap.command(A.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 10]) == A.MAV_RESULT_ACCEPTED
    lw.until(lambda: ap.pos[2] < -9.5, 30)
    assert ap.set_mode(modes.AUTO)                # the mission's waypoint (its takeoff is done)
    lw.run_for(15.0)
    assert ap.set_mode(modes.LAND)
    lw.until(lambda: not ap.armed, 60)
    lw.run_for(1.0)
    r, msgs = lw.read()
    names = [m.get_type() for m in msgs]
    # what a log starts with: formats, units, every parameter, the firmware, origin / home, mode, mission
    assert names[:len(lw.logs[0].schema.encoders)] == ["FMT"] * len(lw.logs[0].schema.encoders)
    assert len(of(msgs, "PARM")) == len(ap.params.names)
    assert r.params["LOG_DISARMED"] == 0 and r.params["SYSID_THISMAV"] == ap.sysid
    assert [m.Message for m in of(msgs, "MSG")[:3]] == version.banner("copter", ap.sysid)
    assert of(msgs, "MSG")[0].Message.startswith("ArduCopter V4.5.0 (")
    assert [o.Type for o in of(msgs, "ORGN")] == [messages.ORIGIN_EKF, messages.ORIGIN_AHRS_HOME]
    modes_seen = [(m.ModeNum, m.Rsn) for m in of(msgs, "MODE")]
    assert modes_seen == [(modes.GUIDED, 0), (modes.AUTO, 2), (modes.LAND, 2)]    # GCS_COMMAND
    # ARM: armed by MAVLink (1), disarmed by LAND's landing (LANDED, 13); the texts in order
    assert [(a.ArmState, a.Method, a.Forced) for a in of(msgs, "ARM")] == [(1, 1, 0), (0, 13, 1)]
    texts = [m.Message for m in of(msgs, "MSG")]
    assert "Arming motors" in texts and texts.index("Arming motors") == len(version.banner("copter", ap.sysid))
    assert texts[-1] == "Disarming motors: landed", texts
    banner = len(version.banner("copter", ap.sysid))
    order = [m.get_type() for m in msgs if m.get_type() in ("ARM", "MSG")]
    assert order[banner:banner + 2] == ["ARM", "MSG"]   # the banner, ARM, then the "Arming motors" it said
    cmds = of(msgs, "CMD")
    assert [c.CNum for c in cmds[:3]] == [0, 1, 2] and cmds[0].CTot == 3        # the whole mission at start
    assert any(c.CNum == 2 and c.CId == A.MAV_CMD_NAV_WAYPOINT for c in cmds[3:])   # AUTO started item 2
    assert cmds[2].Lat == pytest.approx(-35.363, abs=1e-7) and cmds[2].Alt == 10
    # the samples: 10 Hz, ATT and GPS close to the truth at the same instant
    truth = {round(t, 3): row for t, row in lw.truth}
    atts, gpss = of(msgs, "ATT"), of(msgs, "GPS")
    span = (atts[-1].TimeUS - atts[0].TimeUS) * 1e-6
    assert len(atts) == pytest.approx(span * 10 + 1, abs=2)
    checked = 0
    for a in atts:
        row = truth.get(round(a.TimeUS * 1e-6, 3))
        if row is None:
            continue
        qx, qy, qz, qw = row[6:10]
        roll = math.degrees(math.atan2(2 * (qw * qx + qy * qz), 1 - 2 * (qx * qx + qy * qy)))
        pitch = math.degrees(math.asin(max(-1, min(1, 2 * (qw * qy - qz * qx)))))
        yaw = math.degrees(math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))) % 360
        assert abs(a.Roll - roll) < 2.0 and abs(a.Pitch - pitch) < 2.0, (a, roll, pitch)
        assert abs((a.Yaw - yaw + 180) % 360 - 180) < 3.0
        checked += 1
    assert checked > 100
    # the attitude target: the controller gets there (in hover and on the leg alike)
    assert np.median([abs(a.DesRoll - a.Roll) + abs(a.DesPitch - a.Pitch) for a in atts]) < 3.0
    assert max(abs(a.DesPitch) for a in atts) > 2.0           # it leaned into the leg
    home = ap.home_lla()
    errs = []
    for g in gpss:
        row = truth.get(round(g.TimeUS * 1e-6, 3))
        if row is None:
            continue
        lat, lon, alt = geo.ned_to_lla(ap.origin, row[0:3])
        n, e, d = geo.lla_to_ned((lat, lon, alt), g.Lat, g.Lng, g.Alt)
        errs.append((math.hypot(n, e), abs(d)))
    errs = np.array(errs)
    assert len(errs) > 100 and errs[:, 0].max() < 2.0 and errs[:, 1].max() < 3.0
    assert max(g.Alt for g in gpss) - home[2] == pytest.approx(10.0, abs=1.5)
    assert max(g.Spd for g in gpss) > 2.0 and all(g.Status == 3 and g.GWk > 2000 for g in gpss)
    # POS, XKF1, CTUN tell the same flight
    pos = of(msgs, "POS")
    assert max(p.RelHomeAlt for p in pos) == pytest.approx(10.0, abs=1.0)
    ctun = of(msgs, "CTUN")
    assert max(c.Alt for c in ctun) == pytest.approx(10.0, abs=1.0)
    assert max(c.DAlt for c in ctun) == pytest.approx(10.0, abs=1.0)
    assert 0.2 < np.median([c.ThO for c in ctun]) < 0.8
    assert all(1000 <= o.C1 <= 2000 for o in of(msgs, "RCOU"))
    assert max(k.PN ** 2 + k.PE ** 2 for k in of(msgs, "XKF1")) > 100
    bat = of(msgs, "BAT")
    assert bat[-1].CurrTot > bat[0].CurrTot and 9 < bat[-1].Volt < 13
    # the rover never armed: no log of its own
    assert lw.files(1) == [] and not rover.armed


def test_gps_reading_either_sampling_path():
    """The GPS record's source: the latest receiver sample, whether the estimator sampled it
    on arrays (big fleets) or on rows (small ones)."""
    from vehicle.sensors import Sensors, vehicle_rngs
    pos = np.array([[1.0, 2.0, -3.0], [4.0, 5.0, -6.0]])
    vel = np.array([[0.5, 0.0, 0.0], [0.0, -0.5, 0.1]])
    acc = np.zeros((2, 3))
    quat = np.array([[0.0, 0.0, 0.0, 1.0]] * 2)
    a, b = Sensors(vehicle_rngs(3, 2)), Sensors(vehicle_rngs(3, 2))
    assert a.gps_reading(0) is None
    a.sample(True, False, pos, vel, acc, quat)
    b.sample_rows(True, False, pos.tolist(), vel.tolist(), acc.tolist(), quat.tolist())
    for i in range(2):
        assert a.gps_reading(i) == pytest.approx(b.gps_reading(i), abs=1e-12)
        assert a.gps_reading(i)[:3] == pytest.approx(pos[i], abs=2.0)
    b.sample_rows(False, True, pos.tolist(), vel.tolist(), acc.tolist(), quat.tolist())
    assert b.gps_reading(1) is not None          # a baro-only epoch keeps the last fix


def test_the_link_serves_the_log_and_drops_a_gone_channel(tmp_path):
    """The link's LOG_* handling in process: a download over a channel, replies on it only,
    a reboot closing the log, and a transfer whose peer went away ending."""
    from pymavlink.dialects.v20 import ardupilotmega as mav

    from vehicle.link.endpoints import Channel
    lw = LoggedWorld(tmp_path)
    lw.ready()
    lw.arm(seconds=2.0).disarm()
    lw.run_for(0.5)
    link = lw.w.vehicles[0].link
    got: list[bytes] = []
    ch = Channel("gcs", got.append)
    parser = mav.MAVLink(None)
    link.logs.on_log_message(mav.MAVLink_log_request_list_message(1, 1, 0, 0xFFFF), ch)
    entry = parser.parse_buffer(b"".join(got))[0]
    assert (entry.get_type(), entry.id, entry.num_logs) == ("LOG_ENTRY", 1, 1)
    assert entry.size == lw.files()[0][1]
    got.clear()
    link.logs.on_log_message(mav.MAVLink_log_request_data_message(1, 1, 1, 0, 0xFFFFFFFF), ch)
    while link.logs.transfer.channel is not None:
        lw.run_for(0.02)
    data = b"".join(bytes(m.data[:m.count]) for m in parser.parse_buffer(b"".join(got)))
    assert data == (lw.folder() / "00000001.BIN").read_bytes()
    # a peer that went away mid-transfer: the transfer ends at the next tick
    link.logs.on_log_message(mav.MAVLink_log_request_data_message(1, 1, 1, 0, 0xFFFFFFFF), ch)
    ch.closed = True
    lw.run_for(0.02)
    assert link.logs.transfer.channel is None
    # a reboot closes the log: the next arming opens log 2
    link.commands.reboot()
    lw.ready()
    lw.arm(seconds=0.5)
    assert [n for n, _ in lw.files()] == [1, 2]
