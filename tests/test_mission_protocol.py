"""The pure mission protocol state machine (vehicle/link/mission_protocol.py): every ACK error,
re-requests and timeouts in sim time, partial writes, concurrent uploads, downloads as stored,
clear, legacy messages, fence validation. No sockets: messages in, messages out."""
from __future__ import annotations

import math

import pytest
from hypothesis import given, strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.mission_store import FENCE, MISSION, RALLY, MissionStore
from vehicle.link import mission_items as mi
from vehicle.link.mission_protocol import MissionProtocol, home_item

GCS = (255, 190)
OTHER = (254, 1)
HOME = (-35.363261, 149.165230, 584.0)
REL = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
WP = mav.MAV_CMD_NAV_WAYPOINT


class Chan:
    def __init__(self, name):
        self.name = name

    def __repr__(self):
        return self.name


A, B = Chan("A"), Chan("B")


def make(running=False):
    store = MissionStore()
    stored = []
    p = MissionProtocol(store, home_item=lambda: home_item(*HOME), running=lambda: running,
                        stored=stored.append)
    return p, store, stored


def wp(seq, lat=-35.36, lon=149.16, alt=20.0, t=MISSION, frame=REL, cmd=WP, p=(0, 0, 0, 0)):
    return mav.MAVLink_mission_item_int_message(1, 1, seq, frame, cmd, 0, 1, *p, int(round(lat * 1e7)),
                                                int(round(lon * 1e7)), alt, t)


def count(n, t=MISSION):
    return mav.MAVLink_mission_count_message(1, 1, n, t)


def msgs(outs, kind):
    return [o.msg for o in outs if o.msg is not None and o.msg.get_type() == kind]


def texts(outs):
    return [o.text for o in outs if o.msg is None]


def acks(outs):
    return [a.type for a in msgs(outs, "MISSION_ACK")]


def upload(p, items, t=MISSION, src=GCS, chan=A, now=0.0):
    """Run a whole upload; returns every output."""
    out = p.handle(count(len(items), t), src, chan, now)
    for it in items:
        out += p.handle(it, src, chan, now)
    return out


def mission6():
    return [wp(0, alt=0, frame=mav.MAV_FRAME_GLOBAL)] + [wp(i, lat=-35.36 + 1e-4 * i) for i in range(1, 6)]


# ----- upload -----------------------------------------------------------------------------
def test_upload_requests_each_item_with_request_int_and_acks_accepted():
    p, store, stored = make()
    out = p.handle(count(3), GCS, A, 0.0)
    reqs = msgs(out, "MISSION_REQUEST_INT")
    assert [(r.seq, r.target_system, r.target_component, r.mission_type) for r in reqs] == [(0, 255, 190, 0)]
    assert out[0].to is A
    out = p.handle(wp(0), GCS, A, 0.1)
    assert [r.seq for r in msgs(out, "MISSION_REQUEST_INT")] == [1]
    p.handle(wp(1), GCS, A, 0.2)
    out = p.handle(wp(2, lat=-35.2), GCS, A, 0.3)
    assert acks(out) == [mav.MAV_MISSION_ACCEPTED]
    assert "Flight plan received" in texts(out)
    assert store.count(MISSION) == 3 and store.get(2).x == -352000000
    assert stored == [MISSION]


def test_items_stored_exactly_as_sent_and_downloaded_back():
    p, store, _ = make()
    items = mission6()
    items[3] = wp(3, lat=-35.3612345, lon=149.1654321, alt=33.25, frame=mav.MAV_FRAME_GLOBAL_INT, p=(5, 2, 0, 90))
    upload(p, items)
    assert acks(p.handle(mav.MAVLink_mission_request_list_message(1, 1, 0), GCS, A, 1)) == []
    cnt = msgs(p.handle(mav.MAVLink_mission_request_list_message(1, 1, 0), GCS, A, 1), "MISSION_COUNT")
    assert cnt[0].count == 6
    for i in range(1, 6):
        got = msgs(p.handle(mav.MAVLink_mission_request_int_message(1, 1, i, 0), GCS, A, 1), "MISSION_ITEM_INT")[0]
        sent = items[i]
        assert (got.seq, got.frame, got.command, got.x, got.y, got.z, got.param1, got.param2, got.param4) == \
            (sent.seq, sent.frame, sent.command, sent.x, sent.y, sent.z, sent.param1, sent.param2, sent.param4)
        assert (got.target_system, got.target_component) == GCS


