"""COMMAND_LONG sent until acknowledged: the base of every action (gcs.client.action)."""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

from gcs.client.errors import CommandRejected, CommandTimeout, command_name
from gcs.client.link import Link
from gcs.client.mav import mavlink


class Commands:
    """Commands to the systems on one link, and the COMMAND_ACKs that answer them."""

    def __init__(self, link: Link) -> None:
        self.link = link
        self._acks: dict[tuple[int, int], tuple[int, int]] = {}  # (sysid, cmd) -> (serial, result)
        self._ack_serial = 0
        link.subscribe("COMMAND_ACK", self._on_ack)

    def _on_ack(self, msg: Any) -> None:
        self._ack_serial += 1
        self._acks[(msg.get_srcSystem(), msg.command)] = (self._ack_serial, msg.result)

    def command_long(self, sysid: int, command: int, params: Sequence[float] = (), *,
                     component: int = 1, timeout: float = 10.0, ack_timeout: float = 1.0,
                     accept: Iterable[int] = (mavlink.MAV_RESULT_ACCEPTED,)) -> int:
        """Send COMMAND_LONG until a COMMAND_ACK arrives; returns the result.

        A lost command or ack is re-sent after `ack_timeout` seconds of the vehicle's own
        clock (or of the client's clock, whichever comes first): in a sped-up SITL a wall-clock
        retry would let sim-time timers (DISARM_DELAY, failsafes) run out between tries.
        Raises CommandRejected for results not in `accept`, CommandTimeout if no ack.
        """
        link = self.link
        p = list(params) + [0.0] * (7 - len(params))
        accept = set(accept)
        end = link.clock() + timeout
        confirmation = 0
        st = link.system(sysid)
        while link.clock() < end:
            before = self._acks.get((sysid, command), (0, 0))[0]
            sent_ms = st.time_boot_ms
            link.send(lambda: link.mav.command_long_send(sysid, component, command, confirmation, *p))
            confirmation = min(confirmation + 1, 255)

            def acked_or_due():
                if self._acks.get((sysid, command), (0, 0))[0] > before:
                    return self._acks[(sysid, command)]
                return (sent_ms and st.time_boot_ms - sent_ms >= ack_timeout * 1000.0) and "retry"

            ack = link.wait_until(acked_or_due, min(ack_timeout, max(0.0, end - link.clock())))
            if ack == "retry":
                continue
            if ack:
                result = ack[1]
                if result == mavlink.MAV_RESULT_IN_PROGRESS:
                    continue
                if result not in accept:
                    raise CommandRejected(command, result)
                return result
        raise CommandTimeout(f"no COMMAND_ACK from system {sysid} for "
                             f"{command_name(command)} in {timeout:g} s")
