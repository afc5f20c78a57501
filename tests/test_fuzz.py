"""A bounded, seeded fuzz of a real `towerlink sitl` (its UDP port) and a real `towerlink bridge`
(its tower port, the side anyone on the network reaches) (issue 8, "Proof"): random bytes,
random valid MAVLink 2 messages of every type in the dialect with random field values
(NaN, +-inf, 1e30, type limits), truncated and bit-flipped frames, MAVLink 1 frames with a bad
CRC and oversized datagrams. Afterwards each still answers (HEARTBEAT, PARAM_REQUEST_READ
through the bridge too), the drone did not arm or move, the malformed input was counted where
the counts are reported (the vehicle's RX_* NAMED_VALUE_INT and exit stats line, the bridge's
TOWERLINK_BRIDGE_STATUS and exit line), and neither process printed a traceback."""
from __future__ import annotations

import math
import random
import socket
import time

import pytest

from bridge_fakes import Endpoint
from common.mavlink.dialect import towerlink as tl
from support import free_ports, wait_until

SEED = 20261123
BUDGET_S = 6.0          # wall seconds of sending per target (the whole test stays under 30 s)
MIN_SENT = 300          # and at least this many datagrams per target, however slowly a loaded machine sends
FLOATS = [math.nan, math.inf, -math.inf, 1e30, -1e30, 0.0, 1.0, -1.0]
INT_RANGE = {"int8_t": (-2**7, 2**7 - 1), "uint8_t": (0, 2**8 - 1), "int16_t": (-2**15, 2**15 - 1),
             "uint16_t": (0, 2**16 - 1), "int32_t": (-2**31, 2**31 - 1), "uint32_t": (0, 2**32 - 1),
             "int64_t": (-2**63, 2**63 - 1), "uint64_t": (0, 2**64 - 1), "uint8_t_mavlink_version": (0, 255)}
# never sent: the one command that must stay possible to detect, arming, is kept out of the
# random ids so "did not arm" tests the vehicle, not luck; everything else is fair game
FORBIDDEN_COMMANDS = {tl.MAV_CMD_COMPONENT_ARM_DISARM, tl.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN}


# the commands the vehicle handles: drawn half the time, so their handlers meet the NaNs
KNOWN_COMMANDS = [tl.MAV_CMD_DO_SET_MODE, tl.MAV_CMD_DO_SET_HOME, tl.MAV_CMD_DO_CHANGE_SPEED,
                  tl.MAV_CMD_NAV_TAKEOFF, tl.MAV_CMD_NAV_LAND, tl.MAV_CMD_NAV_LOITER_UNLIM,
                  tl.MAV_CMD_NAV_RETURN_TO_LAUNCH, tl.MAV_CMD_CONDITION_YAW, tl.MAV_CMD_PREFLIGHT_CALIBRATION,
                  tl.MAV_CMD_SET_MESSAGE_INTERVAL, tl.MAV_CMD_GET_MESSAGE_INTERVAL, tl.MAV_CMD_REQUEST_MESSAGE,
                  tl.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES]


class _Out:
    def write(self, b):
        pass


def _value(rng: random.Random, ftype: str):
    if ftype in ("float", "double"):
        return rng.choice(FLOATS) if rng.random() < 0.7 else rng.uniform(-1e6, 1e6)
    lo, hi = INT_RANGE[ftype]
    return rng.choice([lo, hi, 0, 1, rng.randint(lo, hi)])


def random_message(rng: random.Random, classes):
    """A message of a random type with random field values (None if pymavlink cannot build it)."""
    cls = rng.choice(classes)
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths))
    args = []
    for name, ftype in zip(cls.fieldnames, cls.fieldtypes):
        n = lengths.get(name, 0)
        if ftype == "char":
            args.append(bytes(rng.randrange(256) for _ in range(rng.randint(0, max(1, n)))))
        elif n:
            args.append([_value(rng, ftype) for _ in range(n)])
        elif name == "command" and rng.random() < 0.5:
            args.append(rng.choice(KNOWN_COMMANDS))
        elif name == "target_system" and rng.random() < 0.5:
            args.append(1)                  # the drone
        else:
            args.append(_value(rng, ftype))
    msg = cls(*args)
    cmd = getattr(msg, "command", None)
    if isinstance(cmd, int) and cmd in FORBIDDEN_COMMANDS:
        return None
    return msg


