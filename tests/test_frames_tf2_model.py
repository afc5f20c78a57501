"""Buffer against tf2's rules on random histories: inserts, clear() and lookups, each
answered by Buffer and by tests/tf2_model.py (tf2's BufferCore transliterated).

Every lookup must agree on the outcome: the same transform and stamp, or the same error,
down to which frame's cache an extrapolation error is about (and, after clear(), that no
parent is named). The documented deviations are accounted for: a cache with one sample
gives Past/FutureExtrapolationException where tf2 gives NoDataForExtrapolation.
"""
from __future__ import annotations

import math
import random

from hypothesis import given, settings
from hypothesis import strategies as st

from common.frames import (LATEST, Buffer, ConnectivityException, ExtrapolationException,
                           FutureExtrapolationException, InvalidArgumentException,
                           LookupException, PastExtrapolationException, Transform,
                           TransformStamped)

from tf2_model import ModelError, Tf2Model

FRAMES = ["a", "b", "c", "d", "e"]
ASKED = FRAMES + ["ghost", "", "/a"]
CACHE_TIME = 3.0


def rand_v(seed: int) -> tuple:
    rng = random.Random(seed)
    q = [rng.gauss(0, 1) for _ in range(4)]
    n = math.sqrt(sum(x * x for x in q))
    return Transform([rng.uniform(-5, 5) for _ in range(3)], [x / n for x in q]).to_tuple()


insert = st.tuples(st.just("set"), st.sampled_from(FRAMES), st.sampled_from(FRAMES),
                   st.integers(2, 16).map(lambda k: k * 0.5), st.integers(0, 5).map(lambda k: k == 0),
                   st.integers(0, 2**31 - 1)).filter(lambda op: op[1] != op[2])
lookup = st.tuples(st.just("lookup"), st.sampled_from(ASKED), st.sampled_from(ASKED),
                   st.one_of(st.just(LATEST), st.integers(1, 36).map(lambda k: k * 0.25)))
history = st.lists(st.one_of(insert, insert, lookup, lookup, st.just(("clear",))),
                   min_size=1, max_size=40)


def outcome(call):
    try:
        return call()
    except Exception as e:  # compared with the model's answer by the caller
        return e


def check_error(got: Exception, want: ModelError) -> None:
    kinds = {"lookup": LookupException, "invalid": InvalidArgumentException,
             "connectivity": ConnectivityException, "past": PastExtrapolationException,
             "future": FutureExtrapolationException, "nodata": ExtrapolationException,
             "empty": ExtrapolationException}
    assert isinstance(got, kinds[want.kind]), (got, want.kind, want.frame)
    if want.kind == "empty":
        assert type(got) is ExtrapolationException and got.edge == (None, want.frame), got
    elif want.frame is not None:
        assert got.edge[1] == want.frame and got.edge[0] is not None, (got, want.frame)


@settings(max_examples=300, deadline=None)
@given(history)
def test_buffer_follows_tf2_rules(ops):
    buf, model = Buffer(cache_time=CACHE_TIME), Tf2Model(CACHE_TIME)
    for op in ops:
        if op[0] == "clear":
            buf.clear()
            model.clear()
        elif op[0] == "set":
            _, parent, child, stamp, static, seed = op
            v = rand_v(seed)
            want = model.insert(parent, child, stamp, v, static)
            ts = TransformStamped(parent, child, stamp, Transform._of(v))
            got = outcome(lambda: (buf.set_transform_static if static else buf.set_transform)(ts))
            if want == "loop":
                assert isinstance(got, InvalidArgumentException), got
            else:
                assert got is (want == "ok"), (got, want)
        else:
            _, target, source, t = op
            got = outcome(lambda: buf.lookup_transform(target, source, t))
            try:
                stamp, v = model.lookup(target, source, t)
            except ModelError as want:
                check_error(got, want)
                assert buf.can_transform(target, source, t) is False
                continue
            assert isinstance(got, TransformStamped), (op, got)
            assert got.stamp == stamp
            assert got.transform.almost_equal(Transform._of(v), 1e-9), (op, got.transform, v)
            assert buf.can_transform(target, source, t) is True