def test_item_0_downloads_as_home_whatever_was_uploaded():
    p, _, _ = make()
    items = mission6()
    items[0] = wp(0, lat=10.0, lon=10.0, alt=5.0)
    upload(p, items)
    got = msgs(p.handle(mav.MAVLink_mission_request_int_message(1, 1, 0, 0), GCS, A, 1), "MISSION_ITEM_INT")[0]
    assert (got.command, got.frame) == (WP, mav.MAV_FRAME_GLOBAL)
    assert (got.x, got.y, got.z) == (-353632610, 1491652300, pytest.approx(584.0))


def test_home_readable_with_empty_mission_but_seq_1_is_not():
    p, _, _ = make()
    assert msgs(p.handle(mav.MAVLink_mission_request_int_message(1, 1, 0, 0), GCS, A, 0), "MISSION_ITEM_INT")
    out = p.handle(mav.MAVLink_mission_request_int_message(1, 1, 1, 0), GCS, A, 0)
    assert msgs(out, "MISSION_COUNT")[0].count == 0
    assert acks(out) == [mav.MAV_MISSION_INVALID_SEQUENCE]


def test_legacy_item_accepted_with_one_warning_and_legacy_request_answered_with_mission_item():
    p, store, _ = make()
    out = p.handle(count(2), GCS, A, 0)
    out += p.handle(mav.MAVLink_mission_item_message(1, 1, 0, 0, WP, 0, 1, 0, 0, 0, 0, -35.0, 149.0, 0, 0), GCS, A, 0)
    out += p.handle(mav.MAVLink_mission_item_message(1, 1, 1, REL, WP, 0, 1, 0, 0, 0, 0, -35.5, 149.25, 10, 0), GCS, A, 0)
    assert acks(out) == [mav.MAV_MISSION_ACCEPTED]
    assert texts(out).count("got MISSION_ITEM; GCS should send MISSION_ITEM_INT") == 1
    assert (store.get(1).x, store.get(1).y) == (-355000000, 1492500000)
    out = p.handle(mav.MAVLink_mission_request_message(1, 1, 1, 0), GCS, A, 1)
    item = msgs(out, "MISSION_ITEM")[0]
    assert (item.x, item.y, item.z) == (pytest.approx(-35.5), pytest.approx(149.25), 10)
    assert "got MISSION_REQUEST; use MISSION_REQUEST_INT!" in texts(out)
    assert texts(p.handle(mav.MAVLink_mission_request_message(1, 1, 0, 0), GCS, A, 1)) == []   # once per transfer
    p.handle(mav.MAVLink_mission_request_list_message(1, 1, 0), GCS, A, 2)
    assert texts(p.handle(mav.MAVLink_mission_request_message(1, 1, 0, 0), GCS, A, 2)) == \
        ["got MISSION_REQUEST; use MISSION_REQUEST_INT!"]


def test_count_zero_clears_and_acks_at_once():
    p, store, _ = make()
    upload(p, mission6())
    out = p.handle(count(0), GCS, A, 1)
    assert acks(out) == [mav.MAV_MISSION_ACCEPTED] and store.count() == 0


# ----- errors -----------------------------------------------------------------------------
def test_out_of_sequence_item_refused_and_upload_goes_on():
    p, store, _ = make()
    p.handle(count(3), GCS, A, 0)
    out = p.handle(wp(1), GCS, A, 0)
    assert acks(out) == [mav.MAV_MISSION_INVALID_SEQUENCE]
    assert p.receiving(MISSION)
    out = upload_rest(p, [wp(0), wp(1), wp(2)])
    assert acks(out) == [mav.MAV_MISSION_ACCEPTED] and store.count() == 3


def upload_rest(p, items):
    out = []
    for it in items:
        out += p.handle(it, GCS, A, 0)
    return out


