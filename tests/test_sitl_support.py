"""Helpers for the SITL tests (no tests here): start `towerlink sitl` on free ports, connect
pymavlink as an ArduPilot script would, wait for messages with deadlines."""
from __future__ import annotations

import os
import threading
import time

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil  # noqa: E402

from support import free_ports, wait_until  # noqa: E402

mav = mavutil.mavlink
PORT_TRIES = 3             # worlds started on ports another process took first, before giving up


class Sitl:
    """A `towerlink sitl` subprocess; `udp[i]` / `tcp[i]` are vehicle i's ports."""

    def __init__(self, processes, tmp_path, drones=1, rovers=1, speedup=10.0, extra=(), state_dir=None):
        self.processes = processes
        self.state_dir = str(state_dir or tmp_path / "state")
        for attempt in range(PORT_TRIES):
            self._start(drones, rovers, speedup, extra)
            if self.proc.poll() is None:
                return
            # another process took a port between free_ports and the world's bind: a new set
            if attempt < PORT_TRIES - 1 and "Address already in use" in self.output():
                continue
            raise AssertionError(self.output())

    def _start(self, drones, rovers, speedup, extra) -> None:
        n = drones + rovers
        ports = free_ports(n)
        tports = free_ports(n, kind=__import__("socket").SOCK_STREAM)
        self.udp, self.tcp = ports, tports
        args = ["towerlink", "sitl", "--drones", str(drones), "--rovers", str(rovers),
                "--speedup", str(speedup), "--state-dir", self.state_dir]
        for i in range(n):
            args += ["--endpoint", f"{i}=udpin:127.0.0.1:{ports[i]}", "--endpoint", f"{i}=tcpin:127.0.0.1:{tports[i]}"]
        args += list(extra)
        self.proc = self.processes.start(args)
        self.lines: list[str] = []
        reader = threading.Thread(target=self._reader, daemon=True)
        reader.start()
        wait_until(lambda: any("vehicle" in l for l in self.lines) and len(self.lines) >= n + 1 or self.proc.poll() is not None,
                   30, "sitl banner")
        if self.proc.poll() is not None:
            reader.join(5)                      # the whole output of a process that ended

    def _reader(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line)

    def stop(self) -> int:
        self.processes.stop(self.proc)
        return self.proc.returncode

    def output(self) -> str:
        return "".join(self.lines)


def connect(port: int, tcp: bool = False, sysid: int = 255, timeout: float = 10.0):
    """pymavlink connection like an ArduPilot script; returns after the first HEARTBEAT."""
    url = f"tcp:127.0.0.1:{port}" if tcp else f"udpout:127.0.0.1:{port}"
    m = mavutil.mavlink_connection(url, source_system=sysid, source_component=190 if sysid != 255 else 0)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        if m.wait_heartbeat(timeout=0.5):
            return m
    raise AssertionError(f"no HEARTBEAT from port {port}")


def recv(m, types, timeout=5.0, cond=None, heartbeat_every=0.5):
    """Next message of `types` satisfying `cond` within `timeout` wall s (keeps sending GCS heartbeats)."""
    deadline = time.monotonic() + timeout
    last_hb = 0.0
    while True:
        now = time.monotonic()
        if now > deadline:
            raise AssertionError(f"timed out waiting for {types}")
        if heartbeat_every and now - last_hb > heartbeat_every:
            m.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            last_hb = now
        msg = m.recv_match(type=types, blocking=True, timeout=min(0.2, max(0.01, deadline - now)))
        if msg is not None and (cond is None or cond(msg)):
            return msg


def command(m, cmd, *params, timeout=5.0, tries=3):
    """COMMAND_LONG and its COMMAND_ACK result. Re-sent (confirmation + 1) when no ACK comes
    within timeout / tries, as MAVProxy and MAVSDK do: a UDP datagram can be lost on a loaded
    machine (a full receive buffer), and a GCS that never retries is not how clients behave."""
    p = list(params) + [0.0] * (7 - len(params))
    for confirmation in range(tries):
        m.mav.command_long_send(m.target_system, m.target_component, cmd, confirmation, *p)
        try:
            return recv(m, "COMMAND_ACK", timeout / tries, cond=lambda a: a.command == cmd).result
        except AssertionError:
            if confirmation == tries - 1:
                raise


def local_pos(m, timeout=5.0):
    return recv(m, "LOCAL_POSITION_NED", timeout)


def wait_position(m, target, tol, timeout, idx=(0, 1, 2)):
    """Wait until LOCAL_POSITION_NED is within tol of target on the given axes."""
    def near(p):
        vals = (p.x, p.y, p.z)
        return sum((vals[i] - target[i]) ** 2 for i in idx) ** 0.5 < tol
    return recv(m, "LOCAL_POSITION_NED", timeout, cond=near)


