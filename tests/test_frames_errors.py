"""Every error type: its class, its place in the hierarchy, and what its message names."""
from __future__ import annotations

import math

import pytest

from common.frames import (LATEST, Buffer, ConnectivityException, ExtrapolationException,
                           FutureExtrapolationException, InvalidArgumentException, LookupException,
                           PastExtrapolationException, PointStamped, PoseStamped, TimeoutException,
                           Transform, TransformException, TransformStamped)


def ts(parent, child, stamp, tf=None):
    return TransformStamped(parent, child, stamp, tf or Transform())


@pytest.fixture
def buf():
    b = Buffer()
    b.set_transform_static(ts("world", "tower", 0.0))
    for t in (10.0, 11.0, 12.0):
        b.set_transform(ts("world", "drone", t, Transform((t, 0, 0))))
    b.set_transform_static(ts("moon", "lander", 0.0))
    return b


def test_hierarchy():
    for cls in (LookupException, ConnectivityException, ExtrapolationException,
                InvalidArgumentException, TimeoutException):
        assert issubclass(cls, TransformException)
    assert issubclass(PastExtrapolationException, ExtrapolationException)
    assert issubclass(FutureExtrapolationException, ExtrapolationException)
    assert not issubclass(PastExtrapolationException, FutureExtrapolationException)
    assert issubclass(InvalidArgumentException, ValueError)


def test_lookup_exception_names_frame_and_argument(buf):
    with pytest.raises(LookupException) as e:
        buf.lookup_transform("foo", "drone")
    assert str(e.value).startswith('"foo" passed to lookupTransform argument target_frame does not exist.')
    assert e.value.frame == "foo" and e.value.argument == "target_frame"
    with pytest.raises(LookupException) as e:
        buf.lookup_transform("world", "bar")
    assert '"bar" passed to lookupTransform argument source_frame does not exist.' in str(e.value)
    with pytest.raises(LookupException, match='"baz" passed to lookupTransform argument fixed_frame'):
        buf.lookup_transform_full("world", 10.0, "drone", 10.0, "baz")
    ok, why = buf.can_transform("nope", "world", return_debug_tuple=True)
    assert not ok and '"nope" passed to canTransform argument target_frame does not exist.' in why


def test_connectivity_exception_names_both_frames(buf):
    with pytest.raises(ConnectivityException) as e:
        buf.lookup_transform("tower", "lander")
    msg = str(e.value)
    assert "'tower' and 'lander'" in msg and "not part of the same tree" in msg
    assert "rooted at 'world'" in msg and "rooted at 'moon'" in msg
    assert (e.value.target_frame, e.value.source_frame) == ("tower", "lander")


def test_past_extrapolation_message(buf):
    with pytest.raises(PastExtrapolationException) as e:
        buf.lookup_transform("tower", "drone", 9.5)
    msg = str(e.value)
    assert ("Lookup would require extrapolation into the past. Requested time 9.500000 but the "
            "earliest data is at time 10.000000, when looking up transform from frame [drone] to "
            "frame [tower]") in msg
    assert "[world] -> [drone]" in msg
    assert (e.value.requested, e.value.earliest, e.value.latest) == (9.5, 10.0, 12.0)
    assert e.value.edge == ("world", "drone")


def test_future_extrapolation_message(buf):
    with pytest.raises(FutureExtrapolationException) as e:
        buf.lookup_transform("drone", "tower", 12.25)
    msg = str(e.value)
    assert ("Lookup would require extrapolation into the future. Requested time 12.250000 but the "
            "latest data is at time 12.000000, when looking up transform from frame [tower] to "
            "frame [drone]") in msg
    assert "past" not in msg
    assert not isinstance(e.value, PastExtrapolationException)


def test_extrapolation_with_single_sample():
    b = Buffer()
    b.set_transform(ts("w", "d", 5.0))
    with pytest.raises(PastExtrapolationException):
        b.lookup_transform("w", "d", 4.0)
    with pytest.raises(FutureExtrapolationException):
        b.lookup_transform("w", "d", 6.0)
    assert b.lookup_transform("w", "d", 5.0).stamp == 5.0


