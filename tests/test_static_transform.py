"""`towerlink static-transform`: what it refuses, with one line and exit status 2."""
from __future__ import annotations

import pytest

from tools.cli import main


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(["static-transform", *args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("values", [
    ["1", "2", "3", "0", "0", "0", "world", "world"],
    ["1", "2", "3", "0", "0", "0", "1", "tower", "tower"],
])
def test_a_transform_from_a_frame_to_itself_is_refused(capsys, values):
    """tf2 refuses it too: StaticTransformBroadcasterNode throws "child_frame_id cannot
    equal frame_id", and BufferCore::setTransform ignores it (TF_SELF_TRANSFORM)."""
    code, out, err = run(capsys, *values)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "a frame cannot be its own parent" in err
    assert f'"{values[-1]}"' in err


@pytest.mark.parametrize("parent, child, text", [
    ("", "tower", "cannot be empty"),
    ("/world", "tower", "cannot start with a '/'"),
])
def test_bad_frame_ids_are_refused(capsys, parent, child, text):
    code, out, err = run(capsys, "1", "2", "3", "0", "0", "0", parent, child)
    assert code == 2 and out == "" and text in err and err.count("\n") == 1


def test_a_good_transform_prints_both_directions(capsys):
    code, out, err = run(capsys, "1", "2", "3", "0", "0", "0", "world", "tower")
    assert code == 0 and err == ""
    assert "$ tf_echo world tower" in out and "$ tf_echo tower world" in out
