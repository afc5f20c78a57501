"""Missions, fence and rally points persist atomically beside the parameters; a damaged file is
set aside (.bad) with a warning and the vehicle starts empty. QGC WPL 110 files read/write."""
from __future__ import annotations

import json
import math
import os
from dataclasses import astuple

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from common import wpl
from vehicle.autopilot.mission_persist import PersistentMissionStore, missions_path
from vehicle.autopilot.mission_store import FENCE, MISSION, RALLY, MissionItem
from vehicle.link.mission_items import from_wpl

REL = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT


def items(t=MISSION, n=3):
    return [MissionItem(seq=i, frame=REL, command=16, param4=math.nan if i == 1 else 0.0,
                        x=-353600000 + i, y=1491600000 - i, z=10.0 + i, mission_type=t) for i in range(n)]


def test_path_beside_the_parameter_file():
    assert missions_path("/s/drone0.parm") == "/s/drone0.missions.json"


def test_every_change_saved_and_loaded_back_exactly(tmp_path):
    path = str(tmp_path / "sub" / "drone0.missions.json")
    seen = []
    s = PersistentMissionStore(path, on_change=seen.append)
    s.replace_all(MISSION, items())
    s.replace_all(RALLY, items(RALLY, 2))
    s.write_partial(MISSION, 1, [items()[2].with_seq(1)])
    assert seen == [MISSION, RALLY, MISSION]
    assert [p for p in os.listdir(tmp_path / "sub")] == ["drone0.missions.json"]   # no tmp left behind
    s2 = PersistentMissionStore(path)
    assert s2.load_error is None
    assert [it.x for it in s2.items(MISSION)] == [-353600000, -353599998, -353599998]
    assert math.isnan(s2.get(1, RALLY).param4)                # NaN yaw survives the file
    assert [astuple(it)[:8] + astuple(it)[9:] for it in s2.items(RALLY)] == \
        [astuple(it)[:8] + astuple(it)[9:] for it in s.items(RALLY)]
    assert s2.items(FENCE) == []
    s2.clear(MISSION)
    assert PersistentMissionStore(path).count(MISSION) == 0


@pytest.mark.parametrize("content", [
    "{not json",
    json.dumps({"format": "towerlink-missions", "version": 99, "lists": {}}),
    json.dumps({"format": "towerlink-missions", "version": 1, "lists": {"0": [[0, 3, 16]]}}),
    json.dumps({"format": "towerlink-missions", "version": 1,
                "lists": {"0": [[5, 3, 16, 0, 1, 0.0, 0.0, 0.0, 0.0, 1, 2, 3.0, 0]]}}),
    json.dumps({"format": "towerlink-missions", "version": 1,
                "lists": {"0": [[0, 3, 16, 0, 1, "a", 0.0, 0.0, 0.0, 1, 2, 3.0, 0]]}}),
])
def test_damaged_file_set_aside_with_a_warning_and_start_empty(tmp_path, content):
    path = tmp_path / "drone0.missions.json"
    path.write_text(content)
    with pytest.warns(RuntimeWarning, match="damaged missions file"):
        s = PersistentMissionStore(str(path))
    assert s.load_error and s.count(MISSION) == 0
    assert (tmp_path / "drone0.missions.json.bad").read_text() == content
    assert not path.exists()
    s.replace_all(MISSION, items())                       # and it works from there on
    assert PersistentMissionStore(str(path)).count(MISSION) == 3


WPL = """QGC WPL 110
0\t1\t0\t16\t0\t0\t0\t0\t-35.363261\t149.165230\t584.000000\t1
1\t0\t3\t22\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t20.000000\t1
2\t0\t3\t16\t2.00000000\t0.00000000\t0.00000000\t0.00000000\t-35.36212345\t149.16587654\t25.000000\t1
"""


def test_wpl_parse_convert_and_write_round_trip(tmp_path):
    got = wpl.parse(WPL, "m.waypoints")
    assert [(w.seq, w.frame, w.command) for w in got] == [(0, 0, 16), (1, 3, 22), (2, 3, 16)]
    result, item = from_wpl(got[2])
    assert result == mav.MAV_MISSION_ACCEPTED
    assert (item.x, item.y, item.z, item.param1) == (-353621234, 1491658765, 25.0, 2.0)
    path = tmp_path / "out.waypoints"
    wpl.write(str(path), got)
    assert wpl.read(str(path)) == got


@pytest.mark.parametrize("text,msg", [
    ("QGC WPL 100\n", "m:1: not a waypoint file"),
    ("QGC WPL 110\n0\t1\t0\t16\t0\n", "m:2: expected 12 fields, got 5"),
    ("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\tx\t0\t0\t1\n", "m:2: could not convert"),
    ("QGC WPL 110\n3\t1\t0\t16\t0\t0\t0\t0\t0\t0\t0\t1\n", "m:2: index 3, expected 0"),
    ("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\tnan\t0\t0\t1\n", "m:2: x/y/z must be finite"),
])
def test_wpl_errors_name_file_and_line(text, msg):
    with pytest.raises(wpl.WplError, match=msg):
        wpl.parse(text, "m")


def test_wpl_item_refused_like_an_upload():
    w = wpl.parse("QGC WPL 110\n0\t0\t10\t16\t0\t0\t0\t0\t-35\t149\t5\t1\n")[0]
    assert from_wpl(w) == (mav.MAV_MISSION_UNSUPPORTED_FRAME, None)
