"""towerlink tf-echo: tf2_echo's shape and semantics, offline from a tlog and live from a bridge."""
from __future__ import annotations

import math
import re
import struct
import subprocess

import numpy as np
import pytest

from common.mavlink.dialect import towerlink as tl
from common.frames import Buffer, Transform, TransformStamped
from common.tf2_ros.wire import transform_message
from bridge_fakes import FakeVehicle
from support import free_ports, wait_until
from common.frames import euler_from_quaternion
from tools.tf_format import format_tf_echo

TOWER = TransformStamped("world", "tower", 0.0,
                         Transform.from_euler(yaw=-math.pi / 6, translation=(72.72144, -131.19296, 0)))


def parse_block(text: str):
    """[(time, translation, quaternion, rpy_rad, rpy_deg)] from tf_echo output."""
    nums = lambda s: [float(v) for v in s.split(",")]
    pat = re.compile(r"At time (\S+)\n- Translation: \[(.*)\]\n- Rotation: in Quaternion \[(.*)\]\n"
                     r" {12}in RPY \(radian\) \[(.*)\]\n {12}in RPY \(degree\) \[(.*)\]")
    return [(float(m[0]), nums(m[1]), nums(m[2]), nums(m[3]), nums(m[4])) for m in pat.findall(text)]


def test_format_shape_matches_tf_echo():
    T = Transform.from_euler(yaw=-math.pi / 2, translation=(2.398, 6.783, 0))
    text = format_tf_echo(TransformStamped("a", "b", 1263248513.809, T))
    assert text == ("At time 1263248513.809\n"
                    "- Translation: [2.398, 6.783, 0.000]\n"
                    "- Rotation: in Quaternion [0.000, 0.000, -0.707, 0.707]\n"
                    "            in RPY (radian) [0.000, 0.000, -1.571]\n"
                    "            in RPY (degree) [0.000, 0.000, -90.000]")
    # roll, pitch, yaw order with R = Rz(yaw) Ry(pitch) Rx(roll)
    r, p, y = euler_from_quaternion(Transform.from_euler(yaw=0.3, pitch=-0.2, roll=0.1).xyzw)
    assert (r, p, y) == pytest.approx((0.1, -0.2, 0.3))
    assert format_tf_echo(((1, 2, 3), (0, 0, 0, 1)), 5).startswith("At time 5.000\n")


def write_tlog(path, msgs):
    enc = tl.MAVLink(None, srcSystem=250, srcComponent=191)
    with open(path, "wb") as f:
        for k, m in enumerate(msgs):
            f.write(struct.pack(">Q", 1_700_000_000_000_000 + 1000 * k))
            f.write(bytes(m.pack(enc)))
            enc.seq = (enc.seq + 1) % 256


def drone_at(t):
    return TransformStamped("world", "drone", t,
                            Transform.from_euler(yaw=0.1 * t, pitch=0.05, translation=(t, 2 * t, -9)))


def tfecho(*args):
    """Run `towerlink tf-echo ARGS` in this process: (exit status, stdout, stderr)."""
    import contextlib
    import io

    from tools.cli import main
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(["tf-echo", *args])
    return rc, out.getvalue(), err.getvalue()


