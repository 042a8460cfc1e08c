"""The viewer's events: every parameter change on the graph (``old → new``) and the user's markers, by time.

`EventStore` is fed raw ``/parameter_events`` and ``/_dbglog/markers`` messages (`push`: the engine's ROS
thread live, `events_of` from a recording's history), each node's values when it is first seen (`seed`,
from `ParamClient.watch`: a ParameterEvent carries only new values, so the store keeps every node's last
known ones to say what a change changed) and the user's markers (`add_marker`). Any thread may read it:
`between(t0, t1)` is two binary searches and a slice, `version` tells a reader whether anything changed.
Times are source times (epoch seconds), the time axis of every series. No ROS graph, no Dear PyGui.
"""

from __future__ import annotations

import bisect
import enum
import logging
import threading
import time
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Final, TypeAlias

import numpy as np
import numpy.typing as npt

from dbglog._ros._markers import MARKER_TOPIC, Marker, decode_marker, encode_marker
from dbglog._ros._params import PARAMETER_EVENTS, ParamValue, decode_event
from dbglog.viewer._data._history import History

__all__ = [
    "CHANGES",
    "DEFAULT_CAPACITY",
    "EVENT_TOPICS",
    "Event",
    "EventKind",
    "EventStore",
    "ParamChange",
    "event_json",
    "event_kind",
    "event_label",
    "events_of",
    "unsaved_markers",
]

_log = logging.getLogger("dbglog.viewer.events")

EVENT_TOPICS: Final = (PARAMETER_EVENTS, MARKER_TOPIC)
"""The topics an events store reads."""
DEFAULT_CAPACITY: Final = 100_000
"""Parameter changes kept; past it the oldest go (markers are always kept)."""
_SLACK: Final = 10
"""Past the capacity, a tenth of it goes at once (one move of the lists, not one per event)."""
_ARROW: Final = "\u2192"


class EventKind(enum.StrEnum):
    """What an event is."""

    CHANGED = "changed"
    """A parameter's value changed (a set from anywhere: dbglog, ``ros2 param``, rqt, the node itself)."""
    DECLARED = "declared"
    """A node declared a parameter (every node at start: its initial values)."""
    DELETED = "deleted"
    """A node undeclared a parameter."""
    MARKER = "marker"
    """A user's note at a moment."""


CHANGES: Final = frozenset({EventKind.CHANGED, EventKind.DELETED, EventKind.MARKER})
"""What the timeline and the Events list show by default: changes and markers, not every node's start."""


@dataclass(frozen=True, slots=True)
class ParamChange:
    """One parameter of one node changed (or was declared or deleted) at `time`."""

    time: float
    """Source time of the ParameterEvent (epoch seconds)."""
    node: str
    """The node, fully qualified (``/ns/pid_node``)."""
    name: str
    old: ParamValue | None
    """The value before; None when unknown (the node was not seen before the change) or not declared."""
    new: ParamValue | None
    """The value after; None when deleted."""
    kind: EventKind = EventKind.CHANGED
    stamp: float = 0.0
    """The node's own time of the change (its clock: simulated time under ``use_sim_time``)."""

    @property
    def label(self) -> str:
        """``pid_node.kp 1.25 → 2.5``; ``? → 2.5`` when the old value is unknown."""
        where = f"{self.node.lstrip('/')}.{self.name}"
        if self.kind is EventKind.DECLARED:
            return f"{where} = {_text(self.new)} (declared)"
        if self.kind is EventKind.DELETED:
            return f"{where} deleted (was {_text(self.old)})"
        return f"{where} {_text(self.old)} {_ARROW} {_text(self.new)}"


Event: TypeAlias = ParamChange | Marker
"""What a store holds: a parameter change or a user's marker (both have `time`)."""


def _text(value: ParamValue | None) -> str:
    return "?" if value is None else value.text


def event_label(event: Event) -> str:
    """One line for an event: a change's ``pid_node.kp 1.25 → 2.5``, a marker's note."""
    return event.note if isinstance(event, Marker) else event.label


def event_kind(event: Event) -> EventKind:
    """The kind of an event."""
    return EventKind.MARKER if isinstance(event, Marker) else event.kind


