"""No MAVFTP path leaves the vehicle's root (vehicle/files/jail.py): "..", absolute paths,
symlinks pointing out (to a file, a directory, nowhere, relative or absolute, in loops), NUL
bytes and over-long names are refused with the answer ArduPilot gives for a missing file, and
nothing outside the root is read, listed, written, created, renamed or removed - tried by
hand and by hypothesis over every opcode that takes a path."""
from __future__ import annotations

import errno
import itertools
import os
import tempfile
from pathlib import Path

import pytest
from ftp_support import body, nak_of, req
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vehicle.files.jail import PathJail
from vehicle.link import ftp

SECRET = b"SECRET-BYTES-OUTSIDE"


def make_world(top: Path) -> Path:
    """top/outside (the rest of the disk), top/vehicles/1 (another vehicle), and the root
    top/vehicles/0 with links pointing every which way; returns the root."""
    out = top / "outside"
    (out / "dir").mkdir(parents=True)
    (out / "secret.txt").write_bytes(SECRET)
    (out / "dir" / "inner.txt").write_bytes(SECRET + b"2")
    (top / "vehicles" / "1").mkdir(parents=True)
    (top / "vehicles" / "1" / "other.txt").write_bytes(SECRET + b"3")
    root = top / "vehicles" / "0"
    (root / "logs").mkdir(parents=True)
    (root / "logs" / "00000001.BIN").write_bytes(b"log")
    (root / "notes.txt").write_bytes(b"notes")
    links = {"link_out": out, "link_secret": out / "secret.txt", "link_abs": "/etc",
             "link_rel_out": "../../outside/secret.txt", "link_dangling_out": out / "nothing",
             "link_in": "logs", "link_sibling": "../1", "loop": "loop"}
    for name, target in links.items():
        os.symlink(target, root / name)
    os.symlink("../../../outside/dir", root / "logs" / "deep_out")
    return root


def snapshot(top: Path, skip: set[Path]) -> dict:
    """Everything under top but the skipped trees: paths, types, link targets, contents, modes."""
    seen = {}
    for dirpath, dirnames, filenames in os.walk(top):
        d = Path(dirpath)
        dirnames[:] = [n for n in dirnames if d / n not in skip]
        for n in dirnames + filenames:
            p = d / n
            if p in skip:
                continue
            s = os.lstat(p)
            what = os.readlink(p) if os.path.islink(p) else p.read_bytes() if p.is_file() else None
            seen[str(p.relative_to(top))] = (s.st_mode, what)
    return seen


@pytest.fixture
def world(tmp_path):
    root = make_world(tmp_path)
    return tmp_path, root, ftp.FtpServer({}, root=root)


_SEQ = itertools.count(1)


def ask(srv, opcode, data=b"", session=1, size=None, offset=0):
    return srv.handle(req(opcode, seq=next(_SEQ), session=session, data=data, size=size, offset=offset),
                      255, 190, "udp")


ESCAPES = [b"..", b"/..", b"../outside/secret.txt", b"/../outside/secret.txt", b"logs/../../outside",
           b"logs/../../../outside/secret.txt", b"//..//..//outside", b"link_out", b"link_out/secret.txt",
           b"link_out/dir/inner.txt", b"link_secret", b"link_abs", b"link_abs/passwd", b"link_rel_out",
           b"link_dangling_out", b"link_sibling/other.txt", b"logs/deep_out/inner.txt", b"logs/deep_out",
           b"@MAV_LOG/../..", b"@MAV_LOG/deep_out/inner.txt", b"/etc/passwd", b"/proc/self/environ"]


@pytest.mark.parametrize("path", ESCAPES)
def test_escapes_are_files_that_do_not_exist(world, path):
    top, root, srv = world
    before = snapshot(top, {root, top / "vehicles" / ".0.partial"})
    for op in (ftp.OPEN_FILE_RO, ftp.LIST_DIRECTORY, ftp.CALC_FILE_CRC32, ftp.CREATE_FILE, ftp.OPEN_FILE_WO,
               ftp.TRUNCATE_FILE):
        (r,) = ask(srv, op, path)
        assert nak_of(r) == (ftp.ERR_FILE_NOT_FOUND,), (op, path)
    (r,) = ask(srv, ftp.RENAME, b"notes.txt\0" + path.rstrip(b"/") + b"/moved")
    assert nak_of(r) == (ftp.ERR_FILE_NOT_FOUND,)
    (r,) = ask(srv, ftp.CREATE_DIRECTORY, path + b"/newdir")
    assert nak_of(r) == (ftp.ERR_FILE_NOT_FOUND,)
    assert snapshot(top, {root, top / "vehicles" / ".0.partial"}) == before


def test_links_inside_the_root_work_and_links_out_are_not_listed(world):
    _top, root, srv = world
    (r,) = ask(srv, ftp.LIST_DIRECTORY, b"/")
    names = body(r).split(b"\0")
    assert b"Flink_in\t%d" % os.stat(root / "logs").st_size in names      # a link: "F", sized by its target
    assert not [n for n in names if n.startswith((b"Flink_out", b"Flink_secret", b"Flink_abs", b"Flink_rel",
                                                  b"Flink_dangling", b"Flink_sibling"))]
    (r,) = ask(srv, ftp.LIST_DIRECTORY, b"link_in")
    assert b"F00000001.BIN\t3" in body(r).split(b"\0") and b"deep_out" not in body(r)
    (r,) = ask(srv, ftp.OPEN_FILE_RO, b"link_in/00000001.BIN", session=2)
    assert r[3] == ftp.ACK
    (r,) = ask(srv, ftp.OPEN_FILE_RO, b"loop", session=3)
    assert nak_of(r) == (ftp.ERR_FAIL_ERRNO, errno.ELOOP)


