"""A test's world as a process of its own (``@pytest.mark.towerlink(subprocess=True)`` or
``--towerlink-mode subprocess``): the same warmed-up world as the in-process one
(tools.sitl_child), for scripts that must not share the test's interpreter.

Its truth comes over MAVLink: every vehicle's SIM_STATE, HEARTBEAT and EXTENDED_SYS_STATE as
the recorder hears them (tools.sitl_truth.TruthListener), so it is as fresh as the last of
those (10 Hz sim). The process runs in a session of its own and gets SIGTERM when the test's
process dies (tools.procs.die_with_parent); stop() ends it, and kills it if it will not go.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from tools.procs import die_with_parent
from tools.sitl_child import EXIT_ADDRESS_IN_USE
from tools.sitl_spec import SitlSpec
from tools.sitl_truth import TruthListener, VehicleTruth
from tools.sitl_world import TRIES, Ports

START_TIMEOUT = 60.0       # wall s for the child to import, warm up and bind (a loaded machine)


def planned_sysids(n: int) -> list[int]:
    """The sysids a world of n vehicles with explicit endpoints and nothing saved boots with
    (vehicle.network_plan: SYSID_BASE 1, 254 to a network)."""
    return [1 + i % 254 for i in range(n)]


class ProcessWorld:
    """start() (new ports when the child lost a port race), stop(); truth from `listener`."""

    def __init__(self, spec: SitlSpec, workdir: Path, record_to: str | None, listener: TruthListener) -> None:
        self.spec, self.workdir, self.record_to, self.listener = spec, workdir, record_to, listener
        self.ports: Ports | None = None
        self.proc: subprocess.Popen | None = None
        self.lines: list[str] = []
        self.log_path = workdir / "sitl.log"
        self._reader: threading.Thread | None = None
        self.sysids = planned_sysids(spec.count)

    def start(self) -> None:
        for attempt in range(TRIES):
            self.ports = Ports.pick(self.spec.count)
            code = self._launch()
            if code is None:
                self._wait_streams()
                return
            if code == EXIT_ADDRESS_IN_USE and attempt < TRIES - 1:
                continue
            raise RuntimeError(f"the towerlink world process ended with {code}:\n" + "".join(self.lines[-30:]))

    def _launch(self) -> int | None:
        """Start the child; None once it said READY, else its exit code."""
        cfg = {"spec": self.spec.marker_kwargs(), "udp": list(self.ports.udp), "tcp": list(self.ports.tcp),
               "record_to": self.record_to, "workdir": str(self.workdir)}
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.lines = []
        self.proc = subprocess.Popen([sys.executable, "-m", "tools.sitl_child", json.dumps(cfg)],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     stdin=subprocess.DEVNULL, start_new_session=True,
                                     preexec_fn=die_with_parent())
        ready = threading.Event()
        self._reader = threading.Thread(target=self._read, args=(self.proc, ready), daemon=True)
        self._reader.start()
        end = time.monotonic() + START_TIMEOUT
        while not ready.wait(0.01):
            if self.proc.poll() is not None:
                self._reader.join(2.0)
                return self.proc.returncode
            if time.monotonic() > end:
                self.stop()
                raise RuntimeError(f"the towerlink world process did not start in {START_TIMEOUT:g} s:\n"
                                   + "".join(self.lines[-30:]))
        return None

    def _read(self, proc: subprocess.Popen, ready: threading.Event) -> None:
        with open(self.log_path, "a") as log:
            for line in proc.stdout:
                self.lines.append(line)
                log.write(line)
                log.flush()
                if line.startswith("READY"):
                    ready.set()

    def _wait_streams(self, timeout: float = 20.0) -> None:
        """Until every vehicle's truth has been heard (not in lockstep: that world stands at its
        first TICK, sending nothing, until the test's client joins)."""
        if self.spec.lockstep:
            return
        end = time.monotonic() + timeout
        while not all(self.listener.ready(i) for i in range(self.spec.count)):
            if time.monotonic() > end or self.proc.poll() is not None:
                raise RuntimeError("the towerlink world process streams no SIM_STATE/HEARTBEAT:\n"
                                   + "".join(self.lines[-30:]))
            time.sleep(0.005)  # poll

    def sim_time(self) -> float:
        return self.listener.t

    def truth(self, index: int) -> VehicleTruth:
        return self.listener.truth(index)

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def stop(self, timeout: float = 10.0) -> None:
        """SIGTERM the child's process group, SIGKILL it after `timeout` s; wait for it."""
        proc = self.proc
        if proc is None:
            return
        if proc.poll() is None:
            try:
                os.killpg(proc.pid, signal.SIGTERM)
                proc.wait(timeout)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout)
            except ProcessLookupError:
                pass
        if self._reader is not None:
            self._reader.join(2.0)
