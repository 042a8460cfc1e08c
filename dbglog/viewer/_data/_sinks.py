"""A binding's sink: its field, regex and transforms resolved against a message type, and the feeding.

The engine (live ROS topics) and a replay (a recording's history) turn messages into a binding's
values with the same code: `make_sink` resolves a binding once per topic type, `feed` extracts from
typed messages, `feed_numbers` takes a column already decoded from CDR, `backfill` feeds a new binding
the past its topic has in a `History`. A binding with a stateful transform (derivative, moving average,
unwrap) gets its samples in source time order, whatever the arrival order (`Reorder`, `release`). No Dear
PyGui; rclpy only to deserialize a payload.
"""

from __future__ import annotations

import bisect
import logging
import math
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from dbglog._regex._compile import CompiledRegex, RegexError, compile_regex, parse_number
from dbglog._ros._cdr import decode_fixed
from dbglog._ros._loglevels import node_matches
from dbglog._ros._numbers import NumberType, as_number
from dbglog.viewer._data._fields import FieldPathError, Resolved, parse_path, resolve
from dbglog.viewer._data._history import History
from dbglog.viewer._data._logstore import LOG_TYPE, level_of
from dbglog.viewer._data._model import Binding, ValueKind
from dbglog.viewer._data._series import Series
from dbglog.viewer._values._transforms import (
    Derivative,
    MovingAverage,
    TransformChain,
    TransformError,
    Unwrap,
)

__all__ = [
    "LineFilter",
    "Reorder",
    "Sink",
    "as_received",
    "backfill",
    "break_sink",
    "feed",
    "feed_numbers",
    "flush",
    "make_sink",
    "number_type",
    "release",
    "same_values",
    "scalar_plan",
]

_log = logging.getLogger("dbglog.viewer.engine")
_FAIL_STREAK = 5
"""A binding's transforms that yield NaN with a reason this many samples in a row put it in ERROR."""
_STATEFUL = (Derivative, MovingAverage, Unwrap)
"""Transforms whose output depends on the samples before: they must see them in source time order."""
_REORDER_MAX_S = 0.5
"""The longest a stateful transform's sample waits for older ones that may still arrive."""
_REORDER_DECAY_S = 10.0
"""A wait not needed for this long (no sample arrived too late) is halved."""


@dataclass(eq=False, slots=True, weakref_slot=True)
class Sink:
    """One binding fed by a topic subscription."""

    binding: Binding
    series: Series
    regex: CompiledRegex | None
    resolved: Resolved | None = None
    kind: ValueKind | None = None
    skip_until_ns: int = 0
    """After a re-subscription, messages up to this source stamp were already taken (re-sent history)."""
    chain: TransformChain | None = None
    """The binding's transforms with this sink's own state (derivative, average, unwrap)."""
    extra: dict[str, Resolved] = field(default_factory=dict)
    """Other fields of the same message that the formulas read, by path."""
    fail_streak: int = 0
    lines: LineFilter | None = None
    """A log binding's node and minimum level: only those lines give values."""
    reorder: Reorder | None = None
    """The transforms' input in source time order, when a transform is stateful."""


@dataclass(eq=False, slots=True)
class Reorder:
    """A stateful transform's input, put in source time order: what arrived, waiting for older samples.

    Two publishers of one tag (or a batch that comes late) deliver samples out of source time order, but a
    derivative, a moving average or an unwrap is only right over the samples in order. While the samples
    come in order they pass at once. Once one arrives older than a sample the transforms already took, it
    is left out (the transforms never go back in time) and from then on each sample waits `hold` seconds
    (of source time, or of arrival when nothing newer comes) for older ones: 1.5 times the lateness seen,
    at most `_REORDER_MAX_S`, halved after `_REORDER_DECAY_S` without a late sample.
    """

    hold: float = 0.0
    released: float = -math.inf
    """The newest source time the transforms have taken."""
    newest: float = -math.inf
    """The newest source time that arrived."""
    late_at: float = 0.0
    """When (monotonic) the wait was last lengthened or halved."""
    dropped: int = 0
    """Samples left out: they arrived after newer ones had been transformed."""
    times: list[float] = field(default_factory=list)
    """Waiting samples, by source time (ties in arrival order), with their values, fields and arrivals."""
    values: list[float] = field(default_factory=list)
    columns: dict[str, list[float]] = field(default_factory=dict)
    arrived: list[float] = field(default_factory=list)