@pytest.mark.parametrize("param,expected", [
    ((math.nan, 0, 0, 0), mav.MAV_MISSION_INVALID_PARAM1),
    ((0, math.nan, 0, 0), mav.MAV_MISSION_INVALID_PARAM2),
    ((0, 0, math.inf, 0), mav.MAV_MISSION_INVALID_PARAM3),
    ((0, 0, 0, math.inf), mav.MAV_MISSION_INVALID_PARAM4),
])
def test_nan_or_inf_param_refused_with_its_number(param, expected):
    p, store, _ = make()
    upload(p, mission6())
    before = list(store.items())
    out = upload(p, [wp(0), wp(1, p=param)])
    assert acks(out) == [expected]
    assert not p.receiving(MISSION)
    assert store.items() == before          # the old mission stands


def test_nan_yaw_of_a_waypoint_is_allowed_as_in_ardupilot():
    p, _, _ = make()
    assert acks(upload(p, [wp(0), wp(1, p=(0, 0, 0, math.nan))])) == [mav.MAV_MISSION_ACCEPTED]


@pytest.mark.parametrize("item,expected", [
    (wp(1, lat=91.0), mav.MAV_MISSION_INVALID_PARAM5_X),
    (wp(1, lon=-181.0), mav.MAV_MISSION_INVALID_PARAM6_Y),
    (wp(1, alt=math.nan), mav.MAV_MISSION_INVALID_PARAM7),
    (wp(1, alt=90000.0), mav.MAV_MISSION_INVALID_PARAM7),
    (wp(1, frame=mav.MAV_FRAME_LOCAL_NED), mav.MAV_MISSION_UNSUPPORTED_FRAME),
    (wp(1, frame=mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT), mav.MAV_MISSION_UNSUPPORTED_FRAME),
    (wp(1, frame=mav.MAV_FRAME_BODY_FRD), mav.MAV_MISSION_UNSUPPORTED_FRAME),
    (wp(1, cmd=mav.MAV_CMD_NAV_FOLLOW), mav.MAV_MISSION_UNSUPPORTED),
    (wp(1, cmd=1), mav.MAV_MISSION_INVALID),
    (wp(1, cmd=mav.MAV_CMD_DO_JUMP, p=(0, 2, 0, 0)), mav.MAV_MISSION_ERROR),
    (wp(1, cmd=mav.MAV_CMD_DO_JUMP, p=(7, 2, 0, 0)), mav.MAV_MISSION_ERROR),
])
def test_bad_items_refused_with_ardupilots_result(item, expected):
    p, _, _ = make()
    assert acks(upload(p, [wp(0), item, wp(2)][:2])) == [expected]


def test_do_command_frame_is_not_checked_and_jump_to_a_later_item_is_fine():
    p, _, _ = make()
    items = [wp(0), wp(1), wp(2, cmd=mav.MAV_CMD_DO_JUMP, frame=mav.MAV_FRAME_LOCAL_NED, p=(3, 2, 0, 0)), wp(3)]
    assert acks(upload(p, items)) == [mav.MAV_MISSION_ACCEPTED]


def test_legacy_item_with_bad_latitude_refused_but_upload_goes_on():
    p, _, _ = make()
    p.handle(count(1), GCS, A, 0)
    out = p.handle(mav.MAVLink_mission_item_message(1, 1, 0, 0, WP, 0, 1, 0, 0, 0, 0, math.nan, 149.0, 0, 0), GCS, A, 0)
    assert acks(out) == [mav.MAV_MISSION_INVALID_PARAM5_X]
    assert p.receiving(MISSION)


def test_legacy_raw_xy_that_does_not_fit_int32_refused():
    p, _, _ = make()
    p.handle(count(2), GCS, A, 0)
    p.handle(wp(0), GCS, A, 0)
    cam = mav.MAV_CMD_DO_DIGICAM_CONTROL          # x / y are raw values, not degrees
    out = p.handle(mav.MAVLink_mission_item_message(1, 1, 1, 0, cam, 0, 1, 0, 0, 0, 0, 3e9, 1, 0, 0), GCS, A, 0)
    assert acks(out) == [mav.MAV_MISSION_INVALID_PARAM5_X]
    out = p.handle(mav.MAVLink_mission_item_message(1, 1, 1, 0, cam, 0, 1, 0, 0, 0, 0, 1, 2, 0, 0), GCS, A, 0)
    assert acks(out) == [mav.MAV_MISSION_ACCEPTED]
    got = msgs(p.handle(mav.MAVLink_mission_request_message(1, 1, 1, 0), GCS, A, 0), "MISSION_ITEM")[0]
    assert (got.x, got.y) == (1.0, 2.0)


