"""Waiting for data with a timeout: retry an attempt each time the buffer changes.

tf2's timeouts are wall seconds; the clock is passed in (time.monotonic by default) so
tests can move it by hand.
"""
from __future__ import annotations

import threading
from typing import Any, Callable

from .errors import (ConnectivityException, ExtrapolationException, LookupException,
                     TimeoutException)

#: Errors that later data can cure; any other error ends the wait at once.
WAITABLE = (LookupException, ConnectivityException, ExtrapolationException)


class Waits:
    """Callers blocked until data arrives, on a condition of the buffer's own lock."""

    def __init__(self, lock: threading.Lock, clock: Callable[[], float]) -> None:
        self._cond = threading.Condition(lock)
        self._clock = clock
        self.waiting = 0    # how many callers are blocked now

    def notify(self) -> None:
        """Wake every waiter to retry (lock held; call only when ``waiting``)."""
        self._cond.notify_all()

    def until(self, attempt: Callable[[], Any], timeout: float, what: str) -> Any:
        """attempt()'s result, retried (lock held) after every change until ``timeout``
        wall seconds have passed; then TimeoutException chaining the last error."""
        deadline = self._clock() + timeout
        with self._cond:
            self.waiting += 1
            try:
                while True:
                    try:
                        return attempt()
                    except WAITABLE as e:
                        last = e
                    remaining = deadline - self._clock()
                    if remaining <= 0.0:
                        raise TimeoutException(
                            f"Timed out after {timeout:.3f} s (wall) waiting for {what}. "
                            f"Last error: {last}", waited=timeout, last_error=last) from last
                    self._cond.wait(remaining)
            finally:
                self.waiting -= 1


__all__ = ["Waits", "WAITABLE"]