@dataclass(eq=False, slots=True)
class LineFilter:
    """Which Log lines a binding reads (`Binding.node`, `Binding.level`), as a bridge rule's filters."""

    node: str
    """Logger name, exact or an fnmatch glob; empty: every node."""
    min_level: int
    seen: dict[str, bool] = field(default_factory=dict)
    """Logger name -> whether it passes (a glob is matched once per name)."""

    def keeps(self, msg: Any) -> bool:
        """Whether a Log message passes (its level, then its logger's name)."""
        if msg.level < self.min_level:
            return False
        if not self.node:
            return True
        name = msg.name
        passes = self.seen.get(name)
        if passes is None:
            passes = self.seen[name] = node_matches(name, self.node)
        return passes


def prepare(binding: Binding) -> tuple[CompiledRegex | None, TransformChain | None] | str:
    """Check a binding's field path and compile its regex and transforms once (live and replay alike).

    Returns the compiled regex and transform chain (None where the binding has none), or what is wrong
    in words: the series' ERROR reason.
    """
    try:
        parse_path(binding.field)
    except FieldPathError as exc:
        return str(exc)
    regex: CompiledRegex | None = None
    if binding.regex:
        try:
            regex = compile_regex(binding.regex)
        except RegexError as exc:
            return f"bad regex {binding.regex!r}: {exc}"
    chain: TransformChain | None = None
    if binding.transforms:
        try:  # a rejected list (`Invalid`) refuses with its reason
            chain = TransformChain(binding.transforms)
        except TransformError as exc:
            return f"bad transforms: {exc}"
    return regex, chain


def make_sink(
    binding: Binding,
    series: Series,
    cls: Any,
    msg_type: str,
    regex: CompiledRegex | None,
    chain: TransformChain | None,
) -> Sink:
    """Resolve one binding against the topic's type; any failure is that binding's error alone."""
    try:
        return _build_sink(binding, series, cls, msg_type, regex, chain)
    except Exception as exc:  # a binding must never take its topic's other bindings down
        _log.debug("viewer engine: binding %s failed", binding, exc_info=True)
        series.set_error(f"cannot bind {_describe(binding)} on {msg_type}: {exc}", msg_type=msg_type)
        return Sink(binding, series, None)


def _build_sink(
    binding: Binding,
    series: Series,
    cls: Any,
    msg_type: str,
    regex: CompiledRegex | None,
    chain: TransformChain | None,
) -> Sink:
    sink = Sink(binding, series, regex)
    if binding.node or binding.level:
        if msg_type != LOG_TYPE:
            series.set_error(
                f"a node or level filter applies to {LOG_TYPE} topics, not {msg_type}", msg_type=msg_type
            )
            return sink
        sink.lines = LineFilter(binding.node, level_of(binding.level))
    try:
        resolved = resolve(cls, binding.field)
    except FieldPathError as exc:
        series.set_error(str(exc), msg_type=msg_type)
        return sink
    kind = resolved.kind
    if sink.regex is not None:
        if kind != ValueKind.TEXT:
            series.set_error(
                f"a regex applies to text fields, but {resolved.path!r} is {resolved.leaf_type}",
                msg_type=msg_type,
            )
            return sink
        kind = ValueKind.NUMBER
    if chain is not None:
        if kind not in (ValueKind.NUMBER, ValueKind.BOOL):
            series.set_error(
                f"transforms apply to numbers, but {resolved.path!r} is {resolved.leaf_type}",
                msg_type=msg_type,
            )
            return sink
        for path in sorted(chain.fields):
            try:
                other = resolve(cls, path)
            except FieldPathError as exc:
                series.set_error(f"a formula reads {path!r}: {exc}", msg_type=msg_type)
                return sink
            if other.kind not in (ValueKind.NUMBER, ValueKind.BOOL):
                series.set_error(
                    f"a formula reads {path!r}, which is {other.leaf_type}, not a number",
                    msg_type=msg_type,
                )
                return sink
            sink.extra[path] = other
        sink.chain = chain.fresh()
        if any(isinstance(t, _STATEFUL) for t in chain.transforms):
            sink.reorder = Reorder()
        kind = ValueKind.NUMBER  # a transformed bool is a number
    sink.resolved = resolved
    sink.kind = kind
    return sink