def test_too_many_items_no_space_with_ardupilots_text():
    p, _, _ = make()
    out = p.handle(count(725), GCS, A, 0)
    assert acks(out) == [mav.MAV_MISSION_NO_SPACE]
    assert texts(out) == ["Only 724 items are supported"]
    assert not p.receiving(MISSION)


def test_item_without_upload_is_an_error_and_unknown_type_unsupported():
    p, _, _ = make()
    assert acks(p.handle(wp(0), GCS, A, 0)) == [mav.MAV_MISSION_ERROR]
    assert acks(p.handle(count(2, t=7), GCS, A, 0)) == [mav.MAV_MISSION_UNSUPPORTED]


# ----- timing (sim seconds) ---------------------------------------------------------------
def test_missing_item_rerequested_every_second_then_cancelled_after_8s():
    p, store, _ = make()
    upload(p, mission6())
    p.handle(count(3), GCS, A, 10.0)
    p.handle(wp(0), GCS, A, 10.2)
    assert p.update(11.1) == []                       # 0.9 s since the request: wait
    out = p.update(11.3)
    assert [(r.seq, o.to) for o in out for r in [o.msg]] == [(1, A)]
    assert msgs(out, "MISSION_REQUEST_INT")[0].seq == 1
    rerequests = sum(len(msgs(p.update(11.3 + 0.1 * k), "MISSION_REQUEST_INT")) for k in range(1, 68))
    assert rerequests == 6                            # 12.3 .. 17.9, one a second
    out = p.update(18.3)                              # 8.1 s since the last item
    assert acks(out) == [mav.MAV_MISSION_OPERATION_CANCELLED]
    assert texts(out) == ["Mission upload timeout"]
    assert not p.receiving(MISSION) and store.count() == 6
    assert p.update(30.0) == []


def test_late_item_after_rerequest_completes_the_upload():
    p, store, _ = make()
    p.handle(count(2), GCS, A, 0.0)
    p.handle(wp(0), GCS, A, 0.1)
    assert msgs(p.update(1.2), "MISSION_REQUEST_INT")[0].seq == 1
    assert acks(p.handle(wp(1), GCS, A, 1.3)) == [mav.MAV_MISSION_ACCEPTED]
    assert store.count() == 2


def test_fence_and_rally_timeouts_say_so():
    p, _, _ = make()
    p.handle(count(3, t=FENCE), GCS, A, 0)
    p.handle(count(1, t=RALLY), GCS, A, 0)
    out = p.update(8.5)
    assert sorted(texts(out)) == ["Fence upload timeout", "Rally upload timeout"]
    assert [a.mission_type for a in msgs(out, "MISSION_ACK")] == [FENCE, RALLY]


# ----- concurrency ------------------------------------------------------------------------
def test_count_from_another_gcs_during_upload_denied_and_first_upload_continues():
    p, store, _ = make()
    p.handle(count(2), GCS, A, 0)
    out = p.handle(count(5), OTHER, B, 0)
    assert acks(out) == [mav.MAV_MISSION_DENIED] and out[0].to is B
    assert msgs(out, "MISSION_ACK")[0].target_system == 254
    assert acks(p.handle(wp(0), OTHER, B, 0)) == [mav.MAV_MISSION_DENIED]
    assert acks(p.handle(mav.MAVLink_mission_request_list_message(1, 1, 0), OTHER, B, 0)) == [mav.MAV_MISSION_DENIED]
    assert acks(upload_rest(p, [wp(0), wp(1)])) == [mav.MAV_MISSION_ACCEPTED]
    assert store.count() == 2


def test_count_again_from_the_same_gcs_restarts_the_upload():
    p, store, _ = make()
    p.handle(count(5), GCS, A, 0)
    p.handle(wp(0), GCS, A, 0)
    out = p.handle(count(2), GCS, A, 0)
    assert msgs(out, "MISSION_REQUEST_INT")[0].seq == 0
    assert acks(upload_rest(p, [wp(0), wp(1)])) == [mav.MAV_MISSION_ACCEPTED] and store.count() == 2


