#!/usr/bin/env python3
"""MAVFTP with pymavlink's mavftp: list the root, download the parameters (@PARAM/param.pck
via cmd_getparams), make and remove a folder, upload a small file (after pymavlink's
examples/mavftp_example.py).

Usage: mavftp_params.py [DEVICE]
"""
import logging
import os
import sys
import tempfile

from pymavlink import mavftp, mavutil

logging.basicConfig(level=logging.INFO, format="%(levelname)s - %(message)s")
device = sys.argv[1] if len(sys.argv) > 1 else "tcp:127.0.0.1:5760"
master = mavutil.mavlink_connection(device, source_system=250)
master.wait_heartbeat()
logging.info("Got heartbeat from system %u, component %u", master.target_system, master.target_component)
mav_ftp = mavftp.MAVFTP(master, target_system=master.target_system, target_component=master.target_component)
os.chdir(tempfile.mkdtemp())
failed = 0


def show(ret):
    global failed
    ret.display_message()
    failed += ret.error_code != 0


show(mav_ftp.cmd_list(["/"]))
mav_ftp.cmd_getparams(["params.param", "defaults.param"])
show(mav_ftp.process_ftp_reply("OpenFileRO", timeout=60))
if os.path.exists("params.param"):
    with open("params.param") as f:
        n = sum(1 for line in f if line.strip() and not line.startswith("#"))
    print(f"params.param: {n} parameters")
show(mav_ftp.cmd_mkdir(["test_dir"]))
show(mav_ftp.cmd_rmdir(["test_dir"]))
with open("hello.lua", "w") as f:
    f.write("-- hello\n" * 50)
mav_ftp.cmd_put(["hello.lua", "hello.lua"])
show(mav_ftp.process_ftp_reply("CreateFile", timeout=10))
show(mav_ftp.cmd_list(["/"]))
master.close()
print(f"{failed} operation(s) failed")
sys.exit(1 if failed else 0)