def scalar_plan(cls: Any, msg_type: str) -> tuple[int, str] | None:
    """Return ``data``'s (offset, dtype) when `msg_type` is a one-field std_msgs number or bool."""
    if not msg_type.startswith("std_msgs/msg/"):
        return None
    try:
        resolved = resolve(cls, "")
    except FieldPathError:
        return None
    if resolved.kind not in (ValueKind.NUMBER, ValueKind.BOOL):
        return None
    return resolved.cdr


def same_values(sink: Sink, cls: Any, msg_type: str) -> bool:
    """True when a binding's values are its topic's own (a one-field std_msgs number, untouched).

    Such a series reads its past from the topic's history instead of keeping it twice.
    """
    if sink.resolved is None or sink.regex is not None or sink.chain is not None or sink.extra or sink.lines:
        return False
    plan = scalar_plan(cls, msg_type)
    return plan is not None and sink.resolved.cdr == plan


def backfill(store: History, name: str, cls: Any, sink: Sink) -> bool:
    """Feed a new binding its topic's past held in `store` (before any live message); True when it had one."""
    kind = store.kind(name)
    if kind is None or sink.resolved is None:
        return False
    try:
        if kind == "numbers":
            times, raw = store.range(name, -np.inf, np.inf)
            if not len(times) or sink.kind not in (ValueKind.NUMBER, ValueKind.BOOL):
                return False
            newest = raw[-1].item() if raw.dtype.kind in "iu" else None  # every digit, beyond 2**53 too
            feed_numbers(sink, times, raw.astype(np.float64, copy=False), as_received(times), newest=newest)
            return True
        times, payloads = store.payloads(name, -np.inf, np.inf)
        if not len(times):
            return False
        if sink.resolved.cdr is not None and sink.regex is None and not sink.extra and sink.lines is None:
            columns = decode_fixed(payloads, [sink.resolved.cdr])
            if columns is not None:
                feed_numbers(sink, times, columns[0], as_received(times))
                return True
        from rclpy.serialization import deserialize_message

        messages = [deserialize_message(b, cls) for b in payloads]
        feed(sink, messages, times.tolist(), as_received(times))
        return True
    except Exception as exc:  # this binding's error alone
        break_sink(sink, exc)
        return False


def as_received(times: npt.NDArray[np.float64]) -> float:
    """The monotonic time a sample as old as the newest of `times` would have been received at."""
    return time.monotonic() - max(0.0, time.time() - float(times[-1]))


def _describe(binding: Binding) -> str:
    """Name a binding's field for a message: ``field 'data.x'`` or ``the whole message``."""
    return f"field {binding.field.strip()!r}" if binding.field.strip() else "the whole message"


def break_sink(sink: Sink, exc: Exception) -> None:
    """Stop feeding a binding whose extraction raised; its series shows why (no traceback, once)."""
    _log.debug("viewer engine: binding %s failed", sink.binding, exc_info=True)
    where = sink.resolved.path if sink.resolved is not None else sink.binding.field
    sink.resolved = None
    sink.series.set_error(f"cannot read {where!r}: {type(exc).__name__}: {exc}")


def feed_numbers(
    sink: Sink,
    times: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    now: float,
    *,
    newest: int | None = None,
) -> None:
    """Push one binding's column of numbers decoded from raw CDR (transformed when it has transforms).

    `newest`: the last value exactly, when `values` rounded it (a 64-bit integer beyond 2**53).
    """
    if not len(values):
        return
    if sink.chain is not None:
        _push_transformed(sink, times, values, None, now)
    else:
        last = (
            newest
            if newest is not None and sink.kind != ValueKind.BOOL
            else as_number(values[-1], number_type(sink))
        )
        sink.series.push_numbers(times, values, last, now)


