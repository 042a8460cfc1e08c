"""The logging functions as they work when dbglog is switched on.

Every function counts the call, never raises into the caller (except in strict mode), and returns
quickly: scalar values are checked here and queued with their source time; dbglog's publisher thread
sends them (see ``_pipe``). ``logfloat``/``logint`` to a known tag only append to the queue.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import sys
import time
from collections.abc import Mapping
from types import FrameType
from typing import TYPE_CHECKING, Any

from dbglog._ros._tags import unescape_tag
from dbglog.api import _native
from dbglog.api._channel import Channel
from dbglog.api._convert import (
    KIND_DEFAULT,
    MAX_STRING_CHARS,
    NUL_REPLACEMENT,
    SCALAR_DTYPES,
    ConversionError,
    ScalarKind,
    build_message,
    is_message,
    make_checker,
    multiarray_message,
    resolve_type,
    scalar_spec,
    scrub_nul,
    type_name,
)
from dbglog.api._errors import _API_DIR, DbglogError, DbglogWarning, Reporter, Stats, safe_repr
from dbglog.api._rate import RateLimiter, SiteState, check_throttle
from dbglog.api._runtime import Runtime

__all__ = [
    "REPORTER",
    "RUNTIME",
    "flush",
    "init",
    "log",
    "logbool",
    "logdata",
    "logfloat",
    "logint",
    "logstring",
    "reset",
    "shutdown",
    "stats",
]

REPORTER = Reporter(enabled=True, strict=False)
RUNTIME = Runtime(REPORTER)
_LIMITER = RateLimiter()
os.register_at_fork(after_in_child=_LIMITER.after_fork)
_known = _LIMITER.known
_clock = _LIMITER.clock
_getframe = sys._getframe
_MAX_DEPTH = 8
"""How deep `log` follows nested dicts (a dict that contains itself stops here)."""

_std_msgs: Any = None
_PASS_THROUGH = (DbglogError, DbglogWarning)
"""Strict mode's error, and our warning when the user turned warnings into errors: theirs to see."""

# Bound once: the hot paths below touch only these names.
_fast_float = RUNTIME.fast_float
_fast_int = RUNTIME.fast_int
_fast_bool = RUNTIME.fast_bool
_fast_str = RUNTIME.fast_str
_INF = math.inf
_calls = REPORTER.calls.incr
_published = REPORTER.published.incr
_rate_limited = REPORTER.rate_limited.incr
_PIPE = RUNTIME.pipe
_queue = _PIPE.queue
_append = _queue.append
_now = time.time_ns
_STATS_DRAIN_SECONDS = 30.0
"""stats() publishes what is queued first, for at most this long (a full queue takes a second or two,
longer when subscribers in this very process take the GIL for every message)."""


def _std_type(name: str) -> type:
    global _std_msgs
    if _std_msgs is None:
        import std_msgs.msg

        _std_msgs = std_msgs.msg
    cls: type = getattr(_std_msgs, name)
    return cls


def _user_site() -> tuple[str, int]:
    """Return (file, line) of the user's call into dbglog: the key of rate control."""
    frame = sys._getframe(1)
    while frame.f_back is not None and frame.f_code.co_filename.startswith(_API_DIR):
        frame = frame.f_back
    return frame.f_code.co_filename, frame.f_lineno


class _Options:
    """Rate-control options of one call, validated."""

    __slots__ = ("active", "once", "site", "skip_first", "throttle")

    def __init__(self, once: object, throttle: object, skip_first: object) -> None:
        self.once = bool(once)
        self.skip_first = bool(skip_first)
        self.throttle = check_throttle(throttle)
        self.active = self.once or self.skip_first or self.throttle is not None
        self.site = _user_site() if self.active else ("", 0)

    def allow(self, tag: str) -> bool:
        if not self.active:
            return True
        if _LIMITER.allow(tag, self.site, once=self.once, skip_first=self.skip_first, throttle=self.throttle):
            return True
        REPORTER.rate_limited.incr()
        return False


