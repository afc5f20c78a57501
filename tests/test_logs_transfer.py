"""The log download answerer (vehicle/logs/transfer.py) against ArduPilot's behaviour
(AP_Logger_MAVLinkLogTransfer.cpp): messages in, messages out, logs from a fake catalog."""
from __future__ import annotations

from dataclasses import dataclass

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.logs.transfer import DATA_LEN, SENDS_PER_PUMP, LogTransfer


@dataclass
class Info:
    size: int
    mtime: int


class Catalog:
    def __init__(self, logs: list[bytes]) -> None:
        self.logs = list(logs)
        self.erased = 0

    def entries(self):
        return [Info(len(b), 1_700_000_000 + i) for i, b in enumerate(self.logs)]

    def read(self, list_id, ofs, count):
        return self.logs[list_id - 1][ofs:ofs + count]

    def erase(self):
        self.erased += 1
        self.logs = []


A, B = "gcs-a", "gcs-b"        # two links (channels are any hashable)


def req_list(start=0, end=0xFFFF):
    return mav.MAVLink_log_request_list_message(1, 1, start, end)


def req_data(i, ofs=0, count=0xFFFFFFFF):
    return mav.MAVLink_log_request_data_message(1, 1, i, ofs, count)


def types(out):
    return [m.get_type() for m, _ in out]


def download(t: LogTransfer, i: int, ch=A, ofs=0, count=0xFFFFFFFF) -> tuple[bytes, list]:
    """Request and pump until the transfer ends; the bytes reassembled by offset."""
    out = t.handle(req_data(i, ofs, count), ch, armed=False)
    msgs = list(out)
    while t.channel is not None:
        msgs += t.pump(armed=False)
    buf = bytearray()
    for m, c in msgs:
        assert c == ch and m.get_type() == "LOG_DATA" and m.id == i
        assert m.ofs == ofs + len(buf)
        buf += bytes(m.data[:m.count])
        assert all(b == 0 for b in m.data[m.count:])          # zero padded
    return bytes(buf), [m for m, _ in msgs]


def test_no_logs_is_one_entry_of_zeros():
    t = LogTransfer(Catalog([]))
    out = t.handle(req_list(), A, armed=False)
    assert len(out) == 1
    m, ch = out[0]
    assert ch == A and (m.id, m.num_logs, m.last_log_num, m.time_utc, m.size) == (0, 0, 0, 0, 0)
    assert t.channel is None and t.pump(False) == []


def test_list_numbers_from_one_oldest_first():
    logs = [b"a" * 10, b"b" * 200, b"c" * 3000]
    t = LogTransfer(Catalog(logs))
    out = t.handle(req_list(), A, armed=False)
    got = [(m.id, m.num_logs, m.last_log_num, m.size, m.time_utc) for m, _ in out]
    assert got == [(1, 3, 3, 10, 1_700_000_000), (2, 3, 3, 200, 1_700_000_001), (3, 3, 3, 3000, 1_700_000_002)]
    # a range: start 0 counts as 1, end beyond the last is the last
    out = t.handle(req_list(2, 2), A, armed=False)
    assert [(m.id, m.last_log_num) for m, _ in out] == [(2, 2)]


def test_long_list_is_paced():
    t = LogTransfer(Catalog([b"x"] * (SENDS_PER_PUMP + 5)))
    first = t.handle(req_list(), A, armed=False)
    assert len(first) == SENDS_PER_PUMP and t.channel == A
    rest = t.pump(False)
    assert [m.id for m, _ in rest] == list(range(SENDS_PER_PUMP + 1, SENDS_PER_PUMP + 6))
    assert t.channel is None


@pytest.mark.parametrize("size", [0, 1, 89, 90, 91, 180, 3599, 3600, 3601, 10_000])
def test_download_whole_log(size):
    data = bytes((i * 7 + 3) % 256 for i in range(size))
    t = LogTransfer(Catalog([b"first", data]))
    got, msgs = download(t, 2)
    assert got == data
    last = msgs[-1]
    # the transfer ends with a short packet, or a full one that reaches the end
    assert last.count < DATA_LEN or last.ofs + last.count == size
    assert all(m.count == DATA_LEN for m in msgs[:-1])