def set_mode(m, name, timeout=5.0, tries=3):
    """DO_SET_MODE by name (pymavlink's mode mapping) and its COMMAND_ACK result, re-sent as
    `command` does."""
    number = m.mode_mapping()[name]
    return command(m, mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, number,
                   timeout=timeout, tries=tries)


def set_param(m, name, value, tries=3):
    """PARAM_SET until its PARAM_VALUE echo comes (re-sent as MAVProxy does: UDP may drop it)."""
    for i in range(tries):
        m.mav.param_set_send(m.target_system, m.target_component, name.encode(), float(value),
                             mav.MAV_PARAM_TYPE_REAL32)
        try:
            return recv(m, "PARAM_VALUE", 2, cond=lambda p: p.param_id == name and abs(p.param_value - value) < 1e-6)
        except AssertionError:
            if i == tries - 1:
                raise


def hold_throttle(m, pwm=1500):
    """The throttle (RC3) held at `pwm` by RC_CHANNELS_OVERRIDE, with RC_OVERRIDE_TIME -1 so it
    never times out (a script that does not keep re-sending it as MAVProxy's `rc` does), as
    autotest raises RC3 to 1500 before ALT_HOLD, LOITER or POSHOLD: at the simulated
    receiver's 1000 they descend. pwm 0 releases it back to the receiver."""
    set_param(m, "RC_OVERRIDE_TIME", -1)
    for _ in range(3):                       # UDP: one may be lost
        m.mav.rc_channels_override_send(m.target_system, m.target_component, 65535, 65535, pwm,
                                        *[65535] * 5, *[0] * 10)


def wait_armable(m, timeout=20.0):
    return recv(m, "SYS_STATUS", timeout,
                cond=lambda s: s.onboard_control_sensors_health & mav.MAV_SYS_STATUS_PREARM_CHECK)


def goto_local(m, x, y, z, frame=None, mask=0b110111111000, yaw=0.0):
    m.mav.set_position_target_local_ned_send(0, m.target_system, m.target_component,
                                             frame or mav.MAV_FRAME_LOCAL_NED, mask,
                                             x, y, z, 0, 0, 0, 0, 0, 0, yaw, 0)


def collect(m, types, done, timeout=5.0):
    """All messages of `types` until `done(list)` is true; returns the list."""
    got = []
    while not done(got):
        got.append(recv(m, types, timeout))
    return got


def run_client_script(processes, tmp_path, script: str, ok_marker: str, *, speedup: float,
                      drones: int = 1, rovers: int = 0, timeout: float = 140.0) -> str:
    """Run a client program (a test file run as `python FILE PORT`, as MAVSDK users write
    theirs: its own process, its own asyncio loop) against a fresh sitl pushing to PORT;
    assert it exits 0 having printed `ok_marker`; return its output."""
    import sys
    import threading

    from support import free_ports, wait_until
    (port,) = free_ports(1)
    proc = processes.start([sys.executable, script, str(port)])
    lines: list[str] = []
    threading.Thread(target=lambda: [lines.append(line) for line in proc.stdout], daemon=True).start()
    Sitl(processes, tmp_path, drones=drones, rovers=rovers, speedup=speedup,
         extra=["--out", f"udpout:127.0.0.1:{port}"])
    wait_until(lambda: proc.poll() is not None, timeout, f"{script} to finish")
    out = "".join(lines)
    assert proc.returncode == 0 and ok_marker in out, out[-3000:]
    return out


class MavProxy:
    """MAVProxy as a user runs it (`mavproxy.py --master=tcp:...`), typed into on stdin;
    its output lines collected on a thread."""

    def __init__(self, processes, tmp_path, tcp_port: int) -> None:
        import os
        import subprocess
        import sys
        import threading
        exe = os.path.join(os.path.dirname(sys.executable), "mavproxy.py")
        # MAVProxy is a declared test dependency: missing, this fails rather than skips
        assert os.path.exists(exe), f"mavproxy.py not found next to {sys.executable}"
        self.proc = processes.start([sys.executable, exe, f"--master=tcp:127.0.0.1:{tcp_port}",
                                     "--state-basedir", str(tmp_path)], stdin=subprocess.PIPE, cwd=str(tmp_path))
        self.lines: list[str] = []
        threading.Thread(target=lambda: [self.lines.append(line) for line in self.proc.stdout], daemon=True).start()

    def saw(self, text: str) -> bool:
        return any(text in line for line in self.lines)

    def send(self, cmd: str) -> None:
        self.proc.stdin.write(cmd + "\n")
        self.proc.stdin.flush()
