"""common.frames.Buffer where callers meet tf2's rules (issue 9, list 1-4, and the pruning window).

Checked against ros2/geometry2 tf2/src/buffer_core.cpp (walkToTopParent, lookupTransformImpl,
canTransform, getLatestCommonTime, clear) and tf2/src/cache.cpp (TimeCache::insertData,
findClosest, clearList). Each test fails on the buffer as it was before it matched tf2.
"""
from __future__ import annotations

import math

import pytest

from common.frames import (LATEST, Buffer, ConnectivityException, ExtrapolationException,
                        FutureExtrapolationException, InvalidArgumentException, LookupException,
                        PastExtrapolationException, PointStamped, Transform, TransformStamped)


def ts(parent, child, stamp, x=0.0):
    return TransformStamped(parent, child, stamp, Transform(translation=(x, 0.0, 0.0)))


def two_trees(b_stamps=(5.0, 6.0)) -> Buffer:
    """world -> drone with data at 1..2 s; a second tree map -> rover with data at b_stamps."""
    buf = Buffer()
    for t in (1.0, 2.0):
        buf.set_transform(ts("world", "drone", t, t))
    for t in b_stamps:
        buf.set_transform(ts("map", "rover", t, t))
    return buf


# ---------------------------------------------------------------- 1. different trees, numeric time

def test_different_trees_report_the_target_sides_extrapolation_first():
    # source side (drone) fails at 10 s, then the target side (rover) fails too: tf2 reports
    # the target side's edge, from the walk up from the target
    with pytest.raises(FutureExtrapolationException) as e:
        two_trees().lookup_transform("rover", "drone", 10.0)
    assert e.value.edge == ("map", "rover")
    with pytest.raises(PastExtrapolationException) as e:
        two_trees().lookup_transform("rover", "drone", 1.5)     # drone fine, rover has no data yet
    assert e.value.edge == ("map", "rover")


def test_different_trees_report_the_source_sides_extrapolation_when_the_target_side_is_fine():
    with pytest.raises(FutureExtrapolationException) as e:
        two_trees().lookup_transform("rover", "drone", 5.5)     # rover fine at 5.5, drone is not
    assert e.value.edge == ("world", "drone")
    ok, why = two_trees().can_transform("rover", "drone", 5.5, return_debug_tuple=True)
    assert not ok and "extrapolation into the future" in why


def test_different_trees_with_data_on_every_edge_are_a_connectivity_error():
    buf = two_trees(b_stamps=(1.0, 6.0))
    with pytest.raises(ConnectivityException, match="not part of the same tree"):
        buf.lookup_transform("rover", "drone", 1.5)
    with pytest.raises(ConnectivityException):                  # LATEST: getLatestCommonTime
        two_trees().lookup_transform("rover", "drone", LATEST)


def test_same_tree_failures_on_both_sides_report_the_target_side():
    buf = Buffer()
    for t in (1.0, 2.0):
        buf.set_transform(ts("world", "a", t))
    for t in (5.0, 6.0):
        buf.set_transform(ts("world", "b", t))
    with pytest.raises(PastExtrapolationException) as e:
        buf.lookup_transform("b", "a", 3.0)
    assert e.value.edge == ("world", "b")
    with pytest.raises(FutureExtrapolationException) as e:   # roles swapped: a is the target now
        buf.lookup_transform("a", "b", 3.0)
    assert e.value.edge == ("world", "a")


# ---------------------------------------------------------------- 2. a frame to itself

@pytest.mark.parametrize("frame", ["never_seen", "", "/slashed"])
def test_a_frame_to_itself_is_identity_without_validating_the_id(frame):
    buf = Buffer()
    out = buf.lookup_transform(frame, frame, 12.5)
    assert out.transform == Transform.identity()
    assert (out.frame_id, out.child_frame_id, out.stamp) == (frame, frame, 12.5)
    assert buf.lookup_transform(frame, frame, LATEST).stamp == 0.0
    assert buf.can_transform(frame, frame)
    assert buf.can_transform(frame, frame, 3.0, timeout=0.5)