def event_json(event: Event) -> dict[str, object]:
    """An event for a JSON report: time, kind, and a change's node, name, old and new value (null when
    unknown or absent, with ``old_known``) or a marker's note and id."""
    if isinstance(event, Marker):
        return {"time": event.time, "kind": EventKind.MARKER.value, "note": event.note, "id": event.id}
    return {
        "time": event.time,
        "kind": event.kind.value,
        "node": event.node,
        "name": event.name,
        "old": None if event.old is None else event.old.to_json(),
        "old_type": None if event.old is None else event.old.type.label,
        "old_known": event.old is not None or event.kind is EventKind.DECLARED,
        "new": None if event.new is None else event.new.to_json(),
        "new_type": None if event.new is None else event.new.type.label,
        "label": event.label,
    }


class EventStore:
    """Parameter changes and user markers in time order, with every node's last known parameter values.

    Thread-safe: the engine's thread pushes, the parameter client's thread seeds, the UI thread adds
    markers and reads; every method holds one lock briefly and returns copies.

    Example:
        >>> store = engine.events()                      # live: fed from /parameter_events
        >>> params.watch(store.seed)                     # old values of nodes seen later
        >>> for event in store.between(t0, t1):          # what the timeline draws
        ...     print(event.time, event_label(event))

    Args:
        capacity: parameter changes kept (the oldest go first; markers always stay).
        clock: monotonic clock that orders pushes and seeds (tests give their own).
    """

    def __init__(
        self, capacity: int = DEFAULT_CAPACITY, *, clock: Callable[[], float] = time.monotonic
    ) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be at least 1 event, not {capacity}")
        self.capacity = capacity
        self._clock = clock
        self._lock = threading.Lock()
        self._times: list[float] = []
        self._events: list[Event] = []
        self._values: dict[str, dict[str, ParamValue]] = {}
        """Each node's parameters, as last known (seeded, then followed through its events)."""
        self._updated: dict[tuple[str, str], float] = {}
        """When an event last set each (node, parameter), on `clock`: a seed asked before that is older."""
        self._marker_ids: set[str] = set()
        self._by_param: dict[tuple[str, str], tuple[list[float], list[ParamChange]]] = {}
        """Each (node, parameter)'s changes held, in time order (what `value_at` searches)."""
        self._version = 0
        self._unreadable = 0
        self._changes = 0
        self.publish: Callable[[Marker], object] | None = None
        """Called with each marker the user adds here (live: `ParamClient.publish_marker`, so recorders
        and other viewers get it); None keeps markers in this store only."""

    # --- reading ------------------------------------------------------------------------------------

    @property
    def version(self) -> int:
        """Grows with every change to the store: a reader redraws only when it differs from the last one."""
        return self._version

    @property
    def unreadable(self) -> int:
        """Messages that could not be read (not a ParameterEvent, a malformed marker); skipped."""
        return self._unreadable

    def __len__(self) -> int:
        return len(self._events)

    def between(self, t0: float, t1: float, *, kinds: Collection[EventKind] | None = CHANGES) -> list[Event]:
        """The events with ``t0 <= time <= t1``, oldest first, of `kinds` (None: every kind)."""
        with self._lock:
            i = bisect.bisect_left(self._times, t0)
            j = bisect.bisect_right(self._times, t1)
            chosen = self._events[i:j]
        if kinds is None or len(kinds) == len(EventKind):
            return chosen
        return [e for e in chosen if event_kind(e) in kinds]

    def times(
        self, t0: float, t1: float, *, kinds: Collection[EventKind] | None = CHANGES
    ) -> npt.NDArray[np.float64]:
        """The times of `between`'s events (what a timeline draws its marks at)."""
        return np.array([e.time for e in self.between(t0, t1, kinds=kinds)], dtype=np.float64)

    def all(self, *, kinds: Collection[EventKind] | None = CHANGES) -> list[Event]:
        """Every event held of `kinds`, oldest first."""
        return self.between(-np.inf, np.inf, kinds=kinds)

    def neighbour(
        self, t: float, direction: int, *, kinds: Collection[EventKind] | None = CHANGES
    ) -> Event | None:
        """The nearest event strictly before (`direction` -1) or after (+1) `t`, of `kinds`."""
        with self._lock:
            events = self._events
            if direction < 0:
                order = range(bisect.bisect_left(self._times, t) - 1, -1, -1)
            else:
                order = range(bisect.bisect_right(self._times, t), len(events))
            for i in order:
                if kinds is None or event_kind(events[i]) in kinds:
                    return events[i]
        return None

    def value(self, node: str, name: str) -> ParamValue | None:
        """The last known value of a node's parameter (None: unknown or not declared)."""
        with self._lock:
            return self._values.get(node, {}).get(name)

    def value_at(self, node: str, name: str, t: float) -> ParamValue | None:
        """The value a node's parameter had at source time `t`, as the events held tell it: the new value of
        its last change at or before `t`, else the old value of its first change after `t`, else (no change
        held) its last known value. None: unknown then, not declared yet, or deleted. A binary search."""
        with self._lock:
            held = self._by_param.get((node, name))
            if held is None:
                return self._values.get(node, {}).get(name)
            times, changes = held
            i = bisect.bisect_right(times, t)
            return changes[i - 1].new if i else changes[0].old

    def values(self, node: str) -> dict[str, ParamValue]:
        """Every last known parameter value of `node`, by name."""
        with self._lock:
            return dict(self._values.get(node, {}))

    def nodes(self) -> list[str]:
        """The nodes whose parameter values are known, sorted."""
        with self._lock:
            return sorted(self._values)

    def markers(self) -> list[Marker]:
        """Every user marker held, oldest first."""
        return [e for e in self.all(kinds=(EventKind.MARKER,)) if isinstance(e, Marker)]

    def marker_messages(self) -> tuple[npt.NDArray[np.float64], list[bytes]]:
        """The markers as ``/_dbglog/markers`` messages (times, CDR payloads): what saving a recording
        writes so that its replay shows them."""
        markers = self.markers()
        return np.array([m.time for m in markers], dtype=np.float64), [encode_marker(m) for m in markers]

    # --- writing ------------------------------------------------------------------------------------

    def push(self, topic: str, times: npt.ArrayLike, payloads: Sequence[bytes]) -> int:
        """Take messages of `topic` (``/parameter_events`` or ``/_dbglog/markers``) received at source
        `times`, in order; return how many events they added. Any thread."""
        stamps = np.asarray(times, dtype=np.float64).tolist()
        if topic == MARKER_TOPIC:
            return self._push_markers(payloads)
        if topic != PARAMETER_EVENTS:
            return 0
        decoded = []
        for t, payload in zip(stamps, payloads, strict=True):
            try:
                decoded.append((t, decode_event(payload)))
            except ValueError:
                self._unreadable += 1
        added = 0
        with self._lock:
            now = self._clock()
            for t, message in decoded:
                known = self._values.setdefault(message.node, {})
                for kind, params in (
                    (EventKind.DECLARED, message.new),
                    (EventKind.CHANGED, message.changed),
                    (EventKind.DELETED, message.deleted),
                ):
                    for name, value in params:
                        old = known.get(name)
                        if kind is EventKind.DELETED:
                            known.pop(name, None)
                            new: ParamValue | None = None
                        else:
                            known[name] = new = value
                        self._updated[(message.node, name)] = now
                        change = ParamChange(t, message.node, name, old, new, kind, message.stamp)
                        self._insert(change)
                        self._index(change)
                        added += 1
            if added:
                self._changes += added
                self._version += 1
                self._trim()
        return added

    def _push_markers(self, payloads: Iterable[bytes]) -> int:
        markers = []
        for payload in payloads:
            try:
                markers.append(decode_marker(payload))
            except ValueError as exc:
                self._unreadable += 1
                _log.debug("unreadable marker: %s", exc)
        added = 0
        with self._lock:
            for marker in markers:
                if marker.id not in self._marker_ids:
                    self._marker_ids.add(marker.id)
                    self._insert(marker)
                    added += 1
            if added:
                self._version += 1
        return added

    def seed(self, node: str, values: Mapping[str, ParamValue], asked_at: float) -> None:
        """Take a node's parameter values, asked for at `asked_at` (on this store's clock): the last known
        values from then on, except those a change received since has set (it is at least as new)."""
        with self._lock:
            known = self._values.setdefault(node, {})
            for name in [n for n in known if n not in values]:
                if self._updated.get((node, name), -np.inf) <= asked_at:
                    del known[name]  # gone from the node (it restarted without it)
            for name, value in values.items():
                if self._updated.get((node, name), -np.inf) <= asked_at:
                    known[name] = value
            self._version += 1

    def add_marker(self, note: str, t: float | None = None) -> Marker:
        """Add the user's marker with `note` at source time `t` (None: now); it is published when
        `publish` is set. Returns it.

        Raises:
            ValueError: `t` is not a finite time.
        """
        marker = Marker(time.time() if t is None else t, note.strip())
        with self._lock:
            self._marker_ids.add(marker.id)
            self._insert(marker)
            self._version += 1
        publish = self.publish
        if publish is not None:
            try:
                publish(marker)
            except Exception:  # the marker stays here even when it cannot be sent
                _log.exception("could not publish marker %s", marker.id)
        return marker

    def adopt_markers(self, other: EventStore) -> None:
        """Add the markers of `other` this store lacks (a recording's store made again once loaded whole)."""
        with self._lock:
            mine = set(self._marker_ids)
        fresh = [m for m in other.markers() if m.id not in mine]
        with self._lock:
            for marker in fresh:
                self._marker_ids.add(marker.id)
                self._insert(marker)
            if fresh:
                self._version += 1

    def _insert(self, event: Event) -> None:
        """Insert in time order, after events of the same time (lock held)."""
        if not self._times or event.time >= self._times[-1]:
            self._times.append(event.time)
            self._events.append(event)
            return
        i = bisect.bisect_right(self._times, event.time)
        self._times.insert(i, event.time)
        self._events.insert(i, event)

    def _index(self, change: ParamChange) -> None:
        """Add a change to its parameter's changes, in time order (lock held)."""
        times, changes = self._by_param.setdefault((change.node, change.name), ([], []))
        if not times or change.time >= times[-1]:
            times.append(change.time)
            changes.append(change)
            return
        i = bisect.bisect_right(times, change.time)
        times.insert(i, change.time)
        changes.insert(i, change)

    def _trim(self) -> None:
        """Past the capacity, drop the oldest parameter changes (a tenth of the capacity at once)."""
        if self._changes <= self.capacity:
            return
        drop = self._changes - self.capacity + self.capacity // _SLACK
        kept: list[Event] = []
        for event in self._events:
            if drop and isinstance(event, ParamChange):
                drop -= 1
                continue
            kept.append(event)
        self._events = kept
        self._times = [e.time for e in kept]
        self._changes = sum(1 for e in kept if isinstance(e, ParamChange))
        self._by_param = {}
        for event in kept:
            if isinstance(event, ParamChange):
                self._index(event)


def events_of(history: History, *, capacity: int = DEFAULT_CAPACITY) -> EventStore:
    """Return a store of the parameter changes and markers `history` holds (a recording's, the engine's)."""
    store = EventStore(capacity)
    for topic in EVENT_TOPICS:
        if history.kind(topic) == "payloads":
            times, payloads = history.payloads(topic, -np.inf, np.inf)
            store.push(topic, times, payloads)
    return store


def unsaved_markers(store: EventStore, history: History) -> tuple[npt.NDArray[np.float64], list[bytes]]:
    """The markers of `store` that `history` does not hold (added to a replay, or while ROS was off), as
    ``/_dbglog/markers`` messages at their own times: what saving `history` as a recording adds so that the
    file keeps them."""
    held: set[str] = set()
    if history.kind(MARKER_TOPIC) == "payloads":
        for payload in history.payloads(MARKER_TOPIC, -np.inf, np.inf)[1]:
            try:
                held.add(decode_marker(payload).id)
            except ValueError:
                continue
    fresh = [m for m in store.markers() if m.id not in held]
    return np.array([m.time for m in fresh], dtype=np.float64), [encode_marker(m) for m in fresh]
