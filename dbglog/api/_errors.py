"""What happens when a logging call cannot publish: counters, one warning per problem, strict mode."""

from __future__ import annotations

import itertools
import os
import sys
import threading
import warnings
from dataclasses import dataclass, field
from typing import Literal, get_args

__all__ = ["REASONS", "DbglogError", "DbglogWarning", "Reason", "Reporter", "Stats", "safe_repr"]

Reason = Literal[
    "bad_tag",
    "bad_value",
    "out_of_range",
    "bad_type",
    "type_conflict",
    "bad_option",
    "publish_failed",
    "queue_full",
    "no_ros",
    "forked",
    "shut_down",
    "recursion",
]
"""Why a value was dropped (the keys of `Stats.dropped_by_reason`)."""

REASONS: tuple[Reason, ...] = get_args(Reason)

_API_DIR = os.path.dirname(os.path.abspath(__file__)) + os.sep
_REPR_LIMIT = 80


class DbglogWarning(UserWarning):
    """A dbglog call could not do all it was asked (the value was dropped, or a tag was renamed)."""


class DbglogError(RuntimeError):
    """Raised instead of a `DbglogWarning` when ``DBGLOG_STRICT=1`` (meant for tests)."""


@dataclass(frozen=True, slots=True)
class Stats:
    """A snapshot of dbglog's counters since start (or since the last reset).

    Every call ends as published, rate-limited or dropped, so for calls with a single value
    ``calls == published + rate_limited + dropped``; a dict given to `log` publishes one message per leaf.
    """

    enabled: bool
    """Whether dbglog is switched on (``DBGLOG``)."""
    calls: int
    """Public logging calls made (``log``, ``logfloat``, ...)."""
    published: int
    """Messages handed to the middleware."""
    rate_limited: int
    """Values held back on purpose by ``once=``, ``throttle=`` or ``skip_first=``."""
    dropped: int
    """Values not published because something was wrong (see `dropped_by_reason`)."""
    dropped_by_reason: dict[str, int] = field(default_factory=dict)
    """Dropped values per reason; only reasons that occurred appear."""
    renamed_tags: int = 0
    """Distinct invalid tags that were mapped to a valid one."""
    warnings: int = 0
    """Warnings issued (at most one per problem and tag)."""
    tags: int = 0
    """Topics with a live publisher."""


class _Counter:
    """A counter whose increment is one C call (atomic under the GIL), readable without a lock."""

    __slots__ = ("_lock", "_reads", "counter", "incr")

    def __init__(self) -> None:
        self.counter = itertools.count()
        """The counter itself: the compiled hot path advances it (``incr`` is its bound ``__next__``)."""
        self.incr = self.counter.__next__
        self._reads = 0
        self._lock = threading.Lock()

    def reset(self) -> None:
        """Start again from zero (the bound `incr` stays valid)."""
        with self._lock:
            self._reads = next(self.counter) + 1

    def add(self, n: int) -> None:
        """Count `n` at once (one lock instead of `n` increments)."""
        with self._lock:
            self._reads -= n

    def value(self) -> int:
        """Return how many times `incr` has been called."""
        with self._lock:
            n = next(self.counter) - self._reads
            self._reads += 1
            return n


def safe_repr(value: object) -> str:
    """Return a short repr of `value` that never raises, for warning messages."""
    try:
        text = repr(value)
    except Exception:
        try:
            return f"<{type(value).__name__} object with a failing __repr__>"
        except Exception:
            return "<unrepresentable object>"
    if len(text) > _REPR_LIMIT:
        text = text[: _REPR_LIMIT - 3] + "..."
    return text


def _user_stacklevel() -> int:
    """Return the `warnings.warn` stacklevel of the first frame outside ``dbglog/api``."""
    frame = sys._getframe(1)  # the caller of warn(), which is the frame stacklevel=1 names
    level = 1
    while frame is not None and frame.f_code.co_filename.startswith(_API_DIR):
        frame = frame.f_back  # type: ignore[assignment]
        level += 1
    return level


class Reporter:
    """Counts every outcome; warns once per (reason, key); raises instead in strict mode."""

    def __init__(self, *, enabled: bool, strict: bool) -> None:
        self.enabled = enabled
        self.strict = strict
        self._local = threading.local()
        self._lock = threading.Lock()
        self.calls = _Counter()
        self.published = _Counter()
        self.rate_limited = _Counter()
        self._dropped = {reason: _Counter() for reason in REASONS}
        self._warned: set[tuple[str, str]] = set()
        self._renamed = 0
        self._warnings = 0

    def reset(self) -> None:
        """Zero every counter and forget which warnings were given."""
        for counter in (self.calls, self.published, self.rate_limited, *self._dropped.values()):
            counter.reset()
        with self._lock:
            self._warned.clear()
            self._renamed = 0
            self._warnings = 0

    def stats(self, tags: int) -> Stats:
        """Return a snapshot of the counters."""
        counts = {r: c.value() for r, c in self._dropped.items()}
        by_reason: dict[str, int] = {r: n for r, n in counts.items() if n}
        with self._lock:
            renamed, warned = self._renamed, self._warnings
        return Stats(
            enabled=self.enabled,
            calls=self.calls.value(),
            published=self.published.value(),
            rate_limited=self.rate_limited.value(),
            dropped=sum(by_reason.values()),
            dropped_by_reason=by_reason,
            renamed_tags=renamed,
            warnings=warned,
            tags=tags,
        )

    @property
    def busy(self) -> bool:
        """True while this thread is inside dbglog's warning machinery (a nested call must not log)."""
        return bool(getattr(self._local, "busy", False))

    def drop(self, reason: Reason, key: str, message: str, exc: BaseException | None = None) -> None:
        """Count a dropped value; warn about it once per (reason, key), or raise in strict mode."""
        self._dropped[reason].incr()
        self.warn(reason, key, message, exc)

    def count(self, reason: Reason) -> None:
        """Count a dropped value without warning (e.g. calls during interpreter exit)."""
        self._dropped[reason].incr()

    def after_fork(self) -> None:
        """Replace locks that another thread may have held at a ``fork`` (runs in the child)."""
        self._lock = threading.Lock()
        self._local = threading.local()
        for counter in (self.calls, self.published, self.rate_limited, *self._dropped.values()):
            counter._lock = threading.Lock()

    def renamed(self, key: str, message: str) -> None:
        """Count a renamed tag and warn once about it (the value is still published)."""
        with self._lock:
            self._renamed += 1
        self.warn("bad_tag", key, message, None)

    def warn(self, reason: str, key: str, message: str, exc: BaseException | None) -> None:
        """Warn once per (reason, key) at the user's line; in strict mode raise `DbglogError`."""
        if self.strict:
            raise DbglogError(message) from exc
        with self._lock:
            if (reason, key) in self._warned:
                return
            self._warned.add((reason, key))
            self._warnings += 1
        if self.busy:
            return
        self._local.busy = True
        try:
            warnings.warn(message, DbglogWarning, stacklevel=_user_stacklevel())
        finally:
            self._local.busy = False