def _rate(ch: Channel, once: object, throttle: object, skip_first: object, frame: FrameType) -> bool | None:
    """Rate control on the hot path: pass or hold back (counted), or None when an option needs checking.

    `frame` is the user's call. The hot functions hold back a throttled call from the instruction that
    last rate-controlled the tag themselves, in the fewest steps (a loop's one throttled call per
    iteration runs with cold caches); this finds any call's site by its instruction (the line number,
    which decodes the code's line table, is looked up once per instruction).
    """
    if (type(once) is not bool or type(skip_first) is not bool) or (
        throttle is not None
        and not ((type(throttle) is float or type(throttle) is int) and 0 <= throttle < _INF)
    ):
        return None
    code = frame.f_code
    known = _known.get((ch.tag, id(code), frame.f_lasti))
    if known is None:  # this call instruction's first time
        known = _LIMITER.remember(ch.tag, code, frame.f_lasti, frame.f_lineno)
    else:
        # Held back without the lock: an `once` site that passed before, or a throttle-only site within
        # its period (False from here means "maybe passes": `allow` decides under the lock).
        state = known[2]
        if (once and state.calls) or (
            throttle is not None and not skip_first and _clock() - state.last_pass < throttle
        ):
            state.calls += 1
            _rate_limited()
            ch.rate_site = known
            return False
    ch.rate_site = known
    if _LIMITER.allow(ch.tag, known[3], once=once, skip_first=skip_first, throttle=throttle):
        return True
    _rate_limited()
    return False


def _begin(api: str, tag: object, once: object, throttle: object, skip_first: object) -> _Options | None:
    """Count the call; return its options, or None when it must be dropped (recursion, bad option)."""
    _calls()
    if REPORTER.busy:
        REPORTER.count("recursion")
        return None
    try:
        return _Options(once, throttle, skip_first)
    except ValueError as exc:
        key = tag if isinstance(tag, str) else f"<{type(tag).__name__}>{safe_repr(tag)}"
        REPORTER.drop("bad_option", key, f"dbglog.{api}({safe_repr(tag)}): {exc}; value dropped")
        return None


def _unexpected(api: str, tag: object, exc: Exception) -> None:
    """Count and report an error nobody foresaw, so it never reaches the caller."""
    REPORTER.drop(
        "bad_value",
        f"{api}:{type(exc).__name__}:{safe_repr(tag)}",
        f"dbglog.{api}({safe_repr(tag)}): {type(exc).__name__}: {safe_repr(exc)}; value dropped",
        exc,
    )


def _publish_scalar(
    api: str, given: object, clean: str, value: object, cls: type, opts: _Options, fast: bool
) -> None:
    spec = scalar_spec(cls)
    if spec is None:  # pragma: no cover - callers pass std_msgs scalar types only
        raise ConversionError("bad_type", f"{type_name(cls)} is not a single-value std_msgs type")
    try:
        checked = make_checker(spec)(value)
    except ConversionError as exc:
        REPORTER.drop(
            exc.reason, f"{clean}", f"dbglog.{api}({clean!r}): value {safe_repr(value)} dropped: {exc}"
        )
        return
    if spec.kind == "str" and isinstance(checked, str) and len(checked) > MAX_STRING_CHARS:
        REPORTER.warn(
            "truncated",
            clean,
            f"dbglog.{api}({clean!r}): a string of {len(checked)} characters was cut to {MAX_STRING_CHARS}",
            None,
        )
        checked = checked[:MAX_STRING_CHARS]
    if spec.kind == "str" and isinstance(checked, str) and "\x00" in checked:
        checked = checked.replace("\x00", NUL_REPLACEMENT)
        _warn_nul(api, clean, "the string")
    if not opts.allow(clean):
        return
    ch = RUNTIME.channel(clean, cls, api)
    if ch is None:
        return
    if ch.queued:
        RUNTIME.enqueue(ch, checked, api)
        if fast and isinstance(given, str):
            RUNTIME.remember_fast_path(given, ch)
    elif RUNTIME.send(ch, checked, api):
        _published()


