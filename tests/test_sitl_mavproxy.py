"""MAVProxy, driven through stdin as a user would type: connects over TCP 5760-style,
fetches every parameter (count matches the vehicle's), switches to GUIDED, arms."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import threading

import pytest

from support import wait_until
from test_sitl_support import Sitl, connect, recv

MAVPROXY = shutil.which("mavproxy.py") or os.path.join(os.path.dirname(sys.executable), "mavproxy.py")


@pytest.mark.timeout(120)
def test_mavproxy_params_mode_arm(processes, tmp_path):
    # MAVProxy is a declared test dependency: missing, this fails rather than skips
    assert os.path.exists(MAVPROXY), f"mavproxy.py not found next to {sys.executable}"
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=2)
    m = connect(sitl.udp[0])
    m.mav.param_request_read_send(1, 1, b"SYSID_THISMAV", -1)
    count = recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "SYSID_THISMAV").param_count
    m.close()
    proxy = processes.start([sys.executable, MAVPROXY, f"--master=tcp:127.0.0.1:{sitl.tcp[0]}",
                             "--state-basedir", str(tmp_path)],
                            stdin=subprocess.PIPE, cwd=str(tmp_path))
    lines: list[str] = []
    threading.Thread(target=lambda: [lines.append(l) for l in proxy.stdout], daemon=True).start()

    def saw(text):
        return any(text in l for l in lines)

    def send(cmd):
        proxy.stdin.write(cmd + "\n")
        proxy.stdin.flush()

    try:
        wait_until(lambda: saw("Detected vehicle 1:1"), 30, "MAVProxy to see the vehicle")
        wait_until(lambda: saw("online system 1"), 30, "online")
        send("param fetch")
        wait_until(lambda: saw("Received") and saw("parameters"), 60, "parameters: " + "".join(lines[-5:]))
        got = [l for l in lines if "Received" in l and "parameters" in l][-1]
        assert int(got.split("Received")[1].split()[0]) == count, got
        send("mode GUIDED")
        wait_until(lambda: saw("Mode GUIDED"), 20, "GUIDED")
        send("arm throttle")
        wait_until(lambda: saw("ARMED") and not saw("DISARMED"), 20, "ARMED")
        assert saw("COMPONENT_ARM_DISARM: ACCEPTED")
        send("disarm")
        wait_until(lambda: saw("DISARMED"), 20, "DISARMED")
        send("exit")
    finally:
        processes.stop(proxy)
    assert not saw("fence breach")
