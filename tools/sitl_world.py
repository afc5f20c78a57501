"""A test's world built from its :class:`~tools.sitl_spec.SitlSpec`, already past start-up.

:func:`build_world` makes the vehicle.world.World (every vehicle listening on its own UDP and
TCP port, pushing its streams to the test's recorder, nothing saved to disk) and steps it
synchronously, before any socket is opened, until every vehicle has a good position estimate,
home and the EKF origin and passes its pre-arm checks (about 1 s of sim time, tens of ms of
wall time): a script can arm at once. :class:`ThreadWorld` runs it on a thread of the test's
process (the fixture's default); tools.sitl_child runs the same world as a process.

Ports: each try takes ports the OS says are free now; another process (a pytest-xdist worker)
may bind one first, and then the world is built again on new ones (:data:`TRIES`).
"""
from __future__ import annotations

import asyncio
import errno
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from common.ports import free_ports, free_udp_ports
from tools.sitl_spec import SitlSpec, SpecError, parm_text
from tools.sitl_truth import VehicleTruth, truth_of_world
from vehicle.world import World, WorldConfig

TRIES = 5                 # port sets tried before the fixture gives up
WARMUP_LIMIT_S = 30.0     # sim s a vehicle may take to be ready to arm


@dataclass(frozen=True)
class Ports:
    """Vehicle i listens on udp[i] (udpin) and tcp[i] (tcpin), on 127.0.0.1."""
    udp: tuple[int, ...]
    tcp: tuple[int, ...]

    @classmethod
    def pick(cls, n: int) -> "Ports":
        return cls(tuple(free_udp_ports(n)), tuple(free_ports(n, kind=socket.SOCK_STREAM)))


def address_in_use(exc: BaseException) -> bool:
    return isinstance(exc, OSError) and exc.errno == errno.EADDRINUSE


def load_mission(path: Path):
    """The MissionItems of a QGC WPL 110 file; SpecError naming an item an upload would refuse."""
    from common import wpl
    from vehicle.link.mission_items import from_wpl
    items = []
    for w in wpl.read(str(path)):
        result, item = from_wpl(w)
        if item is None:
            raise SpecError(f"{path}: item {w.seq} refused (MAV_MISSION_RESULT {result})")
        items.append(item)
    return items


def world_config(spec: SitlSpec, ports: Ports, record_to: str | None, workdir: Path) -> WorldConfig:
    """The WorldConfig of `spec` on `ports`, pushing to `record_to` (an udpout spec) if given."""
    params_file = None
    if spec.params:
        workdir.mkdir(parents=True, exist_ok=True)
        params_file = workdir / "params.parm"
        params_file.write_text(parm_text(spec.params))
    endpoints = {i: [f"udpin:127.0.0.1:{ports.udp[i]}", f"tcpin:127.0.0.1:{ports.tcp[i]}"]
                 for i in range(spec.count)}
    return WorldConfig(drones=spec.drones, rovers=spec.rovers, speedup=spec.speedup, home=spec.home,
                       seed=spec.seed, params_file=str(params_file) if params_file else None, state_dir=None,
                       tcp_base=None, udp_base=None, endpoints=endpoints,
                       outs=[record_to] if record_to else [],
                       missions={i: load_mission(p) for i, p in spec.missions.items()},
                       wind=spec.wind, lockstep=1 if spec.lockstep else 0)


def ready_to_arm(world: World) -> bool:
    return all(v.ap.est_ok and v.ap.home is not None and v.ap.prearm_ok() for v in world.vehicles)


def warm_up(world: World) -> None:
    """Step until every vehicle is ready to arm (or WARMUP_LIMIT_S of sim time), then on to a
    lockstep TICK boundary. No socket is open yet: nothing is sent, nobody waits."""
    end = world.steps + int(WARMUP_LIMIT_S / world.dt)
    while not ready_to_arm(world) and world.steps < end:
        world.step()
    frame = world.lockstep.frame_steps if world.lockstep is not None else world.ap_every
    while world.steps % frame:
        world.step()


def build_world(spec: SitlSpec, ports: Ports, record_to: str | None, workdir: Path) -> World:
    world = World(world_config(spec, ports, record_to, workdir))
    warm_up(world)
    return world


async def run_closing(world: World, started=None) -> None:
    """world.run(); when an endpoint cannot be bound, the ones already open are closed before
    the error goes on (the world's own run closes them only once it is running)."""
    try:
        await world.run(started)
    except OSError:
        for v in world.vehicles:
            v.link.close()
        raise
    # the TCP clients' readers see their closed connections end before asyncio.run cancels what
    # is left (a reader cancelled mid-read is logged as an error by Python 3.11's asyncio)
    for _ in range(3):
        await asyncio.sleep(0)


class ThreadWorld:
    """The world on a thread of this process: start() (new ports on a port race), stop()."""

    def __init__(self, spec: SitlSpec, workdir: Path, record_to: str | None) -> None:
        self.spec, self.workdir, self.record_to = spec, workdir, record_to
        self.world: World | None = None
        self.ports: Ports | None = None
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None

    def start(self, timeout: float = 30.0) -> None:
        for attempt in range(TRIES):
            self.ports = Ports.pick(self.spec.count)
            self.world = build_world(self.spec, self.ports, self.record_to, self.workdir)
            self._error = None
            self._thread = threading.Thread(target=self._run, name="towerlink-world", daemon=True)
            self._thread.start()
            deadline = time.monotonic() + timeout
            while not self.world.ready.wait(0.01):
                if not self._thread.is_alive() or time.monotonic() > deadline:
                    break
            if self.world.ready.is_set():
                return
            self.world.request_stop()
            self._thread.join(5.0)
            if self._error is not None and address_in_use(self._error) and attempt < TRIES - 1:
                continue
            raise RuntimeError(f"the towerlink world did not start: {self._error!r}") from self._error
        raise AssertionError("unreachable")

    def _run(self) -> None:
        try:
            asyncio.run(run_closing(self.world))
        except BaseException as exc:  # noqa: BLE001 - handed to start(), which says what it was
            self._error = exc

    @property
    def sysids(self) -> list[int]:
        return [v.sysid for v in self.world.vehicles]

    def sim_time(self) -> float:
        return self.world.t

    def truth(self, index: int) -> VehicleTruth:
        return truth_of_world(self.world, index)

    def alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def stop(self, timeout: float = 10.0) -> None:
        """Stop the world and wait for its thread (its sockets are closed when it ends)."""
        if self.world is not None:
            self.world.request_stop()
        if self._thread is not None:
            self._thread.join(timeout)
            if self._thread.is_alive():
                raise RuntimeError(f"the towerlink world's thread did not end within {timeout:g} s")
