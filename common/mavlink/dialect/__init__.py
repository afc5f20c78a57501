"""The towerlink MAVLink dialect (towerlink.xml, extends ardupilotmega) and helpers.

The module ``common.mavlink.dialect.towerlink`` is generated, not committed (it is over 2 MB):
on first use pymavlink's own generator (``pymavlink.generator.mavgen``, language Python,
wire protocol 2.0) turns ``towerlink.xml`` plus the XML definitions shipped inside the
installed pymavlink (no network) into a module in a cache directory
(``$TOWERLINK_CACHE``, else ``$XDG_CACHE_HOME/towerlink``, else ``~/.cache/towerlink``),
named by a hash of the XML and the pymavlink version, so an edit to the XML or a new
pymavlink regenerates it. That costs a few seconds once; afterwards it is an import.

    python -m common.mavlink.dialect            # generate (if needed) and print where it is
    python -m common.mavlink.dialect --check    # exit 1 if the cached module differs from a fresh run

Other tools get a pymavlink connection that decodes (and can send) the dialect with::

    from common.mavlink.dialect import mavlink_connection, towerlink as tl
    conn = mavlink_connection("udpin:127.0.0.1:14600", source_system=255)
    msg = conn.recv_match(type="TOWERLINK_TRANSFORM", blocking=True, timeout=1)
    conn.mav.towerlink_static_transform_send(0, 0, b"world", b"pad", [1, 2, 0], [0, 0, 0, 1])
"""
from __future__ import annotations

import glob
import hashlib
import importlib.util
import io
import os
import shutil
import sys
import tempfile
from contextlib import redirect_stdout
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")

HERE = Path(__file__).resolve().parent
XML = HERE / "towerlink.xml"
MODULE_NAME = __name__ + ".towerlink"

#: Message ids of the dialect (also in towerlink.xml).
DIALECT_IDS = {
    "TOWERLINK_TRANSFORM": 43000,
    "TOWERLINK_STATIC_TRANSFORM": 43001,
    "TOWERLINK_POSITION_TARGET": 43002,
    "TOWERLINK_FOLLOW_STATUS": 43003,
    "TOWERLINK_BRIDGE_STATUS": 43004,
    "TOWERLINK_LOCKSTEP": 43005,
}


def generate(output: str | os.PathLike, xml: str | os.PathLike = XML) -> Path:
    """Run pymavlink's mavgen on towerlink.xml; write the Python module to `output`.

    The includes (ardupilotmega.xml and what it includes) are taken from the XML files
    that ship inside the installed pymavlink (pymavlink/dialects/v20/*.xml), copied with
    towerlink.xml into a temporary directory so mavgen resolves them by relative path.
    """
    from pymavlink import dialects
    from pymavlink.generator import mavgen, mavparse

    src = Path(dialects.__file__).resolve().parent / "v20"
    output = Path(output)
    with tempfile.TemporaryDirectory() as tmp:
        for f in glob.glob(str(src / "*.xml")):
            shutil.copy(f, tmp)
        shutil.copy(xml, Path(tmp) / "towerlink.xml")
        opts = mavgen.Opts(str(Path(tmp) / "towerlink"), wire_protocol=mavparse.PROTOCOL_2_0,
                           language="Python3", validate=False)
        with redirect_stdout(io.StringIO()):
            ok = mavgen.mavgen(opts, [str(Path(tmp) / "towerlink.xml")])
        if ok is False:
            raise RuntimeError("mavgen failed on towerlink.xml")
        shutil.copy(Path(tmp) / "towerlink.py", output)
    return output


def cache_dir() -> Path:
    """Where the generated module lives (see the module docstring)."""
    env = os.environ.get("TOWERLINK_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "towerlink"


def module_path() -> Path:
    """The generated module's path for this XML and this pymavlink."""
    import pymavlink
    key = hashlib.sha256(XML.read_bytes() + getattr(pymavlink, "__version__", "?").encode()
                         + Path(__file__).read_bytes()).hexdigest()[:16]
    return cache_dir() / f"towerlink_{key}.py"


def load():
    """The generated dialect module, generating it first if the cache has none."""
    mod = sys.modules.get(MODULE_NAME)
    if mod is not None:
        return mod
    path = module_path()
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        # generate beside the target and rename: parallel processes never see half a file
        fd, tmp = tempfile.mkstemp(suffix=".py", dir=path.parent)
        os.close(fd)
        try:
            generate(tmp)
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    spec = importlib.util.spec_from_file_location(MODULE_NAME, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[MODULE_NAME] = mod
    try:
        exec(_code(path), mod.__dict__)
    except BaseException:
        del sys.modules[MODULE_NAME]
        raise
    return mod


def _code(path: Path):
    """The module's code object, compiled once and kept beside it in the cache.

    Compiling the 2 MB generated module takes about a second, and every towerlink process
    loads it; Python's own bytecode cache is often off (PYTHONDONTWRITEBYTECODE), so the
    cache keeps its own, keyed by the source's size and mtime and the interpreter's tag.
    A damaged or stale one is simply compiled again and replaced (atomically)."""
    import marshal

    st = path.stat()
    key = f"{sys.implementation.cache_tag}:{st.st_size}:{st.st_mtime_ns}".encode()
    cached = path.with_name(path.name + ".code")
    try:
        head, _, body = cached.read_bytes().partition(b"\n")
        if head == key:
            return marshal.loads(body)
    except (OSError, ValueError, EOFError, TypeError):
        pass
    code = compile(path.read_bytes(), str(path), "exec", dont_inherit=True)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".code.tmp")
        with os.fdopen(fd, "wb") as f:
            f.write(key + b"\n" + marshal.dumps(code))
        os.replace(tmp, cached)
    except OSError:
        pass        # a read-only cache still works, just slower
    return code


def __getattr__(name: str):
    # PEP 562: `from common.mavlink.dialect import towerlink` generates/loads on first use
    if name == "towerlink":
        return load()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def mavlink_connection(url: str, **kw):
    """``pymavlink.mavutil.mavlink_connection`` whose parser/encoder is the towerlink dialect.

    Works for links (udpin/udpout/tcp/tcpin) and for log files (.tlog): the
    connection's ``mav`` is replaced by a ``towerlink.MAVLink`` before any byte is read,
    so ``recv_match(type="TOWERLINK_TRANSFORM")`` and ``conn.mav.towerlink_*_send`` work,
    alongside every ardupilotmega/common message. MAVLink 2 is used for sending.
    """
    from pymavlink import mavutil

    from . import towerlink as tl

    kw.setdefault("dialect", "ardupilotmega")
    conn = mavutil.mavlink_connection(url, **kw)
    old = conn.mav
    mav = tl.MAVLink(conn, srcSystem=conn.source_system, srcComponent=conn.source_component)
    mav.robust_parsing = getattr(old, "robust_parsing", True)
    mav.callback, mav.callback_args, mav.callback_kwargs = old.callback, old.callback_args, old.callback_kwargs
    mav.send_callback, mav.send_callback_args, mav.send_callback_kwargs = (
        old.send_callback, old.send_callback_args, old.send_callback_kwargs)
    conn.mav = mav
    conn.WIRE_PROTOCOL_VERSION = "2.0"
    return conn


def encoder(srcSystem: int = 250, srcComponent: int = 191):
    """A file-less ``towerlink.MAVLink`` used only to pack messages to bytes."""
    from . import towerlink as tl
    return tl.MAVLink(None, srcSystem=srcSystem, srcComponent=srcComponent)