def test_other_types_upload_in_parallel():
    p, store, _ = make()
    p.handle(count(2), GCS, A, 0)
    out = upload(p, [rally(0)], t=RALLY, src=OTHER, chan=B)
    assert acks(out) == [mav.MAV_MISSION_ACCEPTED] and store.count(RALLY) == 1


# ----- partial write ----------------------------------------------------------------------
def test_partial_write_replaces_in_place():
    p, store, stored = make()
    upload(p, mission6())
    out = p.handle(mav.MAVLink_mission_write_partial_list_message(1, 1, 2, 3, 0), GCS, A, 1)
    assert msgs(out, "MISSION_REQUEST_INT")[0].seq == 2
    assert acks(p.handle(wp(3), GCS, A, 1)) == [mav.MAV_MISSION_INVALID_SEQUENCE]
    p.handle(wp(2, lat=-35.0), GCS, A, 1)
    out = p.handle(wp(3, lat=-35.1), GCS, A, 1)
    assert acks(out) == [mav.MAV_MISSION_ACCEPTED]
    assert store.count() == 6 and store.get(2).x == -350000000 and store.get(3).x == -351000000
    assert store.get(4).x == mission6()[4].x


def test_partial_write_may_append_one_and_rejects_bad_ranges():
    p, store, _ = make()
    upload(p, mission6())
    p.handle(mav.MAVLink_mission_write_partial_list_message(1, 1, 6, 6, 0), GCS, A, 1)
    assert acks(p.handle(wp(6), GCS, A, 1)) == [mav.MAV_MISSION_ACCEPTED] and store.count() == 7
    for start, end in ((8, 9), (3, 2), (2, 9)):
        out = p.handle(mav.MAVLink_mission_write_partial_list_message(1, 1, start, end, 0), GCS, A, 1)
        assert acks(out) == [mav.MAV_MISSION_ERROR] and texts(out) == ["Flight plan update rejected"]


def test_partial_write_denied_during_upload():
    p, _, _ = make()
    p.handle(count(3), GCS, A, 0)
    out = p.handle(mav.MAVLink_mission_write_partial_list_message(1, 1, 0, 0, 0), GCS, A, 0)
    assert acks(out) == [mav.MAV_MISSION_DENIED]


# ----- clear ------------------------------------------------------------------------------
def test_clear_all_accepted_and_refused_while_flying():
    p, store, stored = make()
    upload(p, mission6())
    assert acks(p.handle(mav.MAVLink_mission_clear_all_message(1, 1, 0), GCS, A, 1)) == [mav.MAV_MISSION_ACCEPTED]
    assert store.count() == 0 and stored[-1] == MISSION
    p2, store2, _ = make(running=True)
    upload(p2, mission6())
    assert acks(p2.handle(mav.MAVLink_mission_clear_all_message(1, 1, 0), GCS, A, 1)) == [mav.MAV_MISSION_ERROR]
    assert store2.count() == 6


def test_clear_during_another_gcs_upload_denied():
    p, _, _ = make()
    p.handle(count(3), GCS, A, 0)
    assert acks(p.handle(mav.MAVLink_mission_clear_all_message(1, 1, 0), OTHER, B, 0)) == [mav.MAV_MISSION_DENIED]
    assert p.receiving(MISSION)


def test_clear_all_types():
    p, store, _ = make()
    upload(p, mission6())
    upload(p, [rally(0)], t=RALLY)
    out = p.handle(mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_ALL), GCS, A, 1)
    assert acks(out) == [mav.MAV_MISSION_ACCEPTED]
    assert store.count(MISSION) == store.count(RALLY) == 0


# ----- fence and rally --------------------------------------------------------------------
def fence(seq, cmd, p1, lat=-35.36, lon=149.16):
    return wp(seq, lat=lat, lon=lon, alt=0, t=FENCE, frame=mav.MAV_FRAME_GLOBAL_INT, cmd=cmd, p=(p1, 0, 0, 0))


def rally(seq, lat=-35.362, lon=149.163, alt=30.0, frame=mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT):
    return wp(seq, lat=lat, lon=lon, alt=alt, t=RALLY, frame=frame, cmd=mav.MAV_CMD_NAV_RALLY_POINT)


