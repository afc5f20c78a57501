"""A datagram the world holds to a TICK boundary is judged on arrival, not when handled.

In pipelined lockstep the world holds a participant's packets until the boundary they are due
at, while the participant's ACKs (TOWERLINK_LOCKSTEP) are judged the moment they arrive. Signed
frames of one stream must be judged in the order they arrived: a held HEARTBEAT judged after a
later ACK of the same stream is older than the newest, and was refused as a replay (a signed
lab run's vehicles counted bad_signature=2 under load)."""
from __future__ import annotations

from common.mavlink.dialect import towerlink as tl
from common.mavlink.signing import setup_signing
from vehicle.link.endpoints import Channel
from vehicle.link.link_core import LinkCore

KEY = b"k" * 32


def _sender():
    mav = tl.MAVLink(None, srcSystem=250, srcComponent=191)
    setup_signing(mav, KEY, 0)
    return mav


def _link() -> LinkCore:
    return LinkCore(1, lambda: 0.0, [], signing_key=KEY)


def _heartbeat(mav) -> bytes:
    return bytes(tl.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3).pack(mav))


def test_a_held_frame_judged_on_arrival_is_handled_after_a_later_frame_of_its_stream():
    link, mav, ch = _link(), _sender(), Channel("peer", lambda data: None)
    held = link.drop_refused_now(_heartbeat(mav) + _heartbeat(mav))      # two frames, one datagram
    assert held and link.stats["bad_signature"] == 0
    link.on_data(_heartbeat(mav), ch)                                    # the later frame first
    link.on_data(held, ch, signed_checked=True)
    assert link.stats["bad_signature"] == 0 and link.stats["rx"] == 3


def test_judged_only_when_handled_the_same_order_is_a_replay():
    """What the world did before: the check this guards against still refuses the reorder."""
    link, mav, ch = _link(), _sender(), Channel("peer", lambda data: None)
    first = _heartbeat(mav)
    link.on_data(_heartbeat(mav), ch)
    link.on_data(first, ch)
    assert link.stats["bad_signature"] == 1 and link.stats["rx"] == 1


def test_refused_frames_are_dropped_and_counted_on_arrival_and_the_rest_kept():
    link, mav, ch = _link(), _sender(), Channel("peer", lambda data: None)
    other = tl.MAVLink(None, srcSystem=250, srcComponent=191)
    setup_signing(other, b"x" * 32, 0)                                   # the wrong key
    unsigned = bytes(tl.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3).pack(tl.MAVLink(None, 250, 191)))
    good = _heartbeat(mav)
    cut = _heartbeat(mav)[:15]              # a frame cut short: left to the parser, as before
    kept = link.drop_refused_now(_heartbeat(other) + unsigned + good + cut)
    assert kept == good + cut
    assert link.stats["bad_signature"] == 1 and link.stats["unsigned"] == 1
    link.on_data(kept, ch, signed_checked=True)
    assert link.stats["rx"] == 1 and link.stats["bad_signature"] == 1