def test_a_frame_to_itself_at_latest_is_stamped_with_its_own_newest_sample():
    buf = two_trees()
    buf.set_transform_static(ts("world", "tower", 0.0, 7.0))
    assert buf.lookup_transform("drone", "drone").stamp == 2.0
    assert buf.lookup_transform("drone", "drone", 99.0).stamp == 99.0   # no extrapolation check
    assert buf.lookup_transform("tower", "tower").stamp == 0.0          # static: Time(0)
    assert buf.lookup_transform("world", "world").stamp == 0.0          # a root has no cache
    p = buf.transform_point(PointStamped("nowhere", 4.0, (1.0, 2.0, 3.0)), "nowhere")
    assert p.point.tolist() == [1.0, 2.0, 3.0] and p.stamp == 4.0


def test_a_frame_to_itself_still_needs_a_string_id():
    """Deviation (documented): tf2's C++ ids are always strings; a non-str id is a caller bug."""
    with pytest.raises(InvalidArgumentException):
        Buffer().lookup_transform(None, None)


# ---------------------------------------------------------------- validation order

@pytest.mark.parametrize("target,source,error,argument", [
    ("ghost", "", LookupException, "target_frame"),          # the unknown target, first
    ("ghost", "/drone", LookupException, "target_frame"),
    ("ghost", "nobody", LookupException, "target_frame"),
    ("", "ghost", InvalidArgumentException, "target_frame"),
    ("world", "", InvalidArgumentException, "source_frame"),
    ("world", "ghost", LookupException, "source_frame"),
])
def test_lookup_validates_the_target_frame_fully_before_the_source(target, source, error, argument):
    """tf2's lookupTransformImpl: validateFrameId(target) (empty or '/' -> InvalidArgument,
    unknown -> Lookup), then validateFrameId(source); canTransform in the same order."""
    buf = two_trees()
    with pytest.raises(error, match=argument) as e:
        buf.lookup_transform(target, source, 1.5)
    if error is LookupException:
        assert e.value.argument == argument
    with pytest.raises(error, match=argument):
        buf.lookup_transform(target, source)                   # LATEST: same order
    ok, why = buf.can_transform(target, source, 1.5, return_debug_tuple=True)
    assert not ok and f"canTransform argument {argument}" in why


# ---------------------------------------------------------------- 3. lookup_transform_full

def test_full_lookup_validates_all_three_ids_before_any_lookup():
    buf = two_trees()
    # the source lookup (drone at 50 s) would extrapolate; the unknown target is reported first
    with pytest.raises(LookupException) as e:
        buf.lookup_transform_full("ghost", 1.5, "drone", 50.0, "world")
    assert e.value.argument == "target_frame" and e.value.frame == "ghost"
    with pytest.raises(LookupException) as e:
        buf.lookup_transform_full("drone", 1.5, "ghost", 1.5, "world")
    assert e.value.argument == "source_frame"
    with pytest.raises(LookupException) as e:
        buf.lookup_transform_full("drone", 50.0, "drone", 1.5, "ghost")
    assert e.value.argument == "fixed_frame"
    with pytest.raises(InvalidArgumentException):
        buf.lookup_transform_full("drone", 50.0, "drone", 50.0, "")
    with pytest.raises(LookupException):   # even frames equal to each other are validated here
        buf.lookup_transform_full("ghost", 1.0, "ghost", 1.0, "ghost")
    assert not buf.can_transform_full("ghost", 1.5, "drone", 50.0, "world")


def test_full_lookup_still_time_travels():
    buf = two_trees()
    out = buf.lookup_transform_full("drone", 2.0, "drone", 1.0, "world")
    assert out.stamp == 2.0 and out.transform.translation.tolist() == [-1.0, 0.0, 0.0]


# ---------------------------------------------------------------- 4. clear()