def square(n=4):
    pts = [(-35.36, 149.16), (-35.36, 149.17), (-35.37, 149.17), (-35.37, 149.16)][:n]
    return [fence(i, mi.POLY_INCLUSION, n, *pt) for i, pt in enumerate(pts)]


def test_fence_polygon_and_circle_upload_and_download():
    p, store, _ = make()
    items = square() + [fence(4, mi.CIRCLE_EXCLUSION, 15.0, -35.365, 149.165), fence(5, mi.RETURN_POINT, 0)]
    out = upload(p, items, t=FENCE)
    assert acks(out) == [mav.MAV_MISSION_ACCEPTED] and texts(out) == []
    assert msgs(p.handle(mav.MAVLink_mission_request_list_message(1, 1, FENCE), GCS, A, 1), "MISSION_COUNT")[0].count == 6
    got = msgs(p.handle(mav.MAVLink_mission_request_int_message(1, 1, 4, FENCE), GCS, A, 1), "MISSION_ITEM_INT")[0]
    assert (got.command, got.param1, got.mission_type, got.x) == (mi.CIRCLE_EXCLUSION, 15.0, FENCE, -353650000)
    out = p.handle(mav.MAVLink_mission_request_int_message(1, 1, 6, FENCE), GCS, A, 1)
    assert acks(out) == [mav.MAV_MISSION_INVALID_SEQUENCE]


@pytest.mark.parametrize("items,why", [
    (square(4)[:3], "Incorrect item count"),
    ([fence(0, mi.POLY_INCLUSION, 2), fence(1, mi.POLY_INCLUSION, 2)], "Invalid vertex count (2)"),
    ([fence(0, mi.CIRCLE_INCLUSION, 0.0)], "Non-positive circle radius"),
    ([fence(0, mi.RETURN_POINT, 0), fence(1, mi.RETURN_POINT, 0)], "Multiple return points"),
])
def test_invalid_fence_refused_with_ardupilots_text(items, why):
    p, store, _ = make()
    out = upload(p, items, t=FENCE)
    assert acks(out) == [mav.MAV_MISSION_ERROR]
    assert texts(out) == [why, "Fence validation failed"]
    assert store.count(FENCE) == 0


def test_fence_item_checks():
    p, _, _ = make()
    out = upload(p, [wp(0, t=FENCE, frame=mav.MAV_FRAME_LOCAL_NED, cmd=mi.POLY_INCLUSION)], t=FENCE)
    assert acks(out) == [mav.MAV_MISSION_UNSUPPORTED_FRAME]
    out = upload(p, [wp(0, t=FENCE, frame=mav.MAV_FRAME_GLOBAL_INT, cmd=WP)], t=FENCE)
    assert acks(out) == [mav.MAV_MISSION_UNSUPPORTED]


def test_rally_upload_and_checks():
    p, store, _ = make()
    out = upload(p, [rally(0), rally(1, alt=45.0)], t=RALLY)
    assert acks(out) == [mav.MAV_MISSION_ACCEPTED] and texts(out) == ["Rally points received"]
    assert store.get(1, RALLY).z == 45.0
    assert acks(upload(p, [rally(0, frame=mav.MAV_FRAME_GLOBAL_INT)], t=RALLY)) == [mav.MAV_MISSION_UNSUPPORTED_FRAME]
    assert acks(upload(p, [rally(0, alt=40000.0)], t=RALLY)) == [mav.MAV_MISSION_INVALID_PARAM7]
    assert acks(upload(p, [rally(0, lat=95.0)], t=RALLY)) == [mav.MAV_MISSION_INVALID_PARAM5_X]
    assert store.count(RALLY) == 2