def test_offline_from_tlog(tmp_path):
    tlog = tmp_path / "tower.tlog"
    msgs = [transform_message(TOWER, static=True)]
    msgs += [transform_message(drone_at(t)) for t in (1.0, 1.5, 2.0)]
    msgs.insert(2, tl.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3))      # other traffic is skipped
    write_tlog(tlog, msgs)
    ref = Buffer()
    ref.set_transform_static(TOWER)
    for t in (1.0, 1.5, 2.0):
        ref.set_transform(drone_at(t))

    # tf_echo semantics: `tf-echo world tower` = lookup_transform("world", "tower"): the tower in world
    rc, out, err = tfecho("world", "tower", "--tlog", str(tlog))
    assert rc == 0, err
    (t, tr, q, rpy, deg), = parse_block(out)
    assert t == 0.0 and tr == pytest.approx([72.721, -131.193, 0.0], abs=1e-3)
    assert rpy[2] == pytest.approx(-0.524, abs=1e-3) and deg[2] == pytest.approx(-30.0, abs=1e-3)
    rc, out, _ = tfecho("tower", "world", "--tlog", str(tlog))
    (t, tr, q, rpy, deg), = parse_block(out)
    inv = TOWER.transform.inverse()
    assert tr == pytest.approx(list(inv.xyz), abs=1e-3) and deg[2] == pytest.approx(30.0, abs=1e-3)

    # at a time: interpolated like tf2
    rc, out, _ = tfecho("tower", "drone", "--tlog", str(tlog), "--time", "1.25")
    (t, tr, q, rpy, deg), = parse_block(out)
    want = ref.lookup_transform("tower", "drone", 1.25)
    assert t == 1.25 and tr == pytest.approx(list(want.transform.xyz), abs=1e-3)
    assert abs(np.dot(q, want.transform.xyzw)) == pytest.approx(1.0, abs=2e-3)

    # every stamp of the chain
    rc, out, _ = tfecho("world", "drone", "--tlog", str(tlog))
    blocks = parse_block(out)
    assert [b[0] for b in blocks] == [1.0, 1.5, 2.0]
    assert blocks[-1][1] == pytest.approx([2.0, 4.0, -9.0], abs=1e-3)
    rc, out, _ = tfecho("world", "drone", "--tlog", str(tlog), "--count", "1")
    assert len(parse_block(out)) == 1

    # outside the data: extrapolation error, exit 1; unknown frame: exit 1 and the frame list
    rc, out, err = tfecho("world", "drone", "--tlog", str(tlog), "--time", "5")
    assert rc == 1 and "xtrapolation" in err
    rc, out, err = tfecho("world", "nowhere", "--tlog", str(tlog))
    assert rc == 1 and "Frame tower exists with parent world." in err


@pytest.mark.parametrize("name, says", [
    ("missing.tlog", "file does not exist"),
    ("missing", "file does not exist"),          # pymavlink would take it for a serial port
    ("run.mcap", "file does not exist"),
    ("", "is a directory, not a tlog or .mcap recording"),
])
def test_offline_recording_that_is_not_a_file_is_one_line_and_exit_2(tmp_path, name, says):
    path = str(tmp_path / name) if name else str(tmp_path)
    rc, out, err = tfecho("world", "drone", "--tlog", path)
    assert (rc, out, err) == (2, "", f"tf-echo: {path}: {says}\n")


def test_live_from_running_bridge(processes):
    tport, dport, oport = free_ports(3)
    drone = FakeVehicle(1, dport, name="drone")
    try:
        processes.start(["towerlink", "bridge", "--tower", f"udpin:127.0.0.1:{tport}",
                         "--drone", f"udpout:127.0.0.1:{dport}", "--rover", "none", "--no-follow",
                         "--out", f"udpout:127.0.0.1:{oport}"])
        echo = processes.start(["towerlink", "tf-echo", "tower", "drone_yaw", "--connect",
                                f"udpin:127.0.0.1:{oport}", "--rate", "10", "--count", "3",
                                "--timeout", "30"], stderr=subprocess.DEVNULL)
        wait_until(lambda: drone.peer, 15, "bridge up")
        T = Transform.from_euler(yaw=1.0, pitch=0.2, roll=-0.1, translation=(-4, -2, -9))
        x, y, z, w = T.xyzw
        k = 0
        def feed():
            nonlocal k
            k += 1
            drone.pose(1000 + 50 * k, (-4, -2, -9), (w, x, y, z))
            return echo.poll() is not None
        wait_until(feed, 30, "tf-echo printing 3 times", interval=0.05)
        out = echo.stdout.read()
        assert echo.returncode == 0, out
        blocks = parse_block(out)
        assert len(blocks) == 3
        t, tr, q, rpy, deg = blocks[-1]
        assert tr == pytest.approx([-131.039, 73.524, -9.0], abs=0.06)       # the lab's house in tower
        assert rpy[0] == pytest.approx(0, abs=1e-3) and rpy[1] == pytest.approx(0, abs=1e-3)
        assert rpy[2] == pytest.approx(1.0 + math.pi / 6, abs=2e-3)          # yaw-only, in the tower frame
        assert t > 1.0
    finally:
        drone.close()
