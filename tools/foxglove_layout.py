"""Write the Foxglove layout that opens a towerlink run ready to watch (docs/foxglove_layout.json).

    python -m tools.foxglove_layout [-o docs/foxglove_layout.json]

Built with the foxglove-sdk's layout types (the extra [view]) so it follows the app's schema.
What it shows: a 3D view in the z-up display frame `world_enu` following the drone (the
vehicles, their tracks, the tower's goals, the rover's target through the full-attitude
frame (red) and the yaw-only frame (green)); a plot of the running follow error and the
wobble of both frames; the transform tree; the latest summary.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

DEFAULT_OUT = Path(__file__).resolve().parent.parent / "docs" / "foxglove_layout.json"


def build() -> dict:
    import foxglove.layouts as fl

    three_d = fl.ThreeDeePanel(config=fl.ThreeDeeConfig(
        fixed_frame="world_enu", follow_tf="drone", follow_mode="follow-position",
        topics={t: fl.BaseRendererSceneUpdateTopicSettings(visible=True) for t in ("/vehicles", "/goals", "/follow")}))
    plot = fl.PlotPanel(config=fl.PlotConfig(paths=[
        fl.PlotSeries(value="/summary.follow_error_rms", label="rover follow error RMS (m)"),
        fl.PlotSeries(value="/summary.wobble_full_rms", label="wobble, full attitude RMS (m)"),
        fl.PlotSeries(value="/summary.wobble_yaw_rms", label="wobble, yaw-only RMS (m)"),
    ]))
    side = fl.SplitContainer(direction="column", items=[
        fl.SplitItem(proportion=1, content=plot),
        fl.SplitItem(proportion=1, content=fl.TransformTreePanel()),
        fl.SplitItem(proportion=1, content=fl.RawMessagesPanel(config=fl.RawMessagesConfig(topic_path="/summary"))),
    ])
    layout = fl.Layout(content=fl.SplitContainer(direction="row", items=[
        fl.SplitItem(proportion=2, content=three_d), fl.SplitItem(proportion=1, content=side)]))
    return json.loads(layout.to_json())


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m tools.foxglove_layout", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-o", "--output", default=str(DEFAULT_OUT), help="where to write (default %(default)s)")
    a = p.parse_args(argv)
    Path(a.output).write_text(json.dumps(build(), indent=2) + "\n")
    print(f"wrote {a.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
