"""A faulty radio link as a UDP proxy, and the fault timeline's hand on the tower link.

    proxy = LinkProxy(listen_port, ("127.0.0.1", bridge_tower_port), up=LinkSettings(loss=0.2),
                      down=LinkSettings(loss=0.2, latency=0.3), seed=1)
    proxy.start()         # a thread; the GCS talks to listen_port instead of the bridge
    ...
    proxy.stop()

Datagrams from the client side (whoever writes to listen_port; the latest writer is the
client) go `up` to `upstream`; datagrams from upstream go `down` to the client. Each direction
is a tools.link_shaper.LinkDirection deciding per MAVLink frame (tools.link_frames cuts the
datagrams): loss, latency, jitter, reordering, duplication, a bandwidth cap; seeded.

TOWERLINK_LOCKSTEP frames are the simulator's clock, not radio traffic: they always pass at
once, untouched and uncounted. With ``lockstep=True`` they are also the link's clock: the TICK
going down and the tower's ACK going up mark sim time, the frames between two marks are
shaped as sent over that frame, and whatever is due by a mark goes on just before it; so a
delay is sim seconds and a seed gives the same fates at any speed and load. `exempt(unit)`
names more frames to pass untouched (`towerlink fly` in lockstep: the bridge's wall-clock
traffic, :func:`bridge_wall_paced`). Without lockstep delays are wall seconds.

A `timeline` (tools.fault_timeline.FaultTimeline) changes the settings over sim time and sends
its vehicle faults' PARAM_SETs upstream (`encode(ParamSet) -> bytes`): in lockstep just
before the tower's ACK of the first TICK at or after the fault's time, so the world applies it
at that TICK (pipelined, the TICK saying lag 1: at the next one, like every reaction of the
tower) whatever the machine's speed; without lockstep when `sim_time()` reaches it.
`applied` records each apply and clear with the sim time it took effect.

As a command: python -m tools.link_proxy LISTEN_PORT UPSTREAM_PORT [--link loss=0.2,latency=0.1] [--seed 1]
"""
from __future__ import annotations

import argparse
import selectors
import socket
import threading
import time
from collections.abc import Callable

from common.link_settings import DIRECTIONS, LinkSettings, parse_link_spec, settings_pair
from common.mavlink import lockstep as wire
from tools.fault_timeline import FaultTimeline, ParamSet
from tools.link_frames import Unit, cut, pack
from tools.link_shaper import LinkDirection

SIM_POLL = 0.02         # wall s between readings of sim_time() (without lockstep)


