"""Non-finite and absurd command parameters (issue 8 item 3): every COMMAND_LONG / COMMAND_INT
that needs a number and gets NaN, +-inf or 1e30 there is answered with COMMAND_ACK DENIED or
FAILED, changes nothing and prints no traceback. In-process: the bytes go through the link's
parser and handlers exactly as from a socket; the replies are parsed from what it sends."""
from __future__ import annotations

import math

import pytest

from test_sitl_support import mav
from pymavlink.dialects.v20 import ardupilotmega as v20
from vehicle.autopilot import modes
from vehicle.link.endpoints import Channel
from vehicle.world import World, WorldConfig

BAD = [math.nan, math.inf, -math.inf, 1e30]
C = mav
# command -> (the parameters where a number is needed, a valid set of parameters); index i >= 0:
# param i+1 (0-based) refuses NaN, +-inf and 1e30; -(i+1): a flag or sign, only NaN/inf refused
COPTER = {
    C.MAV_CMD_COMPONENT_ARM_DISARM: ([0], [1, 0, 0, 0, 0, 0, 0]),
    C.MAV_CMD_DO_SET_MODE: ([0, 1], [1, modes.LOITER, 0, 0, 0, 0, 0]),
    C.MAV_CMD_DO_SET_HOME: ([0, 4, 5, 6], [0, 0, 0, 0, -35.3632, 149.1652, 584.0]),
    C.MAV_CMD_DO_CHANGE_SPEED: ([1], [0, 3.0, -1, 0, 0, 0, 0]),
    C.MAV_CMD_NAV_TAKEOFF: ([6], [0, 0, 0, 0, 0, 0, 5.0]),
    C.MAV_CMD_CONDITION_YAW: ([0, 1, 3, -3], [90, 10, 1, 0, 0, 0, 0]),
    C.MAV_CMD_PREFLIGHT_CALIBRATION: ([-1, -2, -3, -4, -5, -6, -7], [0, 0, 1, 0, 0, 0, 0]),
    C.MAV_CMD_SET_MESSAGE_INTERVAL: ([0, 1], [C.MAVLINK_MSG_ID_VFR_HUD, 500000, 0, 0, 0, 0, 0]),
    C.MAV_CMD_GET_MESSAGE_INTERVAL: ([0], [C.MAVLINK_MSG_ID_VFR_HUD, 0, 0, 0, 0, 0, 0]),
    C.MAV_CMD_REQUEST_MESSAGE: ([0], [C.MAVLINK_MSG_ID_HOME_POSITION, 0, 0, 0, 0, 0, 0]),
    C.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: ([0], [1, 0, 0, 0, 0, 0, 0]),
    C.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: ([-1], [1, 0, 0, 0, 0, 0, 0]),
}
ROVER = {k: v for k, v in COPTER.items() if k not in (C.MAV_CMD_NAV_TAKEOFF, C.MAV_CMD_CONDITION_YAW)}
ROVER[C.MAV_CMD_DO_SET_MODE] = ([0, 1], [1, modes.ROVER_HOLD, 0, 0, 0, 0, 0])
ROVER[C.MAV_CMD_DO_CHANGE_SPEED] = ([1], [1, 3.0, -1, 0, 0, 0, 0])


class _Out:
    def write(self, b):
        pass


class Gcs:
    """Sends COMMAND_LONG / COMMAND_INT bytes into a link and reads its replies."""

    def __init__(self, link) -> None:
        self.link = link
        self.enc = v20.MAVLink(_Out(), srcSystem=255, srcComponent=190)
        self.dec = v20.MAVLink(_Out())
        self.dec.robust_parsing = True
        self.got: list = []
        self.ch = Channel("test", self._recv)

    def _recv(self, buf: bytes) -> None:
        self.got += self.dec.parse_buffer(buf) or []

    def command(self, cmd, p, use_int=False):
        self.got.clear()
        tgt = self.link.ap.sysid
        if use_int:
            x, y = (int(p[4] * 1e7), int(p[5] * 1e7)) if all(map(math.isfinite, p[4:6])) else (0, 0)
            msg = self.enc.command_int_encode(tgt, 1, C.MAV_FRAME_GLOBAL, cmd, 0, 0, *p[:4], x, y, p[6])
        else:
            msg = self.enc.command_long_encode(tgt, 1, cmd, 0, *p)
        assert self.link.on_data(msg.pack(self.enc), self.ch)
        acks = [m for m in self.got if m.get_type() == "COMMAND_ACK"]
        assert len(acks) == 1 and acks[0].command == cmd, self.got
        return acks[0].result