def test_removing_or_renaming_a_link_out_touches_only_the_link(world):
    top, root, srv = world
    (r,) = ask(srv, ftp.REMOVE_FILE, b"link_secret")
    assert r[3] == ftp.ACK and not os.path.lexists(root / "link_secret")
    (r,) = ask(srv, ftp.RENAME, b"link_out\0renamed_link")
    assert r[3] == ftp.ACK and os.readlink(root / "renamed_link") == str(top / "outside")
    assert (top / "outside" / "secret.txt").read_bytes() == SECRET
    assert sorted(os.listdir(top / "outside")) == ["dir", "secret.txt"]


def test_the_jail_itself(tmp_path):
    root = make_world(tmp_path)
    jail = PathJail(root)
    real = os.fsencode(os.path.realpath(root))
    assert jail.resolve(b"") == jail.resolve(b"/") == jail.resolve(b"./logs/..") == real
    assert jail.resolve(b"/logs//00000001.BIN") == real + b"/logs/00000001.BIN"
    assert jail.resolve(b"link_in/00000001.BIN") == real + b"/logs/00000001.BIN"
    assert jail.resolve(b"link_out", follow=False) == real + b"/link_out"      # the link itself
    for bad in (b"link_out", b"link_out/secret.txt", b"..", b"a/../..", b"x\0y"):
        with pytest.raises(FileNotFoundError):
            jail.resolve(bad)
    with pytest.raises(FileNotFoundError):
        jail.resolve(b"link_out/x", follow=False)                            # its directory is outside
    with pytest.raises(OSError) as e:
        jail.resolve(b"logs/" + b"n" * 256)
    assert e.value.errno == errno.ENAMETOOLONG
    # a root reached through a symlink: the boundary is its real path
    os.symlink(root, tmp_path / "root_link")
    assert PathJail(tmp_path / "root_link").resolve(b"notes.txt") == real + b"/notes.txt"


def test_nul_bytes_and_long_names_on_the_wire(world):
    _top, _root, srv = world
    (r,) = ask(srv, ftp.OPEN_FILE_RO, b"notes.txt\0../../outside/secret.txt")
    assert nak_of(r) == (ftp.ERR_INVALID_DATA_SIZE,)
    (r,) = ask(srv, ftp.CREATE_FILE, b"n" * 238)                 # the longest name a request holds
    assert r[3] == ftp.ACK
    (r,) = ask(srv, ftp.CREATE_FILE, b"m" * 240, session=2)
    assert nak_of(r) == (ftp.ERR_INVALID_DATA_SIZE,)


TOKENS = [b"..", b".", b"", b"logs", b"link_out", b"link_secret", b"link_abs", b"link_in", b"link_rel_out",
          b"link_dangling_out", b"link_sibling", b"loop", b"deep_out", b"secret.txt", b"outside", b"dir",
          b"inner.txt", b"vehicles", b"1", b"other.txt", b"etc", b"passwd", b"@MAV_LOG", b"@PARAM", b"new",
          b"notes.txt"]
paths = st.builds(lambda lead, parts: lead + b"/".join(parts), st.sampled_from([b"", b"/", b"//"]),
                  st.lists(st.sampled_from(TOKENS), min_size=1, max_size=7)).filter(lambda p: 0 < len(p) <= 200)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(path=paths)
def test_fuzzed_paths_never_reach_outside(path):
    with tempfile.TemporaryDirectory() as t:
        top = Path(t)
        root = make_world(top)
        skip = {root, top / "vehicles" / ".0.partial"}
        before = snapshot(top, skip)
        srv = ftp.FtpServer({}, root=root)
        jail = srv.tree.jail
        try:
            real = jail.resolve(path)
        except OSError:
            real = None
        assert real is None or jail.inside(os.fsencode(os.path.realpath(real)))
        replies = []
        for op in (ftp.LIST_DIRECTORY, ftp.CALC_FILE_CRC32, ftp.TRUNCATE_FILE, ftp.CREATE_DIRECTORY):
            replies += ask(srv, op, path)
        replies += ask(srv, ftp.OPEN_FILE_RO, path, session=2)
        replies += ask(srv, ftp.BURST_READ_FILE, session=2)
        replies += ask(srv, ftp.CREATE_FILE, path, session=3)
        replies += ask(srv, ftp.WRITE_FILE, b"written", session=3)
        replies += ask(srv, ftp.OPEN_FILE_WO, path, session=4)
        replies += ask(srv, ftp.WRITE_FILE, b"W", session=4, offset=2)
        replies += ask(srv, ftp.RENAME, b"notes.txt\0" + path)
        replies += ask(srv, ftp.RENAME, path + b"\0moved")
        replies += ask(srv, ftp.REMOVE_FILE, path)
        replies += ask(srv, ftp.REMOVE_DIRECTORY, path)
        srv.close()                                                      # uploads land now
        assert not any(SECRET in body(r) for r in replies)
        assert snapshot(top, skip) == before
        assert os.listdir(top / "vehicles" / ".0.partial") == []
        assert root.is_dir()
