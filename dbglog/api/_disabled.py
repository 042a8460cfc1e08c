"""The public functions as no-ops, bound once at import when dbglog is switched off.

Each behaves exactly like its switched-on twin at the call: the same parameters, the options keyword-only
(a positional option is a ``TypeError`` switched off too), and ``inspect.signature`` reports the same
signature. Nothing here imports rclpy or starts anything.

Why the options are not written keyword-only below: CPython 3.11 takes its fastest call path only for
functions without keyword-only parameters (a keyword-only no-op costs twice an empty function). So each
no-op takes its options as ordinary parameters behind one guard parameter, ``_positional``: a third
positional argument lands there and is refused, keywords fill the options. The keyword-only twin each
no-op wraps (``__wrapped__``) is what ``inspect.signature`` and ``help()`` show; it is a no-op too.
With the compiled module (``_hot.c``) a call with the positional arguments and keyword options returns in
C, and every other shape goes to these.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Any, NoReturn

from dbglog.api import _native
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


class _KeywordOnly:
    """The guard's default: nothing a caller passes is this object."""

    __slots__ = ()

    def __repr__(self) -> str:
        return "<keyword-only options follow>"


_K = _KeywordOnly()


def _refuse(name: str, positional: str) -> NoReturn:
    """Raise the TypeError the switched-on function raises for a positional option."""
    raise TypeError(
        f"{name}() takes {positional} positional arguments but more were given (its options are keyword-only)"
    )


# ----- the signatures, exactly as switched on (what inspect.signature and help() show) --------------


def _logfloat(
    tag: str,
    value: float,
    *,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Do nothing (dbglog is off)."""


def _logint(
    tag: str,
    value: int,
    *,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Do nothing (dbglog is off)."""


def _logbool(
    tag: str,
    value: bool,
    *,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Do nothing (dbglog is off)."""


def _logstring(
    tag: str,
    value: str,
    *,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Do nothing (dbglog is off)."""


def _logdata(
    tag: str,
    data: object,
    msg_type: object,
    *,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Do nothing (dbglog is off)."""


def _log(
    tag: str, data: object, *, once: bool = False, throttle: float | None = None, skip_first: bool = False
) -> None:
    """Do nothing (dbglog is off)."""


# ----- the no-ops bound to the public names ---------------------------------------------------------


def logfloat(
    tag: object,
    value: object,
    _positional: object = _K,
    msg_type: object = None,
    once: object = False,
    throttle: object = None,
    skip_first: object = False,
) -> None:
    """Do nothing (dbglog is off)."""
    if _positional is not _K:
        _refuse("logfloat", "2")


def logint(
    tag: object,
    value: object,
    _positional: object = _K,
    msg_type: object = None,
    once: object = False,
    throttle: object = None,
    skip_first: object = False,
) -> None:
    """Do nothing (dbglog is off)."""
    if _positional is not _K:
        _refuse("logint", "2")


def logbool(
    tag: object,
    value: object,
    _positional: object = _K,
    msg_type: object = None,
    once: object = False,
    throttle: object = None,
    skip_first: object = False,
) -> None:
    """Do nothing (dbglog is off)."""
    if _positional is not _K:
        _refuse("logbool", "2")


def logstring(
    tag: object,
    value: object,
    _positional: object = _K,
    msg_type: object = None,
    once: object = False,
    throttle: object = None,
    skip_first: object = False,
) -> None:
    """Do nothing (dbglog is off)."""
    if _positional is not _K:
        _refuse("logstring", "2")


def logdata(
    tag: object,
    data: object,
    msg_type: object,
    _positional: object = _K,
    once: object = False,
    throttle: object = None,
    skip_first: object = False,
) -> None:
    """Do nothing (dbglog is off)."""
    if _positional is not _K:
        _refuse("logdata", "3")


def log(
    tag: object,
    data: object,
    _positional: object = _K,
    once: object = False,
    throttle: object = None,
    skip_first: object = False,
) -> None:
    """Do nothing (dbglog is off)."""
    if _positional is not _K:
        _refuse("log", "2")


for _fast, _spec in (
    (logfloat, _logfloat),
    (logint, _logint),
    (logbool, _logbool),
    (logstring, _logstring),
    (logdata, _logdata),
    (log, _log),
):
    setattr(_fast, "__wrapped__", _spec)  # noqa: B010  (a function attribute mypy does not model)
del _fast, _spec

_NATIVE = _native.load()
if not TYPE_CHECKING and _NATIVE is not None:
    # With the compiled module, a call with the positional arguments and keyword options returns in C:
    # cheaper than any Python function. Every other call shape goes to the no-op above, which refuses
    # what is refused switched on.
    def _compiled(noop: Any) -> Any:
        """`noop` as a `NoOp`: its arity and option names are those of the signature it wraps."""
        code = noop.__wrapped__.__code__
        positional, options = code.co_argcount, code.co_kwonlyargcount
        names = code.co_varnames[positional : positional + options]
        return functools.update_wrapper(_NATIVE.NoOp(noop, positional, names), noop)

    logfloat = _compiled(logfloat)
    logint = _compiled(logint)
    logbool = _compiled(logbool)
    logstring = _compiled(logstring)
    logdata = _compiled(logdata)
    log = _compiled(log)


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
