"""Rate control like ROS logging: ``once``, ``skip_first`` and ``throttle``, per tag and call site."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["RateLimiter", "check_throttle"]

Site = tuple[str, int]
"""(file name, line number) of the user's call."""


@dataclass(slots=True)
class _SiteState:
    calls: int = 0
    last_pass: float = -math.inf


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
        self._clock = clock
        self._lock = threading.Lock()
        self._sites: dict[tuple[str, Site], _SiteState] = {}

    def allow(self, tag: str, site: Site, *, once: bool, skip_first: bool, throttle: float | None) -> bool:
        """Return True when this call should publish (filters in the order once, skip_first, throttle)."""
        with self._lock:
            state = self._sites.get((tag, site))
            if state is None:
                state = self._sites[(tag, site)] = _SiteState()
            state.calls += 1
            if once and state.calls > 1:
                return False
            if skip_first and state.calls == 1:
                return False
            if throttle is not None:
                now = self._clock()
                if now - state.last_pass < throttle:
                    return False
                state.last_pass = now
            return True

    def throttled(self, tag: str, site: Site, throttle: float) -> bool:
        """True when a throttle-only call from a known site is held back (no lock: one dict lookup).

        False means "maybe passes": the caller then decides with `allow`, under the lock, so exactly one
        call per period passes even when threads race.
        """
        state = self._sites.get((tag, site))
        if state is None or self._clock() - state.last_pass >= throttle:
            return False
        state.calls += 1  # only once/skip_first read it, which a throttle-only site never uses
        return True

    def clear(self) -> None:
        """Forget every call site."""
        with self._lock:
            self._sites.clear()
