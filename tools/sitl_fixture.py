"""What the ``towerlink_sitl`` fixture yields: a running world on free ports, its addresses,
its vehicles' truth, its sim clock, and waits that count sim seconds.

    def test_takeoff(towerlink_sitl):
        m = mavutil.mavlink_connection(towerlink_sitl.connection(0))    # tcp:127.0.0.1:P
        ...
        towerlink_sitl.wait_for(lambda: towerlink_sitl.vehicle(0).height > 9.5, sim_timeout=20)

Addresses of vehicle i (drones first, then rovers; sysid ``sysid(i)``, 1 + i):
  connection(i)            ``tcp:127.0.0.1:P``: pymavlink (mavutil.mavlink_connection), MAVProxy
                           --master; the vehicle streams at once, wait_heartbeat() works.
  connection(i, "udp")     ``udpout:127.0.0.1:Q``: the vehicle's udpin; it streams to a client
                           only once the client has sent it a packet (a heartbeat).
  mavsdk_address(i)        ``tcpout://127.0.0.1:P``: MAVSDK 4.x ``Mavsdk.add_any_connection``
                           and MAVSDK 3.x ``System().connect(system_address=...)`` alike.
  client(i)                a connected gcs.client.Client (in lockstep mode a participant).

The world is past start-up when the test begins: every vehicle has a position estimate, home
and the EKF origin, and passes its pre-arm checks (a script can arm at once). Sim time starts
near 1 s. Truth (``vehicle(i)``) is tools.sitl_truth.VehicleTruth.
"""
from __future__ import annotations

import math
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from tools.sitl_process import planned_sysids
from tools.sitl_recorder import Recorder
from tools.sitl_spec import SitlSpec
from tools.sitl_truth import TruthListener, VehicleTruth

T = TypeVar("T")
POLL_S = 0.002              # wall s between two looks at a wait_for predicate
WALL_GRACE_S = 60.0         # wall s a wait_for allows beyond its sim timeout at the asked speed


