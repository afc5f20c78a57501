"""Parameters, the link capability: PARAM_REQUEST_LIST, PARAM_REQUEST_READ, PARAM_SET.

Replies are paced as ArduPilot paces them (vehicle/link/paced_queue.py): one outbox per
peer, a PARAM_REQUEST_LIST restarts that peer's list instead of queueing another,
PARAM_REQUEST_READ replies wait in a bounded queue. The PARAM_VALUE a PARAM_SET causes goes
to every endpoint, once per received chunk for each parameter; a refused set answers its
sender with the unchanged value and says why in a STATUSTEXT. Parameters are written to the
saved file once a tick (and when the link closes), not once per PARAM_SET.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping

from pymavlink.dialects.v20 import ardupilotmega as mav

from common.mavlink.mavstr import mav_str
from vehicle.link.link_core import LinkCore, statustext_message
from vehicle.link.stream_link import StreamLink


def param_id(s) -> str:
    """A PARAM_* message's param_id as the parameter's name."""
    return mav_str(s).strip().upper()


class ParamLink:
    def __init__(self, core: LinkCore, params, streams: StreamLink,
                 params_changed: Callable[[Mapping[str, float]], None] | None = None) -> None:
        """params: the vehicle's ParamStore; streams: rescheduled when an SR0_* rate is set;
        params_changed({name: value}) after every accepted PARAM_SET (the world's physics)."""
        self.core = core
        self.params = params
        self.streams = streams
        self.params_changed = params_changed or (lambda values: None)
        core.register("PARAM_REQUEST_LIST", self.on_param_request_list)
        core.register("PARAM_REQUEST_READ", self.on_param_request_read)
        core.register("PARAM_SET", self.on_param_set)
        core.on_tick(params.flush)             # a deferred store's PARAM_SETs of a tick reach the file together
        core.on_close(params.flush)

    def param_value(self, name: str):
        """PARAM_VALUE of parameter `name` as it is now."""
        ps = self.params
        return mav.MAVLink_param_value_message(name.encode(), float(ps[name]), ps.defs[name].mav_type,
                                               len(ps), ps.index[name])

    def on_param_request_list(self, m, ch) -> None:
        # ArduPilot: a new request restarts this peer's list from the first parameter (one
        # list in flight per peer, however many requests arrive), sent paced
        self.core.paced(ch).start_stream("params", self._param_stream())

    def _param_stream(self):
        for name in list(self.params.names):
            if name in self.params:           # the value as it is when it goes out
                msg = self.param_value(name)
                yield msg, self.core.wire_size(msg)

    def on_param_request_read(self, m, ch) -> None:
        ps = self.params
        if m.param_index >= 0:
            if m.param_index >= len(ps):
                return
            name = ps.names[m.param_index]
        else:
            name = param_id(m.param_id)
            if name not in ps:
                return
        self.core.send_paced(self.param_value(name), ch)

    def on_param_set(self, m, ch) -> None:
        ps, core = self.params, self.core
        name = param_id(m.param_id)
        if name not in ps:
            text = f"Param set: unknown {name}"[:50]
            core.broadcast_once(("text", text), lambda: statustext_message(mav.MAV_SEVERITY_WARNING, text))
            return
        why = ps.set(name, float(m.param_value))
        if why is not None:
            text = why[:50]
            core.broadcast_once(("text", text), lambda: statustext_message(mav.MAV_SEVERITY_WARNING, text))
            core.send(self.param_value(name), ch)
            return
        core.broadcast_once(("param", name), lambda: self.param_value(name))
        if name.startswith("SR0_"):
            self.streams.rebuild()
        self.params_changed({name: ps[name]})