@pytest.mark.parametrize("parent,child,what", [
    ("", "drone", "cannot be empty"),
    ("world", "", "cannot be empty"),
    ("/world", "drone", "cannot start with a '/'"),
    ("world", "/drone", "cannot start with a '/'"),
    ("drone", "drone", "its own parent"),
    (None, "drone", "must be str"),
])
def test_invalid_frame_ids_on_insert(parent, child, what):
    b = Buffer()
    for setter in (b.set_transform, b.set_transform_static):
        with pytest.raises(InvalidArgumentException, match=what):
            setter(ts(parent, child, 1.0))


@pytest.mark.parametrize("stamp", [math.nan, math.inf, -math.inf, "1.0", LATEST, None])
def test_invalid_stamp_on_insert(stamp):
    with pytest.raises(InvalidArgumentException):
        Buffer().set_transform(ts("world", "drone", stamp))


def test_invalid_transform_on_insert():
    with pytest.raises(InvalidArgumentException, match="must be a Transform"):
        Buffer().set_transform(TransformStamped("world", "drone", 1.0, (0, 0, 0, 0, 0, 0, 1)))
    with pytest.raises(InvalidArgumentException):
        Transform((0, 0, 0), (0, 0, 0.5, 0.5))  # norm 0.707


def test_invalid_lookup_arguments(buf):
    with pytest.raises(InvalidArgumentException, match="target_frame"):
        buf.lookup_transform("", "drone")
    with pytest.raises(InvalidArgumentException, match="source_frame.*'/'"):
        buf.lookup_transform("world", "/drone")
    for bad in (math.nan, math.inf, "now", None):
        with pytest.raises(InvalidArgumentException):
            buf.lookup_transform("world", "drone", bad)
    for bad_frame in (["world"], None, 3):
        with pytest.raises(InvalidArgumentException, match="must be str"):
            buf.lookup_transform(bad_frame, "drone", 10.0)
        with pytest.raises(InvalidArgumentException, match="must be str"):
            buf.lookup_transform("world", bad_frame)
    with pytest.raises(InvalidArgumentException):
        buf.lookup_transform("world", "drone", 10.0, timeout=-1.0)
    with pytest.raises(InvalidArgumentException):
        buf.lookup_transform_full("world", math.nan, "drone", 10.0, "world")
    assert buf.can_transform("", "drone") is False  # can_transform never raises (tf2)
    with pytest.raises(InvalidArgumentException):
        Buffer(cache_time=0.0)
    with pytest.raises(InvalidArgumentException):
        PointStamped("world", 0.0, [math.nan, 0, 0])
    with pytest.raises(InvalidArgumentException):
        PoseStamped("world", 0.0, [0, 0, 0], [0, 0, 0, 2])


def test_loop_refused_names_frames():
    b = Buffer()
    b.set_transform_static(ts("a", "b", 0.0))
    b.set_transform(ts("b", "c", 1.0))
    b.set_transform(ts("c", "d", 1.0))
    with pytest.raises(InvalidArgumentException) as e:
        b.set_transform(ts("d", "a", 1.0))
    msg = str(e.value)
    assert '"d"' in msg and '"a"' in msg and "loop" in msg
    with pytest.raises(InvalidArgumentException, match="loop"):
        b.set_transform_static(ts("c", "b", 1.0))  # re-parenting b under its own descendant
    # the refused inserts changed nothing
    assert b.all_frames_as_string() == ("Frame b exists with parent a.\nFrame c exists with parent b.\n"
                                        "Frame d exists with parent c.\n")
    assert b.lookup_transform("a", "d").stamp == 1.0


def test_timeout_exception_message():
    b = Buffer()
    b.set_transform(ts("world", "drone", 1.0))
    with pytest.raises(TimeoutException) as e:
        b.lookup_transform("world", "drone", 2.0, timeout=0.05)
    msg = str(e.value)
    assert "Timed out after 0.050 s" in msg and "[drone] to [world]" in msg and "2.000000" in msg
    assert isinstance(e.value.__cause__, FutureExtrapolationException)
    assert e.value.last_error is e.value.__cause__