def datagrams(rng: random.Random):
    """Endless seeded stream of hostile datagrams."""
    classes = [c for c in tl.mavlink_map.values()]
    enc = tl.MAVLink(_Out(), srcSystem=rng.randint(1, 254), srcComponent=rng.randint(0, 255))
    v1 = __import__("pymavlink.dialects.v10.ardupilotmega", fromlist=["x"])
    enc1 = v1.MAVLink(_Out(), srcSystem=200, srcComponent=1)

    def frame():
        for _ in range(5):
            msg = random_message(rng, classes)
            if msg is None:
                continue
            enc.srcSystem = rng.choice([1, 2, 255, rng.randint(0, 255)])
            try:
                return bytes(msg.pack(enc))
            except Exception:           # a value pymavlink itself cannot pack (e.g. a bad enum)
                continue
        return b""

    while True:
        kind = rng.randrange(6)
        if kind == 0:
            yield bytes(rng.randrange(256) for _ in range(rng.randint(1, 600)))
        elif kind == 1:
            yield b"".join(frame() for _ in range(rng.randint(1, 8)))
        elif kind == 2:
            f = frame()
            yield f[:rng.randint(1, max(1, len(f) - 1))]
        elif kind == 3:
            f = bytearray(frame() or b"\xfd\x00")
            for _ in range(rng.randint(1, 3)):
                i = rng.randrange(len(f))
                f[i] ^= 1 << rng.randrange(8)
            yield bytes(f)
        elif kind == 4:
            hb = bytearray(enc1.heartbeat_encode(6, 8, 0, 0, 0).pack(enc1))
            hb[-1] ^= 0x5A                  # MAVLink 1, bad CRC
            yield bytes(hb) * rng.randint(1, 4)
        else:
            if rng.random() < 0.5:
                yield bytes(rng.randrange(256) for _ in range(65507))
            else:
                out = b""
                while len(out) < 60000:
                    out += frame()
                yield out[:65507]


def _fuzz(dst, rng, budget):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sent = 0
    end = time.monotonic() + budget
    gen = datagrams(rng)
    try:
        while time.monotonic() < end or sent < MIN_SENT:
            d = next(gen)
            try:
                s.sendto(d, dst)
                sent += 1
            except OSError:        # EMSGSIZE etc.: nothing reached the target
                pass
            if sent % 50 == 0:
                time.sleep(0.002)  # poll-rate pause: let the receiver's socket buffer drain
    finally:
        s.close()
    return sent


def test_bridge_passes_a_non_finite_yaw_on():
    """What the fuzz found: a tower SET_POSITION_TARGET_LOCAL_NED with yaw = inf made
    translate.heading raise (math domain error) and killed the bridge. The bridge translates;
    the vehicle validates: the yaw goes on as sent and the vehicle refuses the target."""
    from bridge import translate
    from common.frames import Transform
    T = Transform((1.0, 2.0, 0.0))
    for yaw in (math.inf, -math.inf, math.nan):
        msg = tl.MAVLink_set_position_target_local_ned_message(0, 1, 1, tl.MAV_FRAME_LOCAL_NED, 0b0000_1001_1111_1000,
                                                               1, 2, -3, 0, 0, 0, 0, 0, 0, yaw, 0)
        out = translate.set_position_target(msg, T)
        assert (out.x, out.y, out.z) == (2.0, 4.0, -3.0)
        assert not math.isfinite(out.yaw)


def _no_traceback(path):
    text = open(path, errors="replace").read()
    assert "Traceback" not in text, text[-3000:]
    return text