def test_after_clear_the_frames_are_still_known():
    buf = two_trees()
    buf.set_transform_static(ts("world", "tower", 0.0, 7.0))
    version = buf.structure_version
    buf.clear()
    assert buf.frames() == ["drone", "map", "rover", "tower", "world"]
    assert buf.structure_version > version            # the emptied edges' parents are forgotten
    with pytest.raises(ExtrapolationException, match="holds no data") as e:
        buf.lookup_transform("world", "drone", 1.5)
    assert type(e.value) is ExtrapolationException
    with pytest.raises(ConnectivityException):
        buf.lookup_transform("world", "drone", LATEST)
    with pytest.raises(ConnectivityException):
        buf.get_latest_common_time("world", "drone")
    assert buf.get_latest_common_time("drone", "drone") == 0.0
    assert not buf.can_transform("world", "drone", 1.5)
    d = buf.lookup_transform("drone", "drone")
    assert d.transform == Transform.identity() and d.stamp == 0.0
    assert buf.lookup_transform("world", "tower", 1.5).transform.translation[0] == 7.0   # statics stay
    assert buf.all_frames_as_string() == ("Frame drone exists with parent NO_PARENT.\n"
                                          "Frame rover exists with parent NO_PARENT.\n"
                                          "Frame tower exists with parent world.\n")
    assert "drone" not in buf.all_frames_as_yaml() and "tower" in buf.all_frames_as_yaml()
    assert sorted(buf.edge_stats()) == ["tower"]      # an emptied edge has no parent to report
    # new data flows again through the same edge
    buf.set_transform(ts("world", "drone", 30.0, 3.0))
    assert buf.lookup_transform("world", "drone").stamp == 30.0
    assert buf.edge_stats()["drone"].samples == 1


def test_after_clear_the_extrapolation_error_names_no_parent():
    """tf2 keeps the parent with each sample, so a cleared cache has none: its error
    (NoDataForExtrapolation, "but only time 0 is in the buffer") names no parent edge."""
    buf = two_trees()
    buf.clear()
    for target, source in (("world", "drone"), ("drone", "world")):
        with pytest.raises(ExtrapolationException) as e:
            buf.lookup_transform(target, source, 1.5)
        assert e.value.edge == (None, "drone")
        assert "[drone] holds no data" in str(e.value) and "[world] -> [drone]" not in str(e.value)
        assert (e.value.target_frame, e.value.source_frame) == (target, source)


def test_after_clear_a_frame_may_take_its_old_parent_as_child():
    """After clear() tf2 knows no parent for the emptied frame, so the old parent may hang
    below it: no loop. The old edge's new data then would close one, and is refused."""
    buf = two_trees()
    buf.clear()
    assert buf.set_transform(ts("drone", "world", 3.0, 1.0))
    assert buf.lookup_transform("drone", "world", 3.0).transform.translation[0] == 1.0
    assert buf.chain("drone", "world") == ["world", "drone"]
    with pytest.raises(InvalidArgumentException, match="loop"):
        buf.set_transform(ts("world", "drone", 3.0))


def test_yaml_after_clear_of_every_dynamic_edge_is_empty_not_an_empty_list():
    """tf2's allFramesAsYAML prints "[]" only when it knows no frame at all."""
    buf = two_trees()
    assert "drone: " in buf.all_frames_as_yaml()
    buf.clear()
    assert buf.all_frames_as_yaml() == ""
    assert Buffer().all_frames_as_yaml() == "[]"


def test_clear_through_a_cached_path():
    buf = two_trees()
    buf.set_transform_static(ts("drone", "cam", 0.0, 0.5))
    assert buf.lookup_transform("world", "cam", 1.5).transform.translation[0] == pytest.approx(2.0)
    buf.clear()   # the path world <- drone <- cam stays cached; its dynamic edge is empty
    with pytest.raises(ExtrapolationException, match="holds no data"):
        buf.lookup_transform("world", "cam", 1.5)
    with pytest.raises(ConnectivityException):
        buf.lookup_transform("world", "cam")


# ---------------------------------------------------------------- pruning

def test_window_is_exactly_cache_time_behind_the_newest_sample():
    """tf2 before 0.37 (insert, then prune against the new newest stamp). tf2 0.37+ prunes
    against the previous newest stamp before inserting, so it would still hold 9.0 here."""
    buf = Buffer(cache_time=10.0)
    for k in range(21):
        assert buf.set_transform(ts("world", "drone", float(k)))
    st = buf.edge_stats()["drone"]
    assert (st.oldest, st.most_recent, st.samples) == (10.0, 20.0, 11)
    with pytest.raises(PastExtrapolationException):
        buf.lookup_transform("world", "drone", 9.5)
    assert not buf.set_transform(ts("world", "drone", 9.0))          # TF_OLD_DATA
    assert buf.set_transform(ts("world", "drone", 10.0))             # at the edge: kept
    assert math.isclose(buf.lookup_transform("world", "drone", 10.0).stamp, 10.0)
