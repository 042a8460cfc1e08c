"""The compiled hot path (``dbglog/api/_hot.c``) does exactly what the Python functions it wraps do."""

from __future__ import annotations

import gc
import inspect
import itertools
import math
import os
import re
import subprocess
import sys
import time
import warnings
from collections import deque
from collections.abc import Callable
from itertools import count
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import dbglog
from dbglog.api import _native, _public
from dbglog.api._convert import MAX_STRING_CHARS
from dbglog.api._hot import HotCall
from dbglog.api._public import REPORTER, RUNTIME
from dbglog.api._rate import SiteState

FUNCTIONS = ("logfloat", "logint", "logbool", "logstring")
LONG = "x" * (MAX_STRING_CHARS + 1)
VALUE_LIST: list[object] = [
        0.5, -0.0, math.nan, math.inf, 3, -(2**63), 2**63 - 1, 2**63, -(2**63) - 1, 2**70, True, False,
        "ascii", "", "été", "a\x00b", "\ud800", LONG, np.float64(1.5), np.int32(3), None, 1 + 2j, [1.0],
]  # fmt: skip
OPTION_LIST: list[dict[str, object]] = [
        {}, {}, {}, {"throttle": 3600.0}, {"throttle": 3600.0}, {"throttle": 0.0}, {"throttle": 3600},
        {"throttle": -1.0}, {"throttle": math.inf}, {"throttle": math.nan}, {"throttle": None},
        {"throttle": "often"}, {"once": True}, {"skip_first": True}, {"throttle": 3600.0, "once": False},
        {"msg_type": None}, {"msg_type": "std_msgs/msg/Float32"}, {"msg_type": "std_msgs/msg/Int8"},
]  # fmt: skip
FIRST = {"logfloat": 1.0, "logint": 1, "logbool": True, "logstring": "first"}
"""A value each function publishes: a tag's first call, which makes it known to the hot path."""
VALUES = st.sampled_from(VALUE_LIST)
OPTIONS = st.sampled_from(OPTION_LIST)
TAGS = st.sampled_from(["a", "b/c", "bad tag!", "", ["unhashable"]])
CALLS = st.lists(st.tuples(st.sampled_from(FUNCTIONS), TAGS, VALUES, OPTIONS), min_size=1, max_size=30)

_runs = itertools.count()


def _counts(before: dbglog.Stats, after: dbglog.Stats) -> tuple[object, ...]:
    reasons = set(before.dropped_by_reason) | set(after.dropped_by_reason)
    dropped = {
        r: after.dropped_by_reason.get(r, 0) - before.dropped_by_reason.get(r, 0) for r in sorted(reasons)
    }
    return (
        after.calls - before.calls,
        after.published - before.published,
        after.rate_limited - before.rate_limited,
        {r: n for r, n in dropped.items() if n},
    )


def _run(calls: list[tuple[str, Any, object, dict[str, object]]], compiled: bool) -> tuple[object, ...]:
    """Make `calls` (each tag in a namespace of its own) through the C or the Python functions.

    Returns the counters' changes and what was queued, as (tag, value, type) in order. The publisher
    thread is kept off the queue meanwhile (it drains only under the pipe's lock).
    """
    prefix = f"hot{next(_runs)}/"
    functions: dict[str, Callable[..., None]] = {}
    for name in FUNCTIONS:
        hot = getattr(_public, name)
        assert isinstance(hot, HotCall)
        functions[name] = hot if compiled else hot.slow
    pipe = RUNTIME.pipe
    before = REPORTER.stats(0)
    t0 = time.time_ns()
    with pipe.lock, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, tag, value, options in calls:
            functions[name](prefix + tag if isinstance(tag, str) else tag, value, **options)
        items = list(pipe.queue)
        pipe.queue.clear()
    t1 = time.time_ns()
    after = REPORTER.stats(0)
    stamps = [t for _, _, t in items]
    assert all(t0 <= t <= t1 for t in stamps), "a source time outside the calls"
    assert stamps == sorted(stamps), "source times out of order"
    queued = [(re.sub(r"^hot\d+", "hot", ch.tag), repr(v), type(v).__name__) for ch, v, _ in items]
    return _counts(before, after), queued


def test_the_compiled_hot_path_is_built_and_bound() -> None:
    """This install compiled ``_hot.c`` (setup needs a C compiler) and the four functions are wrapped."""
    assert _public.hot_path == "C", "dbglog/api/_hot.c was not compiled: run .ci/setup.sh (needs cc)"
    for name in FUNCTIONS:
        hot = getattr(dbglog, name)
        assert isinstance(hot, HotCall)
        assert hot.__name__ == name
        assert hot.__doc__ == hot.slow.__doc__
        assert inspect.signature(hot) == inspect.signature(hot.slow)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(calls=CALLS)