def number_type(sink: Sink) -> NumberType:
    """The Python type a numeric sink's field holds (bool, float for float and double, int otherwise)."""
    assert sink.resolved is not None
    if sink.kind == ValueKind.BOOL:
        return bool
    if sink.resolved.leaf_type in ("float", "double"):
        return float
    return int


def _number_or_nan(get: Any, msg: Any) -> float:
    """Read one numeric field for a formula; NaN when the message does not have it (short sequence)."""
    try:
        return float(get(msg))
    except (IndexError, AttributeError, TypeError, ValueError):
        return math.nan


def _transform(
    sink: Sink,
    times: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    columns: dict[str, list[float]] | None,
) -> npt.NDArray[np.float64]:
    """Apply the sink's transforms to a batch (its state carries over to the next batch)."""
    assert sink.chain is not None
    cols = {k: np.asarray(v, dtype=np.float64) for k, v in columns.items()} if columns else None
    return sink.chain.apply_array(times, values, cols)


def _check_failures(
    sink: Sink,
    out: npt.NDArray[np.float64],
    sample: tuple[float, float, dict[str, float]],
) -> None:
    """Put the series in ERROR when the transforms keep failing (NaN with a reason) sample after sample.

    `sample` is the batch's last input (time, value, other fields), re-run alone for a precise reason.
    """
    assert sink.chain is not None
    reason = sink.chain.last_error
    if reason is None or not len(out) or not math.isnan(out[-1]):
        sink.fail_streak = 0
        return
    good = np.flatnonzero(~np.isnan(out))
    trailing = len(out) - (int(good[-1]) + 1 if len(good) else 0)
    sink.fail_streak = trailing if len(good) else sink.fail_streak + trailing
    if sink.fail_streak >= _FAIL_STREAK:
        probe = sink.chain.fresh()
        probe.apply(*sample)
        sink.series.set_error(f"transform failed: {probe.last_error or reason}")


def feed(sink: Sink, messages: Iterable[Any], times: list[float], now: float) -> None:
    """Extract one binding's values from typed messages and push them to its series."""
    resolved = sink.resolved
    assert resolved is not None
    get = resolved.get
    regex = sink.regex
    values: list[Any] = []
    value_times: list[float] = []
    extra = list(sink.extra.items())
    columns: dict[str, list[float]] = {path: [] for path, _ in extra}
    error = ""
    unmatched = 0
    lines = sink.lines
    for msg, t in zip(messages, times, strict=True):
        if lines is not None and not lines.keeps(msg):
            continue
        try:
            value: Any = get(msg)
        except (IndexError, AttributeError, TypeError, ValueError) as exc:
            error = f"cannot read {resolved.path!r}: {exc}"
            continue
        if regex is not None:
            captured = regex.extract(value)
            if captured is None:
                unmatched += 1
                continue
            try:
                value = float(parse_number(captured))
            except ValueError:
                try:
                    value = float(parse_number(captured, "bool"))
                except ValueError:
                    error = f"the regex captured {captured!r}, which is not a number"
                    continue
        values.append(value)
        value_times.append(t)
        for path, other in extra:
            columns[path].append(_number_or_nan(other.get, msg))
        error = ""
    series = sink.series
    if values:
        if sink.kind == ValueKind.TEXT:
            series.push_texts(value_times, values, now)
        elif sink.kind == ValueKind.ARRAY:
            series.push_array(len(values), values[-1], value_times[-1], now)
        elif sink.chain is not None:
            t_arr = np.asarray(value_times, dtype=np.float64)
            _push_transformed(sink, t_arr, np.asarray(values, dtype=np.float64), columns, now)
        else:
            series.push_numbers(
                np.asarray(value_times, dtype=np.float64),
                np.asarray(values, dtype=np.float64),
                values[-1],
                now,
            )
    if error:
        series.set_error(error)
    elif unmatched and not values and series.count == 0:
        series.set_waiting(f"no message matched the regex {regex.pattern if regex else ''!r} yet")


