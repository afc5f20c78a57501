"""The faulty link's decisions (tools.link_shaper, pure): nothing invented, delays within their
bounds, order kept unless jitter or reordering is asked for, the bandwidth never exceeded, the
same seed the same schedule; in lockstep the fates do not depend on how the machine interleaved
the senders."""
from __future__ import annotations

import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from common.link_settings import QUEUE_LIMIT, REORDER_HOLD, LinkSettings, parse_link_spec, settings_pair
from tools.link_frames import OPAQUE, Unit, cut, pack
from tools.link_shaper import LinkDirection, draws

EPS = 1e-9


def frame(sysid: int, msgid: int, n: int, size: int = 20) -> Unit:
    """A distinct frame of stream (sysid, 1, msgid): n in its payload."""
    body = n.to_bytes(4, "little") + bytes(max(0, size - 16))
    data = bytes([0xFD, len(body), 0, 0, n % 256, sysid, 1, msgid, 0, 0]) + body + b"\x00\x00"
    return Unit(data, (sysid, 1, msgid))


def run_wall(d: LinkDirection, arrivals: list[tuple[float, Unit]]) -> list[tuple[float, Unit]]:
    """Feed the arrivals (time order) on the wall clock; every delivery with its time."""
    out: list[tuple[float, Unit]] = []
    i = 0
    while i < len(arrivals) or d.next_due() is not None:
        due = d.next_due()
        if i < len(arrivals) and (due is None or arrivals[i][0] <= due):
            t, u = arrivals[i]
            out += [(t, x) for x in d.receive([u], t)]
            i += 1
        else:
            out += [(due, x) for x in d.release(due)]
    return out


settings_st = st.builds(LinkSettings, loss=st.floats(0, 1), latency=st.floats(0, 2), jitter=st.floats(0, 1),
                        reorder=st.floats(0, 1), duplicate=st.floats(0, 1),
                        bandwidth=st.one_of(st.just(0.0), st.floats(200, 1e5)))
arrivals_st = st.lists(st.tuples(st.floats(0, 0.5), st.integers(1, 3), st.integers(0, 4), st.integers(20, 200)),
                       max_size=60)


def _arrivals(raw) -> list[tuple[float, Unit]]:
    t, out = 0.0, []
    for n, (gap, sysid, msgid, size) in enumerate(raw):
        t += gap
        out.append((t, frame(sysid, msgid, n, size)))
    return out


@settings(max_examples=150, deadline=None)
@given(s=settings_st, raw=arrivals_st, seed=st.integers(0, 2 ** 32))
def test_nothing_invented_delays_bounded_and_the_same_seed_the_same_schedule(s, raw, seed):
    arrivals = _arrivals(raw)
    sent_at = {u.data: t for t, u in arrivals}
    out = run_wall(LinkDirection("down", seed, s), arrivals)
    copies: dict[bytes, int] = {}
    for t, u in out:
        assert u.data in sent_at                        # never a frame that was not sent
        copies[u.data] = copies.get(u.data, 0) + 1
        assert t >= sent_at[u.data] + s.latency - EPS   # never early
        if not s.bandwidth:
            assert t <= sent_at[u.data] + s.latency + s.jitter + REORDER_HOLD + EPS
    assert max(copies.values(), default=1) <= (2 if s.duplicate else 1)
    d = LinkDirection("down", seed, s)
    again = run_wall(d, arrivals)
    assert again == out                                  # same seed, same frames: the same schedule
    c = d.counts
    assert c["passed"] + c["dropped"] + c["overflow"] == len(arrivals)
    assert len(out) == c["passed"] + c["duplicated"]


@settings(max_examples=100, deadline=None)
@given(latency=st.floats(0, 2), loss=st.floats(0, 0.9), raw=arrivals_st)
def test_order_is_kept_without_jitter_reordering_or_duplication(latency, loss, raw):
    arrivals = _arrivals(raw)
    out = run_wall(LinkDirection("up", 3, LinkSettings(loss=loss, latency=latency)), arrivals)
    order = [u.data for _t, u in arrivals]
    got = [u.data for _t, u in out]
    assert got == [x for x in order if x in set(got)]