@pytest.mark.timeout(90)
def test_fuzz_sitl_and_bridge(processes, tmp_path):
    dport, tport = free_ports(2)
    sitl_log, bridge_log = tmp_path / "sitl.log", tmp_path / "bridge.log"
    sitl = processes.start(["towerlink", "sitl", "--drones", "1", "--rovers", "0", "--speedup", "2", "--no-save",
                            "--tcp-base", "0", "--udp-base", "0", "--endpoint", f"0=udpin:127.0.0.1:{dport}"],
                           stdout=open(sitl_log, "w"), stderr=__import__("subprocess").STDOUT)
    bridge = processes.start(["towerlink", "bridge", "--tower", f"udpin:127.0.0.1:{tport}",
                              "--drone", f"udpout:127.0.0.1:{dport}", "--rover", "none", "--no-follow", "-q"],
                             stdout=open(bridge_log, "w"), stderr=__import__("subprocess").STDOUT)
    tower = Endpoint(255, 190, tport, listen=False, name="tower")
    try:
        def hb():
            tower.mav.heartbeat_send(tl.MAV_TYPE_GCS, tl.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            return tower.of_type("HEARTBEAT", lambda m: m.get_srcSystem() == 1)
        wait_until(hb, 30, "the drone's heartbeat through the bridge", interval=0.2)
        start = tower.wait("LOCAL_POSITION_NED", lambda m: m.get_srcSystem() == 1, 10)
        rng = random.Random(SEED)
        sent_v = _fuzz(("127.0.0.1", dport), rng, BUDGET_S)
        sent_b = _fuzz(("127.0.0.1", tport), rng, BUDGET_S)
        assert sent_v > 200 and sent_b > 200
        assert sitl.poll() is None and bridge.poll() is None
        # both still answer: a PARAM_REQUEST_READ through the bridge, fresh heartbeats
        tower.clear()
        def read():
            tower.mav.heartbeat_send(tl.MAV_TYPE_GCS, tl.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            # the fuzz's valid REQUEST_DATA_STREAM / SET_MESSAGE_INTERVAL may have (legitimately,
            # as on ArduPilot) switched streams off: a GCS asks again for what it reads, as
            # MAVProxy does when it connects
            tower.mav.request_data_stream_send(1, 1, tl.MAV_DATA_STREAM_ALL, 4, 1)
            for msgid in (0, 32, 251):      # HEARTBEAT, LOCAL_POSITION_NED, NAMED_VALUE_INT
                tower.mav.command_long_send(1, 1, tl.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msgid, 0, 0, 0, 0, 0, 0)
            tower.mav.param_request_read_send(1, 1, b"SYSID_THISMAV", -1)
            return tower.of_type("PARAM_VALUE", lambda m: m.param_id == "SYSID_THISMAV")
        assert wait_until(read, 20, "PARAM_VALUE through the bridge", interval=0.3)[-1].param_value == 1
        hb_after = tower.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 1, 10)
        assert not hb_after.base_mode & tl.MAV_MODE_FLAG_SAFETY_ARMED
        assert not tower.of_type("HEARTBEAT", lambda m: m.get_srcSystem() == 1
                                 and m.base_mode & tl.MAV_MODE_FLAG_SAFETY_ARMED)
        # it did not move (tower-frame coordinates: compare with the sample before the fuzz)
        lp = tower.wait("LOCAL_POSITION_NED", lambda m: m.get_srcSystem() == 1, 10)
        assert math.dist((lp.x, lp.y, lp.z), (start.x, start.y, start.z)) < 0.3
        # malformed input counted where it is reported: the bridge's status for the tower link,
        # and the vehicle's RX_* counters (sent once a second to every peer, the bridge forwards them)
        st = tower.wait("TOWERLINK_BRIDGE_STATUS", lambda m: m.link == "tower" and m.malformed > 0, 10)
        assert st.malformed > 0
        counters = tower.wait("NAMED_VALUE_INT", lambda m: m.get_srcSystem() == 1 and m.name == "RX_BADCRC", 10)
        assert counters.value > 0
    finally:
        tower.close()
        processes.stop(bridge)
        processes.stop(sitl)
    assert sitl.returncode == 0 and bridge.returncode == 0
    out = _no_traceback(sitl_log)
    stats = out[out.index("stats:"):]
    for key in ("bad_crc=", "garbage=", "truncated="):
        assert key in stats, stats
    _no_traceback(bridge_log)
