"""tools/follow_ap.py: what `fly --follow-with ardupilot` sends the rover, in order, until it follows."""
from __future__ import annotations

from common.mavlink.dialect import towerlink as tl
from tools.follow_ap import ApFollowDriver


class Clock:
    t = 0.0

    def __call__(self):
        return self.t


def _msg(m, sysid=3):
    m.pack(tl.MAVLink(None, srcSystem=sysid, srcComponent=1))
    return tl.MAVLink(None).decode(m.get_msgbuf())


def test_params_follow_mode_and_arm_in_order_until_it_follows():
    sent, clock = [], Clock()
    d = ApFollowDriver(lambda sysid, m: sent.append((sysid, m)) or True, 3, 1, (-2.0, 0.5), 0.5, clock)
    d.tick()
    params = [m for _, m in sent if m.get_type() == "PARAM_SET"]
    names = {m.param_id.encode() if isinstance(m.param_id, str) else m.param_id for m in params}
    assert names == {b"FOLL_ENABLE", b"FOLL_SYSID", b"FOLL_OFS_TYPE", b"FOLL_OFS_X", b"FOLL_OFS_Y", b"FOLL_POS_P"}
    assert {str(m.param_id): m.param_value for m in params}["FOLL_OFS_X"] == -2.0
    assert all(s == 3 and m.target_system == 3 for s, m in sent)
    # in one go, in this order: the parameters (FOLL_ENABLE first of all), FOLLOW, arm
    assert [m.get_type() for _, m in sent][-2:] == ["COMMAND_LONG", "COMMAND_LONG"]
    assert [m.command for _, m in sent[-2:]] == [tl.MAV_CMD_DO_SET_MODE, tl.MAV_CMD_COMPONENT_ARM_DISARM]
    assert sent[0][1].param_id in ("FOLL_ENABLE", b"FOLL_ENABLE")
    sent.clear(); d.tick()
    assert not sent                                         # at most every half second
    for name, value in d.params.items():                    # the rover confirms each
        d.on_message(_msg(tl.MAVLink_param_value_message(name.encode(), value, tl.MAV_PARAM_TYPE_REAL32, 9, 0)))
    d.on_message(_msg(tl.MAVLink_heartbeat_message(10, 3, 1, 4, 3, 3)))      # HOLD, disarmed
    clock.t = 1.5; d.tick()                                 # confirmed: no more PARAM_SETs
    assert [m.command for _, m in sent] == [tl.MAV_CMD_DO_SET_MODE, tl.MAV_CMD_COMPONENT_ARM_DISARM]
    assert sent[0][1].param2 == 6
    sent.clear()
    d.on_message(_msg(tl.MAVLink_heartbeat_message(10, 3, 1, 6, 3, 3)))      # FOLLOW, disarmed
    clock.t = 3.0; d.tick()
    assert [m.command for _, m in sent] == [tl.MAV_CMD_COMPONENT_ARM_DISARM] and sent[0][1].param1 == 1
    sent.clear()
    d.on_message(_msg(tl.MAVLink_heartbeat_message(10, 3, 1 | 128, 6, 3, 3)))
    d.on_message(_msg(tl.MAVLink_heartbeat_message(10, 3, 1, 4, 3, 3), sysid=2))  # another vehicle: ignored
    clock.t = 5.0; d.tick()
    assert d.following and not sent
