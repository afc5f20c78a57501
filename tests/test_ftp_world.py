"""Where a world's MAVFTP files live (vehicle/vehicle_root.py): with a state dir, each vehicle's
root is <state_dir>/vehicles/<index> and stays after the world stops; without one (nothing
persisted) it is a temporary directory, kept across a reboot and removed when the world
stops. A world in this process, spoken to over a real UDP socket with pymavlink."""
from __future__ import annotations

import itertools

import pytest
from ftp_support import body, hdr, req
from support import free_ports, wait_until
from test_sitl_support import command, connect, mav, recv

from vehicle.link import ftp
from vehicle.vehicle_root import vehicle_root
from vehicle.world import World, WorldConfig

pytestmark = pytest.mark.timeout(60)
_SEQ = itertools.count(1)


def _ask(m, opcode, data=b"", session=1, offset=0):
    seq = next(_SEQ)
    m.mav.file_transfer_protocol_send(0, m.target_system, m.target_component,
                                      list(req(opcode, seq=seq, session=session, data=data, offset=offset)))
    r = recv(m, "FILE_TRANSFER_PROTOCOL", 5, cond=lambda r: hdr(bytes(r.payload))[0] == (seq + 1) & 0xFFFF)
    return bytes(r.payload)


def _upload(m, path: bytes, content: bytes) -> None:
    assert _ask(m, ftp.CREATE_FILE, path)[3] == ftp.ACK
    assert _ask(m, ftp.WRITE_FILE, content)[3] == ftp.ACK
    assert _ask(m, ftp.TERMINATE_SESSION)[3] == ftp.ACK


def _world(state_dir):
    ports = free_ports(2)
    w = World(WorldConfig(drones=1, rovers=1, state_dir=state_dir, tcp_base=None, udp_base=None,
                          endpoints={0: [f"udpin:127.0.0.1:{ports[0]}"], 1: [f"udpin:127.0.0.1:{ports[1]}"]}))
    w.start_thread()
    return w, ports


def test_a_world_without_state_dir_serves_a_temporary_root_removed_at_stop():
    w, ports = _world(None)
    try:
        m = connect(ports[0])
        _upload(m, b"/notes.txt", b"kept across a reboot")
        root = w.vehicles[0].link.files.root.path()
        assert (root / "notes.txt").read_bytes() == b"kept across a reboot"
        assert command(m, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == mav.MAV_RESULT_ACCEPTED
        wait_until(lambda: w.vehicles[0].link.stats["reboots"] == 1, 5, "reboot")
        assert b"Fnotes.txt\t20" in body(_ask(m, ftp.LIST_DIRECTORY, b"/")).split(b"\0")
        rover = connect(ports[1])
        assert b"Fnotes.txt" not in body(_ask(rover, ftp.LIST_DIRECTORY, b"/"))      # one root each
        m.close()
        rover.close()
    finally:
        w.stop()
    assert not root.exists() and not root.parent.exists()


def test_with_a_state_dir_each_vehicle_has_its_root_there(tmp_path):
    w, ports = _world(str(tmp_path))
    try:
        for i, port in enumerate(ports):
            m = connect(port)
            _upload(m, b"scripts.txt", b"vehicle %d" % i)
            m.close()
    finally:
        w.stop()
    for i in range(2):
        assert (vehicle_root(tmp_path, i) / "scripts.txt").read_bytes() == b"vehicle %d" % i