class TowerlinkSitl:
    """One test's world (see the module docstring). start() and stop() are the fixture's."""

    def __init__(self, spec: SitlSpec, workdir: Path) -> None:
        self.spec = spec
        self.workdir = Path(workdir)
        self.tlog = self.workdir / "world.tlog"
        self._listener = TruthListener(spec.home, planned_sysids(spec.count)) if spec.subprocess else None
        self._recorder: Recorder | None = None
        self._runner = None
        self._clients: list = []
        self.started_at: float | None = None      # time.monotonic() when start() began
        self.ready_at: float | None = None        # ... and when the world was serving

    # ----- life (the fixture's) -------------------------------------------------------
    def start(self) -> "TowerlinkSitl":
        self.started_at = time.monotonic()
        self._recorder = Recorder(self.tlog, self._listener.on_message if self._listener else None).start()
        if self.spec.subprocess:
            from tools.sitl_process import ProcessWorld   # noqa: PLC0415 - a process world only on request
            self._runner = ProcessWorld(self.spec, self.workdir, self._recorder.spec, self._listener)
        else:
            from tools.sitl_world import ThreadWorld
            self._runner = ThreadWorld(self.spec, self.workdir, self._recorder.spec)
        try:
            self._runner.start()
        except BaseException:
            self.stop(keep_logs=True)
            raise
        self.ready_at = time.monotonic()
        return self

    def stop(self, keep_logs: bool = False) -> None:
        """Close the clients, stop the world and the recorder; remove the logs unless kept.
        Raises RuntimeError if the world's thread or process outlived its stop."""
        for c in self._clients:
            c.close()
        self._clients.clear()
        try:
            if self._runner is not None:
                self._runner.stop()
                if self._runner.alive():
                    raise RuntimeError("the towerlink world is still running after stop()")
        finally:
            if self._recorder is not None:
                self._recorder.stop()
            if not keep_logs and self.workdir.exists():
                shutil.rmtree(self.workdir, ignore_errors=True)

    def artefacts(self, title: str) -> str:
        """Leave the tlog and the track plot in the test's tmp_path; the report's text."""
        from tools.sitl_artefacts import failure_artefacts
        tlog = self._recorder.flush()
        return failure_artefacts(tlog, self.spec.home, title, [self.workdir / "sitl.log"])

    # ----- addresses ------------------------------------------------------------------
    def _check(self, i: int) -> int:
        if not 0 <= i < self.spec.count:
            raise IndexError(f"vehicle {i}: this world has vehicles 0..{self.spec.count - 1}")
        return i

    def tcp_port(self, i: int = 0) -> int:
        """Vehicle i's TCP server port on 127.0.0.1 (MAVProxy --master=tcp:127.0.0.1:PORT)."""
        return self._runner.ports.tcp[self._check(i)]

    def udp_port(self, i: int = 0) -> int:
        """Vehicle i's udpin port on 127.0.0.1 (it answers whoever sends it a packet)."""
        return self._runner.ports.udp[self._check(i)]

    def connection(self, i: int = 0, kind: str = "tcp") -> str:
        """pymavlink connection string of vehicle i: "tcp" (streams at once) or "udp" (udpout:
        the vehicle streams once the client sent it a packet)."""
        if kind == "tcp":
            return f"tcp:127.0.0.1:{self.tcp_port(i)}"
        if kind == "udp":
            return f"udpout:127.0.0.1:{self.udp_port(i)}"
        raise ValueError(f"connection kind {kind!r}: 'tcp' or 'udp'")

    def mavsdk_address(self, i: int = 0) -> str:
        """Vehicle i for MAVSDK, 4.x (Mavsdk.add_any_connection) and 3.x (System.connect)."""
        return f"tcpout://127.0.0.1:{self.tcp_port(i)}"

    def sysid(self, i: int = 0) -> int:
        return self._runner.sysids[self._check(i)]

    @property
    def world(self):
        """The in-process vehicle.world.World (None when the world runs as a process)."""
        return getattr(self._runner, "world", None)

    # ----- truth and time ---------------------------------------------------------------
    def vehicle(self, i: int = 0) -> VehicleTruth:
        """Vehicle i's true state now (world NED from the origin, geodetic, velocity, attitude,
        mode, armed, landed: tools.sitl_truth)."""
        self._heard()
        return self._runner.truth(self._check(i))

    @property
    def time(self) -> float:
        """The world's sim time, s."""
        self._heard()
        return self._runner.sim_time()

    def _heard(self) -> None:
        """A process world's truth is what it streamed: take in what has arrived."""
        if self._listener is not None and self._recorder is not None:
            self._recorder.drain()

    def wait_for(self, predicate: Callable[[], T], sim_timeout: float, what: str | None = None,
                 wall_timeout: float | None = None) -> T:
        """Poll predicate() until it returns something truthy (returned) or `sim_timeout` sim s
        pass (AssertionError naming `what` and every vehicle's state). A world that stops
        advancing fails after `wall_timeout` wall s (default: the sim timeout at the asked speed
        plus WALL_GRACE_S). In lockstep mode the test's clients are polled meanwhile: the world
        moves on only when they ACK its TICKs."""
        end_sim = self.time + sim_timeout
        paced = self.spec.speedup if math.isfinite(self.spec.speedup) else 1e9
        if wall_timeout is None:
            wall_timeout = sim_timeout / paced + WALL_GRACE_S
        end_wall = time.monotonic() + wall_timeout
        lockstep_clients = [c for c in self._clients if c.lockstep]
        if self.spec.lockstep and not lockstep_clients:
            raise RuntimeError("towerlink lockstep: the world steps only with a participant: connect one with "
                               "sitl.client(i) before waiting")
        while True:
            value = predicate()
            if value:
                return value
            if self.time >= end_sim or time.monotonic() >= end_wall:
                raise AssertionError(self._timeout_text(what or getattr(predicate, "__name__", "condition"),
                                                        sim_timeout, time.monotonic() >= end_wall))
            if lockstep_clients:
                for c in lockstep_clients:
                    c.poll(0.0)
            else:
                time.sleep(POLL_S)  # poll

    def _timeout_text(self, what: str, sim_timeout: float, wall: bool) -> str:
        why = "the world stopped advancing" if wall else f"{sim_timeout:g} sim s passed"
        states = []
        for i in range(self.spec.count):
            try:
                v = self.vehicle(i)
                states.append(f"  vehicle {i}: {v.mode} armed={v.armed} landed={v.landed} "
                              f"ned=({v.ned[0]:.2f}, {v.ned[1]:.2f}, {v.ned[2]:.2f})")
            except LookupError as exc:
                states.append(f"  vehicle {i}: {exc}")
        return f"towerlink: waiting for {what}: {why} (sim t={self.time:.2f} s)\n" + "\n".join(states)

    # ----- towerlink's own client ---------------------------------------------------------
    def client(self, i: int = 0, **kw: Any):
        """A gcs.client.Client connected to vehicle i's UDP endpoint, closed at teardown; in
        lockstep mode it joins the world's lockstep for that vehicle, so its waits run on sim
        time and what it does depends on the sim alone (any speed, any load)."""
        from gcs.client import Client
        if self.spec.lockstep:
            kw.setdefault("lockstep", True)
            kw.setdefault("lockstep_target", self.sysid(i))
        c = Client.connect(self.connection(i, "udp"), **kw)
        self._clients.append(c)
        return c