def _push_transformed(
    sink: Sink,
    times: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    columns: dict[str, list[float]] | None,
    now: float,
) -> None:
    """Transform samples and push them (a stateful chain's in source time order: `Reorder`)."""
    reorder = sink.reorder
    if reorder is not None:
        if reorder.times or reorder.hold or times[0] <= reorder.released or _unsorted(times):
            _arrive(reorder, times, values, columns or {}, now)
            _release(sink, now)
            return
        reorder.released = reorder.newest = float(times[-1])  # in order, nothing waits: at once
    _transform_push(sink, times, values, columns, now)


def _unsorted(times: npt.NDArray[np.float64]) -> bool:
    """Whether a batch's source times go back somewhere."""
    return len(times) > 1 and bool((times[1:] < times[:-1]).any())


def _transform_push(
    sink: Sink,
    times: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    columns: dict[str, list[float]] | None,
    now: float,
) -> None:
    """Transform a batch (in the order given), push it to the series and watch for failing transforms."""
    out = _transform(sink, times, values, columns)
    sink.series.push_numbers(times, out, float(out[-1]), now)
    last_fields = {k: float(v[-1]) for k, v in columns.items()} if columns else {}
    _check_failures(sink, out, (float(times[-1]), float(values[-1]), last_fields))


def _arrive(
    reorder: Reorder,
    times: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    columns: dict[str, list[float]],
    now: float,
) -> None:
    """Put arriving samples among the waiting ones by source time; leave out those that came too late."""
    t_list: list[float] = times.tolist()
    v_list: list[float] = values.tolist()
    released = reorder.released
    late = [t for t in t_list if t <= released]
    if late:
        reorder.dropped += len(late)
        reorder.hold = min(_REORDER_MAX_S, max(reorder.hold, 1.5 * (released - min(late))))
        reorder.late_at = now
    waiting = reorder.times
    for name in columns:
        reorder.columns.setdefault(name, [math.nan] * len(waiting))
    for i, t in enumerate(t_list):
        if t <= released:
            continue
        at = bisect.bisect_right(waiting, t)
        waiting.insert(at, t)
        reorder.values.insert(at, v_list[i])
        reorder.arrived.insert(at, now)
        for name, column in reorder.columns.items():
            given = columns.get(name)
            column.insert(at, float(given[i]) if given is not None else math.nan)
        if t > reorder.newest:
            reorder.newest = t


def release(sink: Sink, now: float) -> None:
    """Transform and push a stateful binding's samples that waited long enough (the engine, every cycle)."""
    if sink.reorder is not None and sink.reorder.times and sink.resolved is not None:
        _release(sink, now)


def flush(sink: Sink, now: float) -> None:
    """Transform and push a stateful binding's waiting samples at once, whatever their wait: the sink is
    let go (its topic is read another way now), so no older sample can come to it, and what waited in it
    would be lost without a word."""
    reorder = sink.reorder
    if reorder is None or not reorder.times or sink.resolved is None:
        return
    reorder.hold = 0.0
    try:
        _release(sink, now)
    except Exception as exc:  # this binding's error alone
        break_sink(sink, exc)


def _release(sink: Sink, now: float) -> None:
    """Transform and push, in source time order, the waiting samples whose wait is over."""
    reorder = sink.reorder
    assert reorder is not None
    if reorder.hold and now - reorder.late_at > _REORDER_DECAY_S:
        reorder.hold = reorder.hold / 2 if reorder.hold > 0.002 else 0.0
        reorder.late_at = now
    waiting = reorder.times
    if not waiting:
        return
    if reorder.hold:
        # Due: older than the newest arrival by the wait, or waited that long (nothing newer came). An
        # earlier sample goes with a due one: the order is all that matters.
        edge = reorder.newest - reorder.hold
        since = now - reorder.hold
        n = 0
        for i, (t, arrived) in enumerate(zip(waiting, reorder.arrived, strict=True)):
            if t <= edge or arrived <= since:
                n = i + 1
        if n == 0:
            return
    else:
        n = len(waiting)
    times = np.asarray(waiting[:n], dtype=np.float64)
    values = np.asarray(reorder.values[:n], dtype=np.float64)
    columns = {name: column[:n] for name, column in reorder.columns.items()} or None
    del waiting[:n], reorder.values[:n], reorder.arrived[:n]
    for column in reorder.columns.values():
        del column[:n]
    reorder.released = float(times[-1])
    _transform_push(sink, times, values, columns, now)