@pytest.fixture(scope="module")
def world():
    w = World(WorldConfig(drones=1, rovers=1, state_dir=None, tcp_base=None, udp_base=None))
    for _ in range(200):
        w.run_for(0.5)
        if all(v.ap.est_ok and v.ap.home is not None for v in w.vehicles):
            break
    assert all(v.ap.est_ok for v in w.vehicles)
    return w


def _state(v):
    return v.ap.armed, v.ap.mode, v.ap.sysid, v.ap.speed.override, tuple(v.ap.home), v.link.reboots \
        if hasattr(v.link, "reboots") else v.link.stats["reboots"]


@pytest.mark.parametrize("kind", ["copter", "rover"])
@pytest.mark.parametrize("use_int", [False, True], ids=["COMMAND_LONG", "COMMAND_INT"])
def test_non_finite_params_denied_or_failed(world, kind, use_int, capfd):
    v = world.vehicles[0 if kind == "copter" else 1]
    table = COPTER if kind == "copter" else ROVER
    guided = modes.GUIDED if kind == "copter" else modes.ROVER_GUIDED
    gcs = Gcs(v.link)
    assert v.ap.set_mode(guided)           # CONDITION_YAW needs GUIDED to get past the mode check
    tried = 0
    for cmd, (needed, good) in table.items():
        for j in needed:
            i = j if j >= 0 else -j - 1
            if use_int and i in (4, 5):
                continue                    # COMMAND_INT carries these as integers
            for bad in (BAD if j >= 0 else BAD[:3]):
                p = list(good)
                p[i] = bad
                before = _state(v)
                result = gcs.command(cmd, p, use_int)
                assert result in (C.MAV_RESULT_DENIED, C.MAV_RESULT_FAILED), (cmd, i, bad, result)
                assert _state(v) == before, (cmd, i, bad)
                tried += 1
    assert tried > 60
    out, err = capfd.readouterr()
    assert "Traceback" not in out + err and v.link.stats["handler_error"] == 0
    # the valid forms of the same commands still work (the table is not refusing everything)
    assert gcs.command(C.MAV_CMD_DO_CHANGE_SPEED, table[C.MAV_CMD_DO_CHANGE_SPEED][1]) == C.MAV_RESULT_ACCEPTED
    assert gcs.command(C.MAV_CMD_DO_SET_MODE, table[C.MAV_CMD_DO_SET_MODE][1]) == C.MAV_RESULT_ACCEPTED
    assert gcs.command(C.MAV_CMD_DO_SET_HOME, table[C.MAV_CMD_DO_SET_HOME][1], use_int) == C.MAV_RESULT_ACCEPTED


def test_set_mode_message_and_handler_bug_still_acked(world, capfd, monkeypatch):
    v = world.vehicles[0]
    gcs = Gcs(v.link)
    # a bug inside a handler: exactly one ACK (FAILED), the vehicle keeps serving
    monkeypatch.setattr(v.ap.speed, "change", lambda speed: 1 / 0)
    assert gcs.command(C.MAV_CMD_DO_CHANGE_SPEED, [0, 3, -1, 0, 0, 0, 0]) == C.MAV_RESULT_FAILED
    assert v.link.stats["handler_error"] == 1
    assert "ZeroDivisionError" in capfd.readouterr().err
    v.link.stats["handler_error"] = 0
