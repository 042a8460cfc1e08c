"""The viewer's parameter service: what a widget bound to a node's parameter shows, and how it sets it.

`ParamBoard` keeps an entry per parameter a widget asks about (``/pid_node:kp``): its descriptor (asked
once with `ParamClient.describe`: type, range and step, read-only), its value (the events store's, which
``/parameter_events`` keeps current; a get when the store has none yet) and the sets sent, with the node's
answers (a rejection keeps its reason). A dragged control's values go out at most `rate_hz` a second and
through `ParamClient.set_latest`, so the last one always does. Nothing here waits on a node: calls return
futures that `tick` looks at once a frame, on the UI thread; a node that does not answer costs its widget an
error saying so, and is asked again later. Paused at a time, the value is the one the events say the
parameter had then, and nothing is editable. No Dear PyGui here.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Final

from dbglog._ros._params import (
    ParamDescriptor,
    ParamRange,
    ParamType,
    ParamValue,
    SetResult,
    coerce,
    join_name,
    parse_value,
    split_name,
)
from dbglog.viewer._data._events import EventStore
from dbglog.viewer._data._model import Status
from dbglog.viewer._publishing._requests import DEFAULT_RATE_LIMIT_HZ

if TYPE_CHECKING:
    from dbglog._ros._paramclient import ParamClient

__all__ = ["HOLD_S", "RETRY_S", "ParamBoard", "ParamState"]

RETRY_S: Final = 5.0
"""Seconds before a node that could not be asked (not there, no answer) is asked again."""
HOLD_S: Final = 1.0
"""After the node accepted a value, the widget shows it for at most this long while the node's own value
(its ``/parameter_events``, a moment behind the answer) still says the one before."""


@dataclass(frozen=True, slots=True)
class ParamState:
    """What a widget bound to a node's parameter shows: its value (at the time cursor), how it may be set,
    and its status and note.

    `version` changes whenever anything else here does: a widget redraws when it moved.
    """

    target: str
    """The binding as written, ``/pid_node:kp``."""
    status: Status
    reason: str = ""
    """Why the status is what it is (the widget's pill tooltip): the node's error, what is awaited."""
    value: ParamValue | None = None
    """The value shown: the node's (live), the one it had at the cursor (paused), None while unknown."""
    descriptor: ParamDescriptor | None = None
    """What the node says of the parameter (type, range and step, read-only), None until it answered."""
    editable: bool = False
    """Whether a set may be sent now: live, described, not read-only."""
    note: str = ""
    """One line for under the control: why it is not editable, or the last set's outcome."""
    problem: bool = False
    """The note is a problem (a rejection, a failed set, a value that cannot be the parameter's type)."""
    version: int = 0

    @property
    def node(self) -> str:
        """The node, fully qualified."""
        return split_name(self.target)[0]

    @property
    def name(self) -> str:
        """The parameter's name."""
        return split_name(self.target)[1]

    @property
    def range(self) -> ParamRange | None:
        """The descriptor's range and step (None: any value)."""
        return self.descriptor.range if self.descriptor is not None else None

    @property
    def type(self) -> ParamType:
        """The parameter's type: the descriptor's, else the value's (NOT_SET while neither is known)."""
        if self.descriptor is not None and self.descriptor.type is not ParamType.NOT_SET:
            return self.descriptor.type
        return self.value.type if self.value is not None else ParamType.NOT_SET

    @property
    def read_only(self) -> bool:
        """Whether the node says the parameter is read-only."""
        return self.descriptor is not None and self.descriptor.read_only

    @property
    def number(self) -> float | None:
        """The value as a number (an integer or double parameter; a bool as 0 or 1), None otherwise."""
        value = None if self.value is None else self.value.value
        if isinstance(value, bool):
            return 1.0 if value else 0.0
        if isinstance(value, int | float):
            return float(value)
        return None

    def typed(self, value: object) -> ParamValue:
        """`value` as this parameter would take it: of its type (an integer rounded, a double widened), a
        number on its range's grid (`ParamRange.snap`).

        Raises:
            ValueError: the value cannot be of the parameter's type (the message says so).
        """
        ptype = self.type
        if ptype is ParamType.NOT_SET:
            return ParamValue.of(value)
        span = self.range
        if span is not None and ptype in (ParamType.INTEGER, ParamType.DOUBLE):
            if isinstance(value, ParamValue):
                value = value.value
            if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
                value = span.snap(float(value))
        return coerce(value, ptype)

    def parse(self, text: str) -> ParamValue:
        """Typed text as a value of this parameter, read as ``ros2 param set`` reads it: a string parameter
        takes the text as it is, a double one an integer too (widened); the range is the node's to judge.

        Raises:
            ValueError: the text is a value of another type (the message names both).
        """
        ptype = self.type
        if ptype is ParamType.STRING:
            return ParamValue(ParamType.STRING, text)
        parsed = parse_value(text)
        dynamic = self.descriptor is not None and self.descriptor.dynamic_typing
        if ptype is ParamType.NOT_SET or parsed.type is ptype or dynamic:
            return parsed
        widened = {ParamType.INTEGER: ParamType.DOUBLE, ParamType.INTEGER_ARRAY: ParamType.DOUBLE_ARRAY}
        if widened.get(parsed.type) is ptype or (parsed.type is ParamType.BOOL_ARRAY and not parsed.value):
            return coerce(parsed, ptype)
        raise ValueError(f"{text.strip()!r} is {parsed.type.article}, not {ptype.article}")


@dataclass(eq=False)
class _Entry:
    """One parameter a widget shows: what was asked of its node and what was sent to it (UI thread)."""

    node: str
    name: str
    descriptor: ParamDescriptor | None = None
    got: ParamValue | None = None
    """The value a get answered (used while the events store has none)."""
    describing: Future[dict[str, ParamDescriptor]] | None = None
    getting: Future[dict[str, ParamValue]] | None = None
    asked_at: float = -math.inf
    error: str = ""
    """Why the node could not be asked (its last call's error), "" when it answered."""
    missing: bool = False
    """The error is the node not being on the graph (waiting for it, rather than an error)."""
    retry_at: float = math.inf
    sending: list[Future[SetResult]] = field(default_factory=list)
    pending: ParamValue | None = None
    """A dragged value held back by the rate limit (sent by `tick` when due)."""
    rate_hz: float = DEFAULT_RATE_LIMIT_HZ
    sent_at: float = -math.inf
    shown: ParamValue | None = None
    """The value the user set last, shown until the node's value says it or the set ends otherwise."""
    shown_until: float = math.inf
    outcome: str = ""
    """The last set's outcome when it was not taken (a rejection and its reason, a failure)."""
    changes: int = 0
    """Counts what changed here (part of the state's version)."""


class ParamBoard:
    """The parameter service of one viewer: the widgets' parameters, asked, followed and set (UI thread).

    Args:
        client: the parameter client (None: no ROS, a recording: values from the events only, read-only).
        events: returns the current data source's events store (None while it keeps none).
        cursor: returns the time cursor (None while live).
        live: returns whether the data source is the live graph (False for a recording).
        clock: the monotonic clock (tests give their own).
        retry_s: seconds before a node that could not be asked is asked again.
    """

    def __init__(
        self,
        client: ParamClient | None,
        events: Callable[[], EventStore | None],
        cursor: Callable[[], float | None],
        *,
        live: Callable[[], bool] = lambda: True,
        clock: Callable[[], float] = time.monotonic,
        retry_s: float = RETRY_S,
    ) -> None:
        self.client = client
        self._events, self._cursor, self._live = events, cursor, live
        self._clock = clock
        self.retry_s = retry_s
        self._entries: dict[str, _Entry] = {}
        self._states: dict[str, tuple[tuple[object, ...], ParamState]] = {}
        self._versions = 0

    # -- what widgets call ----------------------------------------------------------------------------

    def state(self, target: str) -> ParamState:
        """What a widget bound to `target` (``/pid_node:kp``) shows now; its first call asks the node."""
        try:
            node, name = split_name(target)
        except ValueError as exc:
            return ParamState(target, Status.ERROR, str(exc))
        entry = self._entry(node, name)
        store = self._events()
        cursor = self._cursor()
        live = self._live() and self.client is not None
        known = store.value(node, name) if store is not None else None
        then = store.value_at(node, name, cursor) if store is not None and cursor is not None else None
        now = self._clock()
        holding = entry.shown is not None and (bool(entry.sending) or now < entry.shown_until)
        key = (entry.changes, known, then, cursor, live, holding)
        cached = self._states.get(target)
        if cached is not None and cached[0] == key:
            return cached[1]
        self._versions += 1
        state = self._make(target, entry, known, then, cursor, live, holding)
        self._states[target] = (key, state)
        return state

    def set(self, target: str, value: object, *, final: bool, rate_hz: float = DEFAULT_RATE_LIMIT_HZ) -> None:
        """Set `target` to `value` (made the parameter's type, on its range's grid). While dragged (not
        `final`) at most `rate_hz` values a second go out (the newest waits); a `final` one goes now. Nothing
        is sent while the state is not editable. Never blocks: the node's answer comes with a later `tick`."""
        state = self.state(target)
        if not state.editable or self.client is None:
            return
        entry = self._entry(state.node, state.name)
        try:
            typed = state.typed(value)
        except ValueError as exc:
            entry.outcome = f"not set: {exc}"
            entry.changes += 1
            return
        now = self._clock()
        entry.rate_hz = max(0.1, float(rate_hz))
        if self._asked_already(entry, typed):
            return  # the same value again (a drag that stays on one step, its release): nothing to change
        entry.shown, entry.shown_until, entry.outcome = typed, math.inf, ""
        entry.changes += 1
        if final or now - entry.sent_at >= 1.0 / entry.rate_hz:
            self._send(entry, typed, now)
        else:
            entry.pending = typed

    def _asked_already(self, entry: _Entry, value: ParamValue) -> bool:
        """Whether setting `value` would change nothing: it waits already, it is the newest sent and not
        answered yet, or (nothing under way) the node has it."""
        if entry.pending is not None:
            return entry.pending == value
        if entry.sending:
            return entry.shown == value
        store = self._events()
        current = store.value(entry.node, entry.name) if store is not None else None
        return (current if current is not None else entry.got) == value

    def tick(self) -> bool:
        """Once a frame (UI thread): take the nodes' answers, send what the rate limit held, ask again the
        nodes that could not be asked. Returns whether anything a widget shows may have changed."""
        now = self._clock()
        changed = False
        for entry in list(self._entries.values()):
            before = entry.changes
            self._take_answers(entry, now)
            if entry.pending is not None and now - entry.sent_at >= 1.0 / entry.rate_hz:
                self._send(entry, entry.pending, now)
            idle = entry.describing is None and entry.getting is None
            if idle and ((entry.error and now >= entry.retry_at) or self._unasked(entry)):
                self._ask(entry, now)  # again after a failure; or first, live again after a recording
            if entry.shown is not None and not entry.sending and now >= entry.shown_until:
                entry.shown = None
                entry.changes += 1
            changed = changed or entry.changes != before
        return changed

    # -- inside ------------------------------------------------------------------------------------------

    def _entry(self, node: str, name: str) -> _Entry:
        target = join_name(node, name)
        entry = self._entries.get(target)
        if entry is None:
            entry = self._entries[target] = _Entry(node, name)
            if self.client is not None and self._live():
                self._ask(entry, self._clock())
        return entry

    def _unasked(self, entry: _Entry) -> bool:
        """Whether `entry` was never asked though it could be now (it came while a recording was shown)."""
        return not math.isfinite(entry.asked_at) and self.client is not None and self._live()

    def _ask(self, entry: _Entry, now: float) -> None:
        """Ask the node for the descriptor (and the value, when the events store has none)."""
        client = self.client
        if client is None:
            return
        entry.asked_at, entry.retry_at = now, math.inf
        if entry.descriptor is None:
            entry.describing = client.describe(entry.node, [entry.name])
        store = self._events()
        if entry.got is None and (store is None or store.value(entry.node, entry.name) is None):
            entry.getting = client.get(entry.node, [entry.name])
        entry.changes += 1

    def _take_answers(self, entry: _Entry, now: float) -> None:
        from dbglog._ros._paramclient import NodeNotFoundError

        for attr in ("describing", "getting"):
            future = getattr(entry, attr)
            if future is None or not future.done():
                continue
            setattr(entry, attr, None)
            entry.changes += 1
            error = None if future.cancelled() else future.exception()
            if error is None and not future.cancelled():
                answer = future.result()
                if attr == "describing":
                    entry.descriptor = answer.get(entry.name)
                else:
                    entry.got = answer.get(entry.name)
                if entry.describing is None and entry.getting is None:
                    entry.error, entry.missing = "", False
            else:
                entry.error = str(error) if error is not None else "the call was cancelled"
                entry.missing = isinstance(error, NodeNotFoundError)
                entry.retry_at = now + self.retry_s
        done = [f for f in entry.sending if f.done()]
        for future in done:
            entry.sending.remove(future)
            entry.changes += 1
            if future.cancelled():  # a newer value replaced it before it was sent
                continue
            error = future.exception()
            if error is not None:
                entry.outcome = f"not set: {error}"
                entry.shown = None
                continue
            result = future.result()
            if result.ok:
                entry.outcome = ""
                if not entry.sending and entry.pending is None:
                    entry.shown_until = now + HOLD_S
            else:
                reason = result.reason or "no reason given"
                entry.outcome = f"rejected {result.value.text}: {reason}"
                if not entry.sending and entry.pending is None:
                    entry.shown = None

    def _send(self, entry: _Entry, value: ParamValue, now: float) -> None:
        client = self.client
        if client is None:
            return
        entry.pending, entry.sent_at = None, now
        try:
            entry.sending.append(client.set_latest(entry.node, entry.name, value))
        except ValueError as exc:
            entry.outcome = f"not set: {exc}"
        entry.changes += 1

    def _make(
        self,
        target: str,
        entry: _Entry,
        known: ParamValue | None,
        then: ParamValue | None,
        cursor: float | None,
        live: bool,
        holding: bool,
    ) -> ParamState:
        """The state of `entry` for its widget (see `state`)."""
        version = self._versions
        descriptor = entry.descriptor
        current = known if known is not None else entry.got
        if entry.shown is not None and current == entry.shown:
            holding = False  # the node says it: its own value from now on
        if not live:  # a recording, or no ROS: what the events tell, read-only
            value = then if cursor is not None else current
            if value is None:
                where = "at the cursor" if cursor is not None else "yet"
                return ParamState(
                    target,
                    Status.WAITING,
                    f"{self._whose(entry)}: no value known {where} (the recording holds no change of it)",
                    None,
                    descriptor,
                    note=f"no value known {where}",
                    version=version,
                )
            recording = not self._live()
            return ParamState(
                target,
                Status.LIVE,
                "",
                value,
                descriptor,
                note="a recording: read-only" if recording else "read-only: no parameter client (no ROS)",
                version=version,
            )
        status, reason = self._status(entry, current)
        if cursor is not None:
            note = "paused: the value then, read-only"
            if then is None:
                note = "paused: no value known then"
            return ParamState(target, status, reason, then, descriptor, note=note, version=version)
        value = entry.shown if holding and entry.shown is not None else current
        editable = status is Status.LIVE and descriptor is not None and not descriptor.read_only
        note, problem = "", False
        if entry.outcome:
            note, problem = entry.outcome, True
        elif descriptor is not None and descriptor.read_only:
            note = "read-only (the node says so)"
        elif status is not Status.LIVE:
            note, problem = reason.splitlines()[0] if reason else "", status is Status.ERROR
        return ParamState(target, status, reason, value, descriptor, editable, note, problem, version)

    def _status(self, entry: _Entry, current: ParamValue | None) -> tuple[Status, str]:
        """Where a live parameter stands: asked, answered, or the node's error (asked again later)."""
        who = self._whose(entry)
        if entry.error and (entry.descriptor is None or current is None):
            again = f"; asked again every {self.retry_s:g} s"
            return (Status.WAITING if entry.missing else Status.ERROR), f"{entry.error}{again}"
        if entry.descriptor is None or current is None:
            if not math.isfinite(entry.asked_at):
                return Status.WAITING, f"{who}: not asked yet"
            return Status.WAITING, f"asking {entry.node} about {entry.name}…"
        return Status.LIVE, ""

    @staticmethod
    def _whose(entry: _Entry) -> str:
        return f"{entry.node.lstrip('/')}.{entry.name}"
