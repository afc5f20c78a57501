"""What the tests' MAVSDK client programs share.

Each MAVSDK test runs its client as a program of its own (`python tests/FILE.py PORT`), so a
hang in the native library cannot outlive the test; the vehicle pushes to it with
--out udpout:127.0.0.1:PORT and MAVSDK listens on udpin. A client prints STEP lines and exits
non-zero (SystemExit with a reason) on the first failure.
"""
from __future__ import annotations

import time

_ALIVE: list = []

def step(msg: str) -> None:
    print("STEP", msg, flush=True)


def wait(cond, timeout: float, what: str, period: float = 0.1) -> None:
    """Poll `cond` (MAVSDK's cached telemetry; an exception counts as not yet) until it holds."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            if cond():
                return
        except Exception:  # noqa: BLE001 - telemetry not there yet
            pass
        time.sleep(period)  # poll
    raise SystemExit(f"timeout: {what}")


def autopilot(port: int, timeout: float = 20.0):
    """The first autopilot MAVSDK discovers on udpin PORT, as a ground station."""
    from mavsdk import ComponentType, Configuration, Mavsdk
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    sdk.add_any_connection(f"udpin://127.0.0.1:{port}")
    system = sdk.first_autopilot(timeout)
    if system is None:
        raise SystemExit("no autopilot discovered")
    step("discovered")
    _ALIVE.append(sdk)           # the Mavsdk instance must live as long as the program
    return system


def land_and_finish(act, tel) -> int:
    """Land (Action.land), wait until disarmed on the ground, say MAVSDK OK; the exit status."""
    act.land()
    wait(lambda: not tel.armed(), 60, "landed and disarmed")
    step("landed")
    print("MAVSDK OK", flush=True)
    return 0
