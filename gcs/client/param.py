"""Parameters read by name (PARAM_REQUEST_READ / PARAM_VALUE)."""
from __future__ import annotations

from typing import Any

from common.mavlink.mavstr import mav_str
from gcs.client.errors import ClientTimeout
from gcs.client.link import Link


class Param:
    """The parameters of the systems on one link."""

    def __init__(self, link: Link) -> None:
        self.link = link

    def get_param(self, name: str, sysid: int = 1, timeout: float = 5.0) -> float:
        """PARAM_REQUEST_READ by name, re-sent every second until PARAM_VALUE arrives."""
        link = self.link
        got: dict[str, float] = {}

        def listen(msg: Any) -> None:
            if msg.get_srcSystem() == sysid:
                got[mav_str(msg.param_id)] = msg.param_value

        link.subscribe("PARAM_VALUE", listen)
        try:
            end = link.clock() + timeout
            while link.clock() < end:
                link.send(lambda: link.mav.param_request_read_send(sysid, 1, name.encode(), -1))
                if link.wait_until(lambda: name in got, min(1.0, max(0.0, end - link.clock()))):
                    return got[name]
            raise ClientTimeout(f"no PARAM_VALUE {name} from system {sysid} in {timeout:g} s")
        finally:
            link.unsubscribe("PARAM_VALUE", listen)
