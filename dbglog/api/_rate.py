"""Rate control like ROS logging: ``once``, ``skip_first`` and ``throttle``, per tag and call site."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from types import CodeType

__all__ = ["RateLimiter", "SiteState", "check_throttle"]

Site = tuple[str, int]
"""(file name, line number) of the user's call."""
_MAX_KNOWN = 40_000
"""Call sites remembered by instruction (`RateLimiter.known`) at most."""


@dataclass(slots=True)
class SiteState:
    """What rate control remembers of one (tag, call site)."""

    calls: int = 0
    last_pass: float = -math.inf


Known = tuple[CodeType, int, SiteState, Site]
"""A call instruction (its code object, kept alive so its id stays unique, and its offset), the state of
its (tag, site) and the site."""


def check_throttle(throttle: object) -> float | None:
    """Return a valid throttle period in seconds, or raise ValueError naming the problem."""
    if throttle is None:
        return None
    if isinstance(throttle, bool) or not isinstance(throttle, int | float):
        raise ValueError(f"throttle must be a number of seconds, not {type(throttle).__name__}")
    period = float(throttle)
    if not (math.isfinite(period) and period >= 0):
        raise ValueError(f"throttle must be a finite number of seconds >= 0, not {throttle!r}")
    return period


class RateLimiter:
    """Decides whether a rate-controlled call passes; thread-safe."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self._lock = threading.Lock()
        self._sites: dict[tuple[str, Site], SiteState] = {}
        self.known: dict[tuple[str, int, int], Known] = {}
        """(tag, id of the code object, instruction offset) -> `Known`: the hot path finds a call's
        state without computing its line number (which decodes the code's line table)."""

    def allow(self, tag: str, site: Site, *, once: bool, skip_first: bool, throttle: float | None) -> bool:
        """Return True when this call should publish (filters in the order once, skip_first, throttle)."""
        with self._lock:
            state = self._sites.get((tag, site))
            if state is None:
                state = self._sites[(tag, site)] = SiteState()
            state.calls += 1
            if once and state.calls > 1:
                return False
            if skip_first and state.calls == 1:
                return False
            if throttle is not None:
                now = self.clock()
                if now - state.last_pass < throttle:
                    return False
                state.last_pass = now
            return True

    def remember(self, tag: str, code: CodeType, lasti: int, line: int) -> Known:
        """Return the `Known` entry of the call instruction `lasti` of `code`, on `line` (created if new)."""
        site = (code.co_filename, line)
        with self._lock:
            state = self._sites.get((tag, site))
            if state is None:
                state = self._sites[(tag, site)] = SiteState()
            known = (code, lasti, state, site)
            if len(self.known) < _MAX_KNOWN:
                self.known[(tag, id(code), lasti)] = known
        return known

    def clear(self) -> None:
        """Forget every call site."""
        with self._lock:
            self._sites.clear()
            self.known.clear()

    def after_fork(self) -> None:
        """Replace the lock, which another thread may have held at a ``fork`` (runs in the child)."""
        self._lock = threading.Lock()