@settings(max_examples=100, deadline=None)
@given(bandwidth=st.floats(500, 20000), latency=st.floats(0, 1), dup=st.floats(0, 0.5), raw=arrivals_st)
def test_the_bandwidth_is_never_exceeded(bandwidth, latency, dup, raw):
    arrivals = _arrivals(raw)
    s = LinkSettings(latency=latency, duplicate=dup, bandwidth=bandwidth)
    out = run_wall(LinkDirection("down", 5, s), arrivals)
    biggest = max((len(u.data) for _t, u in arrivals), default=0)
    times = sorted(t for t, _u in out)
    sizes = sorted(out, key=lambda x: x[0])
    for i in range(len(sizes)):             # every window [t_i, t_j]: bytes <= capacity + one frame
        total = 0
        for j in range(i, len(sizes)):
            total += len(sizes[j][1].data)
            assert total <= bandwidth * (times[j] - times[i]) + biggest + 1e-6
    # and a frame waits at most QUEUE_LIMIT for its turn (else it is dropped)
    sent_at = {u.data: t for t, u in arrivals}
    for t, u in out:
        assert t - sent_at[u.data] - latency <= QUEUE_LIMIT + 2 * biggest / bandwidth + EPS


def lockstep_run(s: LinkSettings, batches: list[list[Unit]], seed: int = 7, period: float = 0.04,
                 shuffle: random.Random | None = None) -> list[tuple[float, bytes]]:
    """Frames between markers (a batch per lockstep frame), delivered at markers: (marker t, frame)."""
    d = LinkDirection("down", seed, s, lockstep=True)
    out = []
    d.marker(0.0)
    for k, batch in enumerate(batches, start=1):
        batch = list(batch)
        if shuffle is not None:     # another interleaving of the senders (each sender's own order kept)
            by = {}
            for u in batch:
                by.setdefault(u.key[0], []).append(u)
            batch = []
            while any(by.values()):
                q = shuffle.choice([q for q in by.values() if q])
                batch.append(q.pop(0))
        # a perfect link passes frames at once, in the order they came: before the same marker
        out += [(round(k * period, 9), u.data) for u in d.receive(batch)]
        out += [(round(k * period, 9), u.data) for u in d.marker(k * period)]
    for k in range(len(batches) + 1, len(batches) + 200):
        out += [(round(k * period, 9), u.data) for u in d.marker(k * period)]
    return out


@settings(max_examples=60, deadline=None)
@given(s=settings_st, sizes=st.lists(st.lists(st.tuples(st.integers(1, 3), st.integers(0, 3)), max_size=12),
                                     min_size=1, max_size=12), shuffle_seed=st.integers(0, 1000))
def test_in_lockstep_the_fates_do_not_depend_on_how_the_senders_interleaved(s, sizes, shuffle_seed):
    n = 0
    batches = []
    for b in sizes:
        batch = []
        for sysid, msgid in b:
            batch.append(frame(sysid, msgid, n))
            n += 1
        batches.append(batch)
    a = lockstep_run(s, batches)
    b = lockstep_run(s, batches, shuffle=random.Random(shuffle_seed))
    if not s.active:        # at once, in the machine's interleaving: the same per marker and per sender
        a, b = (sorted(x, key=lambda r: (r[0], r[1][5])) for x in (a, b))
    assert a == b
    # latency in sim time: nothing delivered before the marker its delay reaches
    sent = {u.data: (k + 1) * 0.04 for k, batch in enumerate(batches) for u in batch}
    for t, data in a:
        assert t >= sent[data] + s.latency - 1e-6


