"""Parameters persist across restarts (state dir) and --params FILE gives defaults; SIGTERM stops cleanly."""
from __future__ import annotations

import pytest

from test_sitl_support import Sitl, connect, mav, recv


def _read(m, name):
    m.mav.param_request_read_send(m.target_system, 1, name.encode(), -1)
    return recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == name).param_value


@pytest.mark.timeout(90)
def test_param_saved_and_loaded_on_restart(processes, tmp_path):
    parm = tmp_path / "defaults.parm"
    parm.write_text("# defaults\nDISARM_DELAY 7\nSYSID_THISMAV 42\n")
    state = tmp_path / "state"
    sitl = Sitl(processes, tmp_path, drones=1, rovers=1, speedup=2, state_dir=state, extra=["--params", str(parm)])
    m = connect(sitl.udp[0])
    assert _read(m, "DISARM_DELAY") == 7 and _read(m, "SYSID_THISMAV") == 1   # sysid is per vehicle
    m.mav.param_set_send(1, 1, b"RTL_ALT", 2500, mav.MAV_PARAM_TYPE_INT32)
    assert recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "RTL_ALT").param_value == 2500
    r = connect(sitl.udp[1])
    r.mav.param_set_send(2, 1, b"FS_ACTION", 1, mav.MAV_PARAM_TYPE_INT32)
    assert recv(r, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "FS_ACTION").param_value == 1
    m.close(); r.close()
    assert sitl.stop() == 0                          # SIGTERM: clean exit
    assert "stats:" in sitl.output()
    assert "RTL_ALT 2500" in (state / "drone0.parm").read_text()
    sitl2 = Sitl(processes, tmp_path, drones=1, rovers=1, speedup=2, state_dir=state, extra=["--params", str(parm)])
    m = connect(sitl2.udp[0])
    assert _read(m, "RTL_ALT") == 2500 and _read(m, "DISARM_DELAY") == 7
    r = connect(sitl2.udp[1])
    assert _read(r, "FS_ACTION") == 1
