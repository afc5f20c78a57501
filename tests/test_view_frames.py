"""view-frames: graph model, layout, own SVG/matplotlib drawing, dot source, tlog and CLI."""
from __future__ import annotations

import struct
import xml.etree.ElementTree as ET

import pytest

from common.frames import Buffer, Transform, TransformStamped
from tools import view_frames as vf


def _buffer() -> Buffer:
    from common.scenario import load_scenario
    b = load_scenario().buffer()
    for k in range(21):
        t = 100.0 + 0.1 * k
        b.set_transform(TransformStamped("world", "drone", t,
                                         Transform.from_euler(yaw=0.1, pitch=0.2, translation=(t, 0, -9))),
                        "mavlink:250")
        b.set_transform(TransformStamped("world", "drone_yaw", t,
                                         Transform.from_euler(yaw=0.1, translation=(t, 0, -9))),
                        "mavlink:250")
        b.set_transform(TransformStamped("drone", "camera", t, Transform.identity()), "cam")
    return b


def test_graph_labels_like_tf2_view_frames():
    frames, edges = vf.graph_of(_buffer())
    assert frames[0] == "world"
    assert set(frames) == {"world", "tower", "drone", "drone_yaw", "camera"}
    assert frames.index("drone") < frames.index("camera")
    by_child = {e.child: e for e in edges}
    d = by_child["drone"]
    assert d.parent == "world" and not d.static
    assert d.label[0] == "Broadcaster: mavlink:250"
    assert d.label[1] == "Average rate: 10.000 Hz"
    assert d.label[2] == "Most recent transform: 102.000 (0.000 sec old)"
    assert d.label[3] == "Oldest transform: 100.000"
    assert d.label[4] == "Buffer length: 2.000 sec"
    assert by_child["tower"].static and "Broadcaster: scenario" in by_child["tower"].label
    # age against a later 'now'
    _, edges = vf.graph_of(_buffer(), now=103.5)
    assert "(1.500 sec old)" in {e.child: e for e in edges}["drone"].label[2]


def test_layout_is_a_tidy_tree():
    frames, edges = vf.graph_of(_buffer())
    pos = vf.layout(frames, edges)
    assert pos["world"][1] == 0 and pos["drone"][1] == 1 and pos["camera"][1] == 2
    leaves = sorted(pos[f][0] for f in ("camera", "drone_yaw", "tower"))
    assert leaves == [0.0, 1.0, 2.0]                       # leaves side by side
    assert pos["drone"][0] == pos["camera"][0]             # single child right below
    xs = [pos[c][0] for c in ("drone", "drone_yaw", "tower")]
    assert pos["world"][0] == pytest.approx((min(xs) + max(xs)) / 2)


def test_svg_is_well_formed_and_complete():
    frames, edges = vf.graph_of(_buffer())
    svg = vf.to_svg(frames, edges, title="t <&>")
    root = ET.fromstring(svg)
    texts = [t.text for t in root.iter("{http://www.w3.org/2000/svg}text")]
    for f in frames:
        assert f in texts
    assert "Broadcaster: mavlink:250" in texts and "t <&>" in texts
    lines = list(root.iter("{http://www.w3.org/2000/svg}line"))
    # each edge runs parent -> its label, then label -> child with the one arrowhead
    assert len(lines) == 2 * len(edges)
    assert sum(1 for ln in lines if ln.get("marker-end")) == len(edges)


def test_dot_source():
    frames, edges = vf.graph_of(_buffer())
    dot = vf.to_dot(frames, edges)
    assert dot.startswith("digraph G {") and dot.rstrip().endswith("}")
    assert '"world" -> "drone" [label="Broadcaster: mavlink:250\\nAverage rate: 10.000 Hz' in dot
    assert '"world" -> "tower"' in dot and "style=dashed" in dot


@pytest.mark.parametrize("ext", ["svg", "png", "pdf"])
def test_write_drawing_without_graphviz(tmp_path, ext):
    out = tmp_path / f"frames.{ext}"
    files = vf.write_drawing(_buffer(), out, use_dot=False)
    assert out in files and out.stat().st_size > 500
    magic = out.read_bytes()[:5]
    assert {"svg": b"<svg ", "png": b"\x89PNG\r", "pdf": b"%PDF-"}[ext] == magic
    yml = (tmp_path / "frames.yaml").read_text()
    assert "drone: \n  parent: 'world'\n  broadcaster: 'mavlink:250'" in yml
    with pytest.raises(ValueError):
        vf.write_drawing(_buffer(), tmp_path / "frames.jpg", use_dot=False)


def test_from_tlog_and_cli(tmp_path, capsys):
    from common.mavlink.dialect import encoder
    from common.tf2_ros.wire import transform_message
    mav = encoder(250, 191)
    path = tmp_path / "bridge.tlog"
    with open(path, "wb") as f:
        for ts, static in [(TransformStamped("world", "tower", 0.0,
                                             Transform.from_euler(yaw=-0.5, translation=(72.7, -131.2, 0))), True)] + \
                [(TransformStamped("world", "drone", 5 + 0.1 * k,
                                   Transform(translation=(k, 0, -9))), False) for k in range(30)]:
            f.write(struct.pack(">Q", 1_700_000_000_000_000) + transform_message(ts, static).pack(mav))
    buf, now = vf.buffer_from_tlog(path)
    assert now == pytest.approx(7.9)
    st = buf.edge_stats()
    assert st["drone"].rate_hz == pytest.approx(10.0) and st["tower"].is_static
    assert st["drone"].authority == "mavlink:250"

    from tools.cli import main
    out = tmp_path / "f.svg"
    assert main(["view-frames", "--tlog", str(path), "-o", str(out), "--no-dot"]) == 0
    printed = capsys.readouterr().out
    assert "drone: \n  parent: 'world'" in printed and "wrote" in printed
    assert out.exists()
    assert main(["view-frames", "--scenario", "-o", str(tmp_path / "s.svg"), "--no-dot"]) == 0


@pytest.mark.parametrize("name", ["missing.tlog", "missing", "run.mcap"])
def test_a_missing_recording_is_one_line_and_exit_2(tmp_path, capsys, name):
    from tools.cli import main
    path = str(tmp_path / name)
    assert main(["view-frames", "--tlog", path, "-o", str(tmp_path / "f.svg"), "--no-dot"]) == 2
    out, err = capsys.readouterr()
    assert (out, err) == ("", f"view-frames: {path}: file does not exist\n")
    assert not (tmp_path / "f.svg").exists()


def test_live_listen_with_nothing_there_fails_cleanly(capsys):
    from support import free_port
    from tools.cli import main
    assert main(["view-frames", "--listen", f"udpin:127.0.0.1:{free_port()}", "--duration", "0.3"]) == 1
    assert "no transforms received" in capsys.readouterr().err