def test_c_and_python_functions_queue_and_count_the_same(
    calls: list[tuple[str, Any, object, dict[str, object]]],
) -> None:
    """Any sequence of calls (known and new tags, every value type, options good and bad): the same
    samples queued in the same order, the same calls, publishes, holds and drops per reason."""
    assert _run(calls, compiled=True) == _run(calls, compiled=False)


def test_every_value_and_option_on_a_known_tag_goes_the_same_way_in_c_and_python() -> None:
    """Each function, each option set: a tag made known by a plain call (and its call line's throttle,
    or not), then every kind of value with those options (too-long, non-ASCII and NUL strings,
    out-of-range and numpy numbers, wrong types)."""
    primed: dict[str, object] = {"throttle": 3600.0}  # the call line's rate control known to the hot path
    for name, options, prime in itertools.product(FUNCTIONS, OPTION_LIST, (False, True)):
        calls: list[tuple[str, Any, object, dict[str, object]]] = [(name, "k", FIRST[name], {})]
        if prime:
            calls.append((name, "k", FIRST[name], primed))
        calls += [(name, "k", v, options) for v in VALUE_LIST]
        assert _run(calls, compiled=True) == _run(calls, compiled=False), (name, options, prime)


def test_a_throttled_call_is_held_back_in_c_and_counted_like_python() -> None:
    """A known tag throttled from one line: its first call passes, the other 99 are held back."""
    for compiled in (True, False):
        calls: list[tuple[str, Any, object, dict[str, object]]] = [
            ("logstring", "t", f"v{i}", {"throttle": 3600.0}) for i in range(100)
        ]
        counts, queued = _run(calls, compiled)
        assert counts == (100, 0, 99, {})
        assert queued == [("hot/t", "'v0'", "str")]


def _hot(pipe: object, slow: Callable[..., None]) -> tuple[HotCall, deque[Any]]:
    queue: deque[Any] = deque()
    table: dict[object, object] = {"t": "channel"}
    return HotCall(slow, 0, table, queue, pipe, count(), count(), time.monotonic, 10), queue


def test_the_c_path_queues_wakes_and_falls_back_to_the_python_function() -> None:
    """Known tag and float: queued with a source time, the sleeping thread woken; anything else (a full
    queue, another type, an unknown tag, an option, a third argument) is the Python function's call."""
    woken: list[int] = []
    slow_calls: list[tuple[tuple[object, ...], dict[str, object]]] = []
    pipe = SimpleNamespace(capacity=2, sleeping=True, wake=lambda: woken.append(1))
    hot, queue = _hot(pipe, lambda *a, **k: slow_calls.append((a, k)))
    hot("t", 1.5)
    assert [(c, v) for c, v, _ in queue] == [("channel", 1.5)]
    assert abs(queue[0][2] - time.time_ns()) < 5e9
    assert woken == [1]
    pipe.sleeping = False
    hot("t", 2.5)
    assert woken == [1]
    hot("t", 3.5)  # the queue holds its capacity
    hot("t", 4)
    hot("u", 1.0)
    hot("t", 1.0, once=True)
    hot("t", 1.0, None)
    assert len(queue) == 2
    assert slow_calls == [
        (("t", 3.5), {}),
        (("t", 4), {}),
        (("u", 1.0), {}),
        (("t", 1.0), {"once": True}),
        (("t", 1.0, None), {}),
    ]


def test_the_c_path_never_raises_into_the_caller() -> None:
    """A pipe whose attributes fail, an unhashable tag, a failing wake: the call returns None."""

    class Broken:
        capacity = 10

        @property
        def sleeping(self) -> bool:
            raise RuntimeError("no")

    slow_calls: list[object] = []
    hot, queue = _hot(Broken(), lambda *a, **k: slow_calls.append(a))
    hot("t", 1.0)  # queued; then reading `sleeping` fails, inside the C path
    assert len(queue) == 1

    def fail() -> None:
        raise OSError("wake failed")

    hot, queue = _hot(
        SimpleNamespace(capacity=10, sleeping=True, wake=fail), lambda *a, **k: slow_calls.append(a)
    )
    hot("t", 1.0)
    assert len(queue) == 1
    unhashable: Any = ["t"]
    hot(unhashable, 1.0)  # the dict lookup fails: the Python function's call
    assert slow_calls == [(["t"], 1.0)]


