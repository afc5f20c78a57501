"""A MAVSDK-Python 3.x script under test (the gRPC API: ``System()`` with the bundled
mavsdk_server, the API of MAVSDK-Python's own examples and tutorials): parameters, a
mission_raw upload and download, take off, an Offboard position, land.

``towerlink_sitl.mavsdk_address(0)`` is ``tcpout://127.0.0.1:PORT``, which 3.x's
``System.connect(system_address=...)`` takes as 4.x's ``add_any_connection`` does. Give
``System`` a free gRPC port (``System(port=...)``): its default, 50051, is one port for every
test, and two tests at once (pytest-xdist) would share one mavsdk_server.

With 3.x installed (``pip install 'mavsdk<4'``) the test flies in its own process. In an
environment with 4.x it runs this file as a script under the 3.x interpreter named by
MAVSDK3_PYTHON (towerlink's own suite makes one: tests/test_mavsdk3.py), else it is skipped.

    pytest examples/pytest/test_mavsdk3.py
"""
from __future__ import annotations

import asyncio
import os
import socket
import subprocess
import sys

import pytest

HOME = (-35.363261, 149.165230, 584.0)      # the world's origin (the marker's default home)
TIMEOUT = 30.0                             # wall s for each step


def e7(v: float) -> int:
    return int(round(v * 1e7))


def grpc_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


async def first(stream, cond, what: str, timeout: float = TIMEOUT):
    """The first value of an async telemetry stream satisfying cond (within timeout wall s)."""
    async def scan():
        async for v in stream:
            if cond(v):
                return v
    try:
        return await asyncio.wait_for(scan(), timeout)
    except asyncio.TimeoutError:
        raise AssertionError(f"timed out waiting for {what}") from None


async def fly(address: str) -> None:
    """The script under test (MAVSDK 3.x)."""
    from mavsdk import System
    from mavsdk.mission_raw import MissionItem
    from mavsdk.offboard import PositionNedYaw

    drone = System(port=grpc_port())
    await drone.connect(system_address=address)
    print("STEP connecting", flush=True)
    await first(drone.core.connection_state(), lambda s: s.is_connected, "the connection")
    await first(drone.telemetry.health(), lambda h: h.is_global_position_ok and h.is_home_position_ok
                and h.is_armable, "health")
    print("STEP healthy", flush=True)

    # parameters: a float and an integer one, set and read back
    await drone.param.set_param_float("WPNAV_SPEED", 750.0)
    assert await drone.param.get_param_float("WPNAV_SPEED") == 750.0
    await drone.param.set_param_int("FS_GCS_ENABLE", 0)
    assert await drone.param.get_param_int("FS_GCS_ENABLE") == 0
    print("STEP parameters", flush=True)

    # mission_raw: upload, download, compare, clear
    lat, lon, alt = HOME
    rel = 6                                   # MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    items = [MissionItem(0, 0, 16, 1, 1, 0, 0, 0, 0, e7(lat), e7(lon), alt, 0),
             MissionItem(1, rel, 22, 0, 1, 0, 0, 0, 0, 0, 0, 10.0, 0)]
    items += [MissionItem(i, rel, 16, 0, 1, 0, 0, 0, 0, e7(lat + 1e-4 * i), e7(lon), 10.0, 0) for i in range(2, 6)]
    await drone.mission_raw.upload_mission(items)
    got = await drone.mission_raw.download_mission()
    assert [(g.seq, g.command, g.x, g.y) for g in got[1:]] == [(i.seq, i.command, i.x, i.y) for i in items[1:]]
    await drone.mission_raw.clear_mission()
    print("STEP mission_raw", flush=True)

    # take off, Offboard to (10 N, 5 E, 5 m up), land
    await drone.action.set_takeoff_altitude(5.0)
    await drone.action.arm()
    await drone.action.takeoff()
    await first(drone.telemetry.position_velocity_ned(), lambda p: p.position.down_m < -4.5, "5 m")
    print("STEP took off", flush=True)
    await drone.offboard.set_position_ned(PositionNedYaw(10.0, 5.0, -5.0, 0.0))
    await drone.offboard.start()
    await first(drone.telemetry.position_velocity_ned(),
                lambda p: abs(p.position.north_m - 10.0) < 0.5 and abs(p.position.east_m - 5.0) < 0.5, "offboard goal")
    await drone.offboard.stop()
    print("STEP offboard", flush=True)
    await drone.action.land()
    await first(drone.telemetry.armed(), lambda armed: not armed, "landed and disarmed", 60.0)
    print("STEP landed", flush=True)
    print("MAVSDK3 OK", flush=True)


def mavsdk3_here() -> bool:
    """True when this interpreter's mavsdk is 3.x (4.x keeps a ``System`` that only explains)."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        return int(version("mavsdk").split(".")[0]) < 4
    except PackageNotFoundError:
        return False


def run_in(python: str, address: str, timeout: float = 180.0) -> str:
    """Run this file under another interpreter (a 3.x environment); its output. The script and
    its mavsdk_server are killed whatever happens (a process group of their own)."""
    proc = subprocess.Popen([python, __file__, address], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, 9)
            proc.wait()
        else:
            try:
                os.killpg(proc.pid, 9)          # the mavsdk_server it started, if still there
            except ProcessLookupError:
                pass
    assert proc.returncode == 0 and "MAVSDK3 OK" in out, out[-3000:]
    return out


@pytest.mark.towerlink(drones=1, speedup=5)
def test_mavsdk3_params_mission_offboard_flight(towerlink_sitl):
    python = os.environ.get("MAVSDK3_PYTHON")
    if mavsdk3_here():
        asyncio.run(fly(towerlink_sitl.mavsdk_address(0)))
    elif python:
        run_in(python, towerlink_sitl.mavsdk_address(0))
    else:
        pytest.skip("MAVSDK 3.x is not installed here and MAVSDK3_PYTHON names no 3.x interpreter")
    v = towerlink_sitl.vehicle(0)
    assert v.landed and not v.armed and v.distance_to(10.0, 5.0) < 1.0


if __name__ == "__main__":
    asyncio.run(fly(sys.argv[1]))
