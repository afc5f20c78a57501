"""The MAVLink mission protocol, vehicle side, for MISSION, FENCE and RALLY (pure: no sockets,
no clocks; `now` is sim seconds).

Behaviour follows ArduPilot's GCS_MAVLink MissionItemProtocol:

Upload: MISSION_COUNT -> MISSION_REQUEST_INT for each seq -> MISSION_ITEM_INT (or legacy
MISSION_ITEM, converted, with ArduPilot's one-off warning) -> final MISSION_ACK. An item not
arriving within 1 s is requested again; 8 s without an item ends the upload with
MISSION_ACK OPERATION_CANCELLED and "Mission upload timeout" (Fence/Rally likewise).
A MISSION_COUNT during an upload restarts it when it comes from the same sysid/compid and is
DENIED from anyone else; downloads and partial writes are DENIED while an upload runs.
An item with the wrong seq gets INVALID_SEQUENCE (the upload goes on: the GCS may resend);
from another sender DENIED; an item failing its checks (mission_items) ends the upload with
that result. A count above the list's capacity gets NO_SPACE ("Only N items are supported").
MISSION_WRITE_PARTIAL_LIST rewrites start..end in place (all three lists, as ArduPilot).

Deliberate difference: the new list is stored when the upload completes (all or nothing),
where ArduPilot writes MISSION items to storage as they arrive; a failed or timed-out upload
so leaves the previous list intact, and the runner never sees half a mission.

Download: MISSION_REQUEST_LIST -> MISSION_COUNT -> MISSION_ITEM_INT on MISSION_REQUEST_INT
(MISSION_ITEM on legacy MISSION_REQUEST) exactly as stored. MISSION seq 0 is home: it is
always readable and reports the vehicle's home (NAV_WAYPOINT, GLOBAL frame, absolute
altitude), whatever item 0 an upload carried (ArduPilot reads item 0 from the AHRS home).
A request past the end gets MISSION_COUNT (to tell the GCS the size) and INVALID_SEQUENCE.

MISSION_CLEAR_ALL: ACCEPTED, or ERROR for MISSION while the mission runs (ArduPilot's
AP_Mission::clear), DENIED while another GCS uploads.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.mission_store import FENCE, MISSION, MISSION_TYPES, RALLY, MissionItem, MissionStore
from vehicle.link import mission_items as mi

UPLOAD_TIMEOUT = 8.0        # s without an item: the upload is cancelled (ArduPilot upload_timeout_ms)
REREQUEST_AFTER = 1.0       # s without the requested item: ask again (ArduPilot wp_recv_timeout_ms)

TIMEOUT_TEXT = {MISSION: "Mission upload timeout", FENCE: "Fence upload timeout", RALLY: "Rally upload timeout"}
DONE_TEXT = {MISSION: "Flight plan received", RALLY: "Rally points received"}

ACCEPTED = mav.MAV_MISSION_ACCEPTED


@dataclass
class Out:
    """Something to send: `msg` (a pymavlink message) to `to` (the channel it answers), or a
    STATUSTEXT (`text`, `severity`) for every endpoint when msg is None."""
    msg: object = None
    to: object = None
    text: str = ""
    severity: int = mav.MAV_SEVERITY_INFO


@dataclass
class Upload:
    """One upload in progress (one per mission type)."""
    src: tuple[int, int]            # sysid, compid of the GCS uploading
    chan: object                    # where requests go
    first: int
    last: int                       # seqs first..last are requested
    items: list                     # the whole new list (None where not yet received)
    partial: bool
    next: int = 0                   # the seq requested now
    t_receive: float = 0.0          # last item (or the count) received
    t_request: float = 0.0          # last request sent
    warned_legacy: bool = False


def _text(sev: int, s: str) -> Out:
    return Out(text=s[:50], severity=sev)


@dataclass
class MissionProtocol:
    """The three transfer state machines of one vehicle over its `store`.

    home_item() -> the MissionItem reported as MISSION seq 0 (the vehicle's home);
    running() -> True while the mission is being flown (MISSION_CLEAR_ALL is then refused);
    current_seq() -> the MISSION seq being flown (`current` = 1 in its download);
    stored(mission_type) is called after a list changed (upload, partial write, clear).
    """
    store: MissionStore
    home_item: Callable[[], MissionItem]
    running: Callable[[], bool] = lambda: False
    current_seq: Callable[[], int] = lambda: -1
    stored: Callable[[int], None] = lambda mission_type: None
    max_items: dict = field(default_factory=lambda: dict(mi.MAX_ITEMS))
    uploads: dict = field(default_factory=dict)          # mission_type -> Upload
    warned_request: bool = False

    # ----- entry points ------------------------------------------------------------------
    def handle(self, m, src: tuple[int, int], chan, now: float) -> list[Out]:
        """Handle one mission message from `src` arriving on `chan`; the replies to send."""
        h = getattr(self, "_on_" + m.get_type(), None)
        if h is None:
            return []
        t = int(getattr(m, "mission_type", MISSION) or 0)
        if t not in MISSION_TYPES and not (t == mav.MAV_MISSION_TYPE_ALL and m.get_type() == "MISSION_CLEAR_ALL"):
            return [self._ack(src, chan, mav.MAV_MISSION_UNSUPPORTED, t)]
        return h(m, t, src, chan, now)

    def update(self, now: float) -> list[Out]:
        """Re-request a missing item, or cancel an upload that stalled (call at the link rate)."""
        out: list[Out] = []
        for t, up in list(self.uploads.items()):
            if now - up.t_receive > UPLOAD_TIMEOUT:
                del self.uploads[t]
                out.append(_text(mav.MAV_SEVERITY_WARNING, TIMEOUT_TEXT[t]))
                out.append(self._ack(up.src, up.chan, mav.MAV_MISSION_OPERATION_CANCELLED, t))
            elif now - up.t_request > REREQUEST_AFTER:
                out.append(self._request(up, t, now))
        return out

    def receiving(self, mission_type: int) -> bool:
        return mission_type in self.uploads

    # ----- replies -----------------------------------------------------------------------
    @staticmethod
    def _ack(src, chan, result: int, t: int) -> Out:
        return Out(mav.MAVLink_mission_ack_message(src[0], src[1], result, t), chan)

    def _count(self, src, chan, t: int) -> Out:
        return Out(mav.MAVLink_mission_count_message(src[0], src[1], self.store.count(t), t), chan)

    @staticmethod
    def _request(up: Upload, t: int, now: float) -> Out:
        up.t_request = now
        return Out(mav.MAVLink_mission_request_int_message(up.src[0], up.src[1], up.next, t), up.chan)

    # ----- upload ------------------------------------------------------------------------
    def _cancel_upload(self, t: int, src, chan) -> Out | None:
        """None if no upload runs or it was ours to restart; else the DENIED ack."""
        up = self.uploads.get(t)
        if up is None:
            return None
        if up.src != src:
            return self._ack(src, chan, mav.MAV_MISSION_DENIED, t)
        del self.uploads[t]
        return None

    def _on_MISSION_COUNT(self, m, t, src, chan, now) -> list[Out]:
        denied = self._cancel_upload(t, src, chan)
        if denied is not None:
            return [denied]
        count = int(m.count)
        if count > self.max_items[t]:
            return [self._ack(src, chan, mav.MAV_MISSION_NO_SPACE, t),
                    _text(mav.MAV_SEVERITY_WARNING, f"Only {self.max_items[t]} items are supported")]
        up = Upload(src, chan, 0, count - 1, [None] * count, partial=False, t_receive=now)
        if count == 0:
            return self._complete(up, t)
        self.uploads[t] = up
        return [self._request(up, t, now)]

    def _on_MISSION_WRITE_PARTIAL_LIST(self, m, t, src, chan, now) -> list[Out]:
        if t in self.uploads:
            return [self._ack(src, chan, mav.MAV_MISSION_DENIED, t)]
        n = self.store.count(t)
        start, end = int(m.start_index), int(m.end_index)
        if start < 0 or start > n or end > n or end < start or end >= self.max_items[t]:
            return [_text(mav.MAV_SEVERITY_WARNING, "Flight plan update rejected"),
                    self._ack(src, chan, mav.MAV_MISSION_ERROR, t)]
        items = list(self.store.items(t)) + ([None] if end == n else [])
        up = Upload(src, chan, start, end, items, partial=True, next=start, t_receive=now)
        self.uploads[t] = up
        return [self._request(up, t, now)]

    def _on_MISSION_ITEM(self, m, t, src, chan, now) -> list[Out]:
        up = self.uploads.get(t)
        if up is None:
            return [self._ack(src, chan, mav.MAV_MISSION_ERROR, t)]
        result, item = mi.from_legacy(m, t)
        if item is None:
            return [self._ack(src, chan, result, t)]
        out = []
        if not up.warned_legacy:
            up.warned_legacy = True
            out.append(_text(mav.MAV_SEVERITY_WARNING, "got MISSION_ITEM; GCS should send MISSION_ITEM_INT"))
        return out + self._item(up, item, t, src, chan, now)

    def _on_MISSION_ITEM_INT(self, m, t, src, chan, now) -> list[Out]:
        up = self.uploads.get(t)
        if up is None:
            return [self._ack(src, chan, mav.MAV_MISSION_ERROR, t)]
        return self._item(up, mi.from_int(m, t), t, src, chan, now)

    def _item(self, up: Upload, item: MissionItem, t, src, chan, now) -> list[Out]:
        if item.seq != up.next:
            return [self._ack(src, chan, mav.MAV_MISSION_INVALID_SEQUENCE, t)]
        if src != up.src:
            return [self._ack(src, chan, mav.MAV_MISSION_DENIED, t)]
        result = mi.CHECKS[t](item)
        if result == ACCEPTED and t == MISSION and item.command == mav.MAV_CMD_DO_JUMP:
            # ArduPilot: the jump target must be an item of the list being uploaded, never home
            target = item.param1
            if target < 1 or target >= max(len(up.items), up.last + 1):
                result = mav.MAV_MISSION_ERROR
        if result != ACCEPTED:
            del self.uploads[t]
            return [self._ack(src, up.chan, result, t)]
        up.items[item.seq] = item
        up.t_receive = now
        up.next += 1
        if up.next > up.last:
            del self.uploads[t]
            return self._complete(up, t)
        return [self._request(up, t, now)]

    def _complete(self, up: Upload, t: int) -> list[Out]:
        out: list[Out] = []
        items = [it for it in up.items if it is not None]
        if t == FENCE:
            why = mi.validate_fence(items)
            if why is not None:
                sev = mav.MAV_SEVERITY_INFO if why == "Incorrect item count" else mav.MAV_SEVERITY_WARNING
                return [self._ack(up.src, up.chan, mav.MAV_MISSION_ERROR, t), _text(sev, why),
                        _text(mav.MAV_SEVERITY_WARNING, "Fence validation failed")]
        if up.partial and up.last < self.store.count(t):
            self.store.write_partial(t, up.first, items[up.first:up.last + 1])
        else:
            self.store.replace_all(t, items)
        self.stored(t)
        # the ACK first: ArduPilot queues its STATUSTEXT, which goes out after the ACK
        out.append(self._ack(up.src, up.chan, ACCEPTED, t))
        if t in DONE_TEXT:
            out.append(_text(mav.MAV_SEVERITY_INFO, DONE_TEXT[t]))
        return out

    # ----- download ----------------------------------------------------------------------
    def _on_MISSION_REQUEST_LIST(self, m, t, src, chan, now) -> list[Out]:
        if t in self.uploads:
            return [self._ack(src, chan, mav.MAV_MISSION_DENIED, t)]
        self.warned_request = False          # the legacy-request warning: once per transfer
        return [self._count(src, chan, t)]

    def _get(self, seq: int, t: int) -> MissionItem | None:
        if t == MISSION and seq == 0:
            return self.home_item()
        return self.store.get(seq, t)

    def _on_MISSION_REQUEST_INT(self, m, t, src, chan, now) -> list[Out]:
        if t in self.uploads:
            return [self._ack(src, chan, mav.MAV_MISSION_DENIED, t)]
        it = self._get(int(m.seq), t)
        if it is None:
            return [self._count(src, chan, t), self._ack(src, chan, mav.MAV_MISSION_INVALID_SEQUENCE, t)]
        cur = 1 if (t == MISSION and it.seq == self.current_seq()) else 0
        return [Out(mav.MAVLink_mission_item_int_message(
            src[0], src[1], it.seq, it.frame, it.command, cur, it.autocontinue, it.param1, it.param2,
            it.param3, it.param4, it.x, it.y, it.z, t), chan)]

    def _on_MISSION_REQUEST(self, m, t, src, chan, now) -> list[Out]:
        if t in self.uploads:
            return [self._ack(src, chan, mav.MAV_MISSION_DENIED, t)]
        it = self._get(int(m.seq), t)
        if it is None:
            return [self._count(src, chan, t), self._ack(src, chan, mav.MAV_MISSION_INVALID_SEQUENCE, t)]
        x, y = mi.legacy_xy(it)
        cur = 1 if (t == MISSION and it.seq == self.current_seq()) else 0
        out = [Out(mav.MAVLink_mission_item_message(
            src[0], src[1], it.seq, it.frame, it.command, cur, it.autocontinue, it.param1, it.param2,
            it.param3, it.param4, x, y, it.z, t), chan)]
        if not self.warned_request:
            self.warned_request = True
            out.append(_text(mav.MAV_SEVERITY_WARNING, "got MISSION_REQUEST; use MISSION_REQUEST_INT!"))
        return out

    def _on_MISSION_ACK(self, m, t, src, chan, now) -> list[Out]:
        return []      # the GCS's end of a download: nothing to release

    # ----- clear -------------------------------------------------------------------------
    def _on_MISSION_CLEAR_ALL(self, m, t, src, chan, now) -> list[Out]:
        types = MISSION_TYPES if t == mav.MAV_MISSION_TYPE_ALL else (t,)
        for k in types:
            denied = self._cancel_upload(k, src, chan)
            if denied is not None:
                return [self._ack(src, chan, mav.MAV_MISSION_DENIED, t)]
        if MISSION in types and self.running():
            return [self._ack(src, chan, mav.MAV_MISSION_ERROR, t)]
        for k in types:
            self.store.clear(k)
            self.stored(k)
        return [self._ack(src, chan, ACCEPTED, t)]


def home_item(lat: float, lon: float, alt_amsl: float) -> MissionItem:
    """MISSION seq 0 as ArduPilot reports it: NAV_WAYPOINT at home, GLOBAL frame (alt AMSL, m)."""
    def e7(v: float) -> int:
        return int(round(v * 1e7)) if math.isfinite(v) else 0
    return MissionItem(seq=0, frame=mav.MAV_FRAME_GLOBAL, command=mav.MAV_CMD_NAV_WAYPOINT,
                       x=e7(lat), y=e7(lon), z=float(alt_amsl) if math.isfinite(alt_amsl) else 0.0)
