"""gcs.client against a tiny scripted autopilot over loopback UDP (no SITL needed).

The fake answers like ArduPilot where the client depends on it: COMMAND_ACK for
every command, PreArm STATUSTEXTs while not ready, mode/armed in the heartbeat,
NAV_TAKEOFF only when armed, LOCAL_POSITION_NED stamped with its own clock. It can
drop a fraction of packets both ways (seeded) to prove the client's retries.
"""
from __future__ import annotations

import os
import random
import socket
import threading
import time

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as apm  # noqa: E402

from gcs.client import (ArmError, Client, CommandRejected, GoalTimeout,  # noqa: E402
                        HeartbeatTimeout, ModeChangeError)
from support import free_port, wait_until  # noqa: E402


class FakeCopter(threading.Thread):
    def __init__(self, port, *, prearm_fails=2, loss=0.0, seed=1, speed=40.0, sim_rate=4.0,
                 refuse_guided=False, drop_commands=0, drop_takeoff_acks=0):
        super().__init__(daemon=True)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", port))
        self.sock.settimeout(0.005)
        self.mav = apm.MAVLink(None, srcSystem=1, srcComponent=1)
        self.rx = apm.MAVLink(None)
        self.rx.robust_parsing = True
        self.peer = None
        self.rng = random.Random(seed)
        self.loss = loss
        self.prearm_fails = prearm_fails
        self.refuse_guided = refuse_guided
        self.speed = speed          # m per sim s
        self.sim_rate = sim_rate    # sim s per wall s
        self.mode, self.armed = 0, False
        self.pos = [0.0, 0.0, 0.0]
        self.target = None
        self.sim = 0.0
        self.stop = threading.Event()
        self.commands = []
        self.command_sims = []          # sim time each COMMAND_LONG arrived (dropped ones too)
        self.drop_commands = drop_commands
        self.drop_takeoff_acks = drop_takeoff_acks     # accepted takeoffs whose ACK is "lost"
        self.streaming = True           # LOCAL_POSITION_NED on (a test may pause it)
        self.next_reset = False
        self.steps = self.pos_sent = 0  # loop iterations; LOCAL_POSITION_NED sent

    def send(self, msg):
        if self.peer and self.rng.random() >= self.loss:
            self.sock.sendto(msg.pack(self.mav), self.peer)

    def run(self):
        last = time.monotonic()
        next_hb = next_pos = 0.0
        while not self.stop.is_set():
            try:
                data, addr = self.sock.recvfrom(2048)
                self.peer = addr
                if self.rng.random() >= self.loss:
                    for m in self.rx.parse_buffer(data) or []:
                        self.handle(m)
            except socket.timeout:
                pass
            now = time.monotonic()
            dt, last = (now - last) * self.sim_rate, now
            self.sim += dt
            self.steps += 1
            if self.next_reset:
                self.next_reset = False
                self.sim = next_hb = next_pos = 0.0
            if self.target is not None and self.armed:
                d = [t - p for t, p in zip(self.target, self.pos)]
                n = sum(v * v for v in d) ** 0.5
                step = min(n, self.speed * dt)
                if n > 1e-9:
                    self.pos = [p + v / n * step for p, v in zip(self.pos, d)]
            if self.sim >= next_hb:
                next_hb = self.sim + 1.0
                base = apm.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (apm.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
                self.send(apm.MAVLink_heartbeat_message(apm.MAV_TYPE_QUADROTOR, apm.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                        base, self.mode, apm.MAV_STATE_ACTIVE, 3))
                landed = apm.MAV_LANDED_STATE_ON_GROUND if self.pos[2] > -0.1 else apm.MAV_LANDED_STATE_IN_AIR
                self.send(apm.MAVLink_extended_sys_state_message(0, landed))
            if self.sim >= next_pos and self.streaming:
                next_pos = self.sim + 0.05
                self.pos_sent += self.peer is not None and self.loss == 0
                self.send(apm.MAVLink_local_position_ned_message(int(self.sim * 1000), *self.pos, 0, 0, 0))

    def reboot(self):
        """Restart the vehicle's clock from zero (as a reboot does), where it stands; done
        by the vehicle's own thread on its next step."""
        self.next_reset = True

    def ack(self, cmd, result):
        self.send(apm.MAVLink_command_ack_message(cmd, result, 0, 0, 255, 190))

    def handle(self, m):
        t = m.get_type()
        if t == "COMMAND_LONG":
            self.command_sims.append(self.sim)
            if self.drop_commands > 0:      # this one is "lost on the way"
                self.drop_commands -= 1
                return
            self.commands.append(m.command)
            if m.command == apm.MAV_CMD_DO_SET_MODE:
                if self.refuse_guided and int(m.param2) == 4:
                    return self.ack(m.command, apm.MAV_RESULT_FAILED)
                self.mode = int(m.param2)
                if self.mode == 9:  # LAND
                    self.target = [self.pos[0], self.pos[1], 0.0]
                self.ack(m.command, apm.MAV_RESULT_ACCEPTED)
            elif m.command == apm.MAV_CMD_COMPONENT_ARM_DISARM:
                if m.param1 == 1 and self.prearm_fails > 0:
                    self.prearm_fails -= 1
                    self.send(apm.MAVLink_statustext_message(apm.MAV_SEVERITY_CRITICAL,
                                                             b"PreArm: Need Position Estimate"))
                    return self.ack(m.command, apm.MAV_RESULT_FAILED)
                self.armed = m.param1 == 1
                self.ack(m.command, apm.MAV_RESULT_ACCEPTED)
            elif m.command == apm.MAV_CMD_NAV_TAKEOFF:
                if not self.armed or self.pos[2] < -0.2:
                    return self.ack(m.command, apm.MAV_RESULT_FAILED)
                self.target = [self.pos[0], self.pos[1], -m.param7]
                if self.drop_takeoff_acks > 0:
                    self.drop_takeoff_acks -= 1
                    return
                self.ack(m.command, apm.MAV_RESULT_ACCEPTED)
            else:
                self.ack(m.command, apm.MAV_RESULT_UNSUPPORTED)
        elif t == "SET_POSITION_TARGET_LOCAL_NED" and self.mode == 4:
            self.target = [m.x, m.y, m.z]
        elif t == "PARAM_REQUEST_READ" and m.param_id == "WPNAV_SPEED":
            self.send(apm.MAVLink_param_value_message(b"WPNAV_SPEED", 100.0 * self.speed,
                                                      apm.MAV_PARAM_TYPE_REAL32, 1, 0))


@pytest.fixture
def copter(request):
    kw = getattr(request, "param", {})
    port = free_port()
    fc = FakeCopter(port, **kw)
    fc.start()
    yield fc, f"udpout:127.0.0.1:{port}"
    fc.stop.set()
    fc.join(2)
    fc.sock.close()


def test_full_sequence_with_prearm_feedback(copter):
    fc, url = copter
    logs = []
    with Client.connect(url, log=logs.append) as c:
        c.wait_heartbeat(1, timeout=5)
        c.set_mode("GUIDED", 1, timeout=5)
        assert c.system(1).mode_name == "GUIDED"
        c.arm(1, timeout=10, retry_interval=0.1)
        assert c.system(1).armed
        assert any("PreArm: Need Position Estimate" in s for s in logs)
        p = c.takeoff(9.0, 1, timeout=10)
        assert p.z <= -8.5
        c.goto(5.0, -3.0, -9.0, 1)
        hit = c.wait_reached((5.0, -3.0, -9.0), 0.5, 10, sysid=1,
                             resend=lambda: c.goto(5.0, -3.0, -9.0, 1), resend_interval=0.5)
        assert hit.distance <= 0.5 and hit.position.t > p.t
        c.land(1, timeout=10)
        assert c.position(1).z > -0.2


@pytest.mark.parametrize("copter", [{"loss": 0.2, "seed": 7, "prearm_fails": 1}], indirect=True)
def test_sequence_survives_20_percent_loss(copter):
    fc, url = copter
    with Client.connect(url) as c:
        c.wait_heartbeat(1, timeout=10)
        c.set_mode("GUIDED", 1, timeout=10)
        c.arm(1, timeout=15, retry_interval=0.1)
        c.takeoff(5.0, 1, timeout=15)
        g = (-4.0, -2.0, -5.0)
        c.goto(*g, 1)
        c.wait_reached(g, 0.5, 15, sysid=1, resend=lambda: c.goto(*g, 1), resend_interval=0.3)
        c.land(1, timeout=15)


@pytest.mark.parametrize("copter", [{"prearm_fails": 10**6}], indirect=True)
def test_arm_error_carries_prearm_texts(copter):
    fc, url = copter
    with Client.connect(url) as c:
        c.wait_heartbeat(1, timeout=5)
        with pytest.raises(ArmError) as ei:
            c.arm(1, timeout=1.5, retry_interval=0.1)
        assert ei.value.prearm == ["PreArm: Need Position Estimate"]
        assert "FAILED" in str(ei.value)


@pytest.mark.parametrize("copter", [{"refuse_guided": True}], indirect=True)
def test_mode_refused_is_typed(copter):
    fc, url = copter
    with Client.connect(url) as c:
        c.wait_heartbeat(1, timeout=5)
        with pytest.raises(ModeChangeError, match="FAILED"):
            c.set_mode("GUIDED", 1, timeout=1.5)
        with pytest.raises(CommandRejected):
            c.command_long(1, 31999, [], timeout=2)


def test_takeoff_refused_when_disarmed_and_goal_timeout(copter):
    fc, url = copter
    from gcs.client import TakeoffError
    with Client.connect(url) as c:
        c.wait_heartbeat(1, timeout=5)
        with pytest.raises(TakeoffError, match="FAILED"):
            c.takeoff(9.0, 1, timeout=3)
        with pytest.raises(GoalTimeout) as ei:  # not in GUIDED: the target is ignored
            c.wait_reached((50.0, 0, 0), 0.5, 0.5, sysid=1)
        assert ei.value.distance == pytest.approx(50.0)


@pytest.mark.parametrize("copter", [dict(prearm_fails=0, speed=0.25, sim_rate=1.0, drop_takeoff_acks=1)],
                         indirect=True)
def test_a_takeoff_whose_ack_was_lost_is_not_failed_by_the_refusal_of_its_resend(copter):
    """The takeoff's ACK is lost; the re-send a second later finds the copter just off the ground
    (0.25 m at 0.25 m/s) and is refused FAILED, as ArduPilot refuses a second takeoff. The copter
    is climbing, so the takeoff goes on. (Seen in a lossy sweep run: 'TakeoffError: command
    MAV_CMD_NAV_TAKEOFF rejected: FAILED', when the client looked for 0.5 m after 0.5 s.)"""
    fc, url = copter
    with Client.connect(url) as c:
        c.wait_heartbeat(1, timeout=5)
        c.set_mode("GUIDED", 1)
        c.arm(1)
        p = c.takeoff(1.0, 1, timeout=20)
        assert p.z <= -0.5
        assert fc.commands.count(apm.MAV_CMD_NAV_TAKEOFF) == 2       # the first, and the refused re-send


def test_wait_reached_ignores_a_stale_sample_inside_the_radius(copter):
    """The client's newest position is inside the goal's radius, but it predates the goal:
    it must not count. Only samples the vehicle stamped after the goal was sent do, so
    wait_reached returns once the vehicle has flown back, not at once."""
    fc, url = copter
    goal = (5.0, 0.0, 0.0)
    with Client.connect(url) as c:
        c.wait_heartbeat(1, timeout=5)
        c.set_mode("GUIDED", 1, timeout=5)
        c.arm(1, timeout=10, retry_interval=0.1)
        c.goto(*goal, 1)
        c.wait_reached(goal, 0.5, 10, sysid=1)
        fc.streaming = False                        # the vehicle goes quiet ...
        stale = c.position(1)
        assert stale.distance_to(goal) <= 0.5       # ... the client's newest sample is inside
        wait_until(lambda: fc.sim > stale.t + 0.2, 5, "the vehicle's clock to move on")
        fc.target, fc.pos = None, [35.0, 0.0, 0.0]  # meanwhile it is 30 m away, holding
        c.goto(*goal, 1)                            # the goal again: it flies back
        sent = c.sim_time(1)
        seen = []
        fc.streaming = True
        hit = c.wait_reached(goal, 0.5, 10, sysid=1, on_sample=lambda p, d: seen.append((p.t, d)))
    assert seen[0][1] > 0.5, seen[:3]               # the first sample counted is a fresh, far one
    assert all(t > sent for t, _ in seen) and sent == stale.t
    assert hit.position.t > sent and hit.distance <= 0.5
    assert hit.position.t - sent >= 29.5 / fc.speed      # it had to fly the 30 m back first


@pytest.mark.parametrize("copter", [{"sim_rate": 20.0}], indirect=True)
def test_a_rebooted_vehicle_clock_is_followed(copter):
    """A reboot while a goal is waited for: the vehicle's clock starts again near zero.
    The client follows its clock (sim_time goes back, the reboot is logged), and the
    samples after the reboot count for wait_reached although their stamps are older than
    the call's; the sample from before the reboot still does not."""
    fc, url = copter
    logs = []
    got = [0]                                         # LOCAL_POSITION_NED received
    with Client.connect(url, log=logs.append) as c:
        c.add_listener(lambda m: got.__setitem__(0, got[0] + (m.get_type() == "LOCAL_POSITION_NED")))
        c.wait_heartbeat(1, timeout=5)
        c.wait_position(1, timeout=5)
        wait_until(lambda: c.poll(0.05) < 0 or c.sim_time(1) > 8.0, 10, "8 s of vehicle time")
        fc.streaming = False
        s0 = fc.steps                                 # two steps on, nothing more is sent ...
        wait_until(lambda: c.poll(0.02) >= 0 and fc.steps > s0 + 1 and got[0] >= fc.pos_sent, 5,
                   "every position sent before the pause, received")   # ... and all was read
        before = c.sim_time(1)
        stale = c.position(1)
        fc.reboot()                                   # quiet until the wait below has begun
        seen = []
        hit = c.wait_reached(stale.xyz, 0.5, 10, sysid=1, resend=lambda: setattr(fc, "streaming", True),
                             resend_interval=0.0, on_sample=lambda p, d: seen.append(p))
        # the first sample after the reboot counted (not one once its clock passed the old one)
        assert hit.position.t < before - 5.0 and stale not in seen, (before, hit, seen[:3])
        assert c.system(1).reboots == 1 and any("system 1 rebooted" in line for line in logs), logs
        assert c.sim_time(1) < before - 5.0


def test_heartbeat_timeout_when_nobody_is_there():
    with Client.connect(f"udpout:127.0.0.1:{free_port()}") as c:
        t0 = time.monotonic()
        with pytest.raises(HeartbeatTimeout):
            c.wait_heartbeat(1, timeout=0.5)
        assert time.monotonic() - t0 < 2.0
        assert isinstance(HeartbeatTimeout("x"), TimeoutError)


@pytest.mark.parametrize("copter", [{"sim_rate": 300.0, "drop_commands": 1, "prearm_fails": 0}], indirect=True)
def test_command_retry_is_paced_on_the_vehicle_clock(copter):
    """A lost command is re-sent after ack_timeout seconds of the vehicle's time, so in a
    sped-up SITL sim-time timers (DISARM_DELAY) do not run out between tries. Here the
    vehicle runs 300x: ack_timeout 30 s of its time is 0.1 s of wall time, while the whole
    call may take only 10 wall s. Paced on the wall clock instead, the first retry would
    come after 30 wall s and the call would fail with CommandTimeout; no wall time is
    measured."""
    fc, url = copter
    sent_at = []                        # the vehicle time the client knew at each send (ms)
    with Client.connect(url) as c:
        c.wait_heartbeat(1, timeout=5)
        c.wait_position(1, timeout=5)
        send = c.mav.command_long_send  # a spy on the wire, not on the client's logic

        def spy(*a, **k):
            sent_at.append(c.system(1).time_boot_ms)
            return send(*a, **k)
        c.mav.command_long_send = spy
        c.command_long(1, apm.MAV_CMD_COMPONENT_ARM_DISARM, [1], ack_timeout=30.0, timeout=10)
    assert fc.armed and len(fc.command_sims) == 2 and len(sent_at) == 2
    # re-sent once the vehicle's clock, as the client knows it, had run 30 s on ...
    assert sent_at[1] - sent_at[0] >= 30_000, sent_at
    # ... which the vehicle's own clock confirms: it cannot have been read ahead of it
    assert fc.command_sims[1] >= sent_at[0] / 1000 + 30.0, (sent_at, fc.command_sims)


def test_the_plugins_fly_the_sequence_and_read_a_parameter(copter):
    """The capability plugins on their own (c.telemetry, c.action, c.goals, c.param), as MAVSDK's."""
    fc, url = copter
    with Client.connect(url) as c:
        st = c.telemetry.wait_heartbeat(1, timeout=5)
        assert st is c.system(1) and st.mav_type == apm.MAV_TYPE_QUADROTOR
        assert c.param.get_param("WPNAV_SPEED", 1, timeout=5) == pytest.approx(100.0 * fc.speed)
        c.action.set_mode("GUIDED", 1, timeout=5)
        c.action.arm(1, timeout=10, retry_interval=0.1)
        p = c.action.takeoff(3.0, 1, timeout=10)
        assert p.z <= -2.5 and c.telemetry.position(1).t >= p.t
        c.goals.goto(2.0, 1.0, -3.0, 1)
        hit = c.goals.wait_reached((2.0, 1.0, -3.0), 0.5, 10, sysid=1)
        assert hit.distance <= 0.5 and c.telemetry.sim_time(1) >= hit.position.t
        assert [t for _, _, t in c.telemetry.statustexts_since(0, 1)] == ["PreArm: Need Position Estimate"] * 2
        c.action.disarm(1, force=True)
        assert not c.system(1).armed and not fc.armed


def test_the_clients_calls_are_its_plugins_calls():
    """c.takeoff is c.action.takeoff: same signature and docstring, nothing of its own."""
    import inspect

    from gcs.client import Action, Goals, Param, Telemetry
    from gcs.client.commands import Commands
    for name, plugin in [("takeoff", Action), ("set_mode", Action), ("land", Action), ("rtl", Action),
                         ("arm", Action), ("disarm", Action), ("goto", Goals), ("goto_named", Goals),
                         ("wait_reached", Goals), ("get_param", Param), ("wait_heartbeat", Telemetry),
                         ("wait_position", Telemetry), ("sim_time", Telemetry), ("position", Telemetry),
                         ("statustexts_since", Telemetry), ("set_message_interval", Telemetry),
                         ("command_long", Commands)]:
        ours, theirs = getattr(Client, name), getattr(plugin, name)
        assert ours.__doc__ == theirs.__doc__ and ours.__wrapped__ is theirs, name
        assert inspect.signature(ours) == inspect.signature(theirs), name


def test_the_tracker_notes_each_system_and_follows_a_reboot():
    """gcs.client.state.SystemTracker, pure: the client's clock is only the stamp it is given."""
    from gcs.client.state import SystemTracker
    rx = apm.MAVLink(None)

    def msg(m, sysid=1):
        return rx.parse_buffer(m.pack(apm.MAVLink(None, srcSystem=sysid, srcComponent=1)))[0]

    stamp = [7.5]
    tr = SystemTracker(lambda: stamp[0])
    hb = msg(apm.MAVLink_heartbeat_message(apm.MAV_TYPE_QUADROTOR, apm.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                           apm.MAV_MODE_FLAG_SAFETY_ARMED, 4, apm.MAV_STATE_ACTIVE, 3))
    assert tr.note(hb, "HEARTBEAT") is None
    st = tr.system(1)
    assert st.armed and st.mode_name == "GUIDED" and st.heartbeat_wall == 7.5
    gcs_hb = msg(apm.MAVLink_heartbeat_message(apm.MAV_TYPE_GCS, apm.MAV_AUTOPILOT_INVALID, 0, 0, 4, 3), 2)
    tr.note(gcs_hb, "HEARTBEAT")
    assert tr.system(2).heartbeat_wall is None           # a GCS is not a vehicle
    for ms in (9000, 8000):                              # a late sample: not the newest
        tr.note(msg(apm.MAVLink_local_position_ned_message(ms, 1.0, 2.0, -3.0, 0, 0, 0)), "LOCAL_POSITION_NED")
    assert st.position.time_boot_ms == 9000 and st.sim_time == 9.0 and st.reboots == 0
    said = tr.note(msg(apm.MAVLink_local_position_ned_message(1000, 0, 0, 0, 0, 0, 0)), "LOCAL_POSITION_NED")
    assert "system 1 rebooted" in said and st.reboots == 1 and st.position.time_boot_ms == 1000
    for text in (b"one", b"two"):
        tr.note(msg(apm.MAVLink_statustext_message(apm.MAV_SEVERITY_INFO, text)), "STATUSTEXT")
    tr.note(msg(apm.MAVLink_statustext_message(apm.MAV_SEVERITY_INFO, b"other"), 3), "STATUSTEXT")
    assert tr.text_serial == 3
    assert tr.statustexts_since(1, 1) == [(2, apm.MAV_SEVERITY_INFO, "two")]
    assert [t for _, _, t in tr.statustexts_since(0)] == ["one", "two", "other"]