# ----- properties -------------------------------------------------------------------------
@given(st.floats(allow_nan=True, allow_infinity=True, width=32), st.floats(allow_nan=True, allow_infinity=True, width=32))
def test_legacy_item_accepted_iff_lat_lon_in_range_and_stored_to_1e7(lat, lon):
    m = mav.MAVLink_mission_item_message(1, 1, 1, REL, WP, 0, 1, 0, 0, 0, 0, lat, lon, 10.0, 0)
    result, item = mi.from_legacy(m, MISSION)
    in_range = math.isfinite(lat) and math.isfinite(lon) and abs(lat) <= 90 and abs(lon) <= 180
    assert (result == mav.MAV_MISSION_ACCEPTED) == in_range
    if not in_range:
        assert result == (mav.MAV_MISSION_INVALID_PARAM5_X if not (math.isfinite(lat) and abs(lat) <= 90)
                          else mav.MAV_MISSION_INVALID_PARAM6_Y)
    else:
        assert abs(item.x * 1e-7 - lat) <= 0.5e-7 + 1e-12 and abs(item.y * 1e-7 - lon) <= 0.5e-7 + 1e-12
        assert mi.check_mission_item(item) == mav.MAV_MISSION_ACCEPTED


@given(st.lists(st.integers(min_value=0, max_value=15), min_size=1, max_size=12))
def test_any_order_of_items_stores_exactly_the_requested_sequence(seqs):
    """Whatever a GCS sends, the store only ever holds items 0..n-1 in order, each once."""
    n = 4
    p, store, _ = make()
    p.handle(count(n), GCS, A, 0)
    for s in seqs:
        p.handle(wp(s, lat=-35 + s * 1e-3), GCS, A, 0)
    if p.receiving(MISSION):
        assert store.count() == 0
    else:
        assert [it.seq for it in store.items()] == list(range(n))
        assert [it.x for it in store.items()] == [int(round((-35 + s * 1e-3) * 1e7)) for s in range(n)]


_f = st.floats(allow_nan=True, allow_infinity=True, width=32)
_msg = st.one_of(
    st.builds(lambda n, t: mav.MAVLink_mission_count_message(1, 1, n, t), st.integers(0, 800), st.integers(0, 3)),
    st.builds(lambda s, fr, c, p, x, y, z, t: mav.MAVLink_mission_item_int_message(1, 1, s, fr, c, 0, 1, *p, x, y, z, t),
              st.integers(0, 8), st.sampled_from([0, 1, 3, 5, 6, 10, 12]), st.sampled_from([0, 16, 22, 177, 5001, 5004, 5100, 203]),
              st.tuples(_f, _f, _f, _f), st.integers(-2**31, 2**31 - 1), st.integers(-2**31, 2**31 - 1), _f, st.integers(0, 2)),
    st.builds(lambda s, c, x, y, t: mav.MAVLink_mission_item_message(1, 1, s, 3, c, 0, 1, 0, 0, 0, 0, x, y, 5, t),
              st.integers(0, 8), st.sampled_from([16, 203, 5100]), _f, _f, st.integers(0, 2)),
    st.builds(lambda s, t: mav.MAVLink_mission_request_int_message(1, 1, s, t), st.integers(0, 9), st.integers(0, 2)),
    st.builds(lambda s, t: mav.MAVLink_mission_request_message(1, 1, s, t), st.integers(0, 9), st.integers(0, 2)),
    st.builds(lambda a, b, t: mav.MAVLink_mission_write_partial_list_message(1, 1, a, b, t),
              st.integers(-2, 9), st.integers(-2, 9), st.integers(0, 2)),
    st.builds(lambda t: mav.MAVLink_mission_clear_all_message(1, 1, t), st.sampled_from([0, 1, 2, 255])),
    st.builds(lambda t: mav.MAVLink_mission_request_list_message(1, 1, t), st.integers(0, 2)),
)


@given(st.lists(st.tuples(_msg, st.sampled_from([GCS, OTHER]), st.floats(0, 3)), max_size=40))
def test_any_message_sequence_never_raises_and_every_reply_packs(steps):
    """Whatever arrives, in whatever order and timing: no exception, every reply encodes to a
    MAVLink 2 frame, and the stored lists keep seqs 0..n-1."""
    p, store, _ = make()
    enc = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    now = 0.0
    for m, src, dt in steps:
        now += dt
        for o in p.handle(m, src, A, now) + p.update(now):
            if o.msg is not None:
                o.msg.pack(enc)
            else:
                assert 0 < len(o.text) <= 50
    for t in (MISSION, FENCE, RALLY):
        assert [it.seq for it in store.items(t)] == list(range(store.count(t)))