def test_slots_the_c_path_reads_in_place_still_fail_over_to_the_python_function() -> None:
    """A pipe whose slotted ``capacity`` was never set, or a channel of another type than the one given:
    the Python function's call (the C path reports nothing and raises nothing)."""
    slow_calls: list[object] = []
    pipe = _SlotPipe(10)
    del pipe.capacity
    hot = HotCall(lambda *a, **k: slow_calls.append(a), 0, {"t": "ch"}, deque(), pipe, count(), count(),
                  time.monotonic, 10, channel_type=_SlotChannel, site_type=SiteState)  # fmt: skip
    hot("t", 1.0)
    assert slow_calls == [("t", 1.0)]
    pipe.capacity = 10
    hot("t", 2.0)  # queued in C
    hot("t", 3.0, throttle=1.0)  # "ch" is a str, not a _SlotChannel: read generically, no rate_site
    assert slow_calls == [("t", 1.0), ("t", 3.0)]


def test_the_c_path_leaks_no_reference() -> None:
    """Ten thousand queued calls and a cleared queue leave the channel, the value and the tag as before."""
    channel = object()
    value = 0.25
    tag = "t"
    queue: deque[Any] = deque()
    pipe = SimpleNamespace(capacity=100_000, sleeping=False, wake=lambda: None)
    hot = HotCall(lambda *a, **k: None, 0, {tag: channel}, queue, pipe, count(), count(), time.monotonic, 10)
    gc.collect()
    before = (sys.getrefcount(channel), sys.getrefcount(value), sys.getrefcount(tag))
    for _ in range(10_000):
        hot(tag, value)
    queue.clear()
    assert (sys.getrefcount(channel), sys.getrefcount(value), sys.getrefcount(tag)) == before


_BOUND_PROBE = """
import sys, dbglog
names = ("log", "logfloat", "logint", "logbool", "logstring", "logdata")
print(sorted({type(getattr(dbglog, n)).__name__ for n in names}), "dbglog.api._hot" in sys.modules)
"""


def _bound(**env: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", _BOUND_PROBE],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_dbglog_pure_python_keeps_the_python_functions_on_and_off() -> None:
    """Switched on, the scalar functions are compiled (log and logdata stay Python); switched off, every
    logging function is a compiled no-op; ``DBGLOG_PURE_PYTHON=1`` binds the Python functions either way
    and does not import the compiled module."""
    assert _bound(DBGLOG="on") == "['HotCall', 'function'] True"
    assert _bound(DBGLOG="off") == "['NoOp'] True"
    assert _bound(DBGLOG="on", **{_native.HOT_PATH_ENV: "1"}) == "['function'] False"
    assert _bound(DBGLOG="off", **{_native.HOT_PATH_ENV: "1"}) == "['function'] False"


class _SlotChannel:
    __slots__ = ("rate_site",)

    def __init__(self) -> None:
        self.rate_site: object = None


class _SlotPipe:
    __slots__ = ("capacity", "sleeping", "wake")

    def __init__(self, capacity: int) -> None:
        self.capacity = capacity
        self.sleeping = False
        self.wake: Callable[[], None] = lambda: None


@pytest.mark.parametrize("slots", [False, True], ids=["attributes", "slots"])
def test_the_c_path_holds_back_by_the_callers_instruction_and_the_rate_limiters_clock(slots: bool) -> None:
    """A throttled call is held back in C only from the instruction the Python path recorded (the
    caller's code object and ``f_lasti``, read without a frame object), timed by the limiter's clock;
    the same whether the channel, the site state and the pipe keep these in ``__slots__`` (read in place
    when their types are given) or in a ``__dict__``."""
    now = [100.0]
    state: Any = SiteState(calls=1) if slots else SimpleNamespace(calls=1, last_pass=-math.inf)
    channel: Any = _SlotChannel() if slots else SimpleNamespace(rate_site=None)
    passed: list[float] = []

    def slow(tag: str, value: float, **options: object) -> None:  # what _public._rate records
        caller = sys._getframe(1)
        channel.rate_site = (caller.f_code, caller.f_lasti, state, ("file", 0))
        state.last_pass = now[0]
        passed.append(value)

    calls, limited = count(), count()
    pipe: Any = _SlotPipe(100) if slots else SimpleNamespace(capacity=100, sleeping=False, wake=lambda: None)
    types: dict[str, Any] = {"channel_type": _SlotChannel, "site_type": SiteState} if slots else {}
    hot = HotCall(slow, 0, {"t": channel}, deque(), pipe, calls, limited, lambda: now[0], 10, **types)
    for i in range(3):  # one instruction: the first call passes (Python), the next two are held back (C)
        hot("t", float(i), throttle=1.0)
    hot("t", 9.0, throttle=1.0)  # another instruction: the Python path decides
    now[0] += 2.0
    for i in range(3, 5):  # the period is over: the Python path passes it, then C holds back again
        hot("t", float(i), throttle=1.0)
    assert passed == [0.0, 9.0, 3.0]
    assert state.calls == 1 + 3
    assert (next(calls), next(limited)) == (3, 3)
