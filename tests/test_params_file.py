"""A damaged parameter file (issue 8 item 5): bad lines are skipped with a warning naming the
file and line; a saved file that cannot be read at all is set aside as FILE.bad and the vehicle
starts on its defaults, saying so; `towerlink sitl` starts either way."""
from __future__ import annotations

import os

import pytest

from test_sitl_support import Sitl, connect, recv
from vehicle.autopilot.params import COPTER_TABLE, ParamFileError, ParamStore, read_parm_file

GARBAGE = bytes(range(256)) * 8 + b"\xff\xfe\x00\x01" * 100


def test_stray_ff_byte_skips_that_line_only(tmp_path):
    p = tmp_path / "drone0.parm"
    p.write_bytes(b"RTL_ALT 2500\nDISARM_DELAY\xff 3\nFS_GCS_TIMEOUT 9\nNOVALUE\nWPNAV_SPEED abc\n")
    warnings = []
    values = read_parm_file(str(p), warnings.append)
    assert values == {"RTL_ALT": 2500.0, "FS_GCS_TIMEOUT": 9.0}
    assert warnings == [f"{p}:2: skipped a bad line (not ASCII text)",
                        f"{p}:4: skipped a bad line (expected NAME VALUE)",
                        f"{p}:5: skipped a bad line (value 'abc' is not a number)"]


def test_binary_garbage_is_no_parameter_file(tmp_path):
    p = tmp_path / "x.parm"
    p.write_bytes(GARBAGE)
    with pytest.raises(ParamFileError, match="no readable parameter line"):
        read_parm_file(str(p), lambda w: None)


def test_store_sets_an_unreadable_file_aside_and_starts_on_defaults(tmp_path):
    p = tmp_path / "drone0.parm"
    p.write_bytes(GARBAGE)
    said = []
    ps = ParamStore(COPTER_TABLE, {"SYSID_THISMAV": 3}, str(p), warn=said.append)
    assert ps["RTL_ALT"] == 1500 and ps["SYSID_THISMAV"] == 3
    assert not p.exists() and (tmp_path / "drone0.parm.bad").read_bytes() == GARBAGE
    assert any("moved to" in s and "drone0.parm.bad" in s and "starting on defaults" in s for s in said)
    # the next PARAM_SET writes a clean file, atomically
    assert ps.set("RTL_ALT", 2000) is None
    assert p.read_text() == "RTL_ALT 2000\n"
    assert ParamStore(COPTER_TABLE, None, str(p))["RTL_ALT"] == 2000


def test_store_keeps_the_good_lines_of_a_damaged_file(tmp_path):
    p = tmp_path / "drone0.parm"
    p.write_bytes(b"RTL_ALT 2500\n\xff\nDISARM_DELAY 4\n")
    said = []
    ps = ParamStore(COPTER_TABLE, None, str(p), warn=said.append)
    assert ps["RTL_ALT"] == 2500 and ps["DISARM_DELAY"] == 4
    assert said == [f"{p}:2: skipped a bad line (not ASCII text)"] and p.exists()


@pytest.mark.timeout(60)
@pytest.mark.parametrize("content", [GARBAGE, b"RTL_ALT 2500\n\xff\nDISARM_DELAY 4\n"], ids=["garbage", "stray-ff"])
def test_sitl_starts_with_a_damaged_saved_file(processes, tmp_path, content):
    state = tmp_path / "state"
    os.makedirs(state)
    (state / "drone0.parm").write_bytes(content)
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=2, state_dir=state)
    m = connect(sitl.udp[0])
    m.mav.param_request_read_send(1, 1, b"RTL_ALT", -1)
    value = recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "RTL_ALT").param_value
    out = sitl.output()
    if content is GARBAGE:
        assert value == 1500 and (state / "drone0.parm.bad").exists()
        assert "moved to" in out and "starting on defaults" in out
    else:
        assert value == 2500 and f"{state / 'drone0.parm'}:2: skipped a bad line" in out
    assert "Traceback" not in out
    m.close()


def test_a_deferred_store_writes_on_flush_only(tmp_path):
    """The link's stores are deferred: a burst of PARAM_SETs is one file write, at flush()."""
    p = tmp_path / "drone0.parm"
    ps = ParamStore(COPTER_TABLE, None, str(p), deferred=True)
    assert ps.set("RTL_ALT", 2000) is None and ps.set("DISARM_DELAY", 4) is None
    assert not p.exists() and ps["RTL_ALT"] == 2000
    ps.flush()
    assert p.read_text().splitlines() == ["DISARM_DELAY 4", "RTL_ALT 2000"]
