"""Onboard logs with the clients people use, over sockets to `towerlink sitl`, as they use them:
MAVProxy's typed `log list` / `log download`, MAVSDK's log_files (get_entries,
download_log_file) in a program of its own, QGroundControl's log download (its
LogDownloadController's requests, bins and retries, over UDP with packets lost), then the
downloaded DataFlash log read by pymavlink's DFReader (ATT and GPS against the run's truth,
streamed as SIM_STATE) and by mavlogdump.

One world for the module: a drone that flies (GUIDED takeoff to 10 m, a 25 m leg, LAND) and a
rover that never arms (no logs: ArduPilot still answers, with one empty LOG_ENTRY). The tests
read the flight's log in file order; test_erase, last, erases it.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from support import Processes, free_ports, wait_until
from test_sitl_support import (
    MavProxy,
    Sitl,
    command,
    connect,
    goto_local,
    mav,
    set_mode,
    wait_armable,
)

pytestmark = pytest.mark.timeout(180)

ALT = 10.0


class Truth:
    """SIM_STATE (the simulation's truth) stamped with the time_boot_ms of the ATTITUDE that
    precedes it in the same tick's datagram."""

    def __init__(self) -> None:
        self.rows: list[tuple[int, object]] = []
        self._ms = None

    def see(self, msg) -> None:
        kind = msg.get_type()
        if kind == "ATTITUDE":
            self._ms = msg.time_boot_ms
        elif kind == "SIM_STATE" and self._ms is not None:
            self.rows.append((self._ms, msg))

    def at(self, time_us: int, within_ms: int = 60):
        """The truth nearest `time_us` (µs since boot), None if none within `within_ms`."""
        ms = time_us / 1000.0
        best = min(self.rows, key=lambda r: abs(r[0] - ms), default=None)
        return best[1] if best is not None and abs(best[0] - ms) <= within_ms else None


def _until(m, truth: Truth, cond, timeout: float, what: str):
    """Read the drone's messages (recording the truth) until cond(msg) holds."""
    deadline = time.monotonic() + timeout
    last_hb = 0.0
    while time.monotonic() < deadline:
        if time.monotonic() - last_hb > 0.5:
            m.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            last_hb = time.monotonic()
        msg = m.recv_match(blocking=True, timeout=0.2)
        if msg is None:
            continue
        truth.see(msg)
        if cond(msg):
            return msg
    raise AssertionError(f"timed out: {what}")


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    """The world, MAVProxy on the drone's TCP port (its `log list` before the flight), the
    flight with its truth; yields (sitl, truth, mavproxy, tmp, mavsdk ports)."""
    tmp = tmp_path_factory.mktemp("logs")
    procs = Processes()
    sdk_ports = free_ports(2)
    try:
        sitl = Sitl(procs, tmp, drones=1, rovers=1, speedup=5,
                    extra=["--endpoint", f"0=udpout:127.0.0.1:{sdk_ports[0]}",
                           "--endpoint", f"1=udpout:127.0.0.1:{sdk_ports[1]}"])
        mp = MavProxy(procs, tmp, sitl.tcp[0])
        wait_until(lambda: mp.saw("online system 1"), 30, "MAVProxy online")
        mp.send("log list")
        wait_until(lambda: mp.saw("No logs"), 20, "MAVProxy: No logs")
        m = connect(sitl.udp[0])
        truth = Truth()
        wait_armable(m)
        assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
        assert command(m, 400, 1) == mav.MAV_RESULT_ACCEPTED
        assert command(m, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, ALT) == mav.MAV_RESULT_ACCEPTED
        # armed: ArduPilot refuses log requests and says why, once
        m.mav.log_request_list_send(1, 1, 0, 0xFFFF)
        _until(m, truth, lambda s: s.get_type() == "STATUSTEXT" and s.text == "Disarm for log download",
               10, "Disarm for log download")
        _until(m, truth, lambda p: p.get_type() == "LOCAL_POSITION_NED" and p.z < -(ALT - 0.3), 40, "takeoff")
        goto_local(m, 20.0, 15.0, -ALT)
        _until(m, truth, lambda p: p.get_type() == "LOCAL_POSITION_NED" and abs(p.x - 20) < 1 and abs(p.y - 15) < 1,
               60, "the leg")
        assert set_mode(m, "LAND") == mav.MAV_RESULT_ACCEPTED
        _until(m, truth, lambda h: h.get_type() == "HEARTBEAT" and h.get_srcSystem() == 1
               and not h.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED, 90, "landed and disarmed")
        m.close()
        yield sitl, truth, mp, tmp, sdk_ports
        procs.stop(mp.proc, timeout=0.5)       # MAVProxy sits out a SIGTERM: no need to wait 5 s
    finally:
        procs.stop_all()


def _on_disk(sitl, index: int = 0, num: int = 1) -> bytes:
    """The log as the vehicle keeps it: <state dir>/vehicles/<index>/logs/0000000N.BIN."""
    return (Path(sitl.state_dir) / "vehicles" / str(index) / "logs" / f"{num:08d}.BIN").read_bytes()


def test_mavproxy_log_list_and_download(flight):
    sitl, _, mp, tmp, _ = flight
    mp.send("log list")
    wait_until(lambda: mp.saw("numLogs 1"), 20, "log list: " + "".join(mp.lines[-5:]))
    size = len(_on_disk(sitl))
    entry = [line for line in mp.lines if "numLogs" in line][-1]
    assert entry.startswith("Log 1  numLogs 1 lastLog 1 size ") and int(entry.split()[7]) == size
    mp.send("log download 1 flight.bin")
    wait_until(lambda: mp.saw("Finished downloading flight.bin"), 60, "download: " + "".join(mp.lines[-5:]))
    assert (tmp / "flight.bin").read_bytes() == _on_disk(sitl)
    assert (Path(sitl.state_dir) / "vehicles" / "0" / "logs" / "LASTLOG.TXT").read_bytes() == b"1\r\n"
    assert not (Path(sitl.state_dir) / "vehicles" / "1" / "logs").exists()       # the rover never armed


def _downloaded(flight) -> Path:
    path = flight[3] / "flight.bin"
    if not path.exists():                     # run alone: download it the same way first
        test_mavproxy_log_list_and_download(flight)
    return path


def test_dfreader_reads_the_flight_against_the_truth(flight):
    from pymavlink import DFReader

    from common import geo
    _, truth, _, _, _ = flight
    r = DFReader.DFReader_binary(str(_downloaded(flight)))
    msgs = []
    while (m := r.recv_match()) is not None:
        msgs.append(m)
    kinds = {m.get_type() for m in msgs}
    assert {"FMT", "FMTU", "UNIT", "MULT", "PARM", "MSG", "MODE", "EV", "ARM", "GPS", "ATT", "POS",
            "CTUN", "BAT", "RCIN", "RCOU", "XKF1", "ORGN"} <= kinds
    assert r.params["SYSID_THISMAV"] == 1 and "ArduCopter" in next(m for m in msgs if m.get_type() == "MSG").Message
    assert [m.ModeNum for m in msgs if m.get_type() == "MODE"][-2:] == [4, 9]          # GUIDED, LAND
    home_alt = None
    att_n = gps_n = 0
    for m in msgs:
        kind = m.get_type()
        if kind not in ("ATT", "GPS"):
            continue
        s = truth.at(m.TimeUS)
        if s is None:
            continue
        if kind == "ATT":
            assert abs(m.Roll - math.degrees(s.roll)) < 3 and abs(m.Pitch - math.degrees(s.pitch)) < 3, m
            assert abs((m.Yaw - math.degrees(s.yaw) + 180) % 360 - 180) < 4, m
            att_n += 1
        else:
            n, e, d = geo.lla_to_ned((s.lat, s.lon, s.alt), m.Lat, m.Lng, m.Alt)
            # the receiver's noise (0.3 m, 0.45 m) and up to 60 ms between the two samples
            assert math.hypot(n, e) < 2.5 and abs(d) < 3.0, (m, s)
            gps_n += 1
            home_alt = s.alt if home_alt is None else min(home_alt, s.alt)
    assert att_n > 100 and gps_n > 100
    gps = [m for m in msgs if m.get_type() == "GPS"]
    assert max(g.Alt for g in gps) - home_alt == pytest.approx(ALT, abs=1.5)
    assert r.clock.timebase > 1.7e9            # the GPS week and ms gave DFReader absolute time


def test_mavlogdump_reads_it(flight):
    exe = os.path.join(os.path.dirname(sys.executable), "mavlogdump.py")
    out = subprocess.run([sys.executable, exe, "--types", "GPS,MODE", str(_downloaded(flight))],
                         capture_output=True, text=True, timeout=60, check=False)
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.splitlines()
    assert sum("GPS {" in line for line in lines) > 100 and any("MODE {" in line for line in lines)


def client(drone_port: int, rover_port: int, out_path: str) -> int:
    """MAVSDK's log_files as its users call it: entries, then the first one downloaded."""
    from mavsdk.plugins.log_files import LogFiles, LogFilesError, LogFilesResult
    from mavsdk_client import autopilot, step

    rover = LogFiles(autopilot(rover_port))
    try:
        rover.get_entries()
        raise SystemExit("the rover has logs")
    except LogFilesError as e:
        if e.result != LogFilesResult.NO_LOGFILES:
            raise SystemExit(f"rover entries: {e.result}")
    step("rover: no log files")
    logs = LogFiles(autopilot(drone_port))
    entries = logs.get_entries()
    print("ENTRIES", [(e.id, e.size_bytes) for e in entries], flush=True)
    done = threading.Event()
    results = []

    def progress(result, data, _user):
        results.append((result, data.progress))
        if result != LogFilesResult.NEXT:
            done.set()
    logs.download_log_file_async(entries[0], out_path, progress)
    if not done.wait(60):
        raise SystemExit("download timed out")
    if results[-1][0] != LogFilesResult.SUCCESS:
        raise SystemExit(f"download: {results[-1]}")
    step(f"downloaded {os.path.getsize(out_path)} bytes")
    print("MAVSDK LOGS OK", flush=True)
    return 0


def test_mavsdk_log_files(flight, processes):
    sitl, _, _, tmp, (drone_port, rover_port) = flight
    out_path = tmp / "mavsdk.bin"
    proc = processes.start([sys.executable, __file__, str(drone_port), str(rover_port), str(out_path)])
    lines: list[str] = []
    threading.Thread(target=lambda: [lines.append(line) for line in proc.stdout], daemon=True).start()
    wait_until(lambda: proc.poll() is not None, 120, "the MAVSDK client")
    out = "".join(lines)
    assert proc.returncode == 0 and "MAVSDK LOGS OK" in out, out[-3000:]
    data = _on_disk(sitl)
    assert f"ENTRIES [(1, {len(data)})]" in out
    assert out_path.read_bytes() == data


class QgcLogDownload:
    """QGroundControl's LogDownloadController (src/AnalyzeView) on a pymavlink connection:
    refresh() asks LOG_REQUEST_LIST 0..0xffff and re-asks the first run of missing entries
    after each 5 s silence (at most 3 times); download(entry) fetches the log in chunks of
    512 bins of 90 bytes: LOG_REQUEST_DATA for the whole chunk, the bins ticked off as LOG_DATA
    arrives (data for another chunk or at an offset not on a bin ignored), the next chunk asked
    for when one is complete, and after each 500 ms without data -- or on reaching the end of a
    gap -- the first gap of the chunk asked for again. ArduPilot's ids start at 1 (QGC's
    _apmOffset). `lose` drops the first arrival of the LOG_DATA at those offsets, as a radio
    would, so the retries have something to do."""

    BINS, DATA_LEN = 512, 90
    CHUNK = BINS * DATA_LEN
    TIMEOUT, LIST_TIMEOUT = 0.5, 5.0

    def __init__(self, m, lose: set[int] = frozenset()) -> None:
        self.m = m
        self.lose = set(lose)
        self.requests: list[tuple[int, int, int]] = []     # LOG_REQUEST_DATA (id, ofs, count)
        self._hb = 0.0

    def _next(self, types: tuple[str, ...], timeout: float):
        """The next message of `types` within `timeout` s (None), with QGC's 1 Hz heartbeat."""
        deadline = time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            if time.monotonic() - self._hb > 1.0:
                self.m.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                self._hb = time.monotonic()
            msg = self.m.recv_match(type=list(types), blocking=True, timeout=min(left, 0.2))
            if msg is not None:
                return msg
        return None

    def refresh(self) -> list[tuple[int, int]]:
        """The log list: [(size, time_utc)] in QGC's order (index = id - 1)."""
        self.m.mav.log_request_list_send(1, 1, 0, 0xFFFF)
        entries: list[tuple[int, int] | None] = []
        retries = 0
        while True:
            e = self._next(("LOG_ENTRY",), self.LIST_TIMEOUT)
            if e is None:
                missing = [i for i, x in enumerate(entries) if x is None]
                assert missing and retries < 3, "log list: no answer"
                retries += 1
                run = [missing[0]]
                while run[-1] + 1 in missing:
                    run.append(run[-1] + 1)
                self.m.mav.log_request_list_send(1, 1, run[0] + 1, run[-1] + 1)
                continue
            if e.num_logs == 0:
                return []
            if not entries:
                entries = [None] * e.num_logs
            if e.size > 0 and 0 <= e.id - 1 < len(entries):
                entries[e.id - 1] = (e.size, e.time_utc)
            retries = 0
            if all(x is not None for x in entries):
                return entries

    def _request(self, log_id: int, ofs: int, count: int) -> None:
        self.requests.append((log_id, ofs, count))
        self.m.mav.log_request_data_send(1, 1, log_id, ofs, count)

    def download(self, index: int, size: int, give_up_after: float) -> bytes:
        """Log `index` (0-based, QGC's) of `size` bytes, as QGC writes it to its .bin (QGC
        retries for ever; a test gives up after `give_up_after` s)."""
        log_id, out = index + 1, bytearray(size)
        deadline = time.monotonic() + give_up_after
        chunks = -(-size // self.CHUNK)
        chunk = 0

        def bins_of(c: int) -> int:
            return min(-(-(size - c * self.CHUNK) // self.DATA_LEN), self.BINS)
        table = [False] * bins_of(0)

        def find_missing() -> bool:
            """QGC's _findMissingData; True when the log is complete."""
            nonlocal chunk, table
            if all(table) and chunk + 1 == chunks:
                return True
            if all(table):
                chunk += 1
                table = [False] * bins_of(chunk)
            start = table.index(False)
            end = table.index(True, start) if True in table[start:] else len(table)
            self._request(log_id, chunk * self.CHUNK + start * self.DATA_LEN, (end - start) * self.DATA_LEN)
            return False

        self._request(log_id, 0, len(table) * self.DATA_LEN)
        while True:
            assert time.monotonic() < deadline, ("download stalled", chunk, table.count(False), self.requests[-5:])
            d = self._next(("LOG_DATA",), self.TIMEOUT)
            if d is None:
                if find_missing():
                    return bytes(out)
                continue
            if d.ofs in self.lose:
                self.lose.discard(d.ofs)
                continue
            if d.id != log_id or d.ofs % self.DATA_LEN or d.ofs > size or d.ofs // self.CHUNK != chunk:
                continue                                     # QGC ignores these
            b = (d.ofs - chunk * self.CHUNK) // self.DATA_LEN
            if b < len(table):
                table[b] = True
            out[d.ofs:d.ofs + d.count] = bytes(d.data[:d.count])
            if all(table) and chunk + 1 == chunks:
                return bytes(out)
            if all(table):
                chunk += 1
                table = [False] * bins_of(chunk)
                self._request(log_id, chunk * self.CHUNK, len(table) * self.DATA_LEN)
            elif b < len(table) - 1 and table[b + 1] and find_missing():
                return bytes(out)


def test_qgroundcontrol_log_download(flight):
    """QGC's list, download with lost packets (gap retries in two chunks), LOG_REQUEST_END;
    the .bin equals the vehicle's file and DFReader reads it."""
    from pymavlink import DFReader
    sitl, _, _, tmp, _ = flight
    data = _on_disk(sitl)
    assert len(data) > 2 * QgcLogDownload.CHUNK, len(data)     # several chunks
    m = connect(sitl.udp[0])
    lose = {k * 90 for k in (3, 4, 5, 100, 511, 512, 513, 1100)} | {(len(data) - 1) // 90 * 90}
    qgc = QgcLogDownload(m, lose)
    entries = qgc.refresh()
    assert [size for size, _ in entries] == [len(data)]
    got = qgc.download(0, len(data), give_up_after=60.0)
    m.mav.log_request_end_send(1, 1)
    assert got == data
    assert not qgc.lose                                            # every loss happened, and was refilled
    retried = [r for r in qgc.requests if r[1] % QgcLogDownload.CHUNK]
    assert (1, 3 * 90, 3 * 90) in retried and len(retried) >= 5, qgc.requests
    assert qgc._next(("LOG_DATA",), 1.0) is None                   # LOG_REQUEST_END: nothing more
    path = tmp / "log_1_qgc.bin"
    path.write_bytes(got)
    r = DFReader.DFReader_binary(str(path))
    kinds = set()
    while (msg := r.recv_match()) is not None:
        kinds.add(msg.get_type())
    assert {"FMT", "PARM", "MODE", "GPS", "ATT"} <= kinds and r.params["SYSID_THISMAV"] == 1
    m.close()


def test_erase(flight):
    sitl, _, mp, _, _ = flight
    _downloaded(flight)
    mp.send("log erase")
    logs = Path(sitl.state_dir) / "vehicles" / "0" / "logs"
    wait_until(lambda: not any(p.suffix == ".BIN" or p.name == "LASTLOG.TXT" for p in logs.iterdir()), 20,
               "logs and LASTLOG.TXT erased")
    n = sum("No logs" in line for line in mp.lines)
    mp.send("log list")
    wait_until(lambda: sum("No logs" in line for line in mp.lines) > n, 20, "No logs after the erase")


if __name__ == "__main__":
    sys.exit(client(int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]))