def test_loss_and_duplication_rates_and_seeds():
    s = LinkSettings(loss=0.2, duplicate=0.1)
    arrivals = [(k * 0.001, frame(1 + k % 2, k % 7, k)) for k in range(20000)]
    d = LinkDirection("down", 1, s)
    out = run_wall(d, arrivals)
    assert 0.18 < d.counts["dropped"] / 20000 < 0.22
    assert 0.09 < d.counts["duplicated"] / d.counts["passed"] < 0.11
    other = run_wall(LinkDirection("down", 2, s), arrivals)
    assert other != out                                 # another seed, another schedule
    up = run_wall(LinkDirection("up", 1, s), arrivals)
    assert up != out                                    # and the two directions draw apart


def test_the_queue_of_a_narrow_link_overflows_instead_of_growing():
    # 100 B/s for 50 frames of 100 B at once: one second of backlog fits, the rest is dropped
    d = LinkDirection("up", 1, LinkSettings(bandwidth=100))
    out = run_wall(d, [(0.0, frame(1, 0, k, 100)) for k in range(50)])
    assert d.counts["overflow"] > 40 and len(out) == d.counts["passed"]
    assert max(t for t, _u in out) <= QUEUE_LIMIT + 2.0


def test_settings_change_and_a_perfect_link_passes_at_once():
    d = LinkDirection("down", 1)
    u = frame(1, 0, 0)
    assert d.receive([u], 5.0) == [u] and d.counts["passed"] == 1
    d.set_settings(LinkSettings(latency=0.5))
    assert d.receive([frame(1, 0, 1)], 6.0) == [] and d.next_due() == pytest.approx(6.5)
    d.set_settings(LinkSettings())
    # the link is fast again: a new frame goes at once, the one sent on the slow link comes in its time
    assert d.receive([frame(1, 0, 2)], 6.1) == [frame(1, 0, 2)]
    assert d.release(6.4) == [] and d.release(6.5) == [frame(1, 0, 1)]


def test_draws_are_uniform_and_keyed():
    xs = [draws(1, (1, 1, 0), 0, k)[0] for k in range(20000)]
    assert 0.49 < sum(xs) / len(xs) < 0.51 and min(xs) >= 0 and max(xs) < 1
    assert draws(1, (1, 1, 0), 0, 5) == draws(1, (1, 1, 0), 0, 5)
    assert draws(1, (1, 1, 0), 0, 5) != draws(1, (1, 1, 0), 40000, 5) != draws(1, (2, 1, 0), 0, 5)


def test_frames_are_cut_and_packed_back():
    a, b = frame(1, 30, 0).data, frame(2, 33, 1, 40).data
    assert [(u.data, u.key) for u in cut(a + b)] == [(a, (1, 1, 30)), (b, (2, 1, 33))]
    assert cut(a + b"\x01\x02") == [Unit(a + b"\x01\x02", OPAQUE)]       # not a clean run: as it is
    assert cut(b"hello") == [Unit(b"hello", OPAQUE)]
    signed = bytearray(a[:-2] + b"\x00\x00") + bytes(13)
    signed[2] = 1
    assert cut(bytes(signed) + b) == [Unit(bytes(signed), (1, 1, 30)), Unit(b, (2, 1, 33))]
    units = [Unit(bytes(600), (1, 1, 0))] * 5 + [Unit(b"junk", OPAQUE), Unit(a, (1, 1, 30))]
    assert [len(x) for x in pack(units)] == [1200, 1200, 600, 4, len(a)]


def test_link_spec_and_settings():
    assert parse_link_spec("loss=0.1, up.latency=0.2") == {"loss": 0.1, "up.latency": 0.2}
    pair = settings_pair({"loss": 0.1, "up.loss": 0.3, "down.bandwidth": 2000})
    assert pair["up"] == LinkSettings(loss=0.3) and pair["down"] == LinkSettings(loss=0.1, bandwidth=2000)
    assert pair["down"].describe() == "loss=0.1 bandwidth=2000" and LinkSettings().describe() == "perfect"
    for bad, why in (("loss=2", "outside 0..1"), ("lag=1", "unknown link setting"), ("side.loss=0.1", "up.NAME"),
                     ("loss", "NAME=VALUE"), ("loss=x", "not a number"), ("latency=-1", "outside")):
        with pytest.raises(ValueError, match=why):
            parse_link_spec(bad)