def test_offset_and_count_and_past_the_end():
    data = bytes(range(256)) * 4
    t = LogTransfer(Catalog([data]))
    got, _ = download(t, 1, ofs=180, count=200)
    assert got == data[180:380]
    # at or past the end: one LOG_DATA with count 0 (how MAVProxy learns a 90-multiple log ended)
    out = t.handle(req_data(1, len(data)), A, armed=False)
    assert [(m.count, m.ofs) for m, _ in out] == [(0, len(data))] and t.channel is None


def test_bad_id_cancels_silently():
    t = LogTransfer(Catalog([b"x" * 10_000]))
    t.handle(req_data(1), A, armed=False)
    assert t.channel == A
    t.end()
    assert t.handle(req_data(0), A, armed=False) == []
    assert t.handle(req_data(2), A, armed=False) == []
    assert t.channel is None and t.pump(False) == []


def test_one_transfer_at_a_time():
    t = LogTransfer(Catalog([b"x" * 10_000]))
    t.handle(req_data(1), A, armed=False)
    # another link is told; the same link's repeat (MAVProxy's gap filling) is dropped
    (m, ch), = t.handle(req_list(), B, armed=False)
    assert ch == B and m.get_type() == "STATUSTEXT" and m.text == "Log download in progress"
    assert m.severity == mav.MAV_SEVERITY_INFO
    (m, ch), = t.handle(req_data(1), B, armed=False)
    assert ch == B and m.text == "Log download in progress"
    assert t.handle(req_data(1, 90, 90), A, armed=False) == []
    assert t.handle(req_list(), A, armed=False)[0][0].get_type() == "STATUSTEXT"


def test_end_stops_and_erase_erases():
    cat = Catalog([b"x" * 10_000])
    t = LogTransfer(cat)
    t.handle(req_data(1), A, armed=False)
    assert t.handle(mav.MAVLink_log_request_end_message(1, 1), A, armed=False) == []
    assert t.channel is None and t.pump(False) == []
    assert t.handle(mav.MAVLink_log_erase_message(1, 1), A, armed=False) == []
    assert cat.erased == 1
    (m, _), = t.handle(req_list(), A, armed=False)
    assert m.num_logs == 0


def test_armed_refuses_once_per_armed_period_and_pauses():
    t = LogTransfer(Catalog([b"x" * 10_000]))
    (m, ch), = t.handle(req_list(), A, armed=True)
    assert ch == A and m.text == "Disarm for log download" and m.severity == mav.MAV_SEVERITY_ERROR
    assert t.handle(req_list(), A, armed=True) == []
    assert t.handle(req_data(1), B, armed=True) == []
    # disarmed again: answered; armed mid-transfer: paused, then resumed
    first = t.handle(req_data(1), A, armed=False)
    assert len(first) == SENDS_PER_PUMP
    assert t.pump(armed=True) == []
    more = t.pump(armed=False)
    assert more[0][0].ofs == SENDS_PER_PUMP * DATA_LEN
    # a new armed period warns again
    t.handle(req_list(), B, armed=False)
    assert t.handle(req_list(), A, armed=True)[0][0].text == "Disarm for log download"


def test_bytes_not_on_disk_yet_are_waited_for():
    class Late(Catalog):
        ready = False

        def read(self, list_id, ofs, count):
            return super().read(list_id, ofs, count) if self.ready else None
    cat = Late([bytes(range(200))])
    t = LogTransfer(cat)
    assert t.handle(req_data(1), A, armed=False) == [] and t.channel == A
    assert t.pump(False) == [] and t.channel == A          # still waiting, nothing lost
    cat.ready = True
    got, _ = download(t, 1)
    assert got == bytes(range(200))