class LinkProxy(threading.Thread):
    """The proxy thread (see the module doc). `up`/`down`: the settings of a link without a
    `timeline` (a timeline carries the link's own settings). `counts()` and `applied` are read
    after stop()."""

    def __init__(self, listen_port: int, upstream: tuple[str, int], *, up: LinkSettings | None = None,
                 down: LinkSettings | None = None, seed: int = 1, host: str = "127.0.0.1",
                 lockstep: bool = False, exempt: Callable[[Unit], bool] | None = None,
                 timeline: FaultTimeline | None = None, encode: Callable[[ParamSet], bytes] | None = None,
                 sim_time: Callable[[], float] | None = None) -> None:
        super().__init__(daemon=True, name=f"link-proxy:{listen_port}")
        self.lockstep = lockstep
        self.exempt = exempt
        self.timeline = timeline
        self.encode = encode
        self.sim_time = sim_time
        first = timeline.link_at(0.0) if timeline is not None else {"up": up, "down": down}
        self.dirs = {d: LinkDirection(d, seed, first[d], lockstep) for d in DIRECTIONS}
        self._log = timeline.cursor() if timeline is not None else None
        self._params = timeline.cursor() if timeline is not None else None
        self.applied: list[dict] = []       # {"fault", "kind", "t", "at"}: when each took effect (sim s)
        self.reaction_delay = 0.0           # sim s after its TICK a reaction takes effect (the TICK's lag periods)
        self.injected = 0                   # PARAM_SETs sent
        self.upstream = upstream
        self.front = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.front.bind((host, listen_port))
        self.back = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.back.bind((host, 0))
        self.client: tuple[str, int] | None = None
        self._halt = threading.Event()
        self._next_sim = 0.0

    # -- what the launcher and the tests read

    @property
    def passed(self) -> dict[str, int]:
        return {d: self.dirs[d].counts["passed"] for d in DIRECTIONS}

    @property
    def dropped(self) -> dict[str, int]:
        return {d: self.dirs[d].counts["dropped"] for d in DIRECTIONS}

    def counts(self) -> dict[str, dict[str, int]]:
        """{"passed": {"up": n, "down": n}, "dropped": ..., "overflow": ..., "duplicated": ...} (frames)."""
        return {k: {d: self.dirs[d].counts[k] for d in DIRECTIONS} for k in self.dirs["up"].counts}

    # -- the thread

    def run(self) -> None:
        sel = selectors.DefaultSelector()
        sel.register(self.front, selectors.EVENT_READ, "up")
        sel.register(self.back, selectors.EVENT_READ, "down")
        try:
            while not self._halt.is_set():
                for key, _ in sel.select(timeout=self._wait()):
                    try:
                        data, addr = key.fileobj.recvfrom(65535)
                    except OSError:
                        continue
                    if key.data == "up":
                        self.client = addr
                    self._send(key.data, self._arrived(key.data, data))
                if not self.lockstep:
                    self._wall_upkeep()
        finally:
            sel.close()

    def _wait(self) -> float:
        if self.lockstep:
            return 0.1
        due = [t for t in (d.next_due() for d in self.dirs.values()) if t is not None]
        wait = min(due) - time.monotonic() if due else 0.1
        if self.timeline is not None and self.sim_time is not None:
            wait = min(wait, SIM_POLL)
        return min(max(wait, 0.0), 0.1)

    def _arrived(self, way: str, data: bytes) -> list[Unit]:
        """What goes on now for a datagram that came `way`."""
        d = self.dirs[way]
        out: list[Unit] = []
        for u in cut(data):
            m = wire.unpack(u.data)[0] if wire.is_lockstep(u.data) else None
            if m is not None:
                if self.lockstep and m.kind == (wire.TICK if way == "down" else wire.ACK):
                    if m.kind == wire.TICK:
                        self.reaction_delay = m.lag * m.period_usec / 1e6
                    out += self._marker(way, m.t)
                out.append(u)
            elif self.exempt is not None and self.exempt(u):
                out.append(u)
            else:
                out += d.receive([u], time.monotonic())
        return out

    def _marker(self, way: str, t: float) -> list[Unit]:
        """Lockstep: the marker of sim time t came `way`; what goes before it."""
        injected = self._faults_due(t, inject=(way == "up"))
        d = self.dirs[way]
        if self.timeline is not None:
            d.set_settings(self.timeline.link_at(t)[way])
        return d.marker(t) + injected

    def _faults_due(self, t: float, inject: bool) -> list[Unit]:
        """Record the events due by sim time t; with `inject`, their PARAM_SETs (to go upstream)."""
        if self.timeline is None:
            return []
        for e in self._log.advance(t):
            # a vehicle's fault is a PARAM_SET the world applies as a reaction to TICK(t); the link's are the proxy's own
            at = t + self.reaction_delay if e.params else t
            self.applied.append({"fault": e.fault, "kind": e.kind, "t": e.t, "at": round(at, 6)})
        out: list[Unit] = []
        if inject:
            for e in self._params.advance(t):
                for p in e.params:
                    if self.encode is not None:
                        out.append(Unit(self.encode(p), (0, 0, 0)))
                        self.injected += 1
        return out

    def _wall_upkeep(self) -> None:
        """Without lockstep: the timeline by sim_time(), and the frames due by the wall clock."""
        now = time.monotonic()
        if self.timeline is not None and self.sim_time is not None and now >= self._next_sim:
            self._next_sim = now + SIM_POLL
            sim = self.sim_time()
            self._send("up", self._faults_due(sim, inject=True))
            for way, s in self.timeline.link_at(sim).items():
                self.dirs[way].set_settings(s)
        for way, d in self.dirs.items():
            self._send(way, d.release(now))

    def _send(self, way: str, units: list[Unit]) -> None:
        if not units:
            return
        sock, addr = (self.back, self.upstream) if way == "up" else (self.front, self.client)
        if addr is None:
            return
        for datagram in pack(units):
            try:
                sock.sendto(datagram, addr)
            except OSError:
                pass  # nobody listening right now (e.g. the bridge restarting): a lost packet

    def stop(self) -> None:
        self._halt.set()
        if self.is_alive():
            self.join(2.0)
        self.front.close()
        self.back.close()


def bridge_wall_paced(unit: Unit) -> bool:
    """The bridge's frames paced by its wall clock, not by the sim: TOWERLINK_BRIDGE_STATUS and
    the static TOWERLINK_TRANSFORMs it re-sends every wall second. How many fall in a sim
    second depends on the machine, so in lockstep they pass the link untouched."""
    from common.mavlink.dialect import towerlink as tl
    msgid = unit.key[2]
    if msgid == tl.MAVLINK_MSG_ID_TOWERLINK_BRIDGE_STATUS:
        return True
    if msgid != tl.MAVLINK_MSG_ID_TOWERLINK_TRANSFORM:
        return False
    try:
        m = tl.MAVLink(None).decode(bytearray(unit.data))
    except Exception:  # noqa: BLE001 - a frame that does not decode is ordinary traffic
        return False
    return bool(m.flags & tl.TOWERLINK_TRANSFORM_FLAGS_STATIC)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m tools.link_proxy", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("listen_port", type=int)
    p.add_argument("upstream_port", type=int)
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--link", default="loss=0.2", metavar="SPEC",
                   help="link settings, e.g. loss=0.2,latency=0.1,up.bandwidth=2000 (wall seconds)")
    p.add_argument("--seed", type=int, default=1)
    a = p.parse_args(argv)
    try:
        pair = settings_pair(parse_link_spec(a.link))
    except ValueError as exc:
        p.error(str(exc))
    proxy = LinkProxy(a.listen_port, (a.host, a.upstream_port), up=pair["up"], down=pair["down"],
                      seed=a.seed, host=a.host)
    proxy.start()
    try:
        while proxy.is_alive():
            proxy.join(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        proxy.stop()
        print(f"frames: {proxy.counts()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
