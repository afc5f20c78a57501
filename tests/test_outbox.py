"""vehicle.link.outbox: the world's writes held while it steps, written in order when it yields."""
from __future__ import annotations

import math
import socket

from vehicle.link.outbox import Outbox
from vehicle.world import World, WorldConfig


def test_writes_wait_for_the_flush_in_order_and_go_at_once_when_not_corked():
    out, box = [], Outbox()
    box.send(out.append, 1)
    assert out == [1]
    box.cork()
    box.send(out.append, 2)
    box.send(out.append, 3)
    assert out == [1]
    box.flush()
    assert out == [1, 2, 3]
    box.send(out.append, 4)                 # flushed: uncorked again
    assert out == [1, 2, 3, 4]


def test_a_push_writes_what_is_held_and_stays_corked():
    """A pipelined lockstep TICK: the frame's writes and the TICK go out now, the world steps on corked."""
    out, box = [], Outbox()
    box.push()                              # uncorked, nothing held: nothing happens
    box.cork()
    box.send(out.append, 1)
    box.push()
    assert out == [1]
    box.send(out.append, 2)
    assert out == [1]                       # still corked
    box.flush()
    assert out == [1, 2]


def test_a_write_failing_at_the_flush_does_not_stop_the_others():
    out, box = [], Outbox()

    def gone(_):
        raise OSError("peer gone")
    box.cork()
    box.send(gone, 1)
    box.send(out.append, 2)
    box.flush()
    assert out == [2]


def test_a_stepping_world_flushes_its_outbox_when_it_yields():
    """The world corks its endpoints for each chunk it steps: what it pushes still arrives (and
    the world's outbox holds a write until its flush)."""
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    sink.settimeout(5)
    w = World(WorldConfig(drones=1, rovers=0, state_dir=None, tcp_base=None, udp_base=None, speedup=math.inf,
                          outs=[f"udpout:127.0.0.1:{sink.getsockname()[1]}"]))
    written = []
    w.outbox.cork()
    w.outbox.send(written.append, b"held")
    assert written == []
    w.outbox.flush()
    assert written == [b"held"]
    w.start_thread()
    try:
        assert sink.recv(65535)             # telemetry arrives: the world flushes as it yields
    finally:
        w.stop()
        sink.close()
