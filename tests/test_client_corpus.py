"""The client corpus (examples/clients, tools/client_corpus*): the manifest is whole and every
check in it is one the checker knows; the checks mean what they say; and, slow, the runner
runs a program against a fresh world and tells a behaving run from a differing one."""
from __future__ import annotations

import dataclasses

import pytest

from tools.client_corpus import MANIFEST
from tools.client_corpus_checks import Record, check_failure, failures, last_exception
from tools.client_corpus_plan import DEFAULT_ARGS, KINDS, load


def test_manifest_is_whole_and_every_check_is_known():
    corpus = load(MANIFEST)
    assert len(corpus.programs) >= 45
    groups = {p.group for p in corpus.programs}
    assert groups == {"mavsdk", "pymavlink", "autotest", "mavproxy"}
    assert {p.kind for p in corpus.programs} == set(KINDS)
    for p in corpus.programs:
        assert p.checks, p.name
        assert p.ardupilot and p.source, p.name
        for c in p.checks:
            check_failure(c, Record(), "")          # raises on a check the checker does not know


def test_argv_fills_the_run_s_ports():
    p = next(p for p in load(MANIFEST).programs if p.kind == "mavsdk3")
    ports = {"udp": 1, "tcp": 2, "out": 3, "grpc": 4}
    assert p.argv(ports) == ["udpin://0.0.0.0:3", "4"]
    q = dataclasses.replace(p, kind="mavproxy", args=())
    assert q.argv(ports) == [str(q.path), "2"]
    assert set(DEFAULT_ARGS) == set(KINDS)


def flight() -> Record:
    rec = Record()
    rec.heartbeat("STABILIZE", False)
    rec.heartbeat("GUIDED", True)
    rec.position(-35.363261, 149.165230, 0.0)
    rec.position(-35.363081, 149.165230, 10.2)        # 20 m north, 10.2 m up
    rec.attitude(0.6)                                  # 34.4 degrees
    rec.heartbeat("LAND", True)
    rec.heartbeat("LAND", False)
    rec.texts.append("Auto: Missing Takeoff Cmd")
    return rec


@pytest.mark.parametrize("check", ["alt>=10", "alt<11", "dist>=19.9", "roll>=34", "mode:GUIDED", "!mode:AUTO",
                                   "armed", "disarmed", "text:Missing Takeoff", "!text:Fence", "out:^-- done$",
                                   "!out:Error"])
def test_a_check_that_holds(check):
    assert check_failure(check, flight(), "x\n-- done\n") is None


@pytest.mark.parametrize("check, why", [
    ("alt>=11", "max alt 10.2 m, wanted >=11"), ("alt<1", "max alt 10.2 m, wanted <1"),
    ("dist>=25", "max dist 20.0 m, wanted >=25"), ("mode:AUTO", "mode 'AUTO' not seen"),
    ("!mode:LAND", "mode 'LAND' seen"), ("!armed", "was armed"), ("text:Fence", "STATUSTEXT 'Fence' not seen"),
    ("out:PASSED", "output 'PASSED' not seen"),
])
def test_a_check_that_fails_says_why(check, why):
    assert check_failure(check, flight(), "-- done\n") == why


def test_still_armed_and_never_armed():
    rec = Record()
    rec.heartbeat("GUIDED", True)
    assert check_failure("disarmed", rec, "") == "still armed at the end"
    assert check_failure("armed", Record(), "") == "never armed"


def test_failures_name_the_timeout_the_exit_and_what_was_raised():
    out = ("Traceback (most recent call last):\n"
           "mavsdk.action.ActionError: COMMAND_DENIED: 'Command Denied'; origin: arm(); params: ()\n")
    assert failures(["alt>=5"], Record(), out, 1, 0, False) == [
        "exit 1, wanted 0", "max alt 0.0 m, wanted >=5", "it raised ActionError: COMMAND_DENIED: 'Command Denied'"]
    said = "AT-1.0: AP: Param set: unknown SIM_GPS1_ENABLE\nFAILED: ValueError: Param fetch returned incorrect value\n"
    assert failures(["out:PASSED"], Record(), said, 1, 0, False)[-1] == \
        "it said: ValueError: Param fetch returned incorrect value"
    assert failures([], Record(), "", None, 0, True) == ["timed out"]
    assert failures([], Record(), "", None, None, True) == []              # any exit, or none
    assert failures(["alt<1"], Record(), "", 3, None, False) == []        # any exit status wanted
    assert last_exception("all fine\n") is None


def test_unknown_check_is_refused():
    with pytest.raises(ValueError):
        check_failure("altitude>=3", Record(), "")


@pytest.mark.slow
@pytest.mark.alone          # a client program against a world on the wall clock
@pytest.mark.timeout(120)
def test_runner_tells_behaving_from_differing(tmp_path):
    from tools.client_corpus import run_one
    p = next(p for p in load(MANIFEST).programs if p.name == "autotest_telemetry_extra2")
    ok = run_one(p, tmp_path / "ok")
    assert ok.behaves, ok.reasons
    assert (tmp_path / "ok" / "program.log").read_text().count("VFR_HUD") >= 1
    wrong = dataclasses.replace(p, args=p.args + ("SCALED_IMU3",))     # a message this group does not carry
    bad = run_one(wrong, tmp_path / "bad")
    assert not bad.behaves and "output 'missing: none' not seen" in bad.reasons


def test_the_table_counts_and_names_the_reasons():
    from tools.client_corpus import Outcome, markdown
    ps = load(MANIFEST).programs[:2]
    text = markdown([Outcome(ps[0], True, [], 3.0, "modes GUIDED"),
                     Outcome(ps[1], False, ["mode 'LAND' not seen"], 4.0, "modes GUIDED")], 60.0, 2)
    assert "**1 of 2 behave as against ArduPilot SITL.** By kind: mavsdk3 1/2." in text
    assert f"| {ps[1].name} | mavsdk3 |" in text and "| **differs** | mode 'LAND' not seen |" in text
    assert "with 2 program(s) at once" in text
