"""@SYS, the system-information directory ArduPilot's AP_Filesystem_Sys serves over MAVFTP, as
SITL (AP_HAL_SITL, HAL_NUM_CAN_IFACES 2) has it. Pure: the ports and the clock are given.

- The files, in ArduPilot's order: threads.txt, tasks.txt, dma.txt, memory.txt, uarts.txt,
  timers.txt, can0_stats.txt, can1_stats.txt, storage.bin (crash_dump.bin only where a
  crash dump is kept in flash, never on SITL). No subdirectories, no "." or "..".
- Their size as stat gives it (and so the listing and OpenFileRO's ACK): storage.bin is
  HAL_STORAGE_SIZE (16384 on SITL), every other file 100000, whatever its content.
- Their content, made when opened: uarts.txt is Util::uart_info's "UARTV1" table, one line
  per port ("SERIAL<n> TX=... RX=... TXBD=... RXBD=... connected (<path>)": bytes since the
  previous read and their rate in bytes/s), the ports being the vehicle's link endpoints in
  order; tasks.txt is AP_Scheduler::task_info's header "TasksV2" (what its first read gives:
  the simulated vehicle keeps no per-task timings); storage.bin is HAL_STORAGE_SIZE zero
  bytes (the simulated vehicle keeps its parameters elsewhere, not in ArduPilot's storage
  layout). SITL's HAL has no thread, DMA, memory or timer report and no CAN interface
  unless one is configured, so those files are empty: opening one fails with ENOENT, as
  AP_Filesystem_Sys refuses an empty file.
- Read-only: the tree answers EROFS to any write (AP_Filesystem_Sys::open refuses a write
  with EROFS).
"""
from __future__ import annotations

import errno
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass

SYS = b"@SYS"
HAL_STORAGE_SIZE = 16384
STAT_SIZE = 100000           # AP_Filesystem_Sys::stat's size for every generated file
NAMES = (b"threads.txt", b"tasks.txt", b"dma.txt", b"memory.txt", b"uarts.txt", b"timers.txt",
         b"can0_stats.txt", b"can1_stats.txt", b"storage.bin")


@dataclass(frozen=True)
class Port:
    """One serial port as uarts.txt shows it: its path (the endpoint spec), whether anyone is
    connected, and the bytes sent and received since the link started."""
    path: str
    connected: bool
    tx_bytes: int
    rx_bytes: int


class UartReport:
    """uarts.txt: each read reports the bytes since the previous read (ArduPilot's StatsTracker)."""

    def __init__(self) -> None:
        self.last_ms: int = 0
        self.last: dict[int, tuple[int, int]] = {}

    def text(self, ports: Sequence[Port], now_ms: int) -> bytes:
        dt_ms = max(1, now_ms - self.last_ms)
        self.last_ms = now_ms
        lines = ["UARTV1\n"]
        for i, p in enumerate(ports):
            tx0, rx0 = self.last.get(i, (0, 0))
            self.last[i] = (p.tx_bytes, p.rx_bytes)
            tx, rx = (p.tx_bytes - tx0) & 0xFFFFFFFF, (p.rx_bytes - rx0) & 0xFFFFFFFF
            state = "connected    " if p.connected else "not connected"
            lines.append(f"SERIAL{i} TX={tx:8d} RX={rx:8d} TXBD={tx * 1000 // dt_ms:6d} "
                         f"RXBD={rx * 1000 // dt_ms:6d} {state} ({p.path})\n")
        return "".join(lines).encode()


def _enoent(name: bytes) -> OSError:
    return OSError(errno.ENOENT, os.strerror(errno.ENOENT), os.fsdecode(SYS + b"/" + name))


class SysDir:
    def __init__(self, ports: Callable[[], Sequence[Port]] = tuple,
                 clock_ms: Callable[[], int] = lambda: 0) -> None:
        """ports(): the vehicle's serial ports (its link endpoints) in SERIAL order;
        clock_ms(): ArduPilot's millis (ms since boot) for the rates of uarts.txt."""
        self.ports = ports
        self.clock_ms = clock_ms
        self.uarts = UartReport()

    def listing(self) -> list[bytes]:
        """The directory's entries as GCS_FTP lists them (without their NULs)."""
        return [b"F%s\t%d" % (n, self.size(n)) for n in NAMES]

    def size(self, name: bytes) -> int:
        """stat's st_size of a file; raises ENOENT for a name not in @SYS."""
        if name not in NAMES:
            raise _enoent(name)
        return HAL_STORAGE_SIZE if name == b"storage.bin" else STAT_SIZE

    def content(self, name: bytes) -> bytes:
        """The file's bytes now; raises ENOENT for an unknown or (on SITL) empty file."""
        self.size(name)
        if name == b"uarts.txt":
            return self.uarts.text(self.ports(), self.clock_ms())
        if name == b"tasks.txt":
            return b"TasksV2\n"
        if name == b"storage.bin":
            return bytes(HAL_STORAGE_SIZE)
        raise _enoent(name)
