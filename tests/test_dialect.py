"""The towerlink dialect: ids collide with nothing pymavlink ships, the committed module is
exactly what mavgen makes from the XML, and the helper connection decodes it."""
from __future__ import annotations

import importlib
import pkgutil
import xml.etree.ElementTree as ET


import pymavlink.dialects.v20 as v20
from common.mavlink.dialect import DIALECT_IDS, XML, generate, mavlink_connection, module_path
from common.mavlink.dialect import towerlink as tl
from support import free_port, wait_until


def test_ids_collide_with_nothing_shipped():
    ours = {int(m.get("id")): m.get("name") for m in ET.parse(XML).getroot().iter("message")}
    assert ours == {v: k for k, v in DIALECT_IDS.items()}
    for info in pkgutil.iter_modules(v20.__path__):
        if info.name == "towerlink":    # ours, put there by `python -m common.mavlink.dialect --install`
            continue
        mod = importlib.import_module(f"pymavlink.dialects.v20.{info.name}")
        clash = set(ours) & set(getattr(mod, "mavlink_map", {}))
        assert not clash, f"{info.name} already uses {sorted(clash)}"
    # and the generated module has all of common + ardupilotmega besides ours
    from pymavlink.dialects.v20 import ardupilotmega as apm
    assert set(apm.mavlink_map) | set(ours) == set(tl.mavlink_map)
    for mid, cls in apm.mavlink_map.items():
        assert tl.mavlink_map[mid].crc_extra == cls.crc_extra


def test_loaded_module_is_what_mavgen_makes_from_the_xml(tmp_path):
    out = generate(tmp_path / "towerlink.py")
    assert module_path().exists() and tl.__file__ == str(module_path())
    assert out.read_bytes() == module_path().read_bytes()
    assert "towerlink.xml" in out.read_text()[:2000]   # mavgen's header names its source


def test_protocol_2_and_roundtrip():
    assert tl.WIRE_PROTOCOL_VERSION == "2.0"
    enc = tl.MAVLink(None, srcSystem=250, srcComponent=191)
    m = tl.MAVLink_towerlink_follow_status_message(5, *range(16), 1, 1)
    back = tl.MAVLink(None).decode(bytearray(m.pack(enc)))
    assert back.get_type() == "TOWERLINK_FOLLOW_STATUS" and back.err_yaw == 15 and back.state == 1


def test_mavlink_connection_helper_decodes_dialect():
    port = free_port()
    rx = mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=254)
    tx = mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=250, source_component=191)
    try:
        def poll():
            tx.mav.towerlink_static_transform_send(0, 0, b"world", b"pad", [1, 2, 3], [0, 0, 0, 1])
            return rx.recv_match(type="TOWERLINK_STATIC_TRANSFORM", blocking=True, timeout=0.1)
        m = wait_until(poll, 5, "dialect message through mavutil")
        assert m.child_frame_id == "pad" and m.get_srcSystem() == 250 and list(m.translation) == [1, 2, 3]
    finally:
        rx.close(); tx.close()


def test_pymavlink_tools_decode_the_dialect_after_install(tmp_path):
    """`python -m common.mavlink.dialect --install`, then pymavlink's own mavlogdump.py decodes TOWERLINK_*
    in a tlog (instead of UNKNOWN_43000), as the README says."""
    import os
    import shutil
    import struct
    import subprocess
    import sys

    from common.mavlink.dialect import towerlink as tl
    from common.mavlink.dialect.__main__ import main as dialect_main

    assert dialect_main(["--install"]) == 0
    enc = tl.MAVLink(None, srcSystem=250, srcComponent=1)
    msg = tl.MAVLink_towerlink_transform_message(1_500_000, b"world", b"drone", [1.0, 2.0, -3.0],
                                                 [0.0, 0.0, 0.0, 1.0], 0)
    tlog = tmp_path / "bridge.tlog"
    tlog.write_bytes(struct.pack(">Q", 1_700_000_000_000_000) + msg.pack(enc))
    tool = shutil.which("mavlogdump.py", path=os.path.dirname(sys.executable)) or shutil.which("mavlogdump.py")
    assert tool, "pymavlink's mavlogdump.py is installed with pymavlink"
    out = subprocess.run([sys.executable, tool, "--dialect", "towerlink", str(tlog)],
                         capture_output=True, text=True, timeout=120, env=dict(os.environ, MAVLINK20="1"))
    assert out.returncode == 0, out.stderr
    assert "TOWERLINK_TRANSFORM" in out.stdout and "child_frame_id : drone" in out.stdout
    assert "UNKNOWN" not in out.stdout


def test_compiled_module_is_cached_and_a_damaged_cache_is_replaced(tmp_path):
    """Every towerlink process loads the 2 MB module: its code is compiled once and kept
    beside it (even with PYTHONDONTWRITEBYTECODE); a damaged cache is compiled again."""
    import marshal

    from common.mavlink import dialect
    src = tmp_path / "towerlink_x.py"
    src.write_text("ANSWER = 42\n")
    code = dialect._code(src)
    cached = tmp_path / "towerlink_x.py.code"
    head, _, body = cached.read_bytes().partition(b"\n")
    assert marshal.loads(body).co_consts == code.co_consts and head.endswith(str(src.stat().st_size).encode() + b":" + str(src.stat().st_mtime_ns).encode())
    ns: dict = {}
    exec(dialect._code(src), ns)           # from the cache
    assert ns["ANSWER"] == 42
    cached.write_bytes(head + b"\n" + b"\x00garbage")
    ns = {}
    exec(dialect._code(src), ns)           # damaged: compiled again, cache rewritten
    assert ns["ANSWER"] == 42 and marshal.loads(cached.read_bytes().partition(b"\n")[2]) is not None