def _scalar_call(
    api: str,
    kind: ScalarKind,
    tag: object,
    value: object,
    msg_type: object,
    once: object,
    throttle: object,
    skip_first: object,
) -> None:
    opts = _begin(api, tag, once, throttle, skip_first)
    if opts is None:
        return
    try:
        clean = RUNTIME.resolve_tag(tag, api)
        if clean is None:
            return
        if msg_type is None:
            cls = _std_type(KIND_DEFAULT[kind])
        else:
            try:
                cls = resolve_type(msg_type)
                spec = scalar_spec(cls)
                if spec is None or spec.kind != kind:
                    raise ConversionError(
                        "bad_type", f"msg_type {type_name(cls)} does not fit a {kind} value"
                    )
            except ConversionError as exc:
                REPORTER.drop(exc.reason, f"{clean}:msg_type", f"dbglog.{api}({clean!r}): {exc}")
                return
        _publish_scalar(api, tag, clean, value, cls, opts, fast=msg_type is None)
    except _PASS_THROUGH:
        raise
    except Exception as exc:
        _unexpected(api, tag, exc)


def logfloat(
    tag: str,
    value: float,
    *,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Publish a number on ``/rosdashboard/<tag>`` as ``std_msgs/msg/Float64``.

    Args:
        tag: topic name below ``/rosdashboard/``; ``/`` makes namespaces.
        value: any real number (int, float, numpy scalar, Decimal, ...); NaN and infinities are kept.
        msg_type: ``Float32`` (class or ``"std_msgs/msg/Float32"``) instead of Float64.
        once: publish only the first call from this line.
        throttle: publish at most once per this many seconds from this line.
        skip_first: drop the first call from this line.
    """
    if type(value) is float and msg_type is None:
        try:
            ch = _fast_float.get(tag)
            if ch is not None and len(_queue) < _PIPE.capacity:
                if not (once or skip_first or throttle is not None):
                    _calls()
                    _append((ch, value, _now()))
                    if _PIPE.sleeping:
                        _PIPE.wake()
                    return
                frame = _getframe(1)
                known = ch.rate_site
                if (
                    known is not None
                    and known[0] is frame.f_code
                    and known[1] == frame.f_lasti
                    and once is False
                    and skip_first is False
                    and type(throttle) is float
                    and _clock() - known[2].last_pass < throttle < _INF
                ):  # held back: throttled, from the instruction that last rate-controlled the tag
                    known[2].calls += 1
                    _calls()
                    _rate_limited()
                    return
                verdict = _rate(ch, once, throttle, skip_first, frame)
                if verdict is not None:
                    _calls()
                    if verdict:
                        _append((ch, value, _now()))
                        if _PIPE.sleeping:
                            _PIPE.wake()
                    return
        except Exception:  # noqa: S110  (unhashable tag...: the general path reports)
            pass
    _scalar_call("logfloat", "float", tag, value, msg_type, once, throttle, skip_first)


def logint(
    tag: str,
    value: int,
    *,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Publish an integer on ``/rosdashboard/<tag>`` as ``std_msgs/msg/Int64``.

    Args:
        tag: topic name below ``/rosdashboard/``.
        value: an int (or numpy integer); values outside the type's range are dropped with a warning.
        msg_type: another std_msgs integer type (``Int8`` ... ``Int64``, ``UInt8`` ... ``UInt64``).
        once: publish only the first call from this line.
        throttle: publish at most once per this many seconds from this line.
        skip_first: drop the first call from this line.
    """
    if type(value) is int and msg_type is None and -0x8000000000000000 <= value <= 0x7FFFFFFFFFFFFFFF:
        try:
            ch = _fast_int.get(tag)
            if ch is not None and len(_queue) < _PIPE.capacity:
                if not (once or skip_first or throttle is not None):
                    _calls()
                    _append((ch, value, _now()))
                    if _PIPE.sleeping:
                        _PIPE.wake()
                    return
                frame = _getframe(1)
                known = ch.rate_site
                if (
                    known is not None
                    and known[0] is frame.f_code
                    and known[1] == frame.f_lasti
                    and once is False
                    and skip_first is False
                    and type(throttle) is float
                    and _clock() - known[2].last_pass < throttle < _INF
                ):  # held back: throttled, from the instruction that last rate-controlled the tag
                    known[2].calls += 1
                    _calls()
                    _rate_limited()
                    return
                verdict = _rate(ch, once, throttle, skip_first, frame)
                if verdict is not None:
                    _calls()
                    if verdict:
                        _append((ch, value, _now()))
                        if _PIPE.sleeping:
                            _PIPE.wake()
                    return
        except Exception:  # noqa: S110  (unhashable tag...: the general path reports)
            pass
    _scalar_call("logint", "int", tag, value, msg_type, once, throttle, skip_first)


def logbool(
    tag: str,
    value: bool,
    *,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Publish a bool on ``/rosdashboard/<tag>`` as ``std_msgs/msg/Bool`` (0 and 1 are accepted too).

    Args:
        tag: topic name below ``/rosdashboard/``.
        value: True or False.
        msg_type: only ``Bool`` fits.
        once: publish only the first call from this line.
        throttle: publish at most once per this many seconds from this line.
        skip_first: drop the first call from this line.
    """
    if type(value) is bool and msg_type is None:
        try:
            ch = _fast_bool.get(tag)
            if ch is not None and len(_queue) < _PIPE.capacity:
                if not (once or skip_first or throttle is not None):
                    _calls()
                    _append((ch, value, _now()))
                    if _PIPE.sleeping:
                        _PIPE.wake()
                    return
                frame = _getframe(1)
                known = ch.rate_site
                if (
                    known is not None
                    and known[0] is frame.f_code
                    and known[1] == frame.f_lasti
                    and once is False
                    and skip_first is False
                    and type(throttle) is float
                    and _clock() - known[2].last_pass < throttle < _INF
                ):  # held back: throttled, from the instruction that last rate-controlled the tag
                    known[2].calls += 1
                    _calls()
                    _rate_limited()
                    return
                verdict = _rate(ch, once, throttle, skip_first, frame)
                if verdict is not None:
                    _calls()
                    if verdict:
                        _append((ch, value, _now()))
                        if _PIPE.sleeping:
                            _PIPE.wake()
                    return
        except Exception:  # noqa: S110  (unhashable tag...: the general path reports)
            pass
    _scalar_call("logbool", "bool", tag, value, msg_type, once, throttle, skip_first)


def logstring(
    tag: str,
    value: str,
    *,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Publish text on ``/rosdashboard/<tag>`` as ``std_msgs/msg/String``.

    Args:
        tag: topic name below ``/rosdashboard/``.
        value: a str (other objects go through ``str()``); longer than 65536 characters is cut.
        msg_type: only ``String`` fits.
        once: publish only the first call from this line.
        throttle: publish at most once per this many seconds from this line.
        skip_first: drop the first call from this line.
    """
    if type(value) is str and msg_type is None and len(value) <= MAX_STRING_CHARS and value.isascii():
        try:
            ch = _fast_str.get(tag)
            if ch is not None and len(_queue) < _PIPE.capacity and "\x00" not in value:
                if not (once or skip_first or throttle is not None):
                    _calls()
                    _append((ch, value, _now()))
                    if _PIPE.sleeping:
                        _PIPE.wake()
                    return
                frame = _getframe(1)
                known = ch.rate_site
                if (
                    known is not None
                    and known[0] is frame.f_code
                    and known[1] == frame.f_lasti
                    and once is False
                    and skip_first is False
                    and type(throttle) is float
                    and _clock() - known[2].last_pass < throttle < _INF
                ):  # held back: throttled, from the instruction that last rate-controlled the tag
                    known[2].calls += 1
                    _calls()
                    _rate_limited()
                    return
                verdict = _rate(ch, once, throttle, skip_first, frame)
                if verdict is not None:
                    _calls()
                    if verdict:
                        _append((ch, value, _now()))
                        if _PIPE.sleeping:
                            _PIPE.wake()
                    return
        except Exception:  # noqa: S110  (unhashable tag...: the general path reports)
            pass
    _scalar_call("logstring", "str", tag, value, msg_type, once, throttle, skip_first)


def logdata(
    tag: str,
    data: object,
    msg_type: object,
    *,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """Publish any ROS message type on ``/rosdashboard/<tag>``.

    Args:
        tag: topic name below ``/rosdashboard/``.
        data: an instance of `msg_type`, or a dict of its fields (nested dicts for nested messages).
        msg_type: the message class, or its name as ``"pkg/msg/Type"``.
        once: publish only the first call from this line.
        throttle: publish at most once per this many seconds from this line.
        skip_first: drop the first call from this line.

    Example:
        ``dbglog.logdata("goal", {"x": 1.0, "y": 2.0}, "geometry_msgs/msg/Point")``
    """
    opts = _begin("logdata", tag, once, throttle, skip_first)
    if opts is None:
        return
    try:
        clean = RUNTIME.resolve_tag(tag, "logdata")
        if clean is None:
            return
        try:
            cls = resolve_type(msg_type)
            msg = build_message(cls, data)
        except ConversionError as exc:
            REPORTER.drop(exc.reason, clean, f"dbglog.logdata({clean!r}): {exc}; value dropped")
            return
        _send_message(clean, msg, opts, "logdata")
    except _PASS_THROUGH:
        raise
    except Exception as exc:
        _unexpected("logdata", tag, exc)


def _warn_nul(api: str, clean: str, where: str) -> None:
    """Warn once per tag that NUL characters were replaced (a ROS 2 string would end at the first one)."""
    REPORTER.warn(
        "nul_replaced",
        clean,
        f"dbglog.{api}({clean!r}): {where} held NUL characters, which a ROS 2 string cannot carry "
        f"(it would end at the first one); each was replaced with U+FFFD",
        None,
    )


def _send_message(clean: str, msg: object, opts: _Options, api: str) -> None:
    if not opts.allow(clean):
        return
    msg, nul_fields = scrub_nul(msg)
    if nul_fields:
        more = f" and {len(nul_fields) - 3} more" if len(nul_fields) > 3 else ""
        _warn_nul(api, clean, "field " + ", ".join(nul_fields[:3]) + more)
    ch = RUNTIME.channel(clean, type(msg), api)
    if ch is None:
        return
    if ch.queued:
        RUNTIME.enqueue(ch, msg.data, api)  # type: ignore[attr-defined]
    elif RUNTIME.send(ch, msg, api, message=True):
        _published()


def log(
    tag: str, data: object, *, once: bool = False, throttle: float | None = None, skip_first: bool = False
) -> None:
    """Publish `data` with the message type its Python type calls for.

    bool → Bool, int → Int64, float → Float64, str → String, numpy scalars by dtype, sequences and
    numpy arrays of numbers → the matching ``*MultiArray``, a ROS message → its own type, and a dict →
    one sub-topic ``/rosdashboard/<tag>/<key>`` per key (recursively).

    Args:
        tag: topic name below ``/rosdashboard/``.
        data: the value.
        once: publish only the first call from this line.
        throttle: publish at most once per this many seconds from this line (per sub-topic).
        skip_first: drop the first call from this line.
    """
    opts = _begin("log", tag, once, throttle, skip_first)
    if opts is None:
        return
    try:
        clean = RUNTIME.resolve_tag(tag, "log")
        if clean is not None:
            _dispatch(clean, data, opts, 0)
    except _PASS_THROUGH:
        raise
    except Exception as exc:
        _unexpected("log", tag, exc)


def _dispatch(clean: str, data: object, opts: _Options, depth: int) -> None:
    """Publish one value of `log` (recursing into dicts)."""
    if isinstance(data, Mapping):
        if depth >= _MAX_DEPTH:
            REPORTER.drop(
                "bad_value", f"{clean}:depth", f"dbglog.log({clean!r}): dicts nested deeper than {_MAX_DEPTH}"
            )
            return
        for key, value in list(data.items()):
            text = f"{unescape_tag(clean)}/{key if isinstance(key, str) else safe_repr(key)}"
            sub = RUNTIME.resolve_tag(text, "log")
            if sub is not None:
                _dispatch(sub, value, opts, depth + 1)
        return
    name = _scalar_name(data)
    if name is not None:
        _publish_scalar("log", None, clean, data, _std_type(name), opts, fast=False)
        return
    if is_message(data):
        _send_message(clean, data, opts, "log")
        return
    if isinstance(data, list | tuple | bytes | bytearray) or type(data).__name__ == "ndarray":
        try:
            msg = multiarray_message(data)
        except ConversionError as exc:
            REPORTER.drop(exc.reason, clean, f"dbglog.log({clean!r}): {exc}; value dropped")
            return
        _send_message(clean, msg, opts, "log")
        return
    REPORTER.drop(
        "bad_value",
        f"{clean}:{type(data).__name__}",
        f"dbglog.log({clean!r}): cannot publish a {type(data).__name__} ({safe_repr(data)}); "
        "use logdata() with a message type",
    )


def _scalar_name(data: object) -> str | None:
    """Return the std_msgs scalar type for a Python or numpy scalar, else None."""
    if type(data).__module__ == "numpy" and hasattr(data, "dtype") and getattr(data, "ndim", 1) == 0:
        return SCALAR_DTYPES.get(data.dtype.name)
    if isinstance(data, bool):
        return "Bool"
    if isinstance(data, int):
        return "Int64"
    if isinstance(data, float):
        return "Float64"
    if isinstance(data, str):
        return "String"
    return None


def init(*, node: Any = None) -> None:
    """Connect to ROS 2 now (otherwise the first logging call does it).

    Args:
        node: an rclpy ``Node`` to create dbglog's publishers on, in its namespace
            (``/robot1/rosdashboard/<tag>``); by default dbglog uses its own context and node (in the
            namespace of ``--ros-args -r __ns:=...``, else ``DBGLOG_NAMESPACE``) and never touches
            ``rclpy.init()``'s global context. Also call it in a forked child that should publish.

    Raises:
        TypeError: `node` is not an rclpy node.
        ValueError: the node's namespace cannot hold dbglog's topics (a ``rosdashboard`` part).
    """
    RUNTIME.init(node)


def shutdown() -> None:
    """Destroy dbglog's publishers, node and context now; a later call reconnects."""
    RUNTIME.shutdown()


def flush(timeout: float = 1.0) -> bool:
    """Wait until current subscribers acknowledged every message; return False on timeout.

    Args:
        timeout: the most seconds to wait in total.
    """
    try:
        return RUNTIME.flush(float(timeout) if math.isfinite(float(timeout)) else 1.0)
    except Exception:
        return False


def stats() -> Stats:
    """Return dbglog's counters: calls, published, rate-limited and dropped values per reason.

    Values still queued are published first (for at most 30 s), so the counts add up.
    """
    with contextlib.suppress(Exception):  # the counters are still worth returning
        RUNTIME.pipe.drain(_STATS_DRAIN_SECONDS)
    return REPORTER.stats(len(RUNTIME.channels))


def reset() -> None:
    """Disconnect and zero all counters, warnings and rate-control state (for tests)."""
    RUNTIME.shutdown()
    RUNTIME.forget_tags()
    _LIMITER.clear()
    REPORTER.reset()


# ----- the compiled hot path ----------------------------------------------------------------------

_NATIVE = _native.load()
hot_path = "C" if _NATIVE is not None else "Python"
"""Which implementation runs the common case of logfloat/logint/logbool/logstring."""


def _hot(native: Any, slow: Any, kind: int, table: dict[object, Channel]) -> Any:
    """Wrap `slow` in the compiled hot path (`kind`: 0 float, 1 int, 2 bool, 3 str; `table`: known tags)."""
    hot = native.HotCall(
        slow,
        kind,
        table,
        _queue,
        _PIPE,
        REPORTER.calls.counter,
        REPORTER.rate_limited.counter,
        _LIMITER.clock,
        MAX_STRING_CHARS,
        channel_type=Channel,
        site_type=SiteState,
    )
    return functools.update_wrapper(hot, slow)


if not TYPE_CHECKING and _NATIVE is not None:
    logfloat = _hot(_NATIVE, logfloat, 0, _fast_float)
    logint = _hot(_NATIVE, logint, 1, _fast_int)
    logbool = _hot(_NATIVE, logbool, 2, _fast_bool)
    logstring = _hot(_NATIVE, logstring, 3, _fast_str)
