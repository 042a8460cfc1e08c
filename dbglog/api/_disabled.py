"""The public functions as fixed-arity no-ops, bound once at import when dbglog is switched off.

They take the same parameter names as the enabled functions. The options are ordinary parameters with
defaults here rather than keyword-only: CPython calls such functions through its fastest path (a
keyword-only parameter alone doubles the cost of a call). Nothing here imports rclpy or starts anything.
"""

from __future__ import annotations

from typing import Any

from dbglog.api._errors import Stats

__all__ = [
    "flush",
    "init",
    "log",
    "logbool",
    "logdata",
    "logfloat",
    "logint",
    "logstring",
    "shutdown",
    "stats",
]


def logfloat(
    tag: str,
    value: float,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Do nothing (dbglog is off)."""


def logint(
    tag: str,
    value: int,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Do nothing (dbglog is off)."""


def logbool(
    tag: str,
    value: bool,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Do nothing (dbglog is off)."""


def logstring(
    tag: str,
    value: str,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Do nothing (dbglog is off)."""


def logdata(
    tag: str,
    data: object,
    msg_type: object,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Do nothing (dbglog is off)."""


def log(
    tag: str, data: object, once: bool = False, throttle: float | None = None, skip_first: bool = False
) -> None:
    """Do nothing (dbglog is off)."""


def init(*, node: Any = None) -> None:
    """Do nothing (dbglog is off)."""


def shutdown() -> None:
    """Do nothing (dbglog is off)."""


def flush(timeout: float = 1.0) -> bool:
    """Return True at once (dbglog is off: nothing is ever pending)."""
    return True


_OFF = Stats(enabled=False, calls=0, published=0, rate_limited=0, dropped=0)


def stats() -> Stats:
    """Return all-zero counters (dbglog is off and counts nothing)."""
    return _OFF
