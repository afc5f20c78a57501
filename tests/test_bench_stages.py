"""tools.bench_stages: self time per stage, nested stages subtracted, disturbed calls left
out, and every wrapped callable put back."""
from __future__ import annotations

import types

from tools.bench_stages import StageTimer


class Box:
    def inner(self) -> str:
        return "inner"

    def outer(self) -> str:
        return self.inner() + "+outer"


def test_self_time_nesting_and_restore():
    mod = types.SimpleNamespace(helper=lambda: "helper")
    box = Box()
    readings = iter([0.0, 1.0, 3.0, 10.0,       # outer (10) around inner (2)
                     20.0, 21.0, 24.0, 30.0,    # again: outer 10, inner 3
                     40.0, 45.0])               # helper 5
    spots = [(Box, "outer", "outer"), (box, "inner", "inner"), (mod, "helper", "helper")]
    with StageTimer(spots, limit=100.0, clock=lambda: next(readings)) as st:
        assert box.outer() == "inner+outer" and box.outer() == "inner+outer"
        assert mod.helper() == "helper"
    assert st.seconds == {"outer": 8.0 + 7.0, "inner": 2.0 + 3.0, "helper": 5.0}
    assert st.calls == {"outer": 2, "inner": 2, "helper": 1}
    assert "inner" not in vars(box) and Box.outer.__name__ == "outer" and mod.helper() == "helper"
    assert box.outer() == "inner+outer"          # no timer left in the way


def test_a_disturbed_call_is_replaced_by_the_mean_of_the_others():
    mod = types.SimpleNamespace(f=lambda: None)
    readings = iter([0.0, 1.0, 10.0, 12.0, 20.0, 27.0])    # 1, 2 and a descheduled 7
    with StageTimer([(mod, "f", "f")], limit=5.0, clock=lambda: next(readings)) as st:
        for _ in range(3):
            mod.f()
    assert st.dropped["f"] == 1 and st.calls["f"] == 3
    assert st.seconds["f"] == 1.5 * 3
