"""Files, the link capability: FILE_TRANSFER_PROTOCOL (MAVFTP) answered by the file server of
vehicle/link/ftp.py over the vehicle's root directory (vehicle/vehicle_root.py, or a
temporary one removed when the link closes), @PARAM/param.pck and @SYS (whose uarts.txt
reports the link's endpoints as SITL's serial ports, SERIAL0 first). Sessions are the
requester's on its channel; a reboot or the link's close closes them (uploads in progress
are put in place).
"""
from __future__ import annotations

import os

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.files.root_dir import RootDir
from vehicle.files.sys_dir import Port, SysDir
from vehicle.link import ftp
from vehicle.link.link_core import LinkCore


class FtpLink:
    def __init__(self, core: LinkCore, params, root: str | os.PathLike | None = None) -> None:
        """params: the vehicle's ParamStore (the content of @PARAM/param.pck); root: the
        directory served, None for a temporary one."""
        self.core = core
        self.params = params
        self.root = RootDir(root)
        self.server: ftp.FtpServer | None = None      # opened by the first request
        core.register("FILE_TRANSFER_PROTOCOL", self.on_file_transfer_protocol)
        core.on_reboot(self.forget)
        core.on_close(self.close)

    def forget(self) -> None:
        """A new boot has no MAVFTP session open."""
        if self.server is not None:
            self.server.close()
        self.server = None

    def close(self) -> None:
        self.forget()
        self.root.close()

    def on_file_transfer_protocol(self, m, ch) -> None:
        if self.server is None:
            self.server = ftp.FtpServer({"@PARAM/param.pck": self._param_pck}, root=self.root.path(),
                                        sys_dir=SysDir(self._ports, lambda: int(self.core.clock() * 1000)))
        for reply in self.server.handle(m.payload, m.get_srcSystem(), m.get_srcComponent(), ch):
            self.core.send(mav.MAVLink_file_transfer_protocol_message(0, m.get_srcSystem(), m.get_srcComponent(),
                                                                      list(reply)), ch)

    def _ports(self) -> list[Port]:
        return [Port(ep.spec, ep.listened(), ep.tx_bytes, ep.rx_bytes) for ep in self.core.endpoints]

    def _param_pck(self, with_defaults: bool) -> bytes:
        ps = self.params
        return ftp.param_pck([(n, ps[n], ps.defs[n].mav_type, ps.defs[n].default) for n in ps.names],
                             with_defaults)
