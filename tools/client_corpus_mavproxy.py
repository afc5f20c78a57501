"""Play a MAVProxy command script as a user types it (a client program of the corpus).

    python -m tools.client_corpus_mavproxy SCRIPT TCP_PORT

starts ``mavproxy.py --master=tcp:127.0.0.1:TCP_PORT`` in a scratch folder and feeds it the
script's lines on stdin. A script line is one of:

    wait SECONDS REGEX   wait (wall s) until a MAVProxy output line matches REGEX
    until SECONDS REGEX :: COMMAND
                         type COMMAND, again every 3 s (as a user retries `arm throttle` until
                         the vehicle is ready), until a line matches REGEX
    sleep SECONDS        pause, as a user reading the screen
    # ...                a comment
    anything else        typed into MAVProxy; {dir} is the script's folder

Prints MAVProxy's output; exits 0 after the last line, 1 when a wait times out.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path


def mavproxy_exe() -> str:
    exe = Path(sys.executable).with_name("mavproxy.py")
    return str(exe) if exe.exists() else "mavproxy.py"


class Session:
    """One MAVProxy process and the lines it printed."""

    def __init__(self, tcp_port: int, workdir: str) -> None:
        self.lines: list[str] = []
        self.seen = 0           # lines already shown
        self.proc = subprocess.Popen([sys.executable, mavproxy_exe(), f"--master=tcp:127.0.0.1:{tcp_port}",
                                      "--state-basedir", workdir], cwd=workdir, text=True,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     errors="replace")
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line)
            sys.stdout.write(line)
            sys.stdout.flush()

    def type(self, text: str) -> None:
        print(f"MAVPROXY> {text}", flush=True)
        self.proc.stdin.write(text + "\n")
        self.proc.stdin.flush()

    def wait(self, pattern: str, timeout: float) -> bool:
        """A line from now on matching pattern, within timeout wall s."""
        rx, start, end = re.compile(pattern), self.seen, time.monotonic() + timeout
        while time.monotonic() < end:
            for i in range(start, len(self.lines)):
                if rx.search(self.lines[i]):
                    self.seen = i + 1
                    return True
            start = max(start, len(self.lines) - 1)
            time.sleep(0.05)  # poll the reader's lines
        return False

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()           # MAVProxy fed on stdin has no `exit` command
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def retry(s: Session, command: str, pattern: str, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        s.type(command)
        if s.wait(pattern, min(3.0, max(0.1, end - time.monotonic()))):
            return True
    return False


def play(script: Path, tcp_port: int) -> int:
    with tempfile.TemporaryDirectory(prefix="mavproxy-") as workdir:
        s = Session(tcp_port, workdir)
        try:
            for raw in script.read_text().splitlines():
                line = raw.strip()
                if not line or line.startswith("#"):
                    continue
                word, _, rest = line.partition(" ")
                if word == "wait":
                    secs, _, pattern = rest.partition(" ")
                    if not s.wait(pattern, float(secs)):
                        print(f"MAVPROXY-SCRIPT FAILED: no line matching {pattern!r} within {secs} s", flush=True)
                        return 1
                elif word == "until":
                    secs, _, rest2 = rest.partition(" ")
                    pattern, _, command = rest2.partition(" :: ")
                    if not retry(s, command.replace("{dir}", str(script.parent)), pattern, float(secs)):
                        print(f"MAVPROXY-SCRIPT FAILED: {command!r} never gave {pattern!r} within {secs} s", flush=True)
                        return 1
                elif word == "sleep":
                    time.sleep(float(rest))  # the script's own pause
                else:
                    s.type(line.replace("{dir}", str(script.parent)))
            print("MAVPROXY-SCRIPT OK", flush=True)
            return 0
        finally:
            s.stop()


if __name__ == "__main__":
    os.environ.setdefault("MAVLINK20", "1")
    sys.exit(play(Path(sys.argv[1]), int(sys.argv[2])))
