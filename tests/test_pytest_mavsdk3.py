"""MAVSDK-Python 3.x (the gRPC API: System() with its bundled mavsdk_server) in an environment
of its own, as the suite makes it, talking to the fixture's world on mavsdk_address.

`make test` creates the environment first (the Makefile's mavsdk3 target, beside the suite's
venv: .venv/mavsdk3) and names it in MAVSDK3_PYTHON; run without make, the session fixture
below creates it there once. 4.x stays the test environment's own `mavsdk`.
The full 3.x flight (take off and land, Offboard, mission_raw, parameters) is the example
examples/pytest/test_mavsdk3.py, which flies under MAVSDK3_PYTHON.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from plugin_support import run_group

PROBE = r'''
import asyncio, socket, sys
from importlib.metadata import version
from mavsdk import System

async def main(address):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    drone = System(port=port)
    await drone.connect(system_address=address)
    async def connected():
        async for st in drone.core.connection_state():
            if st.is_connected:
                return
    await asyncio.wait_for(connected(), 30)
    print("VERSION", version("mavsdk"), flush=True)
    print("WPNAV_SPEED", await asyncio.wait_for(drone.param.get_param_float("WPNAV_SPEED"), 30), flush=True)

asyncio.run(main(sys.argv[1]))
'''


def mavsdk3_env(where: Path) -> Path:
    """The 3.x environment's python under `where` (created with this interpreter's Python and
    pip install 'mavsdk<4' pytest when missing)."""
    python = where / "bin" / "python"
    stamp = where / ".installed"
    if not stamp.exists():
        base = getattr(sys, "_base_executable", sys.executable)
        subprocess.run([base, "-m", "venv", str(where)], check=True, timeout=300)
        subprocess.run([str(python), "-m", "pip", "install", "-q", "mavsdk<4", "pytest"], check=True, timeout=900)
        stamp.touch()
    return python


@pytest.fixture(scope="session")
def mavsdk3_python() -> str:
    named = os.environ.get("MAVSDK3_PYTHON")
    return named if named else str(mavsdk3_env(Path(sys.prefix) / "mavsdk3"))


@pytest.mark.timeout(900)
@pytest.mark.towerlink(drones=1, params={"WPNAV_SPEED": 650})
def test_mavsdk3_system_connects_on_mavsdk_address_and_reads_a_parameter(mavsdk3_python, towerlink_sitl):
    code, text = run_group([mavsdk3_python, "-c", PROBE, towerlink_sitl.mavsdk_address(0)], timeout=120)
    assert code == 0, text[-3000:]
    assert "VERSION 3." in text and "WPNAV_SPEED 650.0" in text, text[-3000:]
