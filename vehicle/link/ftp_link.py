"""Files, the link capability: FILE_TRANSFER_PROTOCOL (MAVFTP) answered by the pure server of
vehicle/link/ftp.py, which serves @PARAM/param.pck and answers everything else at once, so
clients never wait on a timeout. A reboot closes every session.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.link import ftp
from vehicle.link.link_core import LinkCore


class FtpLink:
    def __init__(self, core: LinkCore, params) -> None:
        """params: the vehicle's ParamStore (the content of @PARAM/param.pck)."""
        self.core = core
        self.params = params
        self.server: ftp.FtpServer | None = None      # opened by the first request
        core.register("FILE_TRANSFER_PROTOCOL", self.on_file_transfer_protocol)
        core.on_reboot(self.forget)

    def forget(self) -> None:
        """A new boot has no MAVFTP session open."""
        self.server = None

    def on_file_transfer_protocol(self, m, ch) -> None:
        if self.server is None:
            self.server = ftp.FtpServer({"@PARAM/param.pck": self._param_pck})
        for reply in self.server.handle(m.payload):
            self.core.send(mav.MAVLink_file_transfer_protocol_message(0, m.get_srcSystem(), m.get_srcComponent(),
                                                                      list(reply)), ch)

    def _param_pck(self, with_defaults: bool) -> bytes:
        ps = self.params
        return ftp.param_pck([(n, ps[n], ps.defs[n].mav_type, ps.defs[n].default) for n in ps.names],
                             with_defaults)
