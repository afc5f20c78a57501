"""Where a step's time goes: self time per named stage, measured by timing wrappers.

A benchmark names the callables that make up its stages (module functions, class methods,
or one object's methods); for the duration of a ``with StageTimer(...)`` block each is
replaced by a wrapper that times it, and put back afterwards. Stages nest: a wrapped call
inside another wrapped call is subtracted from the outer one, so each stage gets its own
(self) time and the stages add up to the instrumented total. A wrapper costs about half a
microsecond per call, so read the shares, and the plain (unwrapped) run for the total.

Wall clock, because a CPU clock costs microseconds a reading on a VM; on a shared machine
the process is descheduled now and then and that pause lands on whichever stage runs, so a
call whose self time exceeds ``limit`` (1 ms, far above any stage's own cost) is taken as
disturbed: it is left out and the stage's mean over its other calls stands in for it.
"""
from __future__ import annotations

import collections
import time
from collections.abc import Callable, Iterable
from typing import Self


class StageTimer:
    """spots: (owner, attribute name, stage label); owner is a module, a class or an object.
    After the block, ``seconds[label]`` is the self time (disturbed calls replaced by the
    mean of the others) and ``calls[label]`` the count; ``dropped[label]`` disturbed calls."""

    def __init__(self, spots: Iterable[tuple[object, str, str]], limit: float = 1e-3,
                 clock: Callable[[], float] = time.perf_counter) -> None:
        """limit: self time (s) above which a call counts as disturbed (math.inf: never);
        clock: time.process_time for stages that each take milliseconds (big fleets), where
        its cost per reading does not matter and descheduled time is not counted at all."""
        self.spots = list(spots)
        self.limit = limit
        self.clock = clock
        self._kept: dict[str, float] = collections.Counter()
        self.calls: dict[str, int] = collections.Counter()
        self.dropped: dict[str, int] = collections.Counter()
        self._saved: list[tuple[object, str, object, bool]] = []
        self._stack: list[float] = []        # time of nested stages, per open call

    @property
    def seconds(self) -> dict[str, float]:
        out = {}
        for label, n in self.calls.items():
            kept = n - self.dropped[label]
            out[label] = self._kept[label] * n / kept if kept else 0.0
        return out

    def _wrap(self, fn, label: str):
        kept, calls, dropped, stack, clock = self._kept, self.calls, self.dropped, self._stack, self.clock
        limit = self.limit

        def timed(*args, **kwargs):
            stack.append(0.0)
            t0 = clock()
            try:
                return fn(*args, **kwargs)
            finally:
                spent = clock() - t0
                own = spent - stack.pop()
                calls[label] += 1
                if own > limit:
                    dropped[label] += 1
                else:
                    kept[label] += own
                if stack:
                    stack[-1] += spent
        return timed

    def __enter__(self) -> Self:
        for owner, name, label in self.spots:
            own = name in getattr(owner, "__dict__", {})     # else inherited / from the class
            fn = getattr(owner, name)
            if isinstance(owner, type) and isinstance(owner.__dict__.get(name), staticmethod):
                raise TypeError(f"{owner.__name__}.{name} is a staticmethod: wrap its callers")
            self._saved.append((owner, name, owner.__dict__.get(name) if own else None, own))
            setattr(owner, name, self._wrap(fn, label))
        return self

    def __exit__(self, *exc) -> None:
        for owner, name, fn, own in reversed(self._saved):
            if own:
                setattr(owner, name, fn)
            else:
                delattr(owner, name)
        self._saved.clear()


class _Names:
    """A namespace dict seen as an object (its __dict__), so StageTimer can wrap its names."""

    def __init__(self, names: dict) -> None:
        self.__dict__ = names


def scalar_form_spots(caller, callee, label: str) -> list[tuple[object, str, str]]:
    """Spots for the calls `caller`'s scalar form makes to `callee`'s (both @generic cores,
    vehicle.physics.scalar_form): the scalar form binds its callees' forms in its own
    namespace at compile time, so wrapping the module attribute would not see those calls."""
    names = caller.scalar().__globals__
    target = callee.scalar()
    return [(_Names(names), k, label) for k, v in list(names.items()) if v is target]
