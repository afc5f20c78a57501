"""MAVSDK 4.x's ftp plugin against the SITL drone's MAVFTP (vehicle/link/ftp.py), as a
MAVSDK-Python user writes it (the asyncio API): list the root and the logs, download a log with
and without burst reads, list @SYS, upload a file and compare it by CRC32, make, rename and remove a
directory, remove a file; what does not exist (/APM/LOGS, a path out of the root) is
FILE_DOES_NOT_EXIST.

The client runs as a program of its own (tests/mavsdk_client.py); the vehicle pushes to it
with --out. The log it downloads is put in the vehicle's root (<state dir>/vehicles/0) before
the world starts; what it uploads is read back from there."""
from __future__ import annotations

import sys

import pytest

LOG = (bytes(range(251)) * 100)[:20_000]        # logs/00000001.BIN, known to both sides
UPLOAD = bytes(range(7, 250)) * 21              # 5103 bytes


def _read(path: str) -> bytes:
    with open(path, "rb") as f:
        return f.read()


def _write(path: str, data: bytes) -> None:
    with open(path, "wb") as f:
        f.write(data)


def client(port: int) -> int:
    import asyncio
    return asyncio.run(_client(port))


async def _client(port: int) -> int:
    import os
    import tempfile

    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.ftp import FtpAsync
    from mavsdk.plugins.ftp import FilesystemEntry, FtpError, FtpResult
    from mavsdk_client import step

    async with Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION)) as sdk:
        await sdk.add_any_connection(f"udpin://127.0.0.1:{port}")
        system = await sdk.first_autopilot(20.0)
        if system is None:
            raise SystemExit("no autopilot discovered")
        step("discovered")
        ftp = FtpAsync(system)

        def names(listing, kind):
            return {e.name: e.size_bytes for e in listing.entries if e.entry_type == kind}

        root = await ftp.list_directory("/")
        dirs = names(root, FilesystemEntry.EntryType.DIRECTORY)
        if not {"logs", "terrain", "@SYS", "@MAV_LOG"} <= set(dirs):
            raise SystemExit(f"root listing: {[str(e) for e in root.entries]}")
        sys_files = names(await ftp.list_directory("@SYS"), FilesystemEntry.EntryType.FILE)
        if sys_files.get("uarts.txt") != 100000 or sys_files.get("storage.bin") != 16384:
            raise SystemExit(f"@SYS listing: {sys_files}")
        logs = names(await ftp.list_directory("/logs"), FilesystemEntry.EntryType.FILE)
        if logs.get("00000001.BIN") != len(LOG):
            raise SystemExit(f"logs listing: {logs}")
        step("listed")

        with tempfile.TemporaryDirectory() as here:
            for burst in (False, True):
                local = os.path.join(here, "burst" if burst else "plain")
                os.mkdir(local)
                seen = []
                async for result, progress in ftp.download("/logs/00000001.BIN", local, burst):
                    seen.append((result, progress.bytes_transferred, progress.total_bytes))
                got = _read(os.path.join(local, "00000001.BIN"))
                if got != LOG or seen[-1][0] != FtpResult.SUCCESS or (FtpResult.NEXT, len(LOG), len(LOG)) not in seen:
                    raise SystemExit(f"download (burst {burst}): {len(got)} bytes, {seen[:3]}...{seen[-3:]}")
            step("downloaded")

            up = os.path.join(here, "uploaded.bin")
            _write(up, UPLOAD)
            async for _result, _progress in ftp.upload(up, "/terrain"):
                pass
            if not await ftp.are_files_identical(up, "/terrain/uploaded.bin"):
                raise SystemExit("uploaded file differs by CRC32")
            step("uploaded")

            await ftp.create_directory("/scripts")
            try:
                await ftp.create_directory("/scripts")
                raise SystemExit("second create_directory succeeded")
            except FtpError as e:
                if e.result != FtpResult.FILE_EXISTS:
                    raise SystemExit(f"second create_directory: {e}")
            await ftp.rename("/scripts", "/scripts2")
            async for _result, _progress in ftp.upload(up, "/scripts2"):
                pass
            await ftp.remove_file("/scripts2/uploaded.bin")
            await ftp.remove_directory("/scripts2")
            after = names(await ftp.list_directory("/"), FilesystemEntry.EntryType.DIRECTORY)
            if "scripts" in after or "scripts2" in after:
                raise SystemExit(f"directory still listed: {after}")
            step("directories")

            for bad in ("/APM/LOGS", "/../outside", "/logs/../../.."):
                try:
                    await ftp.list_directory(bad)
                    raise SystemExit(f"listed {bad}")
                except FtpError as e:
                    if e.result != FtpResult.FILE_DOES_NOT_EXIST:
                        raise SystemExit(f"list {bad}: {e}")
            try:
                async for _r, _p in ftp.download("/../../outside.txt", here, False):
                    pass
                raise SystemExit("downloaded from outside the root")
            except FtpError as e:
                if e.result != FtpResult.FILE_DOES_NOT_EXIST:
                    raise SystemExit(f"download outside: {e}")
            step("refused")
    print("MAVSDK FTP OK", flush=True)
    return 0


@pytest.mark.timeout(150)
def test_mavsdk_ftp_plugin(processes, tmp_path):
    from test_sitl_support import run_client_script

    from vehicle.vehicle_root import vehicle_root
    root = vehicle_root(tmp_path / "state", 0)                 # the state dir run_client_script's sitl uses
    (root / "logs").mkdir(parents=True)
    (root / "logs" / "00000001.BIN").write_bytes(LOG)
    (root / "terrain").mkdir()
    (tmp_path / "state" / "outside.txt").write_bytes(b"not the vehicle's")
    out = run_client_script(processes, tmp_path, __file__, "MAVSDK FTP OK", speedup=2)
    assert (root / "terrain" / "uploaded.bin").read_bytes() == UPLOAD, out[-2000:]
    assert not (root / "scripts").exists() and not (root / "scripts2").exists()


if __name__ == "__main__":
    sys.exit(client(int(sys.argv[1])))
